"""A sparse ``L D U`` factorisation without pivoting for matrices of one structurally symmetric
pattern, compiled (numba): the symbolic analysis once per pattern, the numbers per matrix.

``C = P K P^T = L D U`` with ``L`` unit lower and ``U`` unit upper triangular of the same
pattern (``pattern(L) = pattern(U^T)``, the pattern of ``C`` being symmetric), ``P`` a
fill-reducing symmetric ordering. The up-looking algorithm of qdldl (Stellato, Goulart et al.,
the OSQP team's LDL^T: elimination tree, then one sparse triangular solve per row) run on the
column above and the row left of each diagonal entry: row ``k`` of ``L D`` and column ``k`` of
``D U`` are ``U_11^T z = C[k, :k]^T`` and ``L_11 y = C[:k, k]``, ``D_k = C_kk - sum z_j y_j / D_j``.
For a symmetric ``K`` it is qdldl's LDL^T; for flexmb's tangent away from equilibrium (not
symmetric) it is the exact Newton step, where an LDL^T of the symmetric part needs refinement
that does not always converge (`flexmb.linear`).
"""

from __future__ import annotations

import numpy as np

from .jit import njit

__all__ = ["etree", "factor", "solve"]


@njit
def etree(n, Up, Ui):
    """Elimination tree ``parent`` (n,) and column counts ``Lnz`` (n,) of the upper triangle
    ``(Up, Ui)`` (CSC, row indices < column, diagonal excluded) of a symmetric pattern."""
    work = np.full(n, -1, dtype=np.int64)
    parent = np.full(n, -1, dtype=np.int64)
    Lnz = np.zeros(n, dtype=np.int64)
    for j in range(n):
        work[j] = j
        for p in range(Up[j], Up[j + 1]):
            i = Ui[p]
            while work[i] != j:
                if parent[i] == -1:
                    parent[i] = j
                Lnz[i] += 1
                work[i] = j
                i = parent[i]
    return parent, Lnz


@njit
def factor(n, data, Up, Ui, upper_at, lower_at, diag_at, parent, Lp, Li, Lx, Ux, D):
    """The numbers of ``L D U`` from the matrix's data: column ``k`` of the permuted upper triangle
    has rows ``Ui[Up[k]:Up[k+1]]``, with ``C[i, k] = data[upper_at[p]]``, ``C[k, i] =
    data[lower_at[p]]``; ``C[k, k] = data[diag_at[k]]``. Fills ``Li, Lx`` (L by columns), ``Ux``
    (U by rows, the same places) and ``D``. Returns False at a zero or non-finite pivot."""
    y = np.zeros(n)
    z = np.zeros(n)
    mark = np.full(n, -1, dtype=np.int64)
    reach = np.empty(n, dtype=np.int64)
    stack = np.empty(n, dtype=np.int64)
    nxt = Lp[:n].copy()
    for k in range(n):
        D[k] = data[diag_at[k]]
        ny = 0
        for p in range(Up[k], Up[k + 1]):
            i = Ui[p]
            y[i] = data[upper_at[p]]
            z[i] = data[lower_at[p]]
            if mark[i] == k:
                continue
            mark[i] = k
            stack[0] = i
            ns = 1
            j = parent[i]
            while j != -1 and j < k and mark[j] != k:
                mark[j] = k
                stack[ns] = j
                ns += 1
                j = parent[j]
            while ns > 0:
                ns -= 1
                reach[ny] = stack[ns]
                ny += 1
        for t in range(ny - 1, -1, -1):
            c = reach[t]
            yc, zc = y[c], z[c]
            end = nxt[c]
            for p in range(Lp[c], end):
                r = Li[p]
                y[r] -= Lx[p] * yc
                z[r] -= Ux[p] * zc
            Li[end] = k
            Ux[end] = yc / D[c]
            Lx[end] = zc / D[c]
            D[k] -= zc * Ux[end]
            nxt[c] = end + 1
            y[c] = 0.0
            z[c] = 0.0
        if not (D[k] != 0.0 and np.isfinite(D[k])):
            return False
    return True


@njit
def solve(n, perm, Lp, Li, Lx, Ux, D, b, x):
    """``x`` with ``K x = b`` from the factors (``perm``: ``C[i, j] = K[perm[i], perm[j]]``)."""
    w = np.empty(n)
    for i in range(n):
        w[i] = b[perm[i]]
    for c in range(n):
        wc = w[c]
        for p in range(Lp[c], Lp[c + 1]):
            w[Li[p]] -= Lx[p] * wc
    for c in range(n):
        w[c] /= D[c]
    for c in range(n - 1, -1, -1):
        v = w[c]
        for p in range(Lp[c], Lp[c + 1]):
            v -= Ux[p] * w[Li[p]]
        w[c] = v
    for i in range(n):
        x[perm[i]] = w[i]


@njit
def backward_error(indptr, indices, data, x, b, r):
    """``r = b - K x`` (``K`` CSR) and the backward error ``max|r| / (max|K| max|x| + max|b|)``;
    inf when ``x`` has a non-finite entry."""
    n = b.shape[0]
    xmax = 0.0
    for i in range(n):
        if not np.isfinite(x[i]):
            return np.inf
        xmax = max(xmax, abs(x[i]))
    kmax = 0.0
    rmax = 0.0
    bmax = 0.0
    for i in range(n):
        v = b[i]
        for p in range(indptr[i], indptr[i + 1]):
            v -= data[p] * x[indices[p]]
            kmax = max(kmax, abs(data[p]))
        r[i] = v
        rmax = max(rmax, abs(v))
        bmax = max(bmax, abs(b[i]))
    return rmax / (kmax * xmax + bmax)


@njit
def symmetric_upper(data, ia, ib, diag, shift, out):
    """``out = (data[ia] + data[ib]) / 2`` (the upper triangle of ``(K + K^T)/2``), its exactly
    zero ``diag`` entries set to ``-shift max|out|``."""
    big = 0.0
    for p in range(ia.shape[0]):
        out[p] = 0.5 * (data[ia[p]] + data[ib[p]])
        big = max(big, abs(out[p]))
    for p in diag:
        if out[p] == 0.0:
            out[p] = -shift * big


@njit
def upper_maps(n, indptr, indices, ia, ib, u_rows, u_indptr):
    """`flexmb.linear.TangentSolver`'s analysis maps in one O(nnz) pass over a CSR pattern with
    sorted indices: for every entry (j, i), i <= j, in CSR order (row j's columns i <= j: column
    j of the upper triangle in CSC order, the pattern being structurally symmetric) its position
    ``ib`` and its mirror (i, j)'s position ``ia`` in the data, its row ``u_rows`` = i, and the
    upper triangle's column pointers ``u_indptr`` (n + 1,). The mirrors come from a cursor per
    row: row i's entries right of the diagonal are met in order as the rows below reach column i.
    Returns the entries written, or -1 when an entry's mirror is missing (not symmetric)."""
    cursor = np.empty(n, dtype=np.int64)
    for i in range(n):  # the first entry right of the diagonal of every row
        p = indptr[i]
        while p < indptr[i + 1] and indices[p] <= i:
            p += 1
        cursor[i] = p
    k = 0
    u_indptr[0] = 0
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            if i > j:
                break
            if i == j:
                ia[k] = p
            else:
                q = cursor[i]
                if q >= indptr[i + 1] or indices[q] != j:
                    return -1
                ia[k] = q
                cursor[i] = q + 1
            ib[k] = p
            u_rows[k] = i
            k += 1
        u_indptr[j + 1] = k
    for i in range(n):  # every entry right of the diagonal was some entry's mirror
        if cursor[i] != indptr[i + 1]:
            return -1
    return k

