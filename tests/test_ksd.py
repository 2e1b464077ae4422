"""KSD method and EOB (Dwarshuis et al. 2020, Secs. 2-4.3): tangents, EOB stiffness, KSD-full =
conventional, the four-bar, over-constrained and indeterminate mechanisms, database range."""

import warnings

import attrs
import numpy as np
import pytest

import flexmb
from flexmb.errors import DatabaseError, ExtrapolationWarning, TopologyError, UnsupportedStrategyError
from flexmb.ksd.geometry import rz
from flexmb.ksd.reduced import ReducedMechanism, template
from flexmb.rotations import expm_so3


def _rel_positions(a, b):
    return np.abs(a.node_positions() - b.node_positions()).max() / np.abs(b.node_positions()).max()


# -- KSD-full converges to the conventional solution (issue 4, "What it must show") -----------

@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_ksd_full_equals_conventional_on_the_cross_flexure(dim, n):
    """Step 5 solves the conventional method's equations (Sec. 2.6): same configuration."""
    m = flexmb.models.cross_flexure_pivot(n, dim=dim, rotation=np.radians(60))
    conv = flexmb.solve(m, method="conventional")
    full = flexmb.solve(m, method="ksd-full")
    assert conv.converged and full.converged
    assert full.residual_history[-1] < 5e-7
    assert _rel_positions(full, conv) < 1e-8


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_ksd_full_equals_conventional_on_the_fourbar(n):
    """Sec. 4.3 at the paper's d = 0.3 m."""
    m = flexmb.models.fourbar(n, displacement=0.3)
    conv = flexmb.solve(m, method="conventional")
    full = flexmb.solve(m, method="ksd-full")
    assert conv.converged and full.converged
    assert full.residual_history[-1] < 5e-7
    assert _rel_positions(full, conv) < 1e-8
    np.testing.assert_allclose(full.reaction("top"), conv.reaction("top"), atol=1e-6)


@pytest.mark.parametrize("n", [3, 5])
def test_ksd_full_first_tangent_takes_the_eob_axial_forces(n, monkeypatch):
    """Step 4's positions are exact to first order; along a leaf their second-order error times
    EA/L puts the full model's axial forces at the start far off, while the EOB's (Eqs. 3.8-3.11
    along each element's axis) are within 1 % of the converged ones (measured at d = 0.3 m, 5
    el./leaf: 2456 N and 1.4 N off a 169 N maximum). With the EOB's axial forces in its first
    geometric stiffness, step 5 takes 3 Newton iterations (4 with the start's own)."""
    import flexmb.solvers.ksd as ksd

    seen = {}
    newton_steps = ksd.newton_steps

    def spy(problem, state, **options):
        seen["start"], seen["geometric"] = state, options["first_geometric_stress"]
        return newton_steps(problem, state, **options)

    monkeypatch.setattr(ksd, "newton_steps", spy)
    full = flexmb.solve(flexmb.models.fourbar(n, displacement=0.3), method="ksd-full")
    assert full.converged and full.stages["full"]["iterations"] == 3
    model = full.compiled.problem.model
    own = model.element_response(seen["start"], tangent=False)[3]
    final = model.element_response(full.state, tangent=False)[3][:, 0]
    eob = seen["geometric"](own)
    scale = np.abs(final).max()
    assert np.abs(eob[:, 0] - final).max() < 0.01 * scale
    assert np.abs(own[:, 0] - final).max() > 5 * scale
    np.testing.assert_array_equal(eob[:, 1:], own[:, 1:])  # only the axial forces are replaced


def test_ksd_reduced_fourbar_is_close_and_reports_its_steps():
    """Fig. 10: KSD-reduced gives the actuation force accurately (flexmb: 0.34 % at d = H, 3
    el./leaf); its internal nodes come from step 4, so node_positions compares with the full model."""
    m = flexmb.models.fourbar(3, displacement=0.3)
    conv = flexmb.solve(m)
    red = flexmb.solve(m, method="ksd-reduced")
    assert red.converged and red.stable is None
    F, Fr = conv.reaction("top")[0], red.reaction("top")[0]
    assert abs(Fr / F - 1) < 4e-3
    assert np.abs(red.node_positions() - conv.node_positions()).max() < 2e-4  # m, of a 0.44 m mechanism
    for step in ("kinematics", "reduced"):
        assert red.stages[step]["iterations"] >= 1 and red.stages[step]["time"] > 0
    assert red.stages["eob"]["time"] > 0 and red.stages["internal"]["time"] > 0
    full = flexmb.solve(m, method="ksd-full")
    assert full.stages["full"]["iterations"] >= 1
    assert full.iterations == sum(full.stages[s]["iterations"] for s in ("kinematics", "reduced", "full"))


def test_fourbar_small_motion_is_eq_4_7_with_the_pivot_distance():
    """Parallelogram of four pivots of stiffness EI/L (Sec. 4.2: M -> M_lin/2, Eq. 4.3) a height
    H + D0 apart: F = 4 EI d / (L (H + D0)^2), i.e. F/F_lin (Eq. 4.7) = (H / (H + D0))^2."""
    d = 1e-4
    sol = flexmb.solve(flexmb.models.fourbar(3, displacement=d))
    D0 = flexmb.CrossFlexure().interface_b(2)[1]
    ratio = sol.reaction("top")[0] / flexmb.models.fourbar_linear_force(d)
    assert ratio == pytest.approx((0.3 / (0.3 + D0)) ** 2, rel=2e-5)


# -- EOB: moment-rotation and stiffness (Sec. 4.2, Fig. 7a) -------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n", [1, 3, 5])
def test_eob_moment_rotation_is_the_fe_curve(dim, n):
    """Fig. 7a: "the line of the FEM result is exactly behind the line of the EOB": KSD-reduced
    (linearised about the EOB near configuration) gives the FE moment within 5e-5 (measured
    4.3e-5 at 1 el./leaf, 1e-5 at 3 and 5) from 15 to 75 degrees."""
    for deg in (15, 45, 75):
        m = flexmb.models.cross_flexure_pivot(n, dim=dim, rotation=np.radians(deg))
        conv, red = flexmb.solve(m), flexmb.solve(m, method="ksd-reduced")
        M, Mr = conv.reaction("B")[-1], red.reaction("B")[-1]
        assert abs(Mr / M - 1) < 5e-5, deg


def _fe_tangent_on_b(state, joint, dim, geometric_stress=None):
    """FE tangent of the joint condensed on node B (node A held), at ``state`` (``geometric_stress``
    as `StaticProblem.evaluate`)."""
    m = flexmb.Mechanism(dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim))
    m.add_joint("A", "B", joint, name="j")
    _, K, _, _ = m.compile().problem.evaluate(state, 1.0, geometric_stress=geometric_stress)
    K = K.toarray()
    nd = 3 if dim == 2 else 6
    return K[:nd, :nd] - K[:nd, nd:] @ np.linalg.solve(K[nd:, nd:], K[nd:, :nd])


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n", [1, 3, 5])
def test_eob_stiffness_is_the_fe_tangent_at_rest(dim, n):
    """At theta = 0 the near configuration is the undeformed one: K_T (Eq. 2.5) = FE tangent."""
    j = flexmb.CrossFlexure(elements_per_leaf=n)
    eob = template(j, dim).evaluate(np.zeros(1), j.interface_b(dim)[None])
    nd = 3 if dim == 2 else 6
    model = flexmb.models.cross_flexure_pivot(n, dim=dim).compile().problem.model
    K = _fe_tangent_on_b(model.initial_state(), j, dim)
    d = np.sqrt(np.abs(np.diag(K)))
    assert np.max(np.abs(eob.K_T[0, nd:, nd:] - K) / np.outer(d, d)) < 1e-12
    assert np.abs(eob.F_hat_T).max() < 1e-9  # no virtual force at rest (Eq. 3.8 with q_hat = 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_eob_condensed_with_node_a_held_is_the_b_block_of_the_full_condensation(dim):
    """Eq. (2.5) with node A held: the Schur complement onto B of K_nodes without A's rows and
    columns is the BB block of the Schur complement onto (A, B); the same for F_hat_T and the
    recovery of the internal nodes (Eq. 2.6). At 50 deg with node B off its near position."""
    j = flexmb.CrossFlexure(elements_per_leaf=4)
    tpl = template(j, dim)
    theta = np.radians([50.0, -20.0])
    b = j.interface_b(dim)[None] * np.array([[0.97], [1.01]])
    full, held = tpl.evaluate(theta, b), tpl.evaluate(theta, b, held_a=True)
    nd = 3 if dim == 2 else 6
    scale = np.abs(full.K_T[:, nd:, nd:]).max()
    assert held.K_T.shape == (2, nd, nd)
    assert np.abs(held.K_T - full.K_T[:, nd:, nd:]).max() < 1e-12 * scale
    assert np.abs(held.F_hat_T - full.F_hat_T[:, nd:]).max() < 1e-12 * np.abs(full.F_hat_T).max()
    assert np.abs(held.recover - full.recover).max() < 1e-12 * np.abs(full.recover).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_eob_node_terms_are_the_assembled_element_terms(dim):
    """Eq. (3.11): K_nodes = sum over elements of L^T K_all L and F_hat_nodes = sum of
    L^T F_hat_all with F_hat_all = -K_all q_hat_all (Eq. 3.8), assembled here element by element
    from the record's K_all, L and F_hat_all (at 40 deg, node B off its near position)."""
    j = flexmb.CrossFlexure(elements_per_leaf=3)
    tpl = template(j, dim)
    eob = tpl.evaluate(np.radians([40.0]), j.interface_b(dim)[None] * 0.98)
    n = tpl.n_nodes * tpl.nd
    K, F = np.zeros((n, n)), np.zeros(n)
    for e, dofs in enumerate(tpl.element_dofs):
        L, Ka = eob.L[0, e], eob.K_all[0, e]
        K[np.ix_(dofs, dofs)] += L.T @ Ka @ L
        F[dofs] += L.T @ eob.F_hat_all[0, e]
    assert np.allclose(eob.F_hat_all, -(eob.K_all @ eob.q_hat[..., None])[..., 0], rtol=0, atol=0)
    assert np.abs(K - eob.K_nodes[0]).max() < 1e-12 * np.abs(K).max()
    assert np.abs(F - eob.F_hat_nodes[0]).max() < 1e-12 * np.abs(F).max()


@pytest.mark.parametrize("n", [3, 5])
def test_eob_support_stiffness_at_training_configurations(n):
    """Sec. 4.2: the EOB's stiffness in the unintended directions matches the FE model. At the
    training rotations the EOB's x, y support stiffness equals the FE tangent without its stress
    terms within 3e-4 (measured 2.0e-4); the full FE tangent is higher by the geometric stiffness of
    the bent leaves (measured 0.5 % at 30 deg, 3.0 % at 75 deg), which the EOB, built from
    stress-free elements (Eq. 3.3), does not have."""
    j = flexmb.CrossFlexure(elements_per_leaf=n)
    tpl = template(j, 2)
    for deg in (30, 75):
        sol = flexmb.solve(flexmb.models.cross_flexure_pivot(n, dim=2, rotation=np.radians(deg)))
        K_eob = tpl.evaluate(np.radians([deg]), sol.pose("B")[0][None]).K_T[0, 3:, 3:]
        K_full = _fe_tangent_on_b(sol.state, j, 2)
        K_mat = _fe_tangent_on_b(sol.state, j, 2, geometric_stress=np.zeros_like)  # D^T S D
        rel_mat = np.diag(K_eob)[:2] / np.diag(K_mat)[:2] - 1
        rel_full = np.diag(K_eob)[:2] / np.diag(K_full)[:2] - 1
        assert np.abs(rel_mat).max() < 3e-4
        assert 0 < rel_full.min() and rel_full.max() < (0.006 if deg == 30 else 0.031)


def test_eob_near_configuration_follows_the_chains():
    """Eq. 3.2: markers at node A sit on block A's points; consecutive elements of a leaf share
    their marker at the internal node; only the markers at B need not coincide (Fig. 4a)."""
    j = flexmb.CrossFlexure(elements_per_leaf=3)
    tpl = template(j, 3)
    th = np.radians(50.0)
    D0 = tpl.data.length
    pB = np.array([tpl.data.function(f)(th) for f in ("x/D0", "y/D0", "z/D0")]) * D0  # B from the fits
    eob = tpl.evaluate(np.array([th]), pB[None])
    mk = eob.marker_position[0]  # (E, 2, 3)
    at_a = tpl.p_node == 0
    np.testing.assert_allclose(mk[at_a, 0], tpl.node_x0[0] + tpl.s_p[at_a], atol=1e-15)
    for k in range(tpl.n_elements):  # every element is rigidly moved: its length is kept
        np.testing.assert_allclose(np.linalg.norm(mk[k, 1] - mk[k, 0]), np.linalg.norm(tpl.d[k]), rtol=1e-14)
    internal_q = tpl.q_node >= 2
    for k in np.flatnonzero(internal_q):
        nxt = np.flatnonzero(tpl.p_node == tpl.q_node[k])
        np.testing.assert_allclose(mk[nxt, 0], np.broadcast_to(mk[k, 1], mk[nxt, 0].shape), atol=1e-15)
    at_b = tpl.q_node == 1  # block B's points, where node B's near pose (pB, rz(th)) puts them
    gaps = np.linalg.norm(mk[at_b, 1] - (pB + tpl.s_q[at_b] @ rz(th).T), axis=1)
    assert 0 < gaps.max() < 1e-3 * j.length  # the loop closes only approximately at node B


# -- analytic tangents of the reduced mechanism --------------------------------------------------

def _reduced(dim):
    m = flexmb.models.fourbar(2, displacement=0.1, moment=3.0, dim=dim)
    m.apply_force("top", (5.0, -7.0) if dim == 2 else (5.0, -7.0, 2.0),
                  point=(0.05, 0.5) if dim == 2 else (0.05, 0.5, 0.02))
    return ReducedMechanism(m.compile())


def _random_poses(red, rng, size=0.05):
    dz = np.zeros((red.n_links, 6))
    dz[:, red.active] = size * rng.standard_normal((red.n_links, len(red.active)))
    return red.rest().moved(dz)


def _fd(f, poses, red, h=1e-7):
    cols = []
    for k in range(6 * red.n_links):
        dz = np.zeros(6 * red.n_links)
        dz[k] = h
        cols.append((f(poses.moved(dz)) - f(poses.moved(-dz))) / (2 * h))
    return np.array(cols).T


def _random_joints(red, rng):
    """Random condensed joints for step 3: symmetric positive stiffnesses (J, 6, 6) of N/m and
    N m/rad scales, forces (J, 6), near poses of node B ``p_hat`` (J, 3) and ``R_hat`` (J, 3, 3)."""
    J = len(red.joint_names)
    A = rng.standard_normal((J, 6, 6))
    W = np.sqrt([1e5, 1e5, 1e5, 10, 10, 10])  # N/m and N m/rad scales
    K = W[:, None] * (A @ np.swapaxes(A, 1, 2)) * W
    F_hat = rng.standard_normal((J, 6)) * [5, 5, 5, 1, 1, 1]
    p_hat = red.b0 + 0.01 * rng.standard_normal((J, 3))
    return K, F_hat, p_hat, expm_so3(0.2 * rng.standard_normal((J, 3)))


def _two_kinds(dim):
    """The four-bar with thicker upper flexures: two joint values, so two constraint groups."""
    m = flexmb.models.fourbar(2, displacement=0.1, dim=dim)
    thick = attrs.evolve(m.graph.edges["left", "top", "top_left"]["joint"], thickness=1.5e-3)
    for link, name in (("left", "top_left"), ("right", "top_right")):
        m.graph.edges[link, "top", name]["joint"] = thick
    red = ReducedMechanism(m.compile())
    assert len(red.groups) == 2
    return red


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("build", [_reduced, _two_kinds])
def test_constraint_jacobian_is_the_finite_difference_one(dim, build):
    red = build(dim)
    poses = _random_poses(red, np.random.default_rng(1))
    c, J, _, _ = red.constraint_equations(poses)
    Jfd = _fd(lambda p: red.constraint_equations(p)[0], poses, red)
    act = (np.arange(red.n_links)[:, None] * 6 + red.active).ravel()
    assert np.max(np.abs(J[:, act] - Jfd[:, act])) < 1e-7 * np.abs(J).max()
    # the deferred and the values-free forms give the same Jacobian
    c2, jac, _, _ = red.constraint_equations(poses, jacobian="deferred")
    none, J3, _, _ = red.constraint_equations(poses, values=False)
    np.testing.assert_array_equal(c2, c)
    np.testing.assert_array_equal(jac(), J)
    np.testing.assert_array_equal(J3, J)
    assert none is None


@pytest.mark.skipif(not flexmb.jit._AVAILABLE, reason="numba not installed")
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("build", [_reduced, _two_kinds])
def test_compiled_constraint_jacobian_is_the_finite_difference_one(dim, build):
    """Step 1's compiled constraints (`flexmb.ksd.reduced_jit.constraints`, the kinematic solve's
    one call per iteration): their Jacobian against central differences of their own values, in a
    deformed configuration, one and two constraint groups (equations in group order)."""
    from flexmb.ksd.kinematics import compiled_constraints

    red = build(dim)
    poses = _random_poses(red, np.random.default_rng(1))
    c, J, _, _ = compiled_constraints(red, poses)
    Jfd = _fd(lambda p: compiled_constraints(red, p)[0], poses, red)
    act = (np.arange(red.n_links)[:, None] * 6 + red.active).ravel()
    assert np.max(np.abs(J[:, act] - Jfd[:, act])) < 1e-7 * np.abs(J).max()


@pytest.mark.skipif(not flexmb.jit._AVAILABLE, reason="numba not installed")
@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_step3_tangent_is_the_finite_difference_one(dim):
    """Step 3's compiled evaluation (`flexmb.ksd.reduced_jit._evaluate`, what its Newton loop
    `reduced_newton` calls: joint wrenches, dead loads at offset points turned with their links):
    its tangent against central differences of its residual, deformed, random joint stiffness;
    its residual equals `ReducedMechanism.equilibrium`'s."""
    from flexmb.ksd.reduced_jit import _evaluate

    rng = np.random.default_rng(4)
    red = _reduced(dim)
    assert red.load_offset.any()
    K, F_hat, p_hat, R_hat = _random_joints(red, rng)
    n = 6 * red.n_links
    fr = red.frames

    def evaluate(poses):
        r, T = np.empty(n), np.empty((n, n))
        _evaluate(np.ascontiguousarray(poses.x), np.ascontiguousarray(poses.R), fr.a, fr.b, fr.s_a, fr.s_b, fr.P, K,
                  F_hat, p_hat, R_hat, red._cols, red.load_node, red.load_offset, red.load_force, red.load_moment, r, T)
        return r, T

    poses = _random_poses(red, rng)
    r, T = evaluate(poses)
    np.testing.assert_allclose(r, red.equilibrium(poses, K, F_hat, p_hat, R_hat, tangent=False)[0], rtol=0,
                               atol=1e-12 * np.abs(r).max())
    Tfd = _fd(lambda p: evaluate(p)[0], poses, red)
    act = (np.arange(red.n_links)[:, None] * 6 + red.active).ravel()
    d = np.sqrt(np.abs(np.diag(T)))[act]
    assert (np.abs(T[np.ix_(act, act)] - Tfd[np.ix_(act, act)]) / np.outer(d, d)).max() < 1e-6


@pytest.mark.parametrize("dim", [2, 3])
def test_reduced_equilibrium_jacobian_is_the_finite_difference_one(dim):
    """Step 3's residual (joint wrenches with the EOB stiffness, statics for node A, dead loads at
    offset points) and its analytic Jacobian, at a deformed state with a random joint stiffness."""
    rng = np.random.default_rng(2)
    red = _reduced(dim)
    K, F_hat, p_hat, R_hat = _random_joints(red, rng)
    poses = _random_poses(red, rng)
    r, Kr = red.equilibrium(poses, K, F_hat, p_hat, R_hat)
    Kfd = _fd(lambda p: red.equilibrium(p, K, F_hat, p_hat, R_hat, tangent=False)[0], poses, red)
    act = (np.arange(red.n_links)[:, None] * 6 + red.active).ravel()
    d = np.sqrt(np.abs(np.diag(Kr)))[act]
    err = np.abs(Kr[np.ix_(act, act)] - Kfd[np.ix_(act, act)]) / np.outer(d, d)
    assert err.max() < 1e-6


def test_reduced_joint_wrenches_balance():
    """Node A's wrench comes from the joint's statics: the joint wrenches on all links sum to zero."""
    red = _reduced(3)
    red.load_force[:] = 0.0
    red.load_moment[:] = 0.0
    rng = np.random.default_rng(3)
    J = len(red.joint_names)
    poses = _random_poses(red, rng)
    r, _ = red.equilibrium(poses, np.tile(np.eye(6), (J, 1, 1)) * 1e4, rng.standard_normal((J, 6)),
                           red.b0, np.tile(np.eye(3), (J, 1, 1)), tangent=False)
    r = r.reshape(-1, 6)
    moment = r[:, 3:] + np.cross(poses.x, r[:, :3])
    assert np.abs(r[:, :3].sum(axis=0)).max() < 1e-9 and np.abs(moment.sum(axis=0)).max() < 1e-9


# -- over-constrained, indeterminate, out of range ------------------------------------------------

def test_overconstrained_fourbar_drops_redundant_equations():
    """Sec. 2.2: the spatial four-bar has 20 constraint equations for 17 unknowns; the three
    out-of-plane loop closures are redundant and removed; the removed ones hold at the solution."""
    sol = flexmb.solve(flexmb.models.fourbar(2, displacement=0.2), method="ksd-reduced")
    k = sol.stages["kinematics"]
    assert (k["equations"], k["removed"]) == (20, 3)
    assert k["removed_residual"] < 1e-12
    k2 = flexmb.solve(flexmb.models.fourbar(2, displacement=0.2, dim=2), method="ksd-reduced").stages["kinematics"]
    assert (k2["equations"], k2["removed"]) == (8, 0)


def test_indeterminate_mechanism_names_the_free_motion():
    m = flexmb.models.cross_flexure_pivot(3, dim=2)
    m.prescribe("B", rotation=None)
    m.apply_moment("B", 2.0)
    with pytest.raises(TopologyError, match=r"indeterminate.*link 'B' rotation"):
        flexmb.solve(m, method="ksd-reduced")
    fb = flexmb.models.fourbar(2, dim=3)
    fb.prescribe("top", x=None)
    with pytest.raises(TopologyError, match=r"free: .*link 'top' x"):
        flexmb.solve(fb, method="ksd-full")


def test_rotation_outside_the_trained_range_is_refused_or_warned():
    m = flexmb.models.cross_flexure_pivot(3, dim=3, rotation=np.radians(80))
    with pytest.raises(DatabaseError, match=r"joint 'cross_flexure'.*80\.00 deg.*\[-75\.0, 75\.0\]"):
        flexmb.solve(m, method="ksd-reduced")
    with pytest.warns(ExtrapolationWarning, match="joint 'cross_flexure'"):
        sol = flexmb.solve(m, method="ksd-full", strict_range=False)
    assert sol.converged  # step 5 is the full model: the converged answer does not depend on the fits


def test_joint_without_database_is_refused():
    m = flexmb.models.cantilever(4)
    m.prescribe("tip", y=0.01)
    with pytest.raises(UnsupportedStrategyError, match="no joint database"):
        flexmb.solve(m, method="ksd-reduced")


def test_solving_leaves_the_mechanism_unchanged():
    m = flexmb.models.fourbar(2, displacement=0.2, moment=1.0)
    before = (repr(m), m.prescribed("top"), len(m._loads))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        flexmb.solve(m, method="ksd-full")
    assert (repr(m), m.prescribed("top"), len(m._loads)) == before


# -- the EOB's known limits (Sec. 4.2) --------------------------------------------------------------

@pytest.mark.slow
def test_eob_limit_wider_outer_leaves():
    """Fig. 7b: four times wider outer leaves lower the normalised moment of the full model more
    than the EOB's (its element rotations are the default joint's). Measured at 75 deg, 2 el./leaf:
    FE 0.6493 -> 0.6321, EOB 0.6493 -> 0.6395 (+1.18 %); with the default widths the EOB is the FE
    curve (1.0e-5 measured; the 5e-5 bound of test_eob_moment_rotation_is_the_fe_curve)."""
    from flexmb.studies import eob as ec

    w = ec.outer_width_study(2, degrees=(45, 75))
    np.testing.assert_allclose(w[0.02]["eob"], w[0.02]["fe"], rtol=5e-5)
    drop_fe = w[0.02]["fe"][-1] - w[0.08]["fe"][-1]
    drop_eob = w[0.02]["eob"][-1] - w[0.08]["eob"][-1]
    assert 0 < drop_eob < 0.6 * drop_fe
    assert 0.005 < w[0.08]["eob"][-1] / w[0.08]["fe"][-1] - 1 < 0.02


@pytest.mark.slow
def test_eob_limit_large_force_along_z():
    """Fig. 8: the EOB follows the z displacement under a large z force (within 3 % at F = 4,
    Eq. 4.5) but its moment hardly changes (linear unintended deformation), while the full model's
    drops (measured at 75 deg, 4 el./leaf: 0.8134 -> 0.7863, -3.3 %)."""
    from flexmb.studies import eob as ec

    z = ec.z_force_study(4, degrees=(75,), forces=(0.0, 4.0))[75]
    assert abs(z["z_eob"][1] / z["z_fe"][1] - 1) < 0.03
    assert abs(z["M_eob"][1] / z["M_eob"][0] - 1) < 1e-3
    assert z["M_fe"][1] / z["M_fe"][0] - 1 < -0.03


# -- regressions found in review ----------------------------------------------------------------------

def test_planar_angles_beyond_pi_are_kept():
    """A chain of three planar cross flexures turned 1.2 rad each: the last link is at 3.6 rad, not
    wrapped to -2.68 (links and internal nodes carry accumulated angles, as the conventional state)."""
    j = flexmb.CrossFlexure(elements_per_leaf=2)
    b = j.interface_b(2)
    m = flexmb.Mechanism(dim=2)
    m.add_link("L0", fixed=True)
    for k in range(1, 4):
        m.add_link(f"L{k}", position=k * b)
        m.add_joint(f"L{k - 1}", f"L{k}", j, origin=(k - 1) * b)
        m.prescribe(f"L{k}", rotation=1.2 * k)
    conv = flexmb.solve(m)
    for method in ("ksd-reduced", "ksd-full"):
        sol = flexmb.solve(m, method=method)
        assert sol.pose("L3")[1] == pytest.approx(3.6, abs=1e-12)
        np.testing.assert_allclose(sol.state.rotations, conv.state.rotations, atol=2e-3)


def _parallel_pivots(rotation):
    """Two cross flexures side by side between the same two links: over-constrained in the plane,
    and inconsistently (the two pivots' centres differ, so their kinematics disagree)."""
    j = flexmb.CrossFlexure(elements_per_leaf=2)
    D0 = j.interface_b(2)[1]
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, D0))
    m.add_joint("A", "B", j, name="j1", origin=(-0.05, 0.0))
    m.add_joint("A", "B", j, name="j2", origin=(0.05, 0.0))
    m.prescribe("B", rotation=rotation)
    return m


def test_inconsistent_redundant_constraints_warn_and_ksd_full_still_converges():
    """Dropped redundant equations that do not hold are reported; step 5 continues from the KSD
    start along r(u) - (1 - lam) r(u_start) when the whole step fails (it converged in 1-25
    iterations; retrying the same whole step had restarted 17 times and failed)."""
    m = _parallel_pivots(1e-3)
    with pytest.warns(RuntimeWarning, match=r"inconsistent.*\('j2', 'y'\)"):
        full = flexmb.solve(m, method="ksd-full")
    conv = flexmb.solve(m)
    assert full.converged and _rel_positions(full, conv) < 1e-8
    with pytest.warns(RuntimeWarning):
        far = flexmb.solve(_parallel_pivots(0.02), method="ksd-full")
    assert far.converged and far.stable  # a stable equilibrium (the conventional one is unstable)


@pytest.mark.slow
def test_speed_study_reports_single_and_steady_ratios_from_one_run():
    """Fig. 11 rows: both timings per method, each speed-up against the conventional time of the
    same timing (so the conventional rows read 1x)."""
    from flexmb.studies import fourbar as fourbar_case

    rows = fourbar_case.speed_study((1,), repeats=1)
    assert [r["method"] for r in rows] == list(fourbar_case.METHODS)
    for r in rows:
        assert r["time"] > 0 and r["time_steady"] > 0
    conv = rows[0]
    assert conv["speedup"] == 1.0 and conv["speedup_steady"] == 1.0
    for r in rows[1:]:
        assert r["speedup"] == conv["time"] / r["time"]
        assert r["speedup_steady"] == conv["time_steady"] / r["time_steady"]


@pytest.mark.slow
def test_timing_on_the_cpu_clock_excludes_waiting_for_a_core():
    """`flexmb demo` times on the process's CPU clock (flexmb.studies._timing): a solve's CPU time
    is not inflated by waits for a core, so a sleeping "solve" costs nothing on it but its wall time."""
    import time

    from flexmb.studies import _timing

    calls = []

    def sleepy_solve(mechanism, method, raise_on_failure):
        calls.append(method)
        time.sleep(0.02)
        return method

    original = _timing.solve
    try:
        _timing.solve = sleepy_solve
        _, wall = _timing.interleaved(None, ("a",), 3)
        _, cpu = _timing.interleaved(None, ("a",), 3, clock="cpu")
    finally:
        _timing.solve = original
    assert wall["a"] >= 0.02 and cpu["a"] < 0.005 and calls == ["a"] * 6
    with pytest.raises(flexmb.ParameterError, match="clock='gpu'; valid: wall, cpu"):
        _timing.interleaved(None, ("a",), 1, clock="gpu")


# -- the per-mechanism cache of the compiled model and KSD's set-up (issue 21 item 4) --------------

def _fresh_answer(build, method):
    return flexmb.solve(build(), method=method)


def _same(a, b):
    return np.array_equal(a.node_positions(), b.node_positions()) and np.array_equal(a.residual, b.residual)


def test_an_unchanged_mechanism_is_compiled_once_and_gives_the_same_answer():
    from flexmb.compiled import compiled_for
    from flexmb.solvers.ksd import reduced_mechanism

    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=0.3)
    c = compiled_for(m)
    assert compiled_for(m) is c
    assert reduced_mechanism(c) is reduced_mechanism(c)
    first, again = flexmb.solve(m, method="ksd-reduced"), flexmb.solve(m, method="ksd-reduced")
    assert first.compiled is again.compiled is c
    assert _same(first, again)
    # the set-up's time is reported as a stage of its own; steps 1 and 2 are computed every solve
    assert {"setup", "kinematics", "eob", "reduced", "internal"} <= again.stages.keys()
    assert again.stages["eob"]["joints"] == 1 and again.stages["setup"]["time"] > 0
    assert again.stages["kinematics"]["iterations"] == first.stages["kinematics"]["iterations"] > 0


class _NotAValue(flexmb.CrossFlexure):  # a plugin joint that does not hash: it could change unseen
    __hash__ = None


def test_a_mechanism_with_a_joint_that_is_not_a_value_is_compiled_every_time():
    from flexmb.compiled import compiled_for

    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    joint = _NotAValue(elements_per_leaf=2)
    m.add_link("B", position=joint.interface_b(2))
    m.add_joint("A", "B", joint)
    m.prescribe("B", rotation=0.2)
    assert compiled_for(m) is not compiled_for(m)
    sols = [flexmb.solve(m, method="ksd-reduced") for _ in range(2)]
    assert sols[0].compiled is not sols[1].compiled and _same(*sols)


def _pivot(rotation=0.3, force=None, moment=None):
    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=rotation)
    if force is not None:
        m.apply_force("B", force)
    if moment is not None:
        m.apply_moment("B", moment)
    return m


@pytest.mark.filterwarnings("ignore:KSD step 1:RuntimeWarning")  # the second pivot over-constrains
@pytest.mark.parametrize("method", ["ksd-reduced", "ksd-full", "conventional"])
@pytest.mark.parametrize("change", ["prescribe", "apply_force", "apply_moment", "clear_loads", "graph link",
                                    "add_joint", "add_point"])
def test_a_mutated_mechanism_gives_the_new_answer_never_a_stale_one(method, change):
    """Every change through the mechanism's methods, or of its graph directly, compiles anew: the
    answer after the change is that of a mechanism built that way from the start (bit for bit)."""
    m = _pivot(force=(0.0, 1.0))
    before = flexmb.solve(m, method=method)
    if change == "prescribe":
        m.prescribe("B", rotation=0.2)
        expected = _fresh_answer(lambda: _pivot(0.2, force=(0.0, 1.0)), method)
    elif change == "apply_force":
        m.apply_force("B", (2.0, 0.0))
        expected = _fresh_answer(lambda: _with(_pivot(force=(0.0, 1.0)), (2.0, 0.0)), method)
    elif change == "apply_moment":
        m.apply_moment("B", 0.05)
        expected = _fresh_answer(lambda: _pivot(force=(0.0, 1.0), moment=0.05), method)
    elif change == "clear_loads":
        m.clear_loads()
        expected = _fresh_answer(lambda: _pivot(), method)
    elif change == "graph link":  # a link replaced in the graph itself: B's reference point moved
        lk = m.graph.nodes["B"]["link"]
        m.graph.nodes["B"]["link"] = attrs.evolve(lk, position=lk.position + 1e-3)

        def build():
            f = _pivot(force=(0.0, 1.0))
            lk = f.graph.nodes["B"]["link"]
            f.graph.nodes["B"]["link"] = attrs.evolve(lk, position=lk.position + 1e-3)
            return f

        expected = _fresh_answer(build, method)
    elif change == "add_joint":  # a second pivot in parallel, 5 mm away: a stiffer mechanism
        def add(mech):
            mech.add_joint("A", "B", "cross_flexure", elements_per_leaf=2, name="second", origin=(0.0, 0.005))
            return mech

        add(m)
        expected = _fresh_answer(lambda: add(_pivot(force=(0.0, 1.0))), method)
    else:  # a named point changes no equilibrium, but the compiled maps to points
        m.add_point("B", "tip", (0.01, 0.0))
        expected = _fresh_answer(lambda: _pivot(force=(0.0, 1.0)), method)
        assert "tip" in flexmb.solve(m, method=method).compiled.points
    after = flexmb.solve(m, method=method)
    assert after.converged == expected.converged
    assert _same(after, expected)
    if change != "add_point":
        assert not _same(after, before)


def _with(m, force):
    m.apply_force("B", force)
    return m


def test_the_cache_does_not_keep_a_mechanism_alive():
    import gc
    import weakref

    m = _pivot(force=(0.0, 1.0))
    sol = flexmb.solve(m, method="ksd-reduced")
    alive = weakref.ref(m)
    del m
    gc.collect()
    assert alive() is None and sol.converged  # the solution keeps its compiled model, not the mechanism


def test_the_shared_compiled_model_cannot_be_changed_through_a_solution():
    m = _pivot(force=(0.0, 1.0))
    sol = flexmb.solve(m, method="ksd-reduced")
    problem = sol.compiled.problem
    for a in (problem.values, problem.prescribed, problem.loads.force, problem.model.x0):
        with pytest.raises(ValueError, match="read-only"):
            a[...] = 0.0
    assert _same(flexmb.solve(m, method="ksd-reduced"), sol)


def test_the_ksd_set_up_is_rebuilt_when_its_joint_database_changes(tmp_path):
    """The set-up is kept with the database content it was built from (as `template`, keyed on
    the content, not the time stamps): a file replaced with its time stamp restored is seen."""
    import os
    import shutil

    from flexmb.compiled import compiled_for
    from flexmb.database import store
    from flexmb.solvers.ksd import reduced_mechanism

    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=0.3)
    joint = next(iter(m.joints.values()))
    src = store.locate(joint, 2)
    for f in src.parent.glob(src.stem + "*"):  # the database and its EOB table
        shutil.copy2(f, tmp_path / f.name)
    c = compiled_for(m)
    red = reduced_mechanism(c, tmp_path)
    assert reduced_mechanism(c, tmp_path) is red
    path = tmp_path / src.name
    stamp = path.stat().st_mtime_ns
    data = store.load(path)
    forged = attrs.evolve(data, elements=attrs.evolve(data.elements, coefficients=1.001 * data.elements.coefficients))
    store.save(forged, path)
    os.utime(path, ns=(stamp, stamp))
    again = reduced_mechanism(c, tmp_path)
    assert again is not red
    np.testing.assert_allclose(again.groups[0][0].data.elements.coefficients,
                               1.001 * red.groups[0][0].data.elements.coefficients, rtol=1e-15)
    assert reduced_mechanism(c, tmp_path) is again
    path.unlink()  # gone: the next folder of the search path (the shipped data) is used again
    shipped = reduced_mechanism(c, tmp_path)
    assert shipped is not again
    np.testing.assert_array_equal(shipped.groups[0][0].data.elements.coefficients,
                                  red.groups[0][0].data.elements.coefficients)


def test_the_ksd_set_up_sees_a_database_file_appear_earlier_or_become_a_broken_link(tmp_path):
    """The freshness check (one lstat per folder searched, a stat through a link): a database file
    put into a folder searched before the one the set-up read, and that file turned into a
    broken link, both make the kept set-up stale (not a paper case: the search path's order)."""
    import shutil

    from flexmb.compiled import compiled_for
    from flexmb.database import store
    from flexmb.solvers.ksd import reduced_mechanism

    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=0.3)
    joint = next(iter(m.joints.values()))
    src = store.locate(joint, 2)
    c = compiled_for(m)
    shipped = reduced_mechanism(c, tmp_path)  # nothing in tmp_path yet: the shipped file
    assert shipped.current()
    for f in src.parent.glob(src.stem + "*"):
        shutil.copy2(f, tmp_path / f.name)
    assert not shipped.current()  # the same bytes, but another file found first
    own = reduced_mechanism(c, tmp_path)
    assert own is not shipped and own.current() and reduced_mechanism(c, tmp_path) is own
    (tmp_path / src.name).unlink()
    (tmp_path / src.name).symlink_to(tmp_path / "missing.json")
    assert not own.current()
    (tmp_path / src.name).unlink()
    (tmp_path / src.name).symlink_to(src)  # a link to the shipped file: a valid file again, read through it
    linked = reduced_mechanism(c, tmp_path)
    assert linked is not own and linked.current() and reduced_mechanism(c, tmp_path) is linked


# -- KSD with ideal hinges (issue 19 item 4) -------------------------------------------------------

def hinged_fourbar(rotation=0.3, k=0.0, motor=False, dim=2, elements_per_leaf=3):
    """A four-bar built as a user would: crank (O2) and coupler (A, B) on hinges, the rocker on a
    cross flexure to the ground (its pivot, mid-leaf, 0.1 m from O2); the crank turned by
    ``rotation`` [rad], prescribed or by O2's motor; a 2 N load on the coupler. Hinges O2 and A
    carry the torsional spring ``k`` [N m/rad]."""
    joint = flexmb.CrossFlexure(elements_per_leaf=elements_per_leaf)
    D0 = joint.interface_b(dim)[1]
    z = [] if dim == 2 else [0.0]
    m = flexmb.Mechanism(dim=dim)
    m.add_link("ground", fixed=True)
    m.add_link("crank", position=[0.0, 0.0] + z)
    m.add_link("coupler", position=[0.0, 0.05] + z)
    m.add_link("rocker", position=[0.1, 0.5 * D0] + z)
    m.add_joint("ground", "crank", flexmb.Hinge(k=k, angle=rotation if motor else None), name="O2")
    m.add_joint("crank", "coupler", "hinge", k=k, name="A", origin=[0.0, 0.05] + z)
    m.add_joint("coupler", "rocker", "hinge", name="B", origin=[0.1, 0.05] + z)
    m.add_joint("ground", "rocker", joint, name="O4", origin=[0.1, -0.5 * D0] + z)
    if not motor:
        m.prescribe("crank", rotation=rotation if dim == 2 else (0.0, 0.0, rotation))
        if dim == 3:
            m.prescribe("crank", z=0.0)
    m.apply_force("coupler", [0.0, -2.0] + z)
    return m


HINGED = [dict(), dict(k=0.5), dict(motor=True, k=0.3), dict(motor=True, rotation=-0.4)]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("case", HINGED, ids=["free", "springs", "motor-springs", "motor-negative"])
def test_ksd_full_equals_conventional_with_hinges(dim, case):
    """A hinge is the ideal joint it is in steps 1-3 and the full model's hinge in step 5, so
    KSD-full converges to the conventional solution (Sec. 2.6): positions to 1e-8 relative (as
    the cross flexure and the four-bar above), reactions and hinge wrenches to 1e-6 N, N m."""
    m = hinged_fourbar(dim=dim, **case)
    conv = flexmb.solve(m)
    full = flexmb.solve(m, method="ksd-full")
    assert conv.converged and full.converged
    assert full.residual_history[-1] < 5e-7
    assert _rel_positions(full, conv) < 1e-8
    for link in ("ground", "crank"):
        np.testing.assert_allclose(full.reaction(link), conv.reaction(link), atol=1e-6)
    for hinge in ("O2", "A", "B"):
        np.testing.assert_allclose(full.joint_wrench(hinge), conv.joint_wrench(hinge), atol=1e-6)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("case", HINGED, ids=["free", "springs", "motor-springs", "motor-negative"])
def test_ksd_reduced_with_hinges_is_within_its_usual_error(dim, case):
    """KSD-reduced's error is its EOB linearisation's alone (the hinges are exact): reactions and
    hinge wrenches within 0.5 % of the conventional ones (the four-bar above: 0.4 %; measured
    here up to 0.12 %), positions within 2 um (measured 0.75 um) on a 0.1 m mechanism."""
    m = hinged_fourbar(dim=dim, **case)
    conv = flexmb.solve(m)
    red = flexmb.solve(m, method="ksd-reduced")
    assert red.converged and red.stages["kinematics"]["iterations"] >= 1
    assert np.abs(red.node_positions() - conv.node_positions()).max() < 2e-6
    for link in ("ground", "crank"):
        a, b = red.reaction(link), conv.reaction(link)
        assert np.abs(a - b).max() <= 5e-3 * np.abs(b).max() + 1e-9
    for hinge in ("O2", "A", "B"):
        a, b = red.joint_wrench(hinge), conv.joint_wrench(hinge)
        assert np.abs(a - b).max() <= 5e-3 * np.abs(b).max()
    # the motor holds its angle exactly (a constraint, not a fit): the crank's pose
    angle = case.get("rotation", 0.3)
    if dim == 2:
        assert abs(red.pose("crank")[1] - angle) < 1e-12
    else:
        np.testing.assert_allclose(red.pose("crank")[1], expm_so3(np.array([0.0, 0.0, angle])), atol=1e-12)


def _hinged(dim):
    return ReducedMechanism(hinged_fourbar(dim=dim, motor=True, k=0.4).compile())


@pytest.mark.parametrize("dim", [2, 3])
def test_hinge_rows_of_the_kinematic_jacobian_are_the_finite_difference_ones(dim):
    red = _hinged(dim)
    poses = _random_poses(red, np.random.default_rng(4))
    c, J, _, _ = red.constraint_equations(poses, lam=0.7)
    assert len(c) == red.n_equations > sum(len(idx) * len(cons) for _, cons, idx in red.groups)
    Jfd = _fd(lambda p: red.constraint_equations(p, lam=0.7)[0], poses, red)
    act = (np.arange(red.n_links)[:, None] * 6 + red.active).ravel()
    assert np.max(np.abs(J[:, act] - Jfd[:, act])) < 1e-7 * np.abs(J).max()
    # the motor rows move with the load factor as lam_rate says
    h = 1e-6
    dc = (red.constraint_equations(poses, lam=0.7 + h)[0] - red.constraint_equations(poses, lam=0.7 - h)[0]) / (2 * h)
    np.testing.assert_allclose(dc, red.lam_rate, atol=1e-8)


@pytest.mark.parametrize("dim", [2, 3])
def test_hinged_reduced_equilibrium_tangent_is_the_finite_difference_one(dim):
    """Step 3 with hinges: the links' residual plus the hinges' multiplier forces and springs, the
    scaled constraints on the multiplier rows; tangent against central differences in the link
    coordinates and the multipliers, at a deformed state with random multipliers."""
    rng = np.random.default_rng(5)
    red = _hinged(dim)
    K, F_hat, p_hat, R_hat = _random_joints(red, rng)
    poses = _random_poses(red, rng)
    # multipliers of physical size: constraint forces of tens of N and N m (scale s: `flexmb.fe.ideal`)
    mu = 10.0 * rng.standard_normal(red.hinges.n_rows) / red.hinges.scale[np.nonzero(red.hinges.active)[1]]
    n = 6 * red.n_links

    def residual(poses, mu):
        r = red.equilibrium(poses, K, F_hat, p_hat, R_hat, tangent=False)[0]
        rh = red.hinge_response(poses, mu)[0]
        rh[:n] += r
        return rh

    Kr = red.equilibrium(poses, K, F_hat, p_hat, R_hat)[1]
    Kh = red.hinge_response(poses, mu)[1]()
    Kh[:n, :n] += Kr
    h = 1e-7
    cols = [c for c in _fd(lambda p: residual(p, mu), poses, red, h).T]
    for k in range(len(mu)):
        e = np.zeros(len(mu))
        e[k] = h
        cols.append((residual(poses, mu + e) - residual(poses, mu - e)) / (2 * h))
    Kfd = np.array(cols).T
    links = (np.arange(red.n_links)[:, None] * 6 + red.active).ravel()
    mult = n + np.arange(len(mu))
    # the links' block, as step 3's test above; a link held by hinges alone (the crank) has a zero
    # diagonal: its scale is then the largest of the same kind (translation, rotation)
    diag = np.abs(np.diag(Kh))[links]
    rotation = links % 6 >= 3
    d = np.sqrt(np.where(diag > 0, diag, np.where(rotation, diag[rotation].max(), diag[~rotation].max())))
    assert (np.abs(Kh[np.ix_(links, links)] - Kfd[np.ix_(links, links)]) / np.outer(d, d)).max() < 1e-6
    G = Kh[np.ix_(mult, links)]  # the scaled constraint gradients (N/m, N m/rad) and their transpose
    assert np.abs(G - Kfd[np.ix_(mult, links)]).max() < 1e-7 * np.abs(G).max()
    assert np.abs(G.T - Kfd[np.ix_(links, mult)]).max() < 1e-7 * np.abs(G).max()
    assert not Kh[np.ix_(mult, mult)].any() and np.abs(Kfd[np.ix_(mult, mult)]).max() < 1e-7 * np.abs(G).max()


def test_ksd_refuses_what_it_cannot_do_with_hinges():
    """Hinges only: no EOB to build; a spring hinge in series with a flexure: how far each turns is
    decided by their stiffnesses, which KSD's kinematic step does not know (named)."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("arm", position=(0.1, 0.0))
    m.add_joint("ground", "arm", "hinge", k=2.0)
    m.apply_moment("arm", 0.1)
    with pytest.raises(UnsupportedStrategyError, match="hinges only"):
        flexmb.solve(m, method="ksd-reduced")
    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=0.2)
    m.add_link("base", fixed=True)
    m.graph.nodes["A"]["link"] = attrs.evolve(m.link("A"), fixed=False)
    m.add_joint("base", "A", "hinge", k=5.0)
    with pytest.raises(TopologyError, match="hinge's rotation"):
        flexmb.solve(m, method="ksd-reduced")
    assert flexmb.solve(m).converged


def _motor_past_a_half_turn(dim, angle=4.0, k=0.5):
    """A disk on a sprung motor hinge turned 4 rad, an arm on a cross flexure 0.1 m out on the
    disk, the arm's rotation prescribed to the disk's plus 0.2 rad."""
    joint = flexmb.CrossFlexure(elements_per_leaf=2)
    z = [] if dim == 2 else [0.0]
    m = flexmb.Mechanism(dim=dim)
    m.add_link("ground", fixed=True)
    m.add_link("disk", position=[0.0, 0.0] + z)
    m.add_link("arm", position=[0.1, joint.interface_b(dim)[1]] + z)
    m.add_joint("ground", "disk", flexmb.Hinge(k=k, angle=angle), name="motor")
    m.add_joint("disk", "arm", joint, name="flexure", origin=[0.1, 0.0] + z)
    m.prescribe("arm", rotation=angle + 0.2 if dim == 2 else (0.0, 0.0, angle + 0.2))
    if dim == 3:
        m.prescribe("arm", z=0.0)
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_ksd_counts_a_motor_hinges_turns_as_the_full_model(dim):
    """A motor turned past pi: KSD's steps follow it (a 3D hinge's angle counted from step to
    step, as `flexmb.fe.ideal.Hinges.advance`), so the spring holds k * 4 rad, not k (4 - 2 pi):
    KSD-full = conventional (motor wrench to 1e-9 N m; a wrapped angle would be k 2 pi = 3.1 N m
    off) and KSD-reduced within 0.5 % (measured 3e-7)."""
    m = _motor_past_a_half_turn(dim)
    conv, full, red = (flexmb.solve(m, method=k) for k in ("conventional", "ksd-full", "ksd-reduced"))
    assert conv.converged and full.converged and red.converged
    assert _rel_positions(full, conv) < 1e-8
    np.testing.assert_allclose(full.joint_wrench("motor"), conv.joint_wrench("motor"), atol=1e-9)
    torque = conv.joint_wrench("motor")[-1]
    assert abs(red.joint_wrench("motor")[-1] - torque) < 5e-3 * abs(torque)


def test_step_1_bounds_its_steps_by_how_fast_the_joints_turn():
    """Between two links turned along exp(lam W_a), exp(lam W_b) the relative orientation turns at
    exactly |W_b - W_a| rad per unit lam (d/dlam of R_a^T R_b is R_a^T skew(W_b - W_a) R_b): checked
    by finite differences; so the manipulator's joint case at 45 deg, whose link 3 turns 1.72 rad
    but whose joints turn 0.81 rad per unit, takes one kinematic step, not two."""
    from flexmb.compiled import compiled_for
    from flexmb.ksd.kinematics import STEP_ROTATION, turn_rate
    from flexmb.rotations import logm_so3
    from flexmb.solvers.ksd import reduced_mechanism

    rng = np.random.default_rng(6)
    Wa, Wb = rng.standard_normal(3), rng.standard_normal(3)

    def relative(lam):
        return expm_so3(lam * Wa).T @ expm_so3(lam * Wb)

    h = 1e-6
    for lam in (0.0, 0.3, 0.8):
        rate = np.linalg.norm(logm_so3(relative(lam).T @ relative(lam + h))) / h
        assert rate == pytest.approx(np.linalg.norm(Wb - Wa), rel=1e-6)
    m = flexmb.models.manipulator("joint", np.radians(45))
    red = reduced_mechanism(compiled_for(m))
    assert turn_rate(red) == pytest.approx(0.8097, abs=1e-4) and STEP_ROTATION / turn_rate(red) > 1
    assert max(np.linalg.norm(w) for w in red._moves[1][1]) > STEP_ROTATION  # link 3 alone: 1.72 rad
    assert flexmb.solve(m, method="ksd-reduced").stages["kinematics"]["iterations"] == 1
