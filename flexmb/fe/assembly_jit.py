"""`flexmb.fe.assembly.node_pattern`'s expansion of the nodes' row patterns into the tangent's
column indices, compiled (numba): used for large models only (numpy's ``repeat`` and ``arange``
over every entry otherwise; 1e5 beam elements: ~11 million entries)."""

from __future__ import annotations

from ..jit import njit

__all__ = ["repeat_rows"]


@njit
def repeat_rows(seg, seg_start, row_len, row_count, indices, indptr):
    """The column indices and row pointers of a pattern whose rows repeat per node:
    node g's pattern ``seg[seg_start[g]:seg_start[g] + row_len[g]]`` for each of its
    ``row_count[g]`` rows, nodes in order (`flexmb.fe.assembly.node_pattern`)."""
    at = 0
    r = 0
    indptr[0] = 0
    for g in range(len(row_len)):
        s, m = seg_start[g], row_len[g]
        for _ in range(row_count[g]):
            for t in range(m):
                indices[at + t] = seg[s + t]
            at += m
            r += 1
            indptr[r] = at
