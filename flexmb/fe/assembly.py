"""Sparse assembly with a pattern built once: COO triplets -> fixed CSR structure via bincount."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["SparsePattern", "PartitionedPattern", "scatter_add"]


class SparsePattern:
    """The CSR structure of a matrix assembled from a fixed list of COO ``(row, col)`` entries.

    Built once per model; `matrix` then sums any value array of the same length into that
    structure with one ``np.bincount`` (duplicate entries add up, as in finite-element assembly).
    Entries whose row or column is negative are dropped (they belong to another partition).
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]):
        rows = np.asarray(rows, dtype=np.int64).ravel()
        cols = np.asarray(cols, dtype=np.int64).ravel()
        self.keep = np.flatnonzero((rows >= 0) & (cols >= 0))
        self.shape = shape
        key = rows[self.keep] * shape[1] + cols[self.keep]
        uniq, self.inv = np.unique(key, return_inverse=True)
        self.nnz = len(uniq)
        r, self.indices = np.divmod(uniq, shape[1])
        self.indptr = np.searchsorted(r, np.arange(shape[0] + 1)).astype(np.int64)
        self.indices = self.indices.astype(np.int64)

    def matrix(self, values: np.ndarray) -> sp.csr_array:
        """CSR matrix with ``values`` (same length as the rows given at construction) summed in."""
        data = np.bincount(self.inv, weights=np.asarray(values).ravel()[self.keep], minlength=self.nnz)
        return sp.csr_array((data, self.indices, self.indptr), shape=self.shape)


class PartitionedPattern:
    """The CSR structures of the free-free and free-prescribed blocks ``K_ff``, ``K_fp`` of a
    matrix assembled from a fixed list of COO ``(row, col)`` entries on all DOFs, and each entry's
    *slot*: ``slot >= 0`` its place in K_ff's data, ``slot <= -2`` in K_fp's at ``-2 - slot``,
    ``-1`` dropped (a prescribed row, or a prescribed column of a prescribed row).

    Built once per problem; `split` sums values into the two data arrays (``np.bincount``; the
    compiled assembly, `flexmb.fe.model_jit`, scatters at the same slots), `matrices` wraps them
    as CSR without re-checking the structure (a per-iteration constructor cost otherwise, ~0.05
    ms). The matrices it returns share their index arrays, which nobody may modify.
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray, slot_f: np.ndarray, slot_p: np.ndarray):
        rows = np.asarray(rows, dtype=np.int64).ravel()
        cols = np.asarray(cols, dtype=np.int64).ravel()
        nf, npres = int(np.sum(slot_f >= 0)), int(np.sum(slot_p >= 0))
        r, cf, cp = slot_f[rows], slot_f[cols], slot_p[cols]
        self.slots = np.full(len(rows), -1, dtype=np.int64)
        self.nnz, self._templates = [], []
        for k, (c, n) in enumerate(((cf, nf), (cp, npres))):
            keep = np.flatnonzero((r >= 0) & (c >= 0))
            uniq, inv = np.unique(r[keep] * n + c[keep], return_inverse=True)
            self.slots[keep] = inv if k == 0 else -2 - inv
            i, j = np.divmod(uniq, n) if n else (uniq, uniq)
            indptr = np.searchsorted(i, np.arange(nf + 1)).astype(np.int64)
            M = sp.csr_array((np.zeros(len(uniq)), j.astype(np.int64), indptr), shape=(nf, n))
            M.has_sorted_indices = True
            self.nnz.append(len(uniq))
            self._templates.append(M)
            del keep, inv, uniq, i, j

    def split(self, values: np.ndarray, first: int = 0, out=None):
        """The data arrays ``(ff, fp)`` with ``values`` (the entries from ``first`` on, in the order
        given at construction) summed in; added to ``out`` if given."""
        values = np.asarray(values, dtype=float).ravel()
        slots = self.slots[first:first + len(values)]
        ff = slots >= 0
        fp = slots <= -2
        a = np.bincount(slots[ff], weights=values[ff], minlength=self.nnz[0]).astype(float, copy=False)
        b = np.bincount(-2 - slots[fp], weights=values[fp], minlength=self.nnz[1]).astype(float, copy=False)
        if out is None:
            return a, b
        np.add(out[0], a, out=out[0])
        np.add(out[1], b, out=out[1])
        return out

    def matrices(self, data_ff: np.ndarray, data_fp: np.ndarray):
        """``(K_ff, K_fp)`` as CSR arrays holding ``data_ff`` and ``data_fp`` (not copied)."""
        out = []
        for M, data in zip(self._templates, (data_ff, data_fp)):
            new = object.__new__(type(M))  # copy.copy without its protocol (~3x faster)
            new.__dict__.update(M.__dict__)
            new.data = data
            out.append(new)
        return tuple(out)


def scatter_add(index: np.ndarray, values: np.ndarray, size: int) -> np.ndarray:
    """Vector of length ``size`` with ``values`` added at ``index`` (negative indices dropped)."""
    index = np.asarray(index).ravel()
    values = np.asarray(values).ravel()
    keep = index >= 0
    return np.bincount(index[keep], weights=values[keep], minlength=size).astype(float, copy=False)
