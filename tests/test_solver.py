"""Conventional solver behaviour (Appendix B): convergence rate, step control, honest failure."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import flexmb


def test_linear_problem_takes_one_newton_iteration():
    """A tiny load on a straight cantilever is linear: one iteration converges. (The chords
    lengthen by ~v^2/L; at P = 1e-5 N that axial force, EA v^2 / L^2 ~ 1e-13 N, is below tol.)"""
    m = flexmb.models.cantilever(elements=4, dim=3)
    m.apply_force("tip", (0.0, 1e-5, 0.0))
    sol = flexmb.solve(m, tol=5e-7)  # the absolute tolerance this docstring argues with
    assert sol.converged and sol.iterations == 1


def _error(model, a, b):
    """Distance between two states: positions [m] and rotations [rad] (log of the relative rotation)."""
    from flexmb.rotations import logm_so3

    rot = (a.rotations - b.rotations if model.dim == 2
           else logm_so3(a.rotations @ np.swapaxes(b.rotations, 1, 2)))
    return np.sqrt(np.sum((a.positions - b.positions) ** 2) + np.sum(rot**2))


@pytest.mark.parametrize("dim", [2, 3])
def test_newton_converges_quadratically_on_a_large_rotation(dim):
    """Consistent tangent => e_{k+1} ~ C e_k^2: from a perturbed ~60-degree equilibrium the observed
    order log(e2/e1)/log(e1/e0) of the state error is 2 (1 would mean an inconsistent tangent)."""
    m = flexmb.models.cantilever(elements=8, dim=dim)
    leaf = m.joints["leaf"]
    EI = leaf.E * leaf.cross_section().Iz
    m.apply_force("tip", np.r_[0.0, 3.0 * EI / leaf.length**2, 0.0][:dim])  # k = 3: ~60 degrees at the tip
    sol = flexmb.solve(m)
    assert sol.converged
    problem, model = sol.compiled.problem, sol.compiled.problem.model
    from flexmb.testing import perturbed_state

    # positions perturbed by 1e-5 m already strain the 12.5 mm elements axially by ~1e-3 (thousands
    # of N against a tip load of 100 N): the quadratic region is narrow along the stiff axial modes
    state = perturbed_state(problem, sol.state, np.random.default_rng(0), displacement=1e-5, rotation=1e-2)
    errors = [_error(model, state, sol.state)]
    for _ in range(2):
        r, K, _, _ = problem.evaluate(state, 1.0)
        du = problem.full_increment(problem.solve_linear(K, -r[problem.free]), np.zeros(len(problem.prescribed)))
        state = model.apply_increment(state, du)
        errors.append(_error(model, state, sol.state))
    e0, e1, e2 = errors
    assert e2 > 1e-12, "perturbation too small to measure the rate above roundoff"
    order = np.log(e2 / e1) / np.log(e1 / e0)
    assert order > 1.8, (errors, order)


def test_cross_flexure_75_degrees_in_bounded_iterations():
    """Fig. 18 step control from the undeformed state: 75 deg at once, halving when needed."""
    for n in (1, 3, 5):
        sol = flexmb.solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=n, rotation=np.radians(75)))
        assert sol.converged
        assert sol.iterations <= 60
        assert sol.residual_history[-1] < 5e-7


def test_non_convergence_is_reported_with_the_load_factor_reached():
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=3, rotation=np.radians(75))
    sol = flexmb.solve(m, max_iter=1, min_step=0.3)
    assert not sol.converged
    assert "not converged" in sol.message and "load factor" in sol.message
    assert 0.0 <= sol.load_factor < 1.0
    assert len(sol.residual_history) > 0
    with pytest.raises(flexmb.ConvergenceError, match="not converged"):
        flexmb.solve(m, max_iter=1, min_step=0.3, raise_on_failure=True)


def test_solve_does_not_modify_the_mechanism():
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, rotation=0.5)
    before = flexmb.solve(m).node_positions()
    flexmb.solve(m, max_iter=1, min_step=0.5)  # a failing solve in between
    after = flexmb.solve(m).node_positions()
    np.testing.assert_array_equal(before, after)


def test_reactions_balance_the_applied_loads():
    """Global equilibrium: support reaction + applied loads = 0 (forces and moments about the origin)."""
    m = flexmb.models.cantilever(elements=6, dim=3)
    f = np.array([3.0, -20.0, 1.5])
    m.apply_force("tip", f)
    sol = flexmb.solve(m)
    R = sol.reaction("ground")
    tip = sol.pose("tip")[0]
    np.testing.assert_allclose(R[:3] + f, 0.0, atol=1e-6)
    np.testing.assert_allclose(R[3:] + np.cross(tip, f), 0.0, atol=1e-6)


def test_an_unstable_equilibrium_is_flagged_not_hidden():
    """2D cross flexure at 270 deg in one step lands on an unstable branch (found in review: the
    strain energy 512 J vs 428 J on the stable branch reached in small steps). Both are equilibria;
    the solution must say which one is stable (inertia of the free tangent)."""
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=3, dim=2, rotation=np.radians(270))
    jump = flexmb.solve(m, initial_step=1.0, step_control="paper")  # the default continuation stays stable
    walk = flexmb.solve(m, initial_step=0.02)
    assert jump.converged and walk.converged
    assert jump.stable is False and "UNSTABLE" in jump.message
    assert walk.stable is True
    assert walk.strain_energy() < jump.strain_energy()


def test_global_equilibrium_of_a_loop_with_offsets_and_prescribed_links():
    """Sum of all support/actuator reactions + applied loads = 0, moments about the origin included,
    on a closed loop with rigid offsets, an offset load, a moment and a prescribed link."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("ground", fixed=True)
    cf = flexmb.CrossFlexure(elements_per_leaf=2)
    b = cf.interface_b(3)
    m.add_link("arm", position=b)
    m.add_joint("ground", "arm", cf, name="hinge")
    m.add_link("hand", position=b + [0.15, 0, 0])
    m.add_joint("arm", "hand", flexmb.LeafSpring(length=0.15, elements=3), origin=b, name="leaf")
    m.add_joint("ground", "hand", flexmb.LeafSpring(length=b[1], elements=3), origin=(0.15, 0, 0),
                rotation=(0, 0, np.pi / 2), name="post")
    f, p = np.array([5.0, -8.0, 2.0]), b + [0.17, 0.02, 0.01]
    mz = np.array([0.1, -0.2, 0.3])
    m.apply_force("hand", f, point=p)
    m.apply_moment("arm", mz)
    m.prescribe("arm", x=2e-3, z=1e-3)
    sol = flexmb.solve(m)
    assert sol.converged
    F = sol.reaction("ground")[:3] + sol.reaction("arm")[:3] + f
    arm = sol.pose("arm")[0]
    hand, R_hand = sol.pose("hand")
    p_now = hand + R_hand @ (p - (b + [0.15, 0, 0]))
    M = (sol.reaction("ground")[3:] + sol.reaction("arm")[3:] + np.cross(arm, sol.reaction("arm")[:3])
         + np.cross(p_now, f) + mz)
    np.testing.assert_allclose(F, 0.0, atol=2e-6)
    np.testing.assert_allclose(M, 0.0, atol=2e-6)


def test_whole_step_does_not_jump_to_a_folded_branch():
    """2D cross flexure (Table 1, 5 el./leaf) taken to 55 degrees in one step: without the
    corrector-rotation limit Newton turned a node by 341 degrees in its third iteration and
    converged to a folded equilibrium with 216 J; the branch reached by continuation (first step 5 degrees)
    stores 6.58 J (measured), and the one-step solve must find that one."""
    import flexmb

    def pivot(theta):
        return flexmb.models.cross_flexure_pivot(elements_per_leaf=5, dim=2, rotation=np.radians(theta))

    one_step = flexmb.solve(pivot(55.0))
    stepped = flexmb.solve(pivot(55.0), initial_step=5.0 / 55.0)
    assert one_step.converged and stepped.converged
    assert one_step.strain_energy() == pytest.approx(stepped.strain_energy(), rel=1e-9)
    assert one_step.strain_energy() < 10.0
    wandering = flexmb.solve(pivot(55.0), max_rotation=None, step_control="paper")  # Fig. 18 alone
    assert wandering.strain_energy() > 100.0  # the failure mode this guards against, still there without it


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 40), seed=st.integers(0, 2**31), shift=st.floats(-2.0, 2.0), density=st.floats(0.05, 0.5))
def test_stability_is_the_sign_of_the_smallest_eigenvalue(n, seed, shift, density):
    """is_stable(K) = (smallest eigenvalue of (K + K^T)/2 > 0), closed form by eigvalsh, on sparse
    random matrices shifted through definiteness (the sparse LDL^T inertia path and its fallback)."""
    import scipy.sparse as sp
    from flexmb.solvers.conventional import is_stable

    rng = np.random.default_rng(seed)
    B = sp.random(n, n, density=density, random_state=rng).toarray()
    A = B @ B.T + 0.1 * np.eye(n) + rng.normal(size=(n, n)) * 1e-3  # slightly non-symmetric
    lo = np.linalg.eigvalsh(0.5 * (A + A.T))[0]
    A = A - (lo + shift * max(abs(lo), 1.0)) * np.eye(n)
    lmin = np.linalg.eigvalsh(0.5 * (A + A.T))[0]
    assume(abs(lmin) > 1e-8)
    assert is_stable(sp.csr_array(A)) == (lmin > 0)


def test_stability_of_a_matrix_that_needs_off_diagonal_pivots():
    """[[0, 1], [1, 0]] has eigenvalues -1 and 1 and no usable diagonal pivot; [[0]] is singular."""
    import scipy.sparse as sp
    from flexmb.solvers.conventional import is_stable

    assert is_stable(sp.csr_array(np.array([[0.0, 1.0], [1.0, 0.0]]))) is False
    assert is_stable(sp.csr_array(np.array([[0.0]]))) is False
    assert is_stable(sp.csr_array(np.array([[2.0, 1.0], [1.0, 2.0]]))) is True
