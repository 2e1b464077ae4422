"""Sparse assembly with a pattern built once: COO triplets -> fixed CSR structure via bincount."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["SparsePattern", "scatter_add"]


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


def scatter_add(index: np.ndarray, values: np.ndarray, size: int) -> np.ndarray:
    """Vector of length ``size`` with ``values`` added at ``index`` (negative indices dropped)."""
    index = np.asarray(index).ravel()
    values = np.asarray(values).ravel()
    keep = index >= 0
    return np.bincount(index[keep], weights=values[keep], minlength=size)
