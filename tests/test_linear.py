"""`flexmb.linear.TangentSolver`: every path gives the exact solution of the true (non-symmetric)
K, the analysis is reused per pattern, and the fallback catches what the LDL^T path cannot do
(issue 21 item 2)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

import flexmb
from flexmb import jit, linear

needs_qdldl = pytest.mark.skipif(not linear.available()["qdldl"], reason="qdldl not installed")


def _banded(n, rng, asym=0.0, shift=4.0):
    """A symmetric banded SPD matrix (bandwidth 6, like a beam chain) plus ``asym`` times a skew part."""
    A = sp.random(n, n, density=0.0, random_state=0, format="lil")
    for k in range(-6, 7):
        d = rng.normal(size=n - abs(k))
        A.setdiag(d, k)
    A = A.tocsr()
    S = A + A.T + sp.eye(n) * (shift + 2 * np.abs(A).sum(axis=1).max())
    W = (A - A.T) * asym
    return sp.csr_matrix(S + W), S


def _backward_error(K, x, b):
    return np.abs(b - K @ x).max() / (np.abs(K.data).max() * np.abs(x).max() + np.abs(b).max())


@needs_qdldl
@pytest.mark.parametrize("asym", [0.0, 1e-4, 1e-2])
def test_ldl_path_solves_the_true_matrix(asym):
    rng = np.random.default_rng(1)
    K, S = _banded(600, rng, asym)
    W = K - S
    solver = linear.TangentSolver()
    for k in range(3):  # same pattern, new numbers: the analysis is reused
        K = sp.csr_matrix(S * (1.0 + 0.1 * k) + W * (1.0 - 0.2 * k))
        K.sort_indices()
        b = rng.normal(size=600)
        x = solver.solve(K, b)
        assert _backward_error(K, x, b) < 1e-13  # exact to refinement tolerance (linear.REFINE_TOL)
    assert solver.stats["ldl"] == 3 and solver.stats["superlu"] == 0
    # a symmetric K needs no refinement; a near-symmetric one a few triangular solves per solve
    assert solver.stats["refinements"] == 0 if asym == 0 else 0 < solver.stats["refinements"] <= 3 * 5


@needs_qdldl
def test_indefinite_symmetric_part_falls_back_to_superlu():
    # K = skew + tiny symmetric: its symmetric part is nearly singular, refinement cannot converge
    rng = np.random.default_rng(2)
    n = 400
    A = sp.random(n, n, density=0.02, random_state=3, format="csr") + sp.eye(n, k=1)
    K = sp.csr_matrix(A - A.T + 1e-9 * sp.eye(n) + 5.0 * (sp.eye(n, k=1) - sp.eye(n, k=-1)))
    K.sort_indices()
    b = rng.normal(size=n)
    solver = linear.TangentSolver()
    x = solver.solve(K, b)
    assert np.abs(K @ x - b).max() < 1e-8 * np.abs(b).max() * np.abs(K.data).max() * np.abs(x).max()
    assert solver.stats["fallbacks"] == 1 and solver.stats["superlu"] == 1


def test_small_systems_are_dense_and_exact():
    rng = np.random.default_rng(4)
    K, _ = _banded(50, rng, 1e-3)
    b = rng.normal(size=50)
    solver = linear.TangentSolver()
    assert _backward_error(K, solver.solve(K, b), b) < 1e-14
    assert solver.stats["dense"] == 1


@needs_qdldl
def test_whole_solves_are_the_same_with_and_without_the_ldl_path(monkeypatch):
    # a case no paper has: a 3D cantilever of 100 elements (600 unknowns) under a large oblique tip load
    def solve():
        m = flexmb.models.cantilever(dim=3, elements=100)
        m.apply_force("tip", (0.0, 60.0, -160.0))
        return flexmb.solve(m)

    with_ldl = solve()
    monkeypatch.setattr(linear, "_HAVE_QDLDL", False)
    without = solve()
    assert with_ldl.converged and without.converged and with_ldl.iterations == without.iterations > 6
    x0 = without.node_positions()
    assert np.abs(with_ldl.node_positions() - x0).max() <= 1e-10 * np.abs(x0).max()


needs_numba = pytest.mark.skipif(not jit.enabled(), reason="the compiled L D U needs numba")


@needs_numba
@pytest.mark.parametrize("use_ldl", [True, False])
def test_compiled_ldu_solves_a_non_symmetric_matrix_exactly(use_ldl):
    # beyond flexmb's tangents: a banded matrix whose skew part is 30 % of its symmetric part (an LDL^T
    # of the symmetric part cannot refine that), new numbers on one pattern three times
    rng = np.random.default_rng(5)
    K, S = _banded(500, rng, 0.3)
    W = K - S
    solver = linear.TangentSolver(use_ldl=use_ldl and linear.available()["qdldl"])
    for k in range(3):
        K = sp.csr_matrix(S * (1.0 + 0.1 * k) + W * (1.0 - 0.2 * k))
        K.sort_indices()
        b = rng.normal(size=500)
        x = solver.solve(K, b)
        assert _backward_error(K, x, b) < 1e-13  # linear.REFINE_TOL
        assert np.abs(x - spsolve(K.tocsc(), b)).max() <= 1e-10 * np.abs(x).max()  # SuperLU, pivoting
    assert solver.stats["ldu"] == 3 and solver.stats["superlu"] == 0


@needs_numba
def test_manipulator_tangents_never_need_superlu(monkeypatch):
    # Dwarshuis et al. (2020) Sec. 4.4, joint case at 45 deg: at predicted states the symmetric part
    # of K_ff is indefinite (smallest eigenvalue -1.9e7 N/m against +0.18 at equilibrium) and its
    # LDL^T refinement diverges; the exact L D U takes those solves: the same equilibrium as with
    # SuperLU taking them
    def solve():
        return flexmb.solve(flexmb.models.manipulator("joint", np.radians(45.0)))

    sol = solve()
    stats = sol.compiled.problem._tangent_solver.stats
    assert sol.converged and stats["ldu"] > 0 and stats["superlu"] == 0
    monkeypatch.setattr(linear.TangentSolver, "_solve_ldu", lambda self, K, b: None)
    ref = solve()
    assert ref.compiled.problem._tangent_solver.stats["superlu"] > 0
    x0 = ref.node_positions()
    assert np.abs(sol.node_positions() - x0).max() <= 1e-12 * np.abs(x0).max()
    # its last steps end just below rtol (6.5e-9 of the force scale against 1e-8): two exact solvers,
    # differing in the last bits, may need one iteration more or less there (measured 53 and 54)
    assert abs(sol.iterations - ref.iterations) <= 1


@pytest.mark.parametrize("compiled", [False, True])
def test_positive_definite_from_the_solvers_pivots_agrees_with_is_stable(compiled):
    # the four-bar's converged tangent (Dwarshuis et al. 2020 Sec. 4.3, 5 el./leaf: stable), and the
    # same shifted along its diagonal by 0.5 and 1.5 times its smallest eigenvalue (still positive
    # definite; one negative eigenvalue): Sylvester's law on the pivots against SuperLU's inertia
    from flexmb.solvers.conventional import is_stable

    if compiled and not jit._AVAILABLE or not compiled and not linear.available()["qdldl"]:
        pytest.skip("needs numba / qdldl")
    previous = jit.use("numba" if compiled else "numpy")
    try:
        sol = flexmb.solve(flexmb.models.fourbar(5, displacement=0.3))
        problem = sol.compiled.problem
        K = problem.evaluate(sol.state, 1.0)[1]
        lowest = np.linalg.eigvalsh(0.5 * (K + K.T).toarray())[0]
        assert lowest > 0.0
        for factor, expected in ((0.0, True), (0.5, True), (1.5, False)):
            shifted = K.copy()
            diagonal = np.flatnonzero(np.repeat(np.arange(K.shape[0]), np.diff(K.indptr)) == K.indices)
            shifted.data[diagonal] -= factor * lowest
            assert problem.positive_definite(shifted) is expected
            assert is_stable(shifted) is expected
    finally:
        jit.use("auto" if previous else "numpy")
