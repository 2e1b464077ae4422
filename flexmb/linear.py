"""Linear solves of the conventional method's tangent, with the sparse analysis done once.

``K x = b`` with ``K`` the free-free tangent of one sparsity pattern, solved many times (every
Newton iteration of every load step). Three paths, chosen by size and by what is installed:

* below `DENSE_BELOW` unknowns (`DENSE_BELOW_LDL` when qdldl is the sparse path): dense LAPACK
  (the sparse set-up costs more there);
* with qdldl (the OSQP team's LDL^T, in the ``fast`` extra): the symmetric part
  ``K_s = (K + K^T)/2`` factorised as ``P K_s P^T = L D L^T`` with the AMD ordering and the
  symbolic factorisation computed once per pattern (`qdldl.Solver.update` refactors the numbers
  only), then iterative refinement against the true ``K`` until the backward error is below
  `REFINE_TOL`: an exact Newton step, not a quasi-Newton one. flexmb's tangent is symmetric at
  equilibrium (1e-17 relative, measured on the four-bar and the manipulator) and ~1e-4 away from
  it, so refinement converges in one or two extra triangular solves;
* SuperLU (scipy) otherwise, and whenever the LDL^T path cannot deliver (a zero pivot of an
  indefinite ``K_s``, or refinement that does not converge): the fallback is always exact.

The hinges' saddle point ``[[K, G^T], [G, 0]]`` (`flexmb.fe.ideal`) goes the LDL^T way with its
zero diagonal shifted to ``-SADDLE_SHIFT max|K|`` in the factorisation only (refinement against
the true matrix removes the shift).

Measured with one BLAS thread on flexmb's own converged tangents (medians of 7, this 2-core host
under load): four-bar at 5 el./leaf (305 unknowns) SuperLU 0.39 ms, qdldl 0.15 ms; manipulator
(369) 0.50 / 0.15 ms; 3D cantilevers of 500 / 2000 / 8000 elements (3000 / 12 000 / 48 000
unknowns) 2.3 / 22 / 108 ms against 0.25 / 0.94 / 11 ms. pypardiso (MKL, ~650 MB installed) took
0.18, 0.10, 0.77, 6.7 and 51 ms; cvxopt's UMFPACK with its symbolic analysis reused was slower
than SuperLU on every case (0.46-243 ms).
"""

from __future__ import annotations

import importlib.util

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

__all__ = ["TangentSolver", "DENSE_BELOW", "DENSE_BELOW_LDL", "REFINE_TOL", "available", "single_threaded"]

DENSE_BELOW = 220  # unknowns; crossover of LAPACK and SuperLU ~200-230 (3D cross flexure, four-bar)
#: The crossover when qdldl's LDL^T (analysis reused) is the sparse path: measured on converged 3D
#: cantilever tangents in one run (benchmarks/bench_scale.py, one BLAS thread, loaded host), dense /
#: LDL^T time 0.54 at 48 unknowns, 0.93 at 60, 1.28 at 72, 1.75 at 90, 10 at 120.
DENSE_BELOW_LDL = 64
REFINE_TOL = 1e-13  # backward error ||b - K x|| / (||K||_max ||x|| + ||b||) accepted from refinement
_MAX_REFINE = 6
#: Shift of a zero diagonal entry in the LDL^T only, relative to max|K| (refinement restores the
#: exact solve). Measured on hinged leaf loops (2D 60 / 200 el./leaf: 368 / 1208 unknowns; 3D 30
#: el./leaf: 377): refinement steps over the Newton solves 1e-6: 19 / 31 / 108 (1-2 SuperLU
#: fallbacks), 1e-8: 9 / 12 / 67, 1e-10: 16 / 15 / 75, 1e-12: 53 / 48 / 161 with 7 / 4 / 6 fallbacks
#: (cancellation). A solve then takes 0.15 / 0.29 / 0.19 ms against SuperLU's 0.43 / 0.77 / 0.45.
SADDLE_SHIFT = 1e-8

_HAVE_QDLDL = importlib.util.find_spec("qdldl") is not None


_CONTROLLER = None


def single_threaded():
    """A context in which BLAS/LAPACK run on one thread (threadpoolctl).

    A solve's linear algebra is small (dense below `DENSE_BELOW` unknowns, KSD's reduced systems
    of tens): a multithreaded BLAS only adds synchronisation, and on a busy machine a thread
    waiting for a taken core stalls every call (measured on this 2-core host with a second core
    busy: a 100 x 100 ``numpy.linalg.solve`` 13.5 ms with OpenBLAS's default threads, 0.05 ms
    with one). Entering costs ~0.3 ms, so solvers enter once per solve, not per iteration."""
    global _CONTROLLER
    if _CONTROLLER is None:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")


def available() -> dict:
    """Which sparse paths this installation has: ``{"qdldl": bool, "superlu": True}``."""
    return {"qdldl": _HAVE_QDLDL, "superlu": True}


class TangentSolver:
    """Solves ``K x = b`` for matrices of one sparsity pattern (CSR, square), reusing the analysis.

    ``stats`` counts the solves per path and the refinement steps taken (for benchmarks).
    """

    def __init__(self, use_ldl: bool | None = None):
        self.use_ldl = _HAVE_QDLDL if use_ldl is None else (bool(use_ldl) and _HAVE_QDLDL)
        self._pattern = None  # (indptr, indices) the analysis belongs to
        self._upper = None  # the symmetric part's upper triangle (CSC) and its gather maps
        self._ldl = None
        self.stats = {"dense": 0, "ldl": 0, "superlu": 0, "refinements": 0, "fallbacks": 0}

    def solve(self, K: sp.csr_array | sp.csr_matrix, b: np.ndarray) -> np.ndarray:
        """``x`` with ``K x = b`` (``K`` CSR with sorted indices, as `flexmb.fe.assembly` builds it)."""
        n = K.shape[0]
        if n < (DENSE_BELOW_LDL if self.use_ldl else DENSE_BELOW):
            self.stats["dense"] += 1
            return np.linalg.solve(K.toarray(), b)
        if self.use_ldl:
            x = self._solve_ldl(K, b)
            if x is not None:
                self.stats["ldl"] += 1
                return x
            self.stats["fallbacks"] += 1
        self.stats["superlu"] += 1
        return splu(K.tocsc()).solve(b)

    def _analyse(self, K) -> None:
        """Gather maps from K's CSR data to the upper triangle of (K + K^T)/2, and the symbolic LDL^T."""
        import qdldl

        n = K.shape[0]
        coo = sp.csr_matrix((np.arange(K.nnz) + 1.0, K.indices, K.indptr), shape=K.shape).tocoo()
        pos = (coo.data - 1.0).astype(np.int64)  # position of each entry in K.data
        rows, cols = coo.row.astype(np.int64), coo.col.astype(np.int64)
        # every stored (i, j) and its mirror (j, i) must be in the pattern: the assembled blocks are
        # symmetric in structure; if not, this path is not used
        key = rows * n + cols
        order = np.argsort(key)
        mirror_key = cols * n + rows
        where = np.searchsorted(key[order], mirror_key)
        found = (where < len(key)) & (key[order][np.minimum(where, len(key) - 1)] == mirror_key)
        if not found.all():
            self.use_ldl = False
            return
        mirror = pos[order][where]
        upper = rows <= cols
        # upper triangle in CSC order (column-major), as qdldl wants
        u_rows, u_cols = rows[upper], cols[upper]
        csc = np.lexsort((u_rows, u_cols))
        self._ia, self._ib = pos[upper][csc], mirror[upper][csc]
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.add.at(indptr, u_cols[csc] + 1, 1)
        self._upper = sp.csc_matrix((np.zeros(len(csc)), u_rows[csc], np.cumsum(indptr)), shape=(n, n))
        self._diag = np.flatnonzero(u_rows[csc] == u_cols[csc])
        self._fill(K)
        try:
            self._ldl = qdldl.Solver(self._upper, upper=True)
        except (ValueError, RuntimeError):  # a zero pivot already at the first matrix
            self._ldl = None
        self._pattern = (K.indptr.copy(), K.indices.copy())

    def _fill(self, K) -> None:
        """The factorised matrix's numbers: the upper triangle of ``(K + K^T)/2``, its exactly zero
        diagonal entries (a saddle point's constraint rows: the hinges' multipliers) set to
        ``-SADDLE_SHIFT max|K|`` so that the LDL^T without pivoting has no zero pivot there;
        refinement against the true ``K`` removes the shift's effect (or the solve falls back)."""
        data = 0.5 * (K.data[self._ia] + K.data[self._ib])
        d = data[self._diag]
        zero = self._diag[d == 0.0]
        if len(zero):
            data[zero] = -SADDLE_SHIFT * np.abs(data).max()
        self._upper.data = data

    def _solve_ldl(self, K, b):
        same = self._pattern is not None and np.array_equal(self._pattern[0], K.indptr) \
            and np.array_equal(self._pattern[1], K.indices)
        if not same:
            self._analyse(K)
            if not self.use_ldl or self._ldl is None:
                return None
        else:
            if self._ldl is None:  # this pattern's first matrix had a zero pivot
                return None
            self._fill(K)
            try:
                self._ldl.update(self._upper, upper=True)
            except (ValueError, RuntimeError):
                return None
        try:
            x = self._ldl.solve(b)
        except (ValueError, RuntimeError):
            return None
        scale = np.abs(K.data).max()
        for _ in range(_MAX_REFINE + 1):
            if not np.all(np.isfinite(x)):
                return None
            r = b - K @ x
            if np.abs(r).max() <= REFINE_TOL * (scale * np.abs(x).max() + np.abs(b).max()):
                return x
            x = x + self._ldl.solve(r)
            self.stats["refinements"] += 1
        return None
