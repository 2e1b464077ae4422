"""The complex step through the numpy element kernels (issue 28): exact directional derivatives of
the residual and the tangent with respect to the model numbers and the state, checked against
central differences of the float kernels; the float path itself is unchanged (tests/test_kernels.py)."""

from __future__ import annotations

import numpy as np
import pytest
from design_cases import PIVOT, PIVOT_BOUNDS, SPATIAL, pivot, spatial
from test_kernels import _batch2d, _batch3d

import flexmb
from flexmb.design import DesignPoint
from flexmb.design.partials import H, mass_forms, residual_rates, tangent_forms
from flexmb.fe import beam2d, beam3d
from flexmb.fe.mass import mass_matrix
from flexmb.problem import StaticProblem


def _directions(args, rng):
    return [rng.normal(size=np.shape(a)) * (np.abs(a) + 1e-3 * np.abs(a).max()) for a in args]


@pytest.mark.parametrize("dim", [2, 3])
def test_complex_step_through_the_kernels_equals_central_differences(dim):
    rng = np.random.default_rng(dim)
    args = _batch3d(rng, n=20, turn=0.6) if dim == 3 else _batch2d(rng, n=20, turn=1.5)
    fn = beam3d.numpy_internal_force_and_tangent if dim == 3 else beam2d.numpy_internal_force_and_tangent
    dirs = _directions(args, rng)
    cs = fn(*[a + 1j * H * d for a, d in zip(args, dirs)])
    h = 1e-6
    plus = fn(*[a + h * d for a, d in zip(args, dirs)])
    minus = fn(*[a - h * d for a, d in zip(args, dirs)])
    valid = ~np.isnan(fn(*args)[2]).any(axis=1)  # elements past 90 degrees are NaN on every path
    assert valid.sum() >= 10 and np.array_equal(np.isnan(cs[2]).any(axis=1), ~valid)
    for k in (0, 1):  # F and K
        fd = (plus[k] - minus[k])[valid] / (2 * h)
        assert np.abs(cs[k][valid].imag / H - fd).max() <= 1e-6 * np.abs(fd).max()
        ref = fn(*args)[k][valid]
        assert np.abs(cs[k][valid].real - ref).max() <= 1e-14 * np.abs(ref).max()


def _problem_at(design, p):
    return design.mechanism(p).compile("fe_model").problem


@pytest.mark.parametrize("case", ["pivot2", "pivot3", "spatial"])
def test_residual_and_tangent_rates_equal_differences_of_rebuilt_models(case):
    # d r / d p at a fixed (deformed) state: the complex step through the model numbers' rates
    # against central differences of the residual of models rebuilt at p +- h (the same state)
    build, p, bounds = {"pivot2": (lambda q: pivot(q, 2), PIVOT, PIVOT_BOUNDS),
                        "pivot3": (lambda q: pivot(q, 3), PIVOT, PIVOT_BOUNDS),
                        "spatial": (spatial, SPATIAL, None)}[case]
    point = DesignPoint(build, p, bounds)
    sol = flexmb.solve(point.design.mechanism(), rtol=1e-12)
    rates = point.rates(sol.compiled)
    problem, state = sol.compiled.problem, sol.state
    dr = residual_rates(problem, state, rates)
    rng = np.random.default_rng(0)
    scale = np.array([q.step / 1e-5 for q in point.design.parameters])  # the parameters' sizes
    du = rng.normal(size=(problem.model.n_dofs, len(point.names))) * 1e-3 / scale  # 1e-3 per relative change
    eye = np.eye(problem.model.n_dofs)
    dK = tangent_forms(problem, state, rates, du, eye, eye)
    dM = mass_forms(problem, state, rates, du, eye, eye)
    for k, q in enumerate(point.design.parameters):
        h = 10 * q.step
        r = [_problem_at(point.design, {**point.design.values, q.name: q.value + s * h}).residual(state, 1.0)
             for s in (1.0, -1.0)]
        fd = (r[0] - r[1]) / (2 * h)
        scale = max(np.abs(dr[:, k]).max(), np.abs(fd).max(), 1e-300)
        assert np.abs(dr[:, k] - fd).max() <= 1e-6 * scale, q.name
        # the tangent's directional derivative along (rates_k, du_k): differences of the full tangent
        Ks = []
        for s in (1.0, -1.0):
            prob: StaticProblem = _problem_at(point.design, {**point.design.values, q.name: q.value + s * h})
            st = prob.model.apply_increment(state, s * h * du[:, k])
            Ks.append(_full_tangent(prob, st))
        fdK = (Ks[0] - Ks[1]) / (2 * h)
        assert np.abs(dK[k] - fdK).max() <= 1e-5 * np.abs(fdK).max(), q.name
        Ms = [mass_matrix(prob.model, prob.model.apply_increment(state, s * h * du[:, k]), prob.model.rigid_masses)
              .toarray() for s, prob in ((s, _problem_at(point.design, {**point.design.values, q.name: q.value + s * h}))
                                         for s in (1.0, -1.0))]
        fdM = (Ms[0] - Ms[1]) / (2 * h)
        assert np.abs(dM[k] - fdM).max() <= 1e-5 * max(np.abs(fdM).max(), 1e-12 * np.abs(Ms[0]).max()), q.name


def _full_tangent(problem, state):
    from flexmb.linearisation import _full_pattern

    m = problem.model
    Ke = m.element_response(state, tangent=True)[1]
    _, G = problem.external_force(state, 1.0)
    return _full_pattern(m, problem.loads).matrix(np.concatenate([Ke.ravel(), -G.ravel()])).toarray()
