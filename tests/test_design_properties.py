"""Design properties over a range of motion (`flexmb.properties`, `sweep(..., properties=)`,
`flexmb.design_properties.summary`, `flexmb.study.joint_range`): the columns are the
per-configuration functions' numbers, failures keep the other rows, studies run anywhere."""

import functools

import numpy as np
import pytest

import flexmb
from flexmb import design_properties as dp
from flexmb.study import joint_range, parameter_study

ANGLES = np.radians([0.0, 15.0, 30.0])


def _pivot(elements=3):
    """The Table 1 cross flexure carrying a 0.2 kg block B (inertia 2e-5 kg m^2), A fixed, B's
    orientation prescribed, compressed by a dead 5 N force along A -> B."""
    J = flexmb.CrossFlexure(elements_per_leaf=elements, density=7800.0)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=J.interface_b(3), mass=0.2, inertia=2e-5 * np.eye(3))
    m.add_joint("A", "B", J, name="pivot")
    m.prescribe("B", rotation=(0.0, 0.0, 0.0))
    axis = J.interface_b(3) / np.linalg.norm(J.interface_b(3))
    m.apply_force("B", -5.0 * axis)
    return m


@pytest.fixture(scope="module")
def swept():
    zeros = np.zeros_like(ANGLES)
    kw = dict(which=("modes", "buckling", "compliance", "stress"), n_modes=3, held=[("B", "rz")], limit=400e6,
              compliance_entries=[("B", "x", "x"), ("B", "z", "z"), ("B", "rx", "ry")])
    res = flexmb.sweep(_pivot(), np.column_stack([zeros, zeros, ANGLES]), motion=("B", "rotation"), properties=kw)
    return res, kw


@pytest.mark.slow
def test_columns_are_the_per_configuration_properties(swept):
    """Every property column equals the function it comes from, at every configuration."""
    res, kw = swept
    t = res.table()
    held = kw["held"]
    for k, sol in enumerate(res):
        np.testing.assert_array_equal([t["f1"][k], t["f2"][k], t["f3"][k]],
                                      flexmb.modes(sol, n_modes=3, held=held).frequencies)
        assert t["buckling"][k] == flexmb.buckling(sol, held=held)[0]
        C = flexmb.compliance(sol, "B", held=held)
        assert (t["C.B.x.x"][k], t["C.B.z.z"][k], t["C.B.rx.ry"][k]) == (C[0, 0], C[2, 2], C[3, 4])
        s = sol.stresses(limit=400e6)
        assert t["von_mises"][k] == s.von_mises.max()
        assert t["safety"][k] == s.safety.min()
        assert t["pivot.von_mises"][k] == s.joint("pivot")["von_mises"]
    # the sweep's own columns are still there, the rows in order
    np.testing.assert_allclose(t["B.rotation_z"], ANGLES, atol=1e-12)
    # the same table from the function over the sweep's solutions
    again = flexmb.properties(res, **kw)
    assert list(again) == list(t)
    for name in t:
        np.testing.assert_array_equal(again[name], t[name])


def test_properties_change_over_the_stroke_as_a_designer_expects(swept):
    """The parasitic frequencies fall and the stress grows with the turn (the support stiffness
    of a cross flexure drops with rotation, Dwarshuis et al. 2020, Fig. 8); a compressive load
    along the axis has a finite positive buckling multiplier."""
    t = swept[0].table()
    assert np.all(np.diff(t["f1"]) < 0)
    assert np.all(np.diff(t["von_mises"]) > 0)
    assert np.all((t["buckling"] > 1.0) & np.isfinite(t["buckling"]))
    s = dp.summary(t)
    assert s["f1.min"] == t["f1"][-1] and s["von_mises.max"] == t["von_mises"][-1]
    assert s["safety.min"] == t["safety"].min() and s["|C.B.rx.ry|.max"] == np.abs(t["C.B.rx.ry"]).max()


def test_any_sequence_of_solutions_and_failures_keep_the_other_rows(swept, monkeypatch):
    """A plain list (e.g. a traced path) gets a ``converged`` column; an unconverged solution
    gets NaN properties; a property failing at a later configuration gets NaN with its reason,
    the other properties and rows kept."""
    res = swept[0]
    bad = flexmb.solve(_pivot(), max_iter=1, min_step=0.9)
    assert not bad.converged
    sols = [res[0], bad, res[1], res[2]]
    real = dp.modes

    def flaky(sol, n_modes, held):
        if sol is res[2]:
            raise flexmb.ModelError("modes: the tangent is singular here")
        return real(sol, n_modes=n_modes, held=held)

    monkeypatch.setattr(dp, "modes", flaky)
    t = flexmb.properties(sols, ("modes", "stress"), n_modes=2, held=[("B", "rz")])
    assert t["converged"].tolist() == [True, False, True, True]
    assert np.isnan(t["f1"][1]) and np.isnan(t["von_mises"][1])
    assert np.isnan(t["f1"][3]) and np.isfinite(t["von_mises"][3])
    assert t["property_errors"][3] == "modes: modes: the tangent is singular here"
    assert t["property_errors"][0] == t["property_errors"][2] == ""
    assert t["f1"][2] == real(res[1], n_modes=2, held=[("B", "rz")]).frequencies[0]


def test_bad_requests_name_what_is_wrong(swept):
    res = swept[0]
    with pytest.raises(flexmb.ParameterError, match="'frequency' is not a property"):
        flexmb.properties(res, ("frequency",))
    with pytest.raises(flexmb.ModelError, match="names no link 'C'"):
        flexmb.properties(res, ("compliance",), compliance_entries=[("C", "x", "x")])
    with pytest.raises(flexmb.ParameterError, match="component 'w'"):
        flexmb.properties(res, ("compliance",), compliance_entries=[("B", "w", "x")])
    with pytest.raises(flexmb.ParameterError, match="must be a flexmb.Solution"):
        flexmb.properties([1, 2], ("modes",))
    with pytest.raises(flexmb.ParameterError, match="n_modes=99"):  # strict on the first converged row
        flexmb.properties(res, ("modes",), n_modes=99)


DESIGN = functools.partial(joint_range, "cross_flexure", (0.0, 0.3), which=("modes", "stress"), n_modes=2,
                           elements_per_leaf=2, limit=500e6)
DESIGNS = [{"thickness": 0.8e-3}, {"thickness": 1.0e-3}]


@pytest.fixture(scope="module")
def serial_study():
    return parameter_study(DESIGN, DESIGNS, executor="serial")


def test_joint_range_is_a_study_design(serial_study):
    """`joint_range` over the stroke: the summary of `properties` of the joint's sweep. A thicker
    leaf raises the lowest parasitic frequency, and the peak stress at a given turn grows ~ t
    (bending: M = k theta with k ~ t^3, sigma = 6 M/(w t^2) ~ t)."""
    t = serial_study
    assert t["converged"].tolist() == [True, True]
    assert t["f1.min"][1] > t["f1.min"][0]
    assert t["von_mises.max"][1] / t["von_mises.max"][0] == pytest.approx(1.0 / 0.8, rel=0.05)
    one = DESIGN(thickness=1.0e-3)
    assert one["f1.min"] == t["f1.min"][1]


@pytest.mark.parametrize("rotations", ["0.1", [], [np.nan], [[0.1, 0.2]], None])
def test_joint_range_refuses_rotations_that_are_not_finite_numbers(rotations):
    with pytest.raises(flexmb.ParameterError, match="joint_range: rotations=.*finite rotations \\[rad\\]"):
        joint_range("cross_flexure", rotations, which=("modes",), n_modes=1, elements_per_leaf=2)


@pytest.mark.slow
def test_joint_range_runs_in_a_process_pool_and_on_dask(serial_study):
    pooled = parameter_study(DESIGN, DESIGNS, max_workers=2)
    for name in serial_study:
        np.testing.assert_array_equal(pooled[name], serial_study[name])
    distributed = pytest.importorskip("distributed")
    with distributed.Client(n_workers=2, threads_per_worker=1, dashboard_address=":0") as client:
        remote = parameter_study(DESIGN, DESIGNS, executor=client.get_executor())
    assert all(np.array_equal(remote[name], serial_study[name]) for name in serial_study)


def test_properties_of_a_traced_path():
    """A `flexmb.trace` path is a sequence of solutions like a sweep: `properties` keeps its
    columns (``load_factor``, ``stable``) and adds the buckling multiplier at every point; on the
    unturned pivot's linear pre-buckling path, multiplier x load factor is the traced bifurcation
    load factor at every point before it (to 1e-3)."""
    J = flexmb.CrossFlexure(elements_per_leaf=3)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=J.interface_b(3))
    m.add_joint("A", "B", J, name="pivot")
    m.apply_force("B", -1200.0 * J.interface_b(3) / np.linalg.norm(J.interface_b(3)))
    path = flexmb.trace(m, max_load_factor=1.0, steps=60, progress=False)
    t = flexmb.properties(path, ("buckling", "stress"), held="fixed")
    assert {"load_factor", "stable", "buckling", "von_mises"} <= set(t)
    first = [c for c in path.critical if c.kind == "bifurcation"][0]
    critical = first.load_factor
    before = (path.arc_length > 0) & (path.arc_length < first.arc_length)  # trace goes on along the bifurcated branch
    assert before.sum() >= 2
    np.testing.assert_allclose(t["buckling"][before] * t["load_factor"][before], critical, rtol=1e-3)


@pytest.mark.slow
def test_default_properties_of_a_ksd_reduced_solution_keep_all_it_has():
    """KSD-reduced has no buckling (`flexmb.buckling` refuses it): the default ``which`` still
    returns the modes and stresses, the buckling column is NaN with the reason in
    ``property_errors`` (the manipulator of Dwarshuis et al. 2020, Sec. 4.4, turned 30 deg)."""
    sol = flexmb.solve(flexmb.models.manipulator("joint", np.radians(30.0)), method="ksd-reduced")
    assert sol.converged
    with pytest.warns(UserWarning, match="NaN for buckling of ksd-reduced"):
        t = flexmb.properties([sol], n_modes=2)
    np.testing.assert_array_equal([t["f1"][0], t["f2"][0]], flexmb.modes(sol, n_modes=2).frequencies)
    assert t["von_mises"][0] == sol.stresses().von_mises.max() > 0.0
    assert np.isnan(t["buckling"][0])
    assert t["property_errors"][0].startswith("buckling: ") and "method='ksd-full'" in t["property_errors"][0]
    with pytest.raises(flexmb.UnsupportedStrategyError):  # the function itself still refuses
        flexmb.buckling(sol)


@pytest.mark.slow
def test_a_ksd_reduced_sweep_with_properties_keeps_its_rows():
    """``sweep(..., properties=)`` on KSD-reduced (the Table 1 pivot turned 0..30 deg, buckling
    asked for explicitly): every row has its frequencies, buckling NaN with the reason."""
    zeros = np.zeros_like(ANGLES)
    with pytest.warns(UserWarning, match="NaN for buckling"):
        res = flexmb.sweep(_pivot(), np.column_stack([zeros, zeros, ANGLES]), motion=("B", "rotation"),
                           method="ksd-reduced", properties={"which": ("modes", "buckling"), "n_modes": 2,
                                                            "held": [("B", "rz")], "n_buckling": 2})
    t = res.table()
    assert all(res.table()["converged"])
    for k, sol in enumerate(res):
        assert t["f1"][k] == flexmb.modes(sol, n_modes=2, held=[("B", "rz")]).frequencies[0]
    assert np.isnan(t["buckling1"]).all() and np.isnan(t["buckling2"]).all()
    assert all(e.startswith("buckling: buckling: the full FE equilibrium is needed") for e in t["property_errors"])
