"""Arc-length path following (issue 19, items 5 and 7): `flexmb.trace` and `flexmb.Path`.

References: closed forms (von Mises truss equilibrium, Euler's load, the clamped-free elastica in
Timoshenko & Gere 1961), published limit loads (Lee's frame, DaDeppo & Schmidt's arch), Qiu,
Lang & Slocum's (2004) modal model of the double curved-beam bistable.
"""

import math
import warnings

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq, minimize_scalar

import flexmb
from flexmb.errors import FlexmbError, ModelError, ParameterError, UnsupportedStrategyError
from flexmb.solvers.arclength import load_tangent
from flexmb.studies import paths as cases

from tolerances import FD_TANGENT


def _eigenvalues(solution):
    """All eigenvalues of the symmetric part of the free tangent at ``solution`` (dense)."""
    problem = solution.compiled.problem
    K = problem.evaluate(solution.state, solution.load_factor)[1].toarray()
    return sla.eigvalsh(0.5 * (K + K.T))


def _check_stability(path):
    """The stable flag of every point is the sign of the symmetric tangent's lowest eigenvalue;
    it changes only across a located critical point, where an eigenvalue vanishes."""
    for sol, stable, neg in zip(path, path.stable, path.negative_eigenvalues):
        ev = _eigenvalues(sol)
        assert stable == (ev[0] > 0) and neg == np.sum(ev < 0)
        assert sol.stable == stable
    arcs = [c.arc_length for c in path.critical]
    for k in np.flatnonzero(np.diff(path.negative_eigenvalues)):
        a, b = path.arc_length[k], path.arc_length[k + 1]
        assert any(a < s < b for s in arcs), f"stability changes between points {k} and {k + 1} without a critical point"
    for c in path.critical:
        ev = _eigenvalues(c.solution)
        assert np.min(np.abs(ev)) < 1e-6 * np.max(np.abs(ev))  # singular at the critical point


# -- the load-factor derivative -------------------------------------------------------------------------------

def _lever_2d():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", (0.1, 0.0))
    m.add_link("C", (0.2, 0.0))
    m.add_joint("A", "B", "leaf_spring", elements=3)
    m.add_joint("B", "C", "leaf_spring", elements=3, origin=(0.1, 0.0))
    m.apply_force("B", (3.0, -20.0), point=(0.13, 0.02))  # offset: the arm turns with B
    m.apply_moment("B", 0.4)
    m.prescribe("C", y=0.01, rotation=0.3)
    return m


def _chain_3d():
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", (0.1, 0.0, 0.0))
    m.add_link("C", (0.2, 0.0, 0.0))
    m.add_joint("A", "B", "leaf_spring", elements=3)
    m.add_joint("B", "C", "leaf_spring", elements=3, origin=(0.1, 0.0, 0.0))
    m.apply_force("B", (1.0, -5.0, 2.0), point=(0.12, 0.01, 0.0))
    m.apply_moment("B", (0.1, 0.2, -0.3))
    m.prescribe("C", x=2e-5, rotation=[(0.0, 0.0, 0.3), (0.2, 0.0, 0.0)])  # a chain of rotations
    return m


@pytest.mark.parametrize("build", [_lever_2d, _chain_3d])
def test_the_load_factor_derivative_equals_central_differences(build):
    """d r_f / d lam (loads and prescribed motion together, free DOFs held) at a deformed state
    and lam = 0.6, against central differences in lam that move the prescribed DOFs exactly."""
    compiled = build().compile()
    problem = compiled.problem
    sol = flexmb.solve(build())
    state, lam, h = sol.state, 0.6, 1e-6
    # a configuration off equilibrium, with the prescribed DOFs at lam
    du = problem.full_increment(np.random.default_rng(1).normal(scale=1e-3, size=problem.n_free),
                                problem.prescribed_increment(lam - 1.0, 1.0))
    state = problem.model.apply_increment(state, du)

    def r_at(x):
        moved = problem.model.apply_increment(state, problem.full_increment(np.zeros(problem.n_free),
                                                                               problem.prescribed_increment(x - lam, lam)))
        return problem.residual(moved, x)[problem.free]

    fd = (r_at(lam + h) - r_at(lam - h)) / (2 * h)
    g, _ = load_tangent(problem, state, lam)
    np.testing.assert_allclose(g, fd, rtol=0, atol=FD_TANGENT * np.max(np.abs(fd)))


# -- closed forms: the von Mises truss and the Euler strut ------------------------------------------------------

def test_von_mises_truss_in_mm_follows_its_closed_form_through_both_limit_points():
    """Half a shallow pinned two-bar truss (mm, N, MPa; a case no paper contains) against the
    apex equilibrium with the beam's own axial law (`von_mises_force`): every point, and the
    snap-through limit load from the closed form's maximum."""
    path = flexmb.trace(cases.von_mises_truss(), steps=40, arc_length=0.05, progress=False,
                        stop=lambda s: -s.displacement("T")[1] > 120.0)
    w = np.array([-s.displacement("T")[1] for s in path])
    # the residual tolerance is 1e-9 of the internal forces (the bar's axial force reaches 7e4 N)
    np.testing.assert_allclose(path.load_factor * 1e4, cases.von_mises_force(w), rtol=0, atol=1e-4)
    best = minimize_scalar(lambda x: -cases.von_mises_force(x), bounds=(0, 50), method="bounded",
                           options={"xatol": 1e-10})
    kinds = [c.kind for c in path.critical]
    assert kinds == ["limit", "limit"]
    # within the residual tolerance, 1e-9 of the internal forces (the bar's 7e4 N): 5e-8 of the
    # limit load; measured 1.5e-10 and 6e-9
    assert path.critical[0].load_factor * 1e4 == pytest.approx(-best.fun, rel=5e-8)  # 4001.4155 N
    assert path.critical[1].load_factor == pytest.approx(-path.critical[0].load_factor, rel=5e-8)  # symmetry
    assert w[-1] > 2 * 50.0  # through to the inverted side (twice the rise)
    assert list(path.stable[[0, -1]]) == [True, True] and path.stopped_by == "stop"
    _check_stability(path)


def test_the_same_truss_in_si_units_takes_the_same_path():
    """m, N, Pa instead of mm, N, MPa: the same load factors and the same steps (the arc length
    and the tolerances are scale-free)."""
    kw = dict(steps=12, arc_length=0.05, progress=False)
    mm = flexmb.trace(cases.von_mises_truss(), **kw)
    si = flexmb.trace(cases.von_mises_truss(span=1.0, rise=0.05, E=210e9, A=1e-4, I=1e-7), **kw)
    np.testing.assert_allclose(si.load_factor, mm.load_factor, rtol=1e-9, atol=1e-12)
    assert [s.iterations for s in si] == [s.iterations for s in mm]
    assert [c.load_factor for c in si.critical] == pytest.approx([c.load_factor for c in mm.critical], rel=1e-9)


def test_a_slender_truss_bar_buckles_first_a_bifurcation_at_eulers_load():
    """With I = 2000 mm^4 the bar (pinned-pinned) buckles before the truss snaps: a bifurcation
    (stability lost, no load-factor extremum) where the axial force reaches pi^2 EI / l^2 (l the
    current length). The co-rotational bar is stiff by 4.7, 1.1, 0.22 % at 4, 8, 16 elements."""
    E, A, I, b, h = 210000.0, 100.0, 2000.0, 500.0, 50.0
    path = flexmb.trace(cases.von_mises_truss(I=I, elements=16), steps=6, arc_length=0.05, progress=False)
    first = path.critical[0]
    assert first.kind == "bifurcation"
    l0 = math.hypot(b, h)

    def excess(w):
        l = math.hypot(b, h - w)
        return E * A * (l0 - l) / l0 - math.pi**2 * E * I / l**2

    w = brentq(excess, 0.0, 20.0)
    assert first.load_factor * 1e4 == pytest.approx(float(cases.von_mises_force(w)), rel=5e-3)
    assert -first.solution.displacement("T")[1] == pytest.approx(w, rel=5e-3)
    _check_stability(path)


def test_the_perfect_euler_strut_bifurcates_at_eulers_load():
    """Clamped-free strut, 20 Euler-Bernoulli elements: the straight path loses stability at
    lam = P / P_E = 1 (Euler, P_E = pi^2 EI / 4 L^2) + the mesh's 5e-4; no limit point. Kept on
    its primary branch (``branch="primary"``) the path goes on straight and unstable."""
    path = flexmb.trace(cases.euler_strut(load=math.pi**2 / 4, imperfection=0.0), arc_length=0.05,
                        max_load_factor=1.5, progress=False, branch="primary")
    assert [c.kind for c in path.critical] == ["bifurcation"] and not path.critical[0].switched
    assert path.critical[0].load_factor == pytest.approx(1.0, rel=1e-3)
    assert path.load_factor[-1] == 1.5 and path.stopped_by == "max_load_factor"  # the target reached exactly
    assert np.all(path.stable == (path.load_factor < path.critical[0].load_factor))
    _check_stability(path)


def test_the_imperfect_strut_follows_the_elastica():
    """Tip load with a 1e-4 lateral imperfection: past the buckling load the path approaches the
    inextensible elastica (Timoshenko & Gere 1961, Sec. 2.7): P / P_E against the tip rotation
    within 1e-3 beyond 0.5 rad (measured 3.5e-4 at 20 elements, 1.1e-4 at 40)."""
    path = flexmb.trace(cases.euler_strut(load=math.pi**2 / 4, imperfection=1e-4), steps=200, arc_length=0.05,
                        progress=False, stop=lambda s: s.rotation_vector("B")[0] > 1.5)
    alpha = np.array([s.rotation_vector("B")[0] for s in path])
    ratio, shortening, deflection = cases.strut_elastica(alpha)
    far = alpha > 0.5
    assert far.sum() > 5 and path.stopped_by == "stop"
    np.testing.assert_allclose(path.load_factor[far], ratio[far], rtol=1e-3)
    tip = np.array([s.displacement("B") for s in path])
    np.testing.assert_allclose(-tip[far, 0], shortening[far], rtol=0, atol=2e-3)
    np.testing.assert_allclose(tip[far, 1], deflection[far], rtol=0, atol=2e-3)
    assert path.stable.all() and not path.critical


# -- published cases -----------------------------------------------------------------------------------------

def test_lee_frame_limit_loads_and_snap_back():
    """Lee's frame (E = 720, A = 6, I = 2, L = 120): the upper limit load in P L^2 / EI against
    the 18.5 commonly quoted from Schweizerhof & Wriggers (1986, 10 elements; quoted, the paper
    not at hand): 18.66 here with 10 elements per member, 18.56 with 40. The lower one has
    no published number at hand: against this model's own 40-element value, -9.427 (-9.618 at
    10: mesh convergence). Snap-back: the load point's downward travel turns back on the
    unstable branch while the load keeps falling."""
    path = flexmb.trace(cases.lee_frame(elements=10), steps=120, arc_length=1.0, progress=False,
                        stop=lambda s: -s.displacement("P")[1] > 95.0)
    EI_L2 = 720.0 * 2.0 / 120.0**2
    limits = [c.load_factor / EI_L2 for c in path.critical if c.kind == "limit"]
    assert len(limits) == 2
    assert limits[0] == pytest.approx(18.5, rel=0.01) and limits[1] == pytest.approx(-9.427, rel=0.025)
    v = np.array([-s.displacement("P")[1] for s in path])
    unstable = ~path.stable
    lam = path.load_factor
    turn = np.flatnonzero(unstable[1:-1] & (np.diff(v)[:-1] > 0) & (np.diff(v)[1:] < 0))
    assert len(turn) == 1 and np.all(np.diff(lam[turn[0]:turn[0] + 3]) < 0)  # v turns back, lam still falls
    _check_stability(path)


@pytest.mark.slow
def test_deep_arch_limit_load():
    """DaDeppo & Schmidt (1975): the 215 deg clamped-hinged arch under an apex load buckles at
    P R^2 / EI = 9.0 (inextensible); here 40 chords, R / r = 1e4: 9.011. Traced on through the
    snap-back of the apex's travel, with the stability flag against the eigenvalues."""
    path = flexmb.trace(cases.deep_arch(), steps=150, arc_length=0.25, progress=False)
    limits = [c for c in path.critical if c.kind == "limit"]
    assert limits and limits[0].load_factor == pytest.approx(9.0, rel=5e-3)
    assert path.load_factor.max() < limits[0].load_factor + 1e-9
    _check_stability(path)


# -- the Path object and bad input ----------------------------------------------------------------------------

def test_path_table_csv_and_vtk(tmp_path):
    path = flexmb.trace(cases.von_mises_truss(), steps=5, arc_length=0.1, progress=False)
    t = path.table(links=["T"])
    for col in ("load_factor", "stable", "negative_eigenvalues", "arc_length", "converged", "T.y", "T.Fx"):
        assert col in t
    np.testing.assert_array_equal(t["load_factor"], path.load_factor)
    assert np.all(np.diff(t["arc_length"]) > 0)
    back = flexmb.read_csv(path.to_csv(tmp_path / "p.csv", links=["T"]))
    np.testing.assert_allclose(back["T.y"], t["T.y"], rtol=1e-12)
    files = flexmb.export.write_series(path, tmp_path / "p.pvd")
    assert files is not None
    assert "Path(6 points" in repr(path)


def test_a_mechanism_with_nothing_to_scale_is_refused():
    m = cases.von_mises_truss()
    m.clear_loads()
    with pytest.raises(ModelError, match="nothing to scale"):
        flexmb.trace(m)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(method="ksd-full"), UnsupportedStrategyError, "conventional"),
    (dict(steps=0), ParameterError, "steps"),
    (dict(arc_length=-1.0), ParameterError, "arc_length"),
    (dict(max_load_factor=0.0), ParameterError, "max_load_factor"),
    (dict(stop=3), ParameterError, "stop"),
    (dict(psi=-1.0), ParameterError, "psi"),
    (dict(colour="red"), UnsupportedStrategyError, "colour"),
    (dict(min_arc=10.0, max_arc=1.0), ParameterError, "min_arc=10.0 must be below max_arc"),  # was accepted
    (dict(progress="no"), ParameterError, "progress"),  # was taken as True
    (dict(rtol=1.0), ParameterError, r"rtol.*\(0, 1\)"),  # accepted every point as converged
    # the first step max_load_factor / 20 = 5e298 overflowed the constraint's square and stopped
    # "at load factor 0" without saying why (issue 19)
    (dict(max_load_factor=1e300, arc_length=1e298), ParameterError, r"arc_length=1e\+298: .* at most 1e\+150"),
    (dict(branch="other"), ParameterError, "branch='other'; valid: stable, primary, bifurcated"),
    (dict(arc_length=0.0), ParameterError, r"arc_length=0.0 must be > 0"),
    (dict(arc_length=float("nan")), ParameterError, "arc_length"),
    (dict(arc_length=1e200), ParameterError, r"arc_length=1e\+200: .* at most 1e\+150"),
    (dict(max_load_factor=float("inf")), ParameterError, "max_load_factor"),
])
def test_bad_arguments_raise_flexmb_errors(kwargs, error, match):
    with pytest.raises(error, match=match):
        flexmb.trace(cases.von_mises_truss(), **kwargs)
    assert issubclass(error, FlexmbError)


def test_sweep_refuses_a_progress_that_is_not_a_flag_as_trace_does():
    m = cases.von_mises_truss()
    with pytest.raises(ParameterError, match="sweep: progress='no' must be True or False"):
        flexmb.sweep(m, [0.1, 0.2], progress="no")


def test_a_path_that_cannot_continue_is_reported_with_its_points():
    """No corrector may turn a node by more than 1e-12 rad, so no step converges: the path stops,
    says where, and keeps what it reached (here the start)."""
    path = flexmb.trace(cases.lee_frame(), steps=5, arc_length=1.0, max_rotation=1e-12, progress=False)
    assert path.stopped_by == "failure" and "cannot continue from load factor 0" in path.message
    assert len(path) == 1 and path[0].converged and path.load_factor[0] == 0.0


def test_the_first_step_is_scaled_to_a_huge_reference_load():
    """The von Mises truss (`flexmb.studies.paths.von_mises_truss`: limit load 4001.4 N, closed
    form) under a 1e12 N reference load: the default first step was max_load_factor / 20 = 5e10
    (5e22 N), and every halving down to min_arc found no equilibrium: "cannot continue from load
    factor 0". The first step now moves the truss by at most `FIRST_MOTION` of its size in the
    linear response, and the path goes through the limit point (at 4001.4 N / 1e12)."""
    m = cases.von_mises_truss(load=1e12)
    path = flexmb.trace(m, max_load_factor=1e12, steps=40, progress=False,
                        stop=lambda s: -s.displacement("T")[1] > 60.0)
    assert path.stopped_by == "stop" and len(path) > 10
    assert [c.kind for c in path.critical][:1] == ["limit"]
    assert path.critical[0].load_factor * 1e12 == pytest.approx(4001.4155, rel=1e-6)
    # the same with a negative target: the first step goes the other way, as small
    back = flexmb.trace(m, max_load_factor=-1e300, steps=3, progress=False)
    assert back.load_factor[1] < 0 and -back.load_factor[1] * 1e12 < 4001.4


def test_a_first_step_too_large_to_converge_is_named_in_the_stop_message():
    """An explicit arc_length of 5e10 on the truss (reference load 1e4 N, limit load factor 0.4):
    every halving down to min_arc (1e-4) x it finds no equilibrium; the message names the step
    and where it came from."""
    path = flexmb.trace(cases.von_mises_truss(), arc_length=5e10, progress=False)
    assert path.stopped_by == "failure" and len(path) == 1
    assert "cannot continue from load factor 0" in path.message
    assert "the first step's 5e+10" in path.message
    assert "first step's load-factor increment 5e+10 is arc_length" in path.message


def test_a_path_beyond_the_elastic_range_warns_as_solve_and_sweep_do():
    """A steel leaf 50 x 10 x 0.5 mm (SI) under 10 kN at its tip (kN typed for N): the path runs
    at strains a linear-elastic beam cannot represent; `solve` and `sweep` say so
    (PlausibilityWarning), and so must `trace`, once, naming the load factor; 1 N stays quiet."""
    def leaf(force):
        m = flexmb.Mechanism(dim=2)
        m.add_link("g", fixed=True)
        m.add_link("t", position=(0.05, 0.0))
        m.add_joint("g", "t", "leaf_spring", length=0.05, thickness=0.0005, width=0.01, elements=8)
        m.apply_force("t", (0.0, force))
        return m

    with pytest.warns(flexmb.errors.PlausibilityWarning, match="trace, at load factor .*peak strain"):
        path = flexmb.trace(leaf(1e4), steps=30, progress=False)  # strain 0.021 at load factor 0.0075
    assert len(path) == 31  # the path itself is kept whole
    with warnings.catch_warnings():
        warnings.simplefilter("error", flexmb.errors.PlausibilityWarning)
        flexmb.trace(leaf(1.0), steps=5, progress=False)


def test_a_stop_predicate_that_raises_ends_the_path_with_its_points():
    """A bug in the user's ``stop`` (here a ZeroDivisionError from its third call on: the start and
    two points passed) does not discard the points already traced: the path ends there, says why,
    and warns."""
    calls = []

    def stop(solution):
        calls.append(solution.load_factor)
        return len(calls) > 2 and 1 / 0

    with pytest.warns(UserWarning, match="stop\\(\\) raised ZeroDivisionError"):
        path = flexmb.trace(cases.von_mises_truss(), steps=10, arc_length=0.05, stop=stop, progress=False)
    assert path.stopped_by == "failure" and "ZeroDivisionError" in path.message
    assert len(path) == 3 and all(s.converged for s in path)  # the start and the two points stop() saw


def test_qiu_bistable_snaps_through_between_two_stable_states():
    """Qiu, Lang & Slocum's (2004) double curved beam (Q = h/t = 12) under force control, with a
    1e-3 third-mode imperfection: stable up to the forward switching force, unstable on the way
    down to the backward one, stable again through the second stable state (force 0 at about
    twice the rise, the mirrored shape). The switching forces against Qiu's modal model
    (`qiu_switching_forces`: 0.0481 N, -0.0237 N): measured -4.9 % and -5.3 % (the model keeps
    modes 1 and 3 of a shallow beam; the imperfection lowers F_top by 2 %)."""
    f_top, f_bot = cases.qiu_switching_forces()
    path = flexmb.trace(cases.qiu_bistable(load=f_top), steps=150, arc_length=0.05, progress=False,
                        stop=lambda s: -s.displacement("C")[1] > 2.6e-4)
    assert [c.kind for c in path.critical] == ["limit", "limit"]
    top, bottom = (c.load_factor * f_top for c in path.critical)
    assert top == pytest.approx(f_top, rel=0.06) and top < f_top
    assert bottom == pytest.approx(f_bot, rel=0.06) and bottom > f_bot
    d = np.array([-s.displacement("C")[1] for s in path])
    second = np.flatnonzero(np.diff(np.sign(path.load_factor)) > 0)[-1] + 1  # the force turns positive again
    assert d[second] == pytest.approx(2 * 1.2e-4, rel=0.02) and path.stable[second]
    arcs = [c.arc_length for c in path.critical]
    between = (path.arc_length > arcs[0]) & (path.arc_length < arcs[1])
    assert between.sum() > 5 and not path.stable[between].any() and path.stable[~between].all()
    _check_stability(path)


def test_the_perfect_bistable_bifurcates_into_the_third_mode():
    """Without the imperfection the beam reaches the third mode's buckling load on its way down
    (Qiu's mode switch): a bifurcation at the forward switching force, 3.0 % below the modal
    model's (measured)."""
    f_top, _ = cases.qiu_switching_forces()
    path = flexmb.trace(cases.qiu_bistable(load=f_top, imperfection=0.0), steps=12, arc_length=0.05,
                        progress=False)
    first = path.critical[0]
    assert first.kind == "bifurcation" and first.load_factor == pytest.approx(1.0, rel=0.05)


# -- hinges (ideal revolute joints, with Lagrange multipliers) ------------------------------------------------

def _hinged_column(top_rotation_held: bool, elements: int = 16):
    """A column of length 1 (EI = 1) from link A, pinned to the ground G by a hinge, to link B,
    held sideways (x) and loaded downwards by pi^2 EI / L^2; B's rotation held or free."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("G", fixed=True)
    m.add_link("A")
    m.add_joint("G", "A", "hinge", origin=(0.0, 0.0))
    cases.polyline(m, np.column_stack([np.zeros(elements + 1), np.linspace(0.0, 1.0, elements + 1)]),
                   cases.beam_section(1.0, 1e7, 1.0), ["A"] + [f"c{i}" for i in range(1, elements)] + ["B"])
    m.prescribe("B", x=0.0, **({"rotation": 0.0} if top_rotation_held else {}))
    m.apply_force("B", (0.0, -math.pi**2))
    return m


@pytest.mark.parametrize("held, critical", [
    (False, 1.0),                      # pinned-pinned: pi^2 EI / L^2
    (True, 4.493409457909064**2 / math.pi**2),  # pinned-fixed: (4.4934)^2 EI / L^2, tan(kL) = kL
])
def test_hinged_euler_columns_bifurcate_at_their_closed_form_loads(held, critical):
    """Pin supports as hinges to a fixed link (`flexmb.joints.Hinge`): the stability is the
    inertia of the tangent on the motions the hinges allow; the straight column loses it at the
    Euler load, from above at order 2 (the co-rotational chord's geometric stiffness): measured
    +1.3, +0.24, +0.08 % pinned-pinned and +2.6, +0.52, +0.13 % pinned-fixed at 8, 16, 32 elements."""
    path = flexmb.trace(_hinged_column(held), arc_length=0.1, max_load_factor=2.2, progress=False, branch="primary")
    assert [c.kind for c in path.critical] == ["bifurcation"]
    assert 0 < path.critical[0].load_factor / critical - 1 < 7e-3  # 16 elements
    assert path.stable[0] and not path.stable[-1]


def _motor_on_leaf(angle: float, elements: int) -> flexmb.Mechanism:
    """A hinge motor (ground G to link A, at the origin) turning A, and a 0.1 m leaf spring from A to B."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("G", fixed=True)
    m.add_link("A")
    m.add_link("B", (0.1, 0.0))
    m.add_joint("G", "A", "hinge", angle=angle, origin=(0.0, 0.0))
    m.add_joint("A", "B", "leaf_spring", elements=elements)
    return m


def test_the_load_factor_derivative_with_a_hinge_motor():
    """A motor hinge ramps its angle with the load factor: its constraint row's rate is part of
    d r / d lam (central differences, as above, at lam = 0.4)."""
    m = _motor_on_leaf(0.5, elements=3)
    m.apply_force("B", (0.0, -2.0))
    problem = m.compile().problem
    lam, h = 0.4, 1e-6
    rng = np.random.default_rng(2)  # a configuration off equilibrium, multipliers included
    state = problem.model.apply_increment(problem.model.initial_state(),
                                          problem.full_increment(rng.normal(scale=1e-2, size=problem.n_free),
                                                                 np.zeros(len(problem.prescribed))))
    g, _ = load_tangent(problem, state, lam)
    fd = (problem.residual(state, lam + h) - problem.residual(state, lam - h))[problem.free] / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=0, atol=FD_TANGENT * np.max(np.abs(fd)))
    assert np.max(np.abs(g[-1:])) > 0  # the motor's row moves


def test_a_motor_alone_is_something_to_scale():
    """A hinge motor turning a leaf spring: the path follows the motor (the leaf bends with it)."""
    m = _motor_on_leaf(0.3, elements=4)
    m.prescribe("B", x=0.0, y=0.0)  # B pinned: the motor bends the leaf
    path = flexmb.trace(m, arc_length=0.1, max_load_factor=1.0, progress=False)
    assert path.stopped_by == "max_load_factor" and path[-1].pose("A")[1] == pytest.approx(0.3, abs=1e-12)


def test_a_spatial_strut_buckles_about_its_weak_axis():
    """3D: a clamped-free leaf spring (width 20 x thickness 1, 10 elements) under an axial tip
    load bifurcates at Euler's load about the weak axis, pi^2 E I_z / (4 L^2) (+0.2 % measured:
    the mesh and shear), long before the strong axis (400 x)."""
    leaf = flexmb.LeafSpring(length=0.1, width=0.02, thickness=1e-3, elements=10)
    s = leaf.cross_section()
    P = math.pi**2 * s.E * s.Iz / (4 * leaf.length**2)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", (0.1, 0.0, 0.0))
    m.add_joint("A", "B", leaf)
    m.apply_force("B", (-P, 0.0, 0.0))
    path = flexmb.trace(m, arc_length=0.1, max_load_factor=1.3, progress=False)
    assert [c.kind for c in path.critical] == ["bifurcation"]
    assert path.critical[0].load_factor == pytest.approx(1.0, rel=5e-3)
    _check_stability(path)


def test_the_sparse_inertia_equals_the_dense_one():
    """Above `DENSE_EIGEN_BELOW` free DOFs the negative count comes from a sparse LDL^T and the
    eigenvalues nearest zero from ARPACK: the same as LAPACK's on a banded symmetric matrix with
    three negative eigenvalues (and a non-symmetric part that the inertia ignores)."""
    import scipy.sparse as sp

    from flexmb.solvers.arclength import DENSE_EIGEN_BELOW, inertia

    n = DENSE_EIGEN_BELOW + 100
    rng = np.random.default_rng(3)
    d = np.linspace(0.5, 10.0, n)
    d[[7, 250, 480]] = [-2.0, -0.3, -5.0]
    off = 0.05 * rng.normal(size=n - 1)
    K = sp.diags([d, off, off + 0.01], [0, 1, -1]).tocsr()  # skew part 0.005 on the off-diagonals
    neg, near = inertia(K)
    ev = sla.eigvalsh(0.5 * (K + K.T).toarray())
    assert neg == np.sum(ev < 0) == 3
    np.testing.assert_allclose(near, np.sort(ev[np.argsort(np.abs(ev))[:4]]), rtol=1e-8)


@pytest.mark.parametrize("build", [_lever_2d, _chain_3d])
def test_the_path_reaches_the_mechanism_as_given_at_load_factor_one(build):
    """lam = 1 is the mechanism as given: the path's last point at max_load_factor=1 is the
    equilibrium `flexmb.solve` finds (2D offset loads and prescribed motion; 3D dead moment and a
    prescribed rotation chain), to the solvers' tolerances."""
    path = flexmb.trace(build(), arc_length=0.1, max_load_factor=1.0, progress=False)
    ref = flexmb.solve(build())
    assert path.stopped_by == "max_load_factor" and path.load_factor[-1] == 1.0
    np.testing.assert_allclose(path[-1].node_positions(), ref.node_positions(), rtol=0, atol=1e-9)
    # free components of a reaction are residuals: both below 1e-8 of the reaction's size
    w = ref.reaction("C")
    np.testing.assert_allclose(path[-1].reaction("C"), w, rtol=0, atol=1e-8 * np.max(np.abs(w)))


def test_the_sparse_kth_eigenvalue_equals_the_dense_one():
    """Above `DENSE_EIGEN_BELOW` the eigenvalue that crosses zero (the k-th ascending) comes from
    the negative count and shift-invert ARPACK at 0: the same as LAPACK's, on either side of 0."""
    import scipy.sparse as sp

    from flexmb.solvers import arclength

    n = arclength.DENSE_EIGEN_BELOW + 100
    d = np.linspace(0.5, 10.0, n)
    d[[7, 250, 480]] = [-2.0, -0.3, -5.0]
    K = sp.diags([d, np.full(n - 1, 0.05), np.full(n - 1, 0.05)], [0, 1, -1]).tocsr()

    class Problem:  # what `_kth_eigenvalue` reads of a problem
        def evaluate(self, state, lam):
            return None, K, None, None

        def reduced_tangent(self, Kff):
            return Kff

    point = _bare_point()
    ev = sla.eigvalsh(K.toarray())
    for k in (0, 2, 3, 5):
        assert arclength._kth_eigenvalue(Problem(), point, k) == pytest.approx(ev[k], rel=1e-9)


def _bare_point():
    """A `PathPoint` with nothing but its place (for functions that evaluate the problem there)."""
    from flexmb.solvers.arclength import PathPoint

    return PathPoint(None, 0.0, None, None, 0.0, 1.0, 0, np.zeros(0), 0.0, 0.0, 0)


def test_both_branches_can_be_asked_for():
    """The hinged pinned-pinned column past its Euler load: by default the path takes the stable
    post-buckled branch (switched at the bifurcation); at the second bifurcation it meets (P /
    P_E = 2.19, the ends turned 131 deg) no branch is stable and the path leaves its unstable
    continuation for the bifurcated branch (the critical mode grows), as ``branch="bifurcated"``
    does; ``branch="primary"`` never leaves the straight path."""
    kw = dict(arc_length=0.1, max_load_factor=2.2, progress=False)
    stable = flexmb.trace(_hinged_column(False), **kw)
    assert [(c.kind, c.switched) for c in stable.critical][:2] == [("bifurcation", True), ("bifurcation", True)]
    after = np.flatnonzero(stable.arc_length > stable.critical[1].arc_length)
    assert stable.negative_eigenvalues[after[0]] > 0  # no stable branch there
    bifurcated = flexmb.trace(_hinged_column(False), **kw, branch="bifurcated")
    assert [(c.kind, c.switched) for c in bifurcated.critical][:2] == [("bifurcation", True), ("bifurcation", True)]
    assert bifurcated.critical[1].load_factor == pytest.approx(stable.critical[1].load_factor, rel=1e-6)
    primary = flexmb.trace(_hinged_column(False), **kw, branch="primary")
    assert [(c.kind, c.switched) for c in primary.critical] == [("bifurcation", False)]
    assert np.allclose([s.rotation_vector("A")[0] for s in primary], 0.0, atol=1e-12)
