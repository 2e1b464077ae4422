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
* with numba (`flexmb.jit.enabled`), when the LDL^T's refinement stalls (a step gaining less than
  `_STALL`) or without qdldl: the compiled ``L D U`` of ``K`` itself (`flexmb.linear_jit`, same
  ordering, no pivoting), checked and refined the same way. At predicted states of the
  manipulator the symmetric part is indefinite (smallest eigenvalue -1.9e7 against +0.18 at
  equilibrium) while K is not: 9 of its 49 solves at 45 deg, which went to SuperLU before;
* SuperLU (scipy) otherwise, and whenever neither can deliver (a zero pivot, or refinement that
  does not converge): the fallback is always exact.

The hinges' saddle point ``[[K, G^T], [G, 0]]`` (`flexmb.fe.ideal`) goes the LDL^T way with its
zero diagonal shifted to ``-SADDLE_SHIFT max|K|`` in the factorisation only (refinement against
the true matrix removes the shift).

The choice of solvers was measured on flexmb's own converged tangents (BENCHMARKS.md, Timings
moved from docstrings): the LDL^T beat SuperLU on every case, pypardiso (MKL) needs a large
install, cvxopt's UMFPACK was slower than SuperLU.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from . import jit

__all__ = ["TangentSolver", "DENSE_BELOW", "DENSE_BELOW_LDL", "REFINE_TOL", "available", "single_threaded"]

DENSE_BELOW = 220  # unknowns; crossover of LAPACK and SuperLU ~200-230 (3D cross flexure, four-bar)
#: The crossover when qdldl's LDL^T (analysis reused) is the sparse path: measured on converged 3D
#: cantilever tangents in one run (benchmarks/bench_scale.py, one BLAS thread, loaded host), dense /
#: LDL^T time 0.54 at 48 unknowns, 0.93 at 60, 1.28 at 72, 1.75 at 90, 10 at 120.
DENSE_BELOW_LDL = 64
REFINE_TOL = 1e-13  # backward error ||b - K x|| / (||K||_max ||x|| + ||b||) accepted from refinement
_MAX_REFINE = 6
#: With the compiled L D U available (numba), refinement of the symmetric part's LDL^T stops as soon
#: as a step cuts the backward error by less than this factor, and the exact L D U takes over
#: (manipulator at 45 deg: 9 of 49 solves had a symmetric part too far from K, whose refinement
#: diverged after 7 steps and went to SuperLU)
_STALL = 0.1
#: Shift of a zero diagonal entry in the LDL^T only, relative to max|K| (refinement restores the
#: exact solve). Measured on hinged leaf loops (2D 60 / 200 el./leaf: 368 / 1208 unknowns; 3D 30
#: el./leaf: 377): refinement steps over the Newton solves 1e-6: 19 / 31 / 108 (1-2 SuperLU
#: fallbacks), 1e-8: 9 / 12 / 67, 1e-10: 16 / 15 / 75, 1e-12: 53 / 48 / 161 with 7 / 4 / 6 fallbacks
#: (cancellation).
SADDLE_SHIFT = 1e-8
#: Patterns with at least this many entries are analysed by the numba pass
#: (`flexmb.linear_jit.upper_maps`; smaller ones by numpy: no compilation for them)
COMPILED_ANALYSIS_FROM = 200_000

_HAVE_QDLDL = importlib.util.find_spec("qdldl") is not None


_CONTROLLER = None


def single_threaded():
    """A context in which BLAS/LAPACK run on one thread (threadpoolctl).

    A solve's linear algebra is small (dense below `DENSE_BELOW` unknowns, KSD's reduced systems
    of tens): a multithreaded BLAS only adds synchronisation, and on a busy machine a thread
    waiting for a taken core stalls every call. Entering has a cost, so solvers enter once per solve, not per iteration."""
    global _CONTROLLER
    if _CONTROLLER is None:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")


def available() -> dict:
    """Which sparse paths this installation has: ``{"qdldl": bool, "superlu": True}``."""
    return {"qdldl": _HAVE_QDLDL, "superlu": True}


def _backward_error(K, x: np.ndarray, b: np.ndarray):
    """``r = b - K x`` and the backward error ``max|r| / (max|K| max|x| + max|b|)`` (inf when ``x``
    is not finite); one numba pass with numba."""
    if jit.enabled() and np.ndim(b) == 1:  # several right-hand sides (compliance): the numpy lines
        from . import linear_jit

        r = np.empty(len(b))
        error = linear_jit.backward_error(K.indptr, K.indices, np.ascontiguousarray(K.data, dtype=float),
                                          np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(b, dtype=float), r)
        return r, error
    if not np.all(np.isfinite(x)):
        return None, np.inf
    r = b - K @ x
    with np.errstate(invalid="ignore", divide="ignore"):  # 0 / 0 (b = x = 0): NaN, silently, as the compiled pass
        return r, np.abs(r).max() / (np.abs(K.data).max() * np.abs(x).max() + np.abs(b).max())


class TangentSolver:
    """Solves ``K x = b`` for matrices of one sparsity pattern (CSR, square), reusing the analysis.

    ``stats`` counts the solves per path and the refinement steps taken (for benchmarks).
    """

    def __init__(self, use_ldl: bool | None = None):
        self.use_ldl = _HAVE_QDLDL if use_ldl is None else (bool(use_ldl) and _HAVE_QDLDL)
        self._pattern = None  # (indptr, indices) the analysis belongs to (copies)
        self._seen = None  # the index arrays last found equal to them (the same objects: no compare)
        self._upper = None  # the symmetric part's upper triangle (CSC) and its gather maps
        self._ldl = None
        self._ldu = None  # the compiled L D U's arrays (`_ldu_analyse`), or False: not usable
        self.stats = {"dense": 0, "ldl": 0, "ldu": 0, "superlu": 0, "refinements": 0, "fallbacks": 0}

    def __getstate__(self) -> dict:
        """Pickled without its analysis (qdldl's factorisation does not pickle; a copy analyses
        its first matrix again): a `Solution`, and the `flexmb.Modes` that hold one, pickle."""
        return {**vars(self), "_pattern": None, "_seen": None, "_upper": None, "_ldl": None, "_ldu": None}

    def solve(self, K: sp.csr_array | sp.csr_matrix, b: np.ndarray) -> np.ndarray:
        """``x`` with ``K x = b`` (``K`` CSR with sorted indices, as `flexmb.fe.assembly` builds it)."""
        n = K.shape[0]
        compiled = jit.enabled()
        sparse_path = self.use_ldl or compiled
        if n < (DENSE_BELOW_LDL if sparse_path else DENSE_BELOW):
            self.stats["dense"] += 1
            return np.linalg.solve(K.toarray(), b)
        if sparse_path and not self._same_pattern(K):
            self._analyse(K)
        if self.use_ldl and self._upper is not None:
            x = self._solve_ldl(K, b, _STALL if compiled else np.inf)
            if x is not None:
                self.stats["ldl"] += 1
                return x
            self.stats["fallbacks"] += 1
        if compiled and self._upper is not None:
            x = self._solve_ldu(K, b)
            if x is not None:
                self.stats["ldu"] += 1
                return x
        self.stats["superlu"] += 1
        return splu(K.tocsc()).solve(b)

    def positive_definite(self, K) -> bool | None:
        """Whether the symmetric part of ``K`` is positive definite, from the signs of the pivots
        of its ``L D L^T`` on this solver's analysis (Sylvester's law of inertia; no pivoting, as
        `flexmb.solvers.conventional.is_stable`'s SuperLU in symmetric mode): qdldl's when installed
        and the compiled L D U not analysed yet (its analysis is costly on large models), else
        the numba factorisation. None where this cannot tell (below the dense limit, no
        sparse path, a pattern not structurally symmetric, a zero diagonal or pivot): the caller
        decides another way. Faster than `is_stable`'s own factorisation (BENCHMARKS.md, Timings
        moved from docstrings)."""
        compiled = jit.enabled()
        if K.shape[0] < DENSE_BELOW_LDL or not (compiled or self.use_ldl):
            return None
        if not self._same_pattern(K):
            self._analyse(K)
        if self._upper is None:
            return None
        data = np.ascontiguousarray(K.data, dtype=float)
        sym = np.empty_like(data)
        sym[self._ia] = sym[self._ib] = 0.5 * (data[self._ia] + data[self._ib])
        if np.any(sym[self._ia[self._diag]] == 0.0):
            return None
        if compiled and (self._ldu is not None or self._ldl is None):  # qdldl's when the L D U is not analysed
            from . import linear_jit

            if self._ldu is None:
                self._ldu_analyse()
            if self._ldu is False:
                return None
            n, Up, Ui, upper_at, lower_at, diag_at, parent, Lp, perm, Li, Lx, Ux, D = self._ldu
            if not linear_jit.factor(n, sym, Up, Ui, upper_at, lower_at, diag_at, parent, Lp, Li, Lx, Ux, D):
                return None
            self._fresh = False  # the L D U's arrays now hold this factorisation (the LDL^T is untouched)
            return bool(np.all(D > 0.0))
        if self._ldl is None:
            return None
        self._upper.data = sym[self._ia]
        try:
            self._ldl.update(self._upper, upper=True)
        except (ValueError, RuntimeError):
            return None
        self._fresh = False
        return bool(np.all(self._ldl.factors()[1] > 0.0))

    def _same_pattern(self, K) -> bool:
        """Whether ``K`` has the pattern of the current analysis (the same index arrays as last
        time: no comparison; `flexmb.fe.assembly.PartitionedPattern` shares them)."""
        if self._pattern is None:
            return False
        if self._seen is not None and K.indptr is self._seen[0] and K.indices is self._seen[1]:
            return True
        same = np.array_equal(self._pattern[0], K.indptr) and np.array_equal(self._pattern[1], K.indices)
        self._seen = (K.indptr, K.indices) if same else None
        return same

    def _analyse(self, K) -> None:
        """Gather maps from K's CSR data to the upper triangle of (K + K^T)/2, the symbolic LDL^T;
        the L D U's analysis (`_ldu_analyse`) waits for its first use. O(nnz), no global sort
        (`_maps`; `_maps_compiled` for large patterns); the pattern must be symmetric in structure
        and sorted (the assembled blocks are), else the sparse paths of this pattern go to SuperLU."""
        # a read-only structure (a `flexmb.fe.assembly.PartitionedPattern`'s) cannot change: kept, not copied
        self._pattern = tuple(a if not a.flags.writeable else a.copy() for a in (K.indptr, K.indices))
        self._seen = (K.indptr, K.indices)
        self._upper = self._ldl = self._ldu = None
        if not K.has_sorted_indices:  # flexmb's patterns are sorted; another matrix: SuperLU
            return
        maps = self._maps_compiled(K) if jit.enabled() and K.nnz >= COMPILED_ANALYSIS_FROM else self._maps(K)
        if maps is None:
            return
        n = K.shape[0]
        self._ia, self._ib, u_rows, u_indptr = maps
        self._upper = sp.csc_matrix((np.zeros(len(u_rows)), u_rows, u_indptr), shape=(n, n))
        self._diag = np.flatnonzero(self._ia == self._ib)
        if not self.use_ldl:
            return
        import qdldl

        self._fill(K)
        try:
            self._ldl = qdldl.Solver(self._upper, upper=True)
            self._fresh = True
        except (ValueError, RuntimeError):  # a zero pivot already at the first matrix
            self._ldl = None

    @staticmethod
    def _maps(K):
        """``(ia, ib, u_rows, u_indptr)``: the upper triangle of ``(K + K^T)/2`` in CSC order, as qdldl
        wants it (by the symmetric structure, column j's rows i <= j are row j's columns i <= j of K
        in CSR order), each entry's position ``ib`` in K's data and its mirror's ``ia``, from the
        transpose by scipy's counting sort; None when the structure is not symmetric."""
        n = K.shape[0]
        T = sp.csr_matrix((np.arange(K.nnz, dtype=np.int64), K.indices, K.indptr), shape=K.shape).T.tocsr()
        T.has_sorted_indices = True  # the CSC conversion writes each column's rows in order
        if not (np.array_equal(T.indptr, K.indptr) and np.array_equal(T.indices, K.indices)):
            return None
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(K.indptr))
        cols = np.asarray(K.indices, dtype=np.int64)
        lower = np.flatnonzero(cols <= rows)
        u_rows = cols[lower]
        return T.data[lower], lower, u_rows, np.searchsorted(rows[lower], np.arange(n + 1))

    @staticmethod
    def _maps_compiled(K):
        """`_maps` by one numba pass (`flexmb.linear_jit.upper_maps`): the same arrays, for large patterns
        (1e5 beam elements: ~11 million entries)."""
        from . import linear_jit

        n = K.shape[0]
        m = (K.nnz + n) // 2 + 1  # at most: the diagonal and one of each mirrored pair
        ia, ib, u_rows, u_indptr = (np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64),
                                    np.empty(m, dtype=np.int64), np.empty(n + 1, dtype=np.int64))
        k = linear_jit.upper_maps(n, np.asarray(K.indptr, dtype=np.int64), np.asarray(K.indices, dtype=np.int64),
                                  ia, ib, u_rows, u_indptr)
        if k < 0:
            return None
        return ia[:k], ib[:k], u_rows[:k], u_indptr

    def _fill(self, K) -> None:
        """The factorised matrix's numbers: the upper triangle of ``(K + K^T)/2``, its exactly zero
        diagonal entries (a saddle point's constraint rows: the hinges' multipliers) set to
        ``-SADDLE_SHIFT max|K|`` so that the LDL^T without pivoting has no zero pivot there;
        refinement against the true ``K`` removes the shift's effect (or the solve falls back)."""
        if jit.enabled():
            from . import linear_jit

            data = np.empty(len(self._ia))
            linear_jit.symmetric_upper(np.ascontiguousarray(K.data, dtype=float), self._ia, self._ib, self._diag,
                                       SADDLE_SHIFT, data)
        else:
            data = 0.5 * (K.data[self._ia] + K.data[self._ib])
            d = data[self._diag]
            zero = self._diag[d == 0.0]
            if len(zero):
                data[zero] = -SADDLE_SHIFT * np.abs(data).max()
        self._upper.data = data

    def _solve_ldl(self, K, b, stall: float):
        if self._ldl is None:  # this pattern's first matrix had a zero pivot
            return None
        if self._fresh:  # factorised by the analysis
            self._fresh = False
        else:
            self._fill(K)
            try:
                self._ldl.update(self._upper, upper=True)
            except (ValueError, RuntimeError):
                return None
        try:
            x = self._ldl.solve(b)
        except (ValueError, RuntimeError):
            return None
        return self._refined(K, b, x, self._ldl.solve, stall)

    def _refined(self, K, b, x, solve, stall: float = np.inf):
        """``x`` refined with the approximate inverse ``solve`` until its backward error against
        the true ``K`` is below `REFINE_TOL`; None after `_MAX_REFINE` steps, or as soon as a step
        cuts the error by less than the factor ``stall``."""
        previous = np.inf
        for k in range(_MAX_REFINE + 1):
            r, error = _backward_error(K, x, b)
            if error <= REFINE_TOL:
                return x
            if not np.isfinite(error) or k == _MAX_REFINE or error > stall * previous:
                return None
            previous = error
            x = x + solve(r)
            self.stats["refinements"] += 1
        return None

    def _ldu_analyse(self) -> None:
        """The compiled ``L D U`` (`flexmb.linear_jit`) of this pattern: the fill-reducing order
        (qdldl's AMD when installed, else SuperLU's minimum degree on ``K + K^T``), the permuted
        upper triangle's gather maps from K's data, the elimination tree."""
        from . import linear_jit

        up = self._upper
        n = up.shape[0]
        cols = np.repeat(np.arange(n), np.diff(up.indptr))
        rows = up.indices.astype(np.int64)
        diag = rows == cols
        if diag.sum() != n:  # a structurally zero diagonal entry: no factorisation without pivoting
            self._ldu = False
            return
        if self._ldl is not None:
            perm = np.asarray(self._ldl.factors()[2], dtype=np.int64)
        else:
            pattern = sp.csc_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
            pattern = (pattern + pattern.T + n * sp.eye(n)).tocsc()
            perm = np.argsort(splu(pattern, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                   options={"SymmetricMode": True}).perm_c).astype(np.int64)
        inv = np.empty(n, dtype=np.int64)
        inv[perm] = np.arange(n)
        pi, pj = inv[rows[~diag]], inv[cols[~diag]]
        ia, ib = self._ia[~diag], self._ib[~diag]
        swap = pi > pj  # entry (i, j) of K lands below the permuted diagonal: its mirror is above
        ur, uc = np.where(swap, pj, pi), np.where(swap, pi, pj)
        # column-major order of the permuted upper triangle by scipy's counting sort (O(nnz); the
        # entries are distinct): the CSC conversion of a COO whose data are the entries' numbers
        M = sp.coo_matrix((np.arange(1, len(ur) + 1, dtype=np.int64), (ur, uc)), shape=(n, n)).tocsc()
        M.sort_indices()
        order = M.data - 1
        Up = M.indptr.astype(np.int64)
        Ui = np.ascontiguousarray(M.indices, dtype=np.int64)
        upper_at = np.ascontiguousarray(np.where(swap, ib, ia)[order])
        lower_at = np.ascontiguousarray(np.where(swap, ia, ib)[order])
        diag_at = np.empty(n, dtype=np.int64)
        diag_at[inv[rows[diag]]] = self._ia[diag]
        parent, Lnz = linear_jit.etree(n, Up, Ui)
        Lp = np.zeros(n + 1, dtype=np.int64)
        Lp[1:] = np.cumsum(Lnz)
        nnz = int(Lp[-1])
        self._ldu = (n, Up, Ui, upper_at, lower_at, diag_at, parent, Lp, perm,
                     np.empty(nnz, dtype=np.int64), np.empty(nnz), np.empty(nnz), np.empty(n))

    def _solve_ldu(self, K, b):
        """The exact solve by the compiled ``L D U`` without pivoting, checked (and refined) like
        the LDL^T's; None when a pivot vanishes or the backward error stays large."""
        from . import linear_jit

        if self._ldu is None:
            self._ldu_analyse()
        if self._ldu is False:
            return None
        n, Up, Ui, upper_at, lower_at, diag_at, parent, Lp, perm, Li, Lx, Ux, D = self._ldu
        data = np.ascontiguousarray(K.data, dtype=float)
        if not linear_jit.factor(n, data, Up, Ui, upper_at, lower_at, diag_at, parent, Lp, Li, Lx, Ux, D):
            return None

        def solve(rhs):
            rhs = np.asarray(rhs, dtype=float)
            if rhs.ndim == 2:  # several right-hand sides (compliance): column by column
                return np.column_stack([solve(col) for col in rhs.T]) if rhs.shape[1] else rhs.copy()
            x = np.empty(n)
            linear_jit.solve(n, perm, Lp, Li, Lx, Ux, D, np.ascontiguousarray(rhs), x)
            return x

        return self._refined(K, b, solve(b), solve, _STALL)
