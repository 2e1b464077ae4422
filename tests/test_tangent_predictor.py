"""The continuation's tangent predictor and first step (issue 31 item 3): the equilibrium path's
derivative (`StaticProblem.path_rate`) against central differences of converged equilibria, the
Hermite extrapolation (`FEModel.extrapolated_increment` with ``rate``) against polynomials it must
reproduce, the linear predictor's stretch (`FEModel.largest_stretch`) against the chord of a turned
element, and Newton iterations that no longer grow with the mesh."""

import numpy as np
import pytest

import flexmb
from flexmb.compiled import compiled_for
from flexmb.fe.model import State


def _equilibrium(mechanism):
    sol = flexmb.solve(mechanism, rtol=1e-13)
    assert sol.converged
    return sol


def _rate_at_the_end(mechanism):
    """The path rate at load factor 1 of ``mechanism``'s converged equilibrium, and its model."""
    sol = _equilibrium(mechanism)
    problem = compiled_for(mechanism, "fe_model").problem
    r, Kff, Kfp, _ = problem.evaluate(sol.state, 1.0)
    return problem.path_rate(sol.state, 1.0, r, Kff, Kfp, 1e-4), problem.model, sol.state


# the whole motion scaled by 1 +- eps is the path at load factor 1 +- eps: prescribed translations
# (the four-bar, 2D and 3D), rotation chains exp(lam w1) exp(lam w2) (the manipulator's joint case,
# where a one-sided difference of the prescribed spins is 1 % off), and a dead load (a cantilever)
PATHS = [
    ("four-bar 2D, 3 el./leaf, d = 0.2 m", lambda s: flexmb.models.fourbar(3, displacement=0.2 * s, dim=2)),
    ("four-bar 3D, 2 el./leaf, d = 0.25 m", lambda s: flexmb.models.fourbar(2, displacement=0.25 * s)),
    ("manipulator, joint case, 30 deg", lambda s: flexmb.models.manipulator("joint", np.radians(30.0) * s)),
]


def _loaded_cantilever(s):
    m = flexmb.models.cantilever(6, dim=3)
    m.apply_force("tip", (0.0, 40.0 * s, 15.0 * s))  # F L^2 / EI ~ 2.4: a large deflection
    return m


PATHS.append(("cantilever 3D under a tip force", _loaded_cantilever))


@pytest.mark.parametrize("name, build", PATHS, ids=[p[0] for p in PATHS])
def test_path_rate_is_the_derivative_of_the_equilibria(name, build):
    eps = 1e-4
    rate, model, state = _rate_at_the_end(build(1.0))
    plus, minus = _equilibrium(build(1.0 + eps)).state, _equilibrium(build(1.0 - eps)).state
    central = (model.increment(state, plus) - model.increment(state, minus)) / (2.0 * eps)
    nodes = lambda v: model.node_part(v).reshape(model.n_nodes, model.ndof)  # noqa: E731
    for part in (slice(0, model.dim), slice(model.dim, model.ndof)):  # translations, rotations
        a, b = nodes(rate)[:, part], nodes(central)[:, part]
        assert np.abs(a - b).max() <= 1e-5 * np.abs(b).max() + 1e-12, name


def test_hermite_extrapolation_reproduces_a_polynomial_one_degree_above_the_lagrange_one():
    # positions on a cubic in the load factor through three states and its slope at the last: the
    # predictor at any target is the cubic itself (2D: rotations add, so exact too)
    model = compiled_for(flexmb.models.fourbar(1, displacement=0.1, dim=2), "fe_model").problem.model
    rng = np.random.default_rng(3)
    coef = rng.normal(size=(4, model.n_dofs))
    path_at = lambda t: sum(c * t**k for k, c in enumerate(coef))  # noqa: E731
    slope_at = lambda t: sum(k * c * t ** (k - 1) for k, c in enumerate(coef) if k)  # noqa: E731
    rest = model.initial_state()
    lams = [0.1, 0.35, 0.5]
    path = [(t, model.apply_increment(rest, path_at(t))) for t in lams]
    for target in (0.6, 0.8, 1.0):
        du = model.extrapolated_increment(path, target, rate=slope_at(0.5))
        np.testing.assert_allclose(du, path_at(target) - path_at(0.5), rtol=0, atol=1e-12)
    # without the slope: the quadratic through the three states, not the cubic
    du = model.extrapolated_increment(path, 1.0)
    assert np.abs(du - (path_at(1.0) - path_at(0.5))).max() > 1e-3


def test_a_single_state_with_its_slope_is_the_tangent_line():
    model = compiled_for(flexmb.models.fourbar(1, displacement=0.1), "fe_model").problem.model
    rate = np.random.default_rng(0).normal(size=model.n_dofs)
    du = model.extrapolated_increment([(0.25, model.initial_state())], 0.75, rate=rate)
    np.testing.assert_allclose(du, 0.5 * rate, rtol=0, atol=1e-15)


@pytest.mark.parametrize("theta", [0.1, 0.5, 1.0])
def test_largest_stretch_is_the_chord_change_of_a_linearly_turned_leaf(theta):
    # a straight leaf along x turned about its clamped end by the linearised rotation theta (points
    # move by theta z x r): each element's chord grows by sqrt(1 + theta^2) - 1; an exact rotation: 0
    model = compiled_for(flexmb.models.cantilever(5, dim=2), "fe_model").problem.model
    rest = model.initial_state()
    x = rest.positions
    linear = State(x + theta * np.column_stack([-x[:, 1], x[:, 0]]), rest.rotations + theta)
    assert model.largest_stretch(rest, linear) == pytest.approx(np.sqrt(1.0 + theta**2) - 1.0, rel=1e-12)
    c, s = np.cos(theta), np.sin(theta)
    exact = State(x @ np.array([[c, s], [-s, c]]), rest.rotations + theta)
    assert model.largest_stretch(rest, exact) < 1e-14


def test_iterations_no_longer_grow_with_the_mesh():
    # issue 31: four-bar (d = 0.3 m) at 5 / 10 / 20 el./leaf took 18 / 47 / 43 Newton iterations
    # (each step started from 1e5-2e7 N); now 23 / 22 / 24 (benchmarks/bench_meshes.py)
    its = [flexmb.solve(flexmb.models.fourbar(n, displacement=0.3)).iterations for n in (5, 10, 20)]
    assert max(its) <= 1.2 * its[0] and max(its) <= 30, its


def test_the_refined_four_bar_reaches_the_papers_equilibrium():
    # the continuation with the tangent predictor ends where Fig. 18's control ends (another path,
    # the same equilibrium; 10 el./leaf, beyond the paper's 5)
    m = flexmb.models.fourbar(10, displacement=0.3)
    paper, default = flexmb.solve(m, step_control="paper"), flexmb.solve(m)
    assert paper.converged and default.converged
    x = paper.node_positions()
    np.testing.assert_allclose(default.node_positions(), x, rtol=0, atol=1e-9 * np.abs(x).max())
    assert default.reaction("top")[0] == pytest.approx(paper.reaction("top")[0], rel=1e-7)
