"""Say it where the user meets it (issue 20, classes 7 and 8): a non-converged answer, strains a
linear-elastic beam cannot carry, a stress above the given yield stress, a modulus in the wrong
unit and the closed-form model's missing shortening each come with a warning; nu is accepted
wherever G is; the solver options are in help(flexmb.solve) and the strategies page (docs/strategies.md)."""

import math
import pathlib
import warnings

import numpy as np
import pytest

import flexmb
from flexmb import ConvergenceWarning, PlausibilityWarning, models
from flexmb.plausibility import STRAIN_LIMIT
from flexmb.solvers import STRATEGIES, options_doc

L, T = 0.05, 0.5e-3  # a parallel leaf-spring guide: two 50 mm x 10 mm x 0.5 mm steel leaves, 20 mm apart


def guide(**leaf):
    sizes = {} if "section" in leaf else dict(width=0.01, thickness=T)  # else the section's
    spring = flexmb.LeafSpring(length=L, elements=8, **sizes, **leaf)
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("stage", position=(0.0, L))
    for i, x in enumerate((-0.01, 0.01)):
        m.add_joint("ground", "stage", spring, name=f"leaf{i}", origin=(x, 0.0), rotation=math.pi / 2)
    return m


def _quiet(call):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails
        return call()


def test_a_solve_that_does_not_converge_warns_and_says_what_the_numbers_are():
    """The issue: at load factor 0 the returned reaction is 0 and only converged=False says so."""
    m = models.cross_flexure_pivot(dim=2, rotation=1.0)
    with pytest.warns(ConvergenceWarning, match="did not converge.*load factor 0 of 1.*not those of the load"):
        sol = flexmb.solve(m, max_iter=1, min_step=0.5)
    assert not sol.converged and sol.load_factor == 0.0
    sol = _quiet(lambda: flexmb.solve(m))
    assert sol.converged


@pytest.mark.parametrize("method", ["newton", "conventional"])
def test_a_sweep_warns_for_each_value_that_does_not_converge(method):
    forces = [10.0, 1e6, 20.0]  # uN on the gripper: 1e6 is far beyond its range
    with pytest.warns(ConvergenceWarning, match="did not converge") as record:
        result = flexmb.sweep(models.gripper(), forces, method=method, max_iter=3)
    assert result.converged.tolist() == [True, False, True]
    assert sum(issubclass(w.category, ConvergenceWarning) for w in record) == 1


def test_a_stroke_in_the_wrong_unit_warns_that_the_strain_is_not_elastic():
    """The issue: a 5 m stroke on a 50 mm guide (mm/m mix-up) 'converged' at 1e4 % strain and
    2e7 MPa. The 5 mm stroke meant: peak strain 0.3 %, no warning."""
    m = guide()
    m.prescribe("stage", x=5.0, rotation=0.0)
    with pytest.warns(PlausibilityWarning, match=r"peak strain 99.* beyond the elastic range.*units"):
        sol = flexmb.solve(m)
    assert sol.converged
    m = guide()
    m.prescribe("stage", x=5e-3, rotation=0.0)
    sol = _quiet(lambda: flexmb.solve(m))
    # the fixed-guided leaf: peak stress 3 E T d / L^2 = 600 MPa (Timoshenko; 602 MPa with the
    # geometric stiffening of the FE model), strain 0.3 % < STRAIN_LIMIT
    assert sol.peak_stress().max() == pytest.approx(3 * 200e9 * T * 5e-3 / L**2, rel=0.01)
    assert sol.peak_stress().max() / 200e9 < STRAIN_LIMIT


def test_a_stress_above_the_given_yield_stress_warns_naming_the_joint():
    m = guide(yield_stress=500e6)
    m.prescribe("stage", x=5e-3, rotation=0.0)
    with pytest.warns(PlausibilityWarning, match=r"exceeds the yield stress 5e\+08 \(joint 'leaf"):
        flexmb.solve(m)
    m = guide(yield_stress=1.5e9)  # spring steel: 600 MPa is fine
    _quiet(lambda: flexmb.solve(m))


def test_the_yield_check_reads_the_sections_of_the_model_solved():
    """The per-element section data (`flexmb.fe.stress.section_table`) is gathered once per
    compiled model and kept across the solves of an unchanged mechanism; a joint replaced with a
    lower yield stress is checked with its own (no stale limit)."""
    from flexmb.fe.stress import section_table

    m = guide(yield_stress=1.5e9)
    m.prescribe("stage", x=5e-3, rotation=0.0)
    first = _quiet(lambda: flexmb.solve(m))
    again = _quiet(lambda: flexmb.solve(m))
    elements = first.compiled.problem.model.elements
    assert again.compiled is first.compiled and section_table(elements) is section_table(elements)
    assert np.all(section_table(elements).yield_stress == 1.5e9)
    weak = flexmb.LeafSpring(length=L, width=0.01, thickness=T, elements=8, yield_stress=500e6)
    for *_, data in m.graph.edges(keys=True, data=True):
        data["joint"] = weak
    with pytest.warns(PlausibilityWarning, match=r"exceeds the yield stress 5e\+08 \(joint 'leaf"):
        flexmb.solve(m)


def test_a_modulus_in_gpa_with_lengths_in_metres_warns():
    with pytest.warns(PlausibilityWarning, match="E=200 .* GPa"):
        flexmb.LeafSpring(E=200, G=77)
    with pytest.warns(PlausibilityWarning, match="E=200 .* GPa"):
        flexmb.CrossFlexure(E=200, G=77)
    _quiet(lambda: flexmb.LeafSpring(length=50.0, width=10.0, thickness=0.5, E=2e5, G=7.7e4))  # MPa and mm
    _quiet(lambda: models.gripper())  # the paper's uN and mm: E = 1e11 uN/mm^2


@pytest.mark.parametrize("section", [lambda: flexmb.rectangle(0.01, T, E=210, G=81),
                                     lambda: flexmb.circle(1e-3, E=210, nu=0.3)])
def test_a_modulus_in_gpa_given_through_a_section_warns_at_the_solve(section):
    # E given in GPa through the leaf's Section: the joint's own E (default steel) is fine, the
    # elements' is 210; a prescribed stroke's strain does not depend on E, so only this says it
    m = guide(section=section())
    m.prescribe("stage", x=1e-3, y=0.0, rotation=0.0)
    with pytest.warns(PlausibilityWarning, match=r"joint 'leaf0'.*E=210 with joint length 0.05 .* GPa"):
        flexmb.solve(m)
    mm = flexmb.Mechanism(dim=2)  # the same guide in MPa, mm: quiet
    mm.add_link("ground", fixed=True)
    mm.add_link("stage", position=(0.0, 50.0))
    sec = flexmb.rectangle(10.0, 0.5, E=2.1e5, G=8.1e4)
    for i, x in enumerate((-10.0, 10.0)):
        mm.add_joint("ground", "stage", flexmb.LeafSpring(length=50.0, width=10.0, thickness=0.5, E=2.1e5, G=8.1e4,
                                                          elements=8, section=sec), name=f"leaf{i}", origin=(x, 0.0),
                     rotation=math.pi / 2)
    mm.prescribe("stage", x=1.0, y=0.0, rotation=0.0)
    _quiet(lambda: flexmb.solve(mm))


def test_the_closed_form_model_warns_about_the_shortening_it_leaves_out():
    """The issue: method='newton' gave a parasitic drop of 0 um, the FE model 300 um. The
    shortening of a bent leaf is 0.6 d^2/L (fixed-guided cubic shape: (1/2) int w'^2 dx)."""
    m = guide()
    m.apply_force("stage", [20.0, 0.0])
    with pytest.warns(PlausibilityWarning, match=r"deflects 0.005.*0.6 d\^2/L = 0.0003.*conventional"):
        closed = flexmb.solve(m, method="newton")
    fe = flexmb.solve(m)
    assert closed.displacement("stage")[1] == pytest.approx(0.0, abs=1e-9)
    d = fe.displacement("stage")[0]
    assert fe.displacement("stage")[1] == pytest.approx(-0.6 * d**2 / L, rel=0.03)
    small = guide()
    small.apply_force("stage", [2.0, 0.0])  # d = 0.5 mm: 0.6 d / L = 0.6 % of d, below the 1 % limit
    _quiet(lambda: flexmb.solve(small, method="newton"))
    _quiet(lambda: flexmb.solve(models.gripper(force=50.0), method="newton"))  # curved beams: not straight leaves


@pytest.mark.parametrize("make", [
    lambda **k: flexmb.LeafSpring(E=200e9, **k), lambda **k: flexmb.CrossFlexure(E=200e9, **k),
    lambda **k: flexmb.ThreeXInfinity(E=200e9, **k),
    lambda **k: flexmb.CurvedBeam(radius=0.05, angle=1.0, E=200e9, width=0.01, height=1e-3, **k)],
    ids=["leaf_spring", "cross_flexure", "three_x_infinity", "curved_beam"])
def test_poissons_ratio_is_accepted_wherever_g_is(make):
    """The issue: LeafSpring(nu=...) raised a raw TypeError. G = E / (2 (1 + nu))."""
    joint = make(nu=0.3)
    assert getattr(joint, "G") == pytest.approx(200e9 / 2.6, rel=1e-15)
    with pytest.raises(flexmb.ParameterError, match="nu=0.7 outside the valid range"):
        make(nu=0.7)
    with pytest.raises(flexmb.ParameterError, match="G or nu, not both"):
        make(nu=0.3, G=70e9)


def test_sections_take_nu_too():
    assert flexmb.rectangle(0.01, 1e-3, 200e9, nu=0.3).G == pytest.approx(200e9 / 2.6, rel=1e-15)
    from flexmb.sections import circle
    assert circle(1e-3, 200e9, nu=0.25).G == pytest.approx(200e9 / 2.5, rel=1e-15)
    with pytest.raises(flexmb.ParameterError, match="give the shear modulus G or Poisson's ratio nu"):
        flexmb.rectangle(0.01, 1e-3, 200e9)


def test_closed_form_is_exported_where_the_readme_names_it():
    from flexmb.joints import ClosedForm

    assert isinstance(flexmb.LeafSpring().closed_form(2), ClosedForm)


def test_every_solver_option_is_in_help_solve_and_the_strategies_page():
    readme = (pathlib.Path(__file__).parents[1] / "docs" / "strategies.md").read_text()
    for name, cls in STRATEGIES.items():
        for option, default, text in options_doc(cls):
            assert f"``{option}={default!r}``" in flexmb.solve.__doc__, (name, option)
            assert text, (name, option)  # every option described
            assert f"`{option}`" in readme, (name, option)
    assert "per load step" in flexmb.solve.__doc__  # max_iter's meaning


def test_the_strategy_table_states_the_missing_shortening():
    readme = (pathlib.Path(__file__).parents[1] / "docs" / "strategies.md").read_text()
    row = next(line for line in readme.splitlines() if line.startswith('| `"newton"`'))
    assert "no shortening" in row


def test_numbers_the_warnings_rest_on():
    """Sanity of the limits' sources: spring steel's elastic strain 1.5 GPa / 200 GPa."""
    assert 1.5e9 / 200e9 < STRAIN_LIMIT
    assert np.isclose(0.6 * (5e-3) ** 2 / L, 3e-4)


def test_an_unstable_equilibrium_is_reported_not_silent():
    """A perfect-geometry arch of two leaf springs (L = 0.1 m at +-10 deg) with its apex pushed down
    4 % of its rise: the leaves buckle and several unstable equilibria exist; the default solve lands
    on Fy = -1571 N where the small-step path and flexmb.trace give about -823 N (found by this
    session's review). Any unstable result carries a PlausibilityWarning naming the way out."""
    L, a = 0.1, np.radians(10)
    h = L * np.sin(a)
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("C", position=(L * np.cos(a), h))
    m.add_link("B", position=(2 * L * np.cos(a), 0.0), fixed=True)
    m.add_joint("A", "C", "leaf_spring", name="left", rotation=a, length=L)
    m.add_joint("C", "B", "leaf_spring", name="right", origin=(L * np.cos(a), h), rotation=-a, length=L)
    m.prescribe("C", y=-0.04 * h)
    with pytest.warns(flexmb.PlausibilityWarning, match="UNSTABLE.*flexmb.trace"):
        sol = flexmb.solve(m)
    assert sol.converged and sol.stable is False and "UNSTABLE" in sol.message
