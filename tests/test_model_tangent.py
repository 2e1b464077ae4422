"""The assembled residual's tangent (elements + rigid offsets + load stiffness) equals finite differences."""

import numpy as np
import pytest

import flexmb
from flexmb.testing import finite_difference_tangent, perturbed_state, scaled_error
from tolerances import FD_TANGENT


def _two_link_frame(dim):
    """Two cross flexures and a leaf spring around two free links; loads at offset points."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("ground", fixed=True)
    cf = flexmb.CrossFlexure(elements_per_leaf=2)
    b = cf.interface_b(dim)
    m.add_link("arm", position=b)
    m.add_joint("ground", "arm", cf, name="hinge")
    shift = np.zeros(dim)
    shift[0] = 0.15
    m.add_link("hand", position=b + shift)
    m.add_joint("arm", "hand", flexmb.LeafSpring(length=0.15, elements=3), origin=b, name="leaf")
    m.add_joint("ground", "hand", flexmb.LeafSpring(length=b[1], elements=2), origin=shift,
                rotation=np.pi / 2 if dim == 2 else (0, 0, np.pi / 2), name="post")
    m.apply_force("hand", np.r_[3.0, -5.0, 1.0][:dim], point=b + shift + np.r_[0.02, 0.03, -0.01][:dim])
    # a large force far from its node: its load stiffness (force x arm ~ 40 N m) must be right
    m.apply_force("hand", np.r_[200.0, 150.0, -100.0][:dim], point=b + shift + np.r_[0.2, -0.15, 0.1][:dim])
    m.apply_force("arm", np.r_[-2.0, 1.0, 0.5][:dim], point=b + np.r_[-0.03, 0.01, 0.02][:dim])
    m.apply_moment("arm", 0.3 if dim == 2 else (0.1, -0.2, 0.3))
    m.prescribe("arm", x=1e-3)  # a prescribed DOF, so K_fp is checked as well
    return m


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_assembled_tangent_matches_central_differences_in_deformed_states(dim, seed):
    problem = _two_link_frame(dim).compile().problem
    state = perturbed_state(problem, problem.model.initial_state(), np.random.default_rng(seed),
                            displacement=2e-3, rotation=0.2)
    K, Kfd = finite_difference_tangent(problem, state, lam=1.0)
    nf = problem.n_free
    # free columns scaled by their diagonal, prescribed columns by their largest entry
    diag_cols = np.concatenate([np.diag(K[:, :nf]), np.abs(K[:, nf:]).max(axis=0)])
    assert scaled_error(K, Kfd, np.diag(K[:, :nf]), diag_cols) <= FD_TANGENT


@pytest.mark.parametrize("dim", [2, 3])
def test_tangent_is_symmetric_at_rest_and_residual_zero(dim):
    problem = _two_link_frame(dim).compile().problem
    state = problem.model.initial_state()
    r, K, _, _ = problem.evaluate(state, 0.0)
    K = K.toarray()
    # zero up to the roundoff of coordinates (~1e-16 x model size) times the stiffness
    assert np.abs(r).max() < 1e-14 * np.abs(K).max() * np.ptp(problem.model.x0)
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-12 * np.abs(K).max())


def test_rigid_offsets_are_exact_constraints():
    """Points on a link keep their distances exactly under a large rigid rotation of the link."""
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=3, rotation=np.radians(60))
    sol = flexmb.solve(m)
    model = sol.compiled.problem.model
    x = sol.node_positions()
    on_b = model.point_master == sol.compiled.link_node["B"]
    x0 = model.point_x0[on_b]
    d = x[on_b][:, None] - x[on_b][None]
    d0 = x0[:, None] - x0[None]
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), np.linalg.norm(d0, axis=-1), rtol=0, atol=1e-15)
