"""`flexmb.fe.assembly.node_pattern`'s passes over every entry, compiled (numba): the expansion of
the nodes' row patterns into the tangent's column indices and the element blocks' slots; used for
large models only (numpy's chunked passes otherwise; 1e5 beam elements: ~11 million entries of
the tangent, 14 million element entries)."""

from __future__ import annotations

import numpy as np

from ..jit import njit

__all__ = ["repeat_rows", "element_slots"]


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


@njit
def element_slots(master, ndof, g_ptr, g_idx, slot_f, slot_p, row_f, row_p, frank, prank, within_f, within_p, out):
    """`flexmb.fe.assembly.node_pattern`'s slots of the element blocks in one pass: for element e
    with end nodes ``master[e]`` and entry (i, j) of its (2 ndof)^2 block, its place in K_ff's data
    (``row_f`` of the row's DOF + ``within_f`` of the node pair + ``frank`` of the column's DOF),
    in K_fp's (-2 minus the same with ``row_p``, ``within_p``, ``prank``) or -1 (a prescribed row);
    the node pair's position in the node graph ``(g_ptr, g_idx)`` (sorted rows) by a scan of the
    row. The same numbers as numpy's chunked pass; each element's DOFs once (no division per entry)."""
    n2 = 2 * ndof
    pair = np.empty((2, 2), dtype=np.int64)
    side = np.empty(n2, dtype=np.int64)  # the end node of each of the block's rows and columns
    comp = np.empty(n2, dtype=np.int64)
    for i in range(n2):
        side[i] = i // ndof
        comp[i] = i - side[i] * ndof
    dof = np.empty(n2, dtype=np.int64)
    at = 0
    for e in range(master.shape[0]):
        for s in range(2):
            a = master[e, s]
            for t in range(2):
                b = master[e, t]
                k = g_ptr[a]
                while g_idx[k] != b:
                    k += 1
                pair[s, t] = k
        for i in range(n2):
            dof[i] = master[e, side[i]] * ndof + comp[i]
        for i in range(n2):
            r = dof[i]
            if slot_f[r] < 0:  # a prescribed row: dropped
                for j in range(n2):
                    out[at + j] = -1
                at += n2
                continue
            rf, rp, si = row_f[r], row_p[r], side[i]
            for j in range(n2):
                c = dof[j]
                k = pair[si, side[j]]
                if slot_f[c] >= 0:
                    out[at] = rf + within_f[k] + frank[c]
                elif slot_p[c] >= 0:
                    out[at] = -2 - (rp + within_p[k] + prank[c])
                else:
                    out[at] = -1
                at += 1
