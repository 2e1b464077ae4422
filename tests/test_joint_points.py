"""Points inside a joint (issue 29, item 4): a load, a prescribed motion and a response at a
fraction of a leaf's length, without splitting the joint (`Mechanism.add_joint_point`,
`flexmb.fe.joint_points`). References: Timoshenko beam closed forms (cantilever under a point
load with shear, Timoshenko & Gere; the clamped-clamped beam under a central load)."""

import json
import math

import numpy as np
import pytest

import flexmb
from flexmb.errors import ModelError, ParameterError, UnsupportedStrategyError

from tolerances import FD_TANGENT

L, E, W, T = 0.1, 200e9, 0.02, 1e-3  # a steel leaf [m, Pa]


def _leaf(dim: int, elements: int, fixed_b: bool = False) -> flexmb.Mechanism:
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", (L,) + (0.0,) * (dim - 1), fixed=fixed_b)
    m.add_joint("A", "B", "leaf_spring", name="leaf", length=L, width=W, thickness=T, E=E, nu=0.3, elements=elements)
    return m


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("elements", [12, 48])
def test_a_point_load_inside_a_cantilever_leaf(dim, elements):
    """A small load P at 0.3 L of a clamped-free leaf (not a mesh node at 12 or 48 elements: the
    element there is split): the deflection at the point ``P a^3 / (3 EI) + P a / (k G A)`` and
    at the tip ``P a^2 (3 L - a) / (6 EI) + P a / (k G A)`` (Timoshenko beam), in-plane and, in
    3D, out of plane (stiff axis, I_y), within the load's geometric nonlinearity (1e-6)."""
    m = _leaf(dim, elements)
    m.add_joint_point("leaf", "P", 0.3)
    P, a = 0.01, 0.3 * L
    force = (0.0, -P) if dim == 2 else (0.0, -P, 0.5 * P)
    m.apply_force("P", force)
    sol = flexmb.solve(m)
    s = flexmb.LeafSpring(length=L, width=W, thickness=T, E=E, nu=0.3).cross_section()
    for axis, I, k, F in [(1, s.Iz, s.ky, -P)] + ([(2, s.Iy, s.kz, 0.5 * P)] if dim == 3 else []):
        shear = F * a / (k * s.G * s.A)
        at_point = F * a**3 / (3 * s.E * I) + shear
        at_tip = F * a**2 * (3 * L - a) / (6 * s.E * I) + shear
        assert sol.displacement("P")[axis] == pytest.approx(at_point, rel=1e-6)
        assert sol.displacement("B")[axis] == pytest.approx(at_tip, rel=1e-6)
    np.testing.assert_allclose(sol.pose("P")[0], np.r_[0.3 * L, np.zeros(dim - 1)] + sol.displacement("P"), atol=1e-15)


@pytest.mark.parametrize("elements", [12, 48])
def test_a_prescribed_motion_inside_a_clamped_leaf_and_its_reaction(elements):
    """Both ends clamped, the midpoint (a mesh node) pushed by 1 um: the force that holds it,
    ``delta / (L^3 / (192 EI) + L / (4 k G A))``, within 1e-6."""
    m = _leaf(2, elements, fixed_b=True)
    m.add_joint_point("leaf", "M", 0.5)
    m.prescribe("M", y=-1e-6)
    sol = flexmb.solve(m)
    s = flexmb.LeafSpring(length=L, width=W, thickness=T, E=E, nu=0.3).cross_section()
    force = -1e-6 / (L**3 / (192 * s.E * s.Iz) + L / (4 * s.ky * s.G * s.A))
    assert sol.reaction("M")[1] == pytest.approx(force, rel=1e-6)
    assert sol.displacement("M")[1] == -1e-6


def test_a_load_inside_a_cross_flexure_leaf():
    """A load at a third of a cross flexure's second leaf (a mesh node at 9 elements per leaf: no
    split), the pivot turned 0.2 rad: the point is that node of the leaf (its reference position)
    and the load is balanced there (the free residual), and it changes the pivot's moment."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", (0.0, 0.1 * math.sin(math.pi / 4)))
    m.add_joint("A", "B", "cross_flexure", name="pivot", elements_per_leaf=9)
    m.add_joint_point("pivot", "Q", 1 / 3, leaf=1)
    m.apply_force("Q", (-2.0, 0.5))
    m.prescribe("B", rotation=0.2)
    sol = flexmb.solve(m)
    compiled = sol.compiled
    node = compiled.joint_points["Q"]
    start, end, _ = flexmb.CrossFlexure(elements_per_leaf=9).leaves(2)[1]
    np.testing.assert_allclose(compiled.problem.model.x0[node], start + (end - start) / 3, atol=1e-15)  # a node: 3 of 9
    r = sol.residual[compiled.problem.model.node_dofs[node]]
    assert np.max(np.abs(r)) < 1e-8  # the load is balanced there
    moved = flexmb.Mechanism(dim=2)
    moved.add_link("A", fixed=True)
    moved.add_link("B", (0.0, 0.1 * math.sin(math.pi / 4)))
    moved.add_joint("A", "B", "cross_flexure", name="pivot", elements_per_leaf=9)
    moved.prescribe("B", rotation=0.2)
    free = flexmb.solve(moved)
    assert abs(sol.reaction("B")[2] - free.reaction("B")[2]) > 1e-3  # the load changes the moment


def test_the_tangent_of_a_remeshed_joint_equals_central_differences():
    """The mesh split at a joint point (0.37 of a 5-element leaf): the free tangent at a deformed,
    unbalanced state against central differences of the residual."""
    m = _leaf(2, 5)
    m.add_joint_point("leaf", "P", 0.37)
    m.apply_force("P", (0.3, -40.0))
    m.apply_force("B", (0.0, 10.0))
    sol = flexmb.solve(m)
    problem = sol.compiled.problem
    rng = np.random.default_rng(7)
    state = problem.model.apply_increment(sol.state, problem.full_increment(rng.normal(scale=1e-3, size=problem.n_free),
                                                                            np.zeros(len(problem.prescribed))))
    _, K, _, _ = problem.evaluate(state, 1.0)
    K = K.toarray()
    h = 1e-7
    fd = np.empty_like(K)
    for j in range(problem.n_free):
        e = np.zeros(problem.n_free)
        e[j] = h
        plus = problem.model.apply_increment(state, problem.full_increment(e, np.zeros(len(problem.prescribed))))
        minus = problem.model.apply_increment(state, problem.full_increment(-e, np.zeros(len(problem.prescribed))))
        fd[:, j] = (problem.residual(plus, 1.0) - problem.residual(minus, 1.0))[problem.free] / (2 * h)
    np.testing.assert_allclose(K, fd, rtol=0, atol=FD_TANGENT * np.max(np.abs(K)))


def test_an_imperfection_load_inside_a_leaf_turns_the_double_bifurcation_into_a_limit_point():
    """The bistable pair pushed by a force, with 0.1 % of it sideways at the middle of one leaf
    (what issue 29's user had to fake by splitting the leaf into two joints): the perfect pair's
    double bifurcation splits into the other (perfect) leaf's simple bifurcation and the loaded
    leaf's limit point (an imperfect unstable-symmetric bifurcation), both below the perfect
    pair's, where the device snaps (`Path.snap`, the limit); the point's sideways travel grows
    towards it."""
    from flexmb.studies.paths import bistable_pair

    perfect = flexmb.trace(bistable_pair(12, "load"), steps=12, progress=False).snap.load_factor
    m = bistable_pair(12, "load")
    m.add_joint_point("leaf_spring_0", "mid", 0.5)
    m.apply_force("mid", (0.0, 0.1))  # 0.1 % of the 100 N push, (nearly) across the leaf
    path = flexmb.trace(m, steps=40, progress=False, stop=lambda s: -s.displacement("S")[1] > 1.0)
    snap = path.snap
    assert [(c.kind, c.multiplicity) for c in path.critical] == [("bifurcation", 1), ("limit", 1)]
    assert snap is path.critical[1] and 0.95 * perfect < path.critical[0].load_factor < snap.load_factor < perfect
    side = [abs(s.displacement("mid")[1]) for s in path]
    assert side[1] < side[3] < abs(snap.solution.displacement("mid")[1])


@pytest.mark.parametrize("call, error, match", [
    (lambda m: m.add_joint_point("nope", "P", 0.5), ModelError, "no joint named 'nope'"),
    (lambda m: m.add_joint_point("leaf", "P", 1.0), ParameterError, r"fraction=1.0 must be in \(0, 1\)"),
    (lambda m: m.add_joint_point("leaf", "P", 0.5, leaf=1), ModelError, "leaf=1; joint 'leaf_spring' has leaves 0 ... 0"),
    (lambda m: m.add_joint_point("leaf", "B", 0.5), ModelError, "named 'B' exists already"),
])
def test_bad_joint_points_are_refused(call, error, match):
    m = _leaf(2, 4)
    with pytest.raises(error, match=match):
        call(m)
        flexmb.solve(m)


def test_a_joint_point_needs_the_finite_element_model():
    m = _leaf(2, 4)
    m.add_joint_point("leaf", "P", 0.5)
    m.apply_force("P", (0.0, -1.0))
    with pytest.raises(UnsupportedStrategyError, match="points inside a joint .* finite-element model"):
        flexmb.solve(m, method="newton")


def test_changing_a_joint_point_load_recompiles():
    """A solve reuses the compiled model while the mechanism is unchanged; a load added at a joint
    point is a change (the cache sees it)."""
    m = _leaf(2, 6)
    m.add_joint_point("leaf", "P", 0.5)
    m.apply_force("P", (0.0, -1.0))
    first = flexmb.solve(m).displacement("B")[1]
    m.apply_force("P", (0.0, -1.0))
    assert flexmb.solve(m).displacement("B")[1] == pytest.approx(2 * first, rel=1e-3)


def _with_points(dim: int) -> flexmb.Mechanism:
    """A clamped-guided leaf and a cross flexure in series, as a user builds them, with points
    inside both: a load and a moment at 0.3 of the leaf, a prescribed motion (3D: a rotation
    vector too) at 0.6 of it, and a load on the cross flexure's second leaf."""
    z = (0.0,) * (dim - 2)
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", (L,) + (0.0,) * (dim - 1))
    m.add_link("C", (L, 0.1 * math.sin(math.pi / 4)) + z)
    m.add_joint("A", "B", "leaf_spring", name="leaf", length=L, width=W, thickness=T, E=E, nu=0.3, elements=7)
    m.add_joint("B", "C", "cross_flexure", name="pivot", elements_per_leaf=5, origin=(L, 0.0) + z,
                rotation=math.pi / 2 if dim == 2 else (0.0, 0.0, math.pi / 2))
    m.add_joint_point("leaf", "P", 0.3)
    m.add_joint_point("leaf", "M", 0.6)
    m.add_joint_point("pivot", "Q", 1 / 3, leaf=1)
    m.apply_force("P", (0.0, -0.5) + (0.1,) * (dim - 2))
    m.apply_moment("P", 1e-3 if dim == 2 else (0.0, 2e-4, 1e-3))
    m.prescribe("M", y=-2e-4)
    if dim == 3:
        m.prescribe("M", z=1e-4, rotation=(0.0, 1e-3, -2e-3))
    m.apply_force("Q", (-0.3, 0.2) + z)
    m.prescribe("C", rotation=0.05 if dim == 2 else (0.0, 0.0, 0.05))
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_joint_points_round_trip_through_a_mechanism_file_bit_for_bit(dim, tmp_path):
    """`flexmb.save` writes the points inside joints (format version 2: ``joint_points``,
    ``joint_point_loads`` and their prescribed motions under ``prescribed``); `flexmb.load`
    gives the same mechanism: the same file again, the same compiled problem and a solve
    identical bit for bit, the points' displacements and reactions included. A mechanism
    without them is still written as version 1."""
    m = _with_points(dim)
    path = flexmb.save(m, tmp_path / "points.json")
    doc = json.loads(path.read_text())
    assert doc["version"] == 2 and [p["name"] for p in doc["joint_points"]] == ["P", "M", "Q"]
    loaded = flexmb.load(path)
    assert flexmb.files.dumps(loaded) == path.read_text()
    assert loaded.joint_points == m.joint_points
    pa, pb = m.compile().problem, loaded.compile().problem
    assert np.array_equal(pa.model.x0, pb.model.x0) and np.array_equal(pa.prescribed, pb.prescribed)
    assert np.array_equal(pa.values, pb.values) and np.array_equal(pa.loads.force, pb.loads.force)
    a, b = flexmb.solve(m), flexmb.solve(loaded)
    assert a.converged and a.iterations == b.iterations
    assert np.array_equal(a.residual_history, b.residual_history)
    assert np.array_equal(a.node_positions(), b.node_positions())
    for name in ("P", "M", "Q", "C"):
        assert np.array_equal(a.displacement(name), b.displacement(name)), name
        assert np.array_equal(a.reaction(name), b.reaction(name)), name
    assert abs(a.reaction("M")[1]) > 1.0  # the prescribed point is held by a real force
    plain = _leaf(dim, 4)
    assert json.loads(flexmb.files.dumps(plain))["version"] == 1 and "joint_points" not in flexmb.files.dumps(plain)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_prescribed_motion_inside_a_joint_swept(dim):
    """`flexmb.sweep(motion=("M", "y"))` at the midpoint of a clamped-clamped leaf: each value's
    holding force is the Timoshenko closed form ``delta / (L^3 / (192 EI) + L / (4 k G A))``
    (within 1e-6: motions below 1e-3 of the thickness, where the
    leaf's stretching adds (delta / t)^2), each solution is `flexmb.solve` of the mechanism prescribed
    there (to 1e-9 of the motion), and the table names the swept column ``M.y``."""
    m = _leaf(dim, 12, fixed_b=True)
    m.add_joint_point("leaf", "M", 0.5)
    m.prescribe("M", y=0.0)
    values = np.array([-2e-7, -4e-7, 1e-7, 6e-7])
    result = flexmb.sweep(m, values, motion=("M", "y"), progress=False)
    assert result.quantity == "M.y" and result.converged.all()
    np.testing.assert_array_equal(result.table()["M.y"], values)
    table = result.table(links=["M"])  # the point's own columns: its position and the force holding it
    np.testing.assert_array_equal(table["M.Fy"], [sol.reaction("M")[1] for sol in result])
    np.testing.assert_array_equal(table["M.y#2"], [sol.pose("M")[0][1] for sol in result])
    s = flexmb.LeafSpring(length=L, width=W, thickness=T, E=E, nu=0.3).cross_section()
    stiffness = 1 / (L**3 / (192 * s.E * s.Iz) + L / (4 * s.ky * s.G * s.A))
    np.testing.assert_allclose([sol.reaction("M")[1] for sol in result], stiffness * values, rtol=1e-6)
    for value, sol in zip(values, result):
        alone = _leaf(dim, 12, fixed_b=True)
        alone.add_joint_point("leaf", "M", 0.5)
        alone.prescribe("M", y=value)
        gap = np.abs(sol.node_positions() - flexmb.solve(alone).node_positions()).max()
        assert gap <= 1e-9 * abs(value)
        assert sol.displacement("M")[1] == value


def test_a_swept_joint_point_must_be_prescribed_and_exist():
    m = _leaf(2, 6, fixed_b=True)
    m.add_joint_point("leaf", "M", 0.5)
    with pytest.raises(ModelError, match=r"the y of joint point 'M' is not prescribed; prescribe it first, e\.g\. "
                                         r"Mechanism\.prescribe\('M', y=0\.0\)"):
        flexmb.sweep(m, [1e-6], motion=("M", "y"), progress=False)
    with pytest.raises(ModelError, match="no link or joint point named 'N'; links: A, B; joint points: M"):
        flexmb.sweep(m, [1e-6], motion=("N", "y"), progress=False)
