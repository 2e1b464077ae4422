"""Sparse assembly with a pattern built once: COO triplets -> fixed CSR structure via bincount."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import jit

__all__ = ["SparsePattern", "PartitionedPattern", "node_pattern", "scatter_add"]

#: Patterns with at least this many entries expand their rows by a numba pass
#: (`flexmb.fe.assembly_jit.repeat_rows`; smaller ones by numpy: no compilation for them)
COMPILED_FROM = 200_000
#: Elements per pass of `node_pattern`'s slot computation: its temporaries stay at ~40 MB (3D)
#: whatever the model's size (1e5 elements: ~1.2 GB in one pass)
_CHUNK = 8192


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


def _read_only_structure(M):
    """``M`` with its index arrays read-only: the matrices of a pattern share them (`matrices`),
    and `flexmb.linear.TangentSolver` keeps them as the pattern its analysis belongs to, uncopied."""
    M.indices.flags.writeable = False
    M.indptr.flags.writeable = False
    return M


class PartitionedPattern:
    """The CSR structures of the free-free and free-prescribed blocks ``K_ff``, ``K_fp`` of a
    matrix assembled from a fixed list of COO ``(row, col)`` entries on all DOFs, and each entry's
    *slot*: ``slot >= 0`` its place in K_ff's data, ``slot <= -2`` in K_fp's at ``-2 - slot``,
    ``-1`` dropped (a prescribed row, or a prescribed column of a prescribed row).

    Built once per problem; `split` sums values into the two data arrays (``np.bincount``; the
    numba assembly, `flexmb.fe.model_jit`, scatters at the same slots), `matrices` wraps them
    as CSR without re-checking the structure (a per-iteration constructor cost otherwise). The
    matrices it returns share their index arrays, read-only.
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
            self._templates.append(_read_only_structure(M))
            del keep, inv, uniq, i, j

    @classmethod
    def _of(cls, slots: np.ndarray, templates: list) -> PartitionedPattern:
        """A pattern from its parts (`node_pattern`)."""
        out = object.__new__(cls)
        out.slots, out._templates = slots, [_read_only_structure(M) for M in templates]
        out.nnz = [M.nnz for M in templates]
        return out

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
            new = object.__new__(type(M))  # copy.copy without its protocol
            new.__dict__.update(M.__dict__)
            new.data = data
            out.append(new)
        return tuple(out)


def _ragged(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """``concatenate([arange(s, s + n) for s, n in zip(starts, lengths)])`` in O(total)."""
    lengths = np.asarray(lengths, dtype=np.int64)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.cumsum(lengths) - lengths
    return np.repeat(np.asarray(starts, dtype=np.int64) - first, lengths) + np.arange(total, dtype=np.int64)


def _node_graph(master: np.ndarray, n_nodes: int) -> sp.csr_array:
    """The nodes' coupling (N, N), sorted CSR: node ``a`` with ``b`` when an element joins them
    (and every element end with itself). scipy's counting sort, O(E + N) (no global sort)."""
    a, b = master[:, 0], master[:, 1]
    rows, cols = np.concatenate([a, a, b, b]), np.concatenate([a, b, a, b])
    G = sp.csr_array((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n_nodes, n_nodes))
    G.sum_duplicates()  # canonical: sorted column indices, no duplicates
    return G


def _block_template(G: sp.csr_array, count: np.ndarray, start: np.ndarray, row_count: np.ndarray):
    """One partition's CSR structure (K_ff or K_fp) from the node graph ``G``: ``count`` (N,) the
    partition's columns per node (free or prescribed DOFs), ``start`` (N,) the first column of each
    node, ``row_count`` (N,) the free rows per node. Returns the template matrix, the position of
    each node pair's columns within its rows (nnz(G),), every node's row length and the first data
    slot of every node's rows."""
    n_nodes = G.shape[0]
    width = count[G.indices]  # columns each node pair contributes to a row
    row_len = _segment_sums(width, G.indptr)
    seg_start = np.cumsum(row_len) - row_len  # where each node's row pattern starts in `seg`
    within = np.cumsum(width) - width - np.repeat(seg_start, np.diff(G.indptr))
    first_slot = np.cumsum(row_count * row_len) - row_count * row_len
    # one node's row: the columns of its neighbours in order, the same for each of its free rows
    seg = _ragged(start[G.indices], width)  # every node's row pattern, concatenated
    n_rows, n_cols = int(row_count.sum()), int(count.sum())
    nnz = int(np.dot(row_len, row_count))
    if jit.enabled() and nnz >= COMPILED_FROM:  # one numba pass instead of four over every entry
        from . import assembly_jit

        indices, indptr = np.empty(nnz, dtype=np.int64), np.empty(n_rows + 1, dtype=np.int64)
        i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731 - one specialisation
        assembly_jit.repeat_rows(i64(seg), i64(seg_start), i64(row_len), i64(row_count), indices, indptr)
    else:
        per_row = np.repeat(np.arange(n_nodes), row_count)
        indices = seg[_ragged(seg_start[per_row], row_len[per_row])] if len(seg) else np.zeros(0, dtype=np.int64)
        indptr = np.concatenate([[0], np.cumsum(row_len[per_row])]).astype(np.int64)
    M = sp.csr_array((np.zeros(len(indices)), indices, indptr), shape=(n_rows, n_cols))
    M.has_sorted_indices = True
    return M, within, row_len, first_slot


def _segment_sums(values: np.ndarray, indptr: np.ndarray) -> np.ndarray:
    """Sums of ``values`` over the CSR rows ``indptr`` (empty rows: 0)."""
    c = np.concatenate([[0], np.cumsum(values)])
    return (c[indptr[1:]] - c[indptr[:-1]]).astype(np.int64)


def node_pattern(master: np.ndarray, n_nodes: int, ndof: int, slot_f: np.ndarray, slot_p: np.ndarray,
                 extra: tuple = ()) -> PartitionedPattern | None:
    """The `PartitionedPattern` of element blocks on all DOFs of their two end nodes (``master``
    (E, 2), DOFs ``node * ndof + 0..ndof-1``), then the ``extra`` blocks (arrays (K, d) of DOFs,
    each within the node pairs the elements couple), built from the connectivity in O(E): the
    nodes' coupling graph (`_node_graph`), every node's row pattern once, each element's slots
    by index arithmetic in chunks (no global sort of the E (2 ndof)^2 entries; the memory of a
    chunk). The same pattern as ``PartitionedPattern(rows, cols, slot_f, slot_p)`` of those
    entries: the same structure, slots and data order (tests/test_assembly_pattern.py). None when
    an extra block leaves the elements' node pairs (the caller builds it the general way)."""
    master = np.ascontiguousarray(master, dtype=np.int64).reshape(-1, 2)
    G = _node_graph(master, n_nodes)
    keys = np.repeat(np.arange(n_nodes, dtype=np.int64), np.diff(G.indptr)) * n_nodes + G.indices
    isf, isp = (slot_f >= 0).reshape(n_nodes, ndof), (slot_p >= 0).reshape(n_nodes, ndof)
    fcount, pcount = isf.sum(axis=1), isp.sum(axis=1)
    fstart, pstart = np.cumsum(fcount) - fcount, np.cumsum(pcount) - pcount
    Mf, within_f, len_f, first_f = _block_template(G, fcount, fstart, fcount)
    Mp, within_p, len_p, first_p = _block_template(G, pcount, pstart, fcount)
    node = np.arange(n_nodes * ndof) // ndof
    frank = np.where(slot_f >= 0, slot_f - fstart[node], -1)  # a free DOF's rank within its node
    prank = np.where(slot_p >= 0, slot_p - pstart[node], -1)
    row_f = np.where(slot_f >= 0, first_f[node] + frank * len_f[node], -1)  # first slot of a free row
    row_p = np.where(slot_f >= 0, first_p[node] + frank * len_p[node], -1)

    def pairs(gr: np.ndarray, gc: np.ndarray) -> np.ndarray | None:
        """Positions in G of the node pairs (gr, gc); None if one is not in G."""
        want = gr * n_nodes + gc
        k = np.minimum(np.searchsorted(keys, want), len(keys) - 1)
        return k if np.array_equal(keys[k], want) else None

    def combine(rows, cols, wf, wp):
        """Slots from the rows' and columns' parts (broadcast) and the node pairs' offsets."""
        free_row = slot_f[rows] >= 0
        ff = row_f[rows] + wf + frank[cols]
        fp = row_p[rows] + wp + prank[cols]
        return np.where(free_row & (slot_f[cols] >= 0), ff, np.where(free_row & (slot_p[cols] >= 0), -2 - fp, -1))

    n2 = 2 * ndof
    E = len(master)
    extra = [np.asarray(b, dtype=np.int64) for b in extra]
    slots = np.empty(E * n2 * n2 + sum(b.shape[0] * b.shape[1] ** 2 for b in extra), dtype=np.int64)
    k = np.arange(ndof)
    chunked = E  # the elements the numpy pass below computes
    if jit.enabled() and E * n2 * n2 >= COMPILED_FROM:  # one compiled pass (fe/assembly_jit)
        from . import assembly_jit

        i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731 - one specialisation
        assembly_jit.element_slots(master, ndof, i64(G.indptr), i64(G.indices), i64(slot_f), i64(slot_p), i64(row_f),
                                   i64(row_p), i64(frank), i64(prank), i64(within_f), i64(within_p), slots)
        chunked = 0
    for lo in range(0, chunked, _CHUNK):
        mc = master[lo:lo + _CHUNK]
        C = len(mc)
        dofs = (mc[:, :, None] * ndof + k).reshape(C, n2)
        kk = pairs(mc[:, :, None], mc[:, None, :])  # (C, 2, 2): the elements' node pairs are in G
        out = slots[lo * n2 * n2:(lo + C) * n2 * n2].reshape(C, 2, ndof, 2, ndof)
        # K_ff's slots, broadcast without expanding the node pairs' offsets (2 passes over the chunk)
        np.add(row_f[dofs].reshape(C, 2, ndof, 1, 1), within_f[kk][:, :, None, :, None], out=out)
        out += frank[dofs].reshape(C, 1, 1, 2, ndof)
        # elements with a prescribed DOF (few: at the supports) again, the general way
        odd = np.flatnonzero(~np.all(slot_f[dofs] >= 0, axis=1))
        if len(odd):
            d = dofs[odd]
            out[odd] = combine(d[:, :, None], d[:, None, :], within_f[kk[odd]].repeat(ndof, 1).repeat(ndof, 2),
                               within_p[kk[odd]].repeat(ndof, 1).repeat(ndof, 2)).reshape(len(odd), 2, ndof, 2, ndof)
    at = E * n2 * n2
    for b in extra:
        if b.size == 0:
            continue
        rows, cols = b[:, :, None], b[:, None, :]
        kk = pairs(rows // ndof, cols // ndof)
        if kk is None:
            return None
        block = combine(rows, cols, within_f[kk], within_p[kk])
        slots[at:at + block.size] = block.ravel()
        at += block.size
    return PartitionedPattern._of(slots, [Mf, Mp])


def scatter_add(index: np.ndarray, values: np.ndarray, size: int) -> np.ndarray:
    """Vector of length ``size`` with ``values`` added at ``index`` (negative indices dropped)."""
    index = np.asarray(index).ravel()
    values = np.asarray(values).ravel()
    keep = index >= 0
    return np.bincount(index[keep], weights=values[keep], minlength=size).astype(float, copy=False)
