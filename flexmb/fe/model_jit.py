"""`flexmb.fe.model.FEModel.assemble` as numba loops: the elements' end points from their
master nodes, the beam kernel, the transfer to the masters and the scatter into the residual
and the tangent's CSR data, in one call per evaluation.

The same operations as the numpy path (`FEModel.element_response`, then ``np.bincount`` on the
slots): ``x_point = x_master + R_master s``; forces ``[f, m + d x f]``; tangents
``T^T K T`` with ``T = [[I, -skew(d)], [0, I]]`` per end (2D: ``[[1, 0, -d_y], [0, 1, d_x],
[0, 0, 1]]``) plus the offset's block ``d f^T - (d.f) I`` (2D: ``-(d.f)``) on the master's
rotation. Ends without offset skip the transfer (``T = I``, the block vanishes).
tests/test_kernels.py holds both paths equal to 1e-12.

numba's on-disk cache tracks this file only: after editing `beam2d_jit` / `beam3d_jit`, whose
element loops these functions inline, delete this module's cache files (``__pycache__/model_jit*.nb*``)
or touch this file, or the assembly keeps the old element (an installed release rewrites all files).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from . import beam2d_jit, beam3d_jit

__all__ = ["assemble3d", "assemble2d"]


@njit
def _scatter(k, dofs, slots, Fm, K, tangent, r, data_ff, data_fp):
    """Element ``k``'s master forces into ``r`` and its tangent ``K`` (n, n) into the data of
    K_ff (slot >= 0) and K_fp (slot <= -2, at ``-2 - slot``)."""
    n = dofs.shape[1]
    for i in range(n):
        r[dofs[k, i]] += Fm[k, i]
    if not tangent:
        return
    for i in range(n):
        for j in range(n):
            s = slots[k, i * n + j]
            if s >= 0:
                data_ff[s] += K[i, j]
            elif s <= -2:
                data_fp[-2 - s] += K[i, j]


@njit
def assemble3d(pos, rot, master, offset, moved, ny0, nz0, L0, S, tangent, sg_given, sg_in, dofs, slots,
               r, data_ff, data_fp, Fm, e_out, sig_out, largest):
    """3D: ``pos`` (N, 3), ``rot`` (N, 3, 3) node states; ``master`` (E, 2) the ends' nodes,
    ``offset`` (E, 2, 3) their undeformed offsets, ``moved`` (E, 2) offset non-zero; element data
    as `flexmb.fe.beam3d_jit`; ``dofs`` (E, 12) master DOFs, ``slots`` (E, 144) (see `_scatter`).
    Adds into ``r``, ``data_ff``, ``data_fp``; writes ``Fm`` (E, 12) master end forces, ``e_out``,
    ``sig_out`` (E, 6) and ``largest`` (2,) `largest_by_kind` of ``Fm``."""
    nE = L0.shape[0]
    xp = np.empty((nE, 3))
    xq = np.empty((nE, 3))
    Rp = np.empty((nE, 3, 3))
    Rq = np.empty((nE, 3, 3))
    d = np.zeros((nE, 2, 3))
    for k in range(nE):
        for b in range(2):
            n = master[k, b]
            if moved[k, b]:
                for i in range(3):
                    d[k, b, i] = rot[n, i, 0] * offset[k, b, 0] + rot[n, i, 1] * offset[k, b, 1] \
                        + rot[n, i, 2] * offset[k, b, 2]
        a, c = master[k, 0], master[k, 1]
        for i in range(3):
            xp[k, i] = pos[a, i] + d[k, 0, i]
            xq[k, i] = pos[c, i] + d[k, 1, i]
            for j in range(3):
                Rp[k, i, j] = rot[a, i, j]
                Rq[k, i, j] = rot[c, i, j]
    F = np.empty((nE, 12))
    K = np.empty((nE if tangent else 1, 12, 12))
    beam3d_jit._kernel(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent, sg_given, sg_in, F, K, e_out, sig_out)
    A = np.empty((3, 3))
    for k in range(nE):
        Kk = K[k] if tangent else K[0]
        for i in range(12):
            Fm[k, i] = F[k, i]
        for b in range(2):
            if not moved[k, b]:
                continue
            o = 6 * b
            d0, d1, d2 = d[k, b, 0], d[k, b, 1], d[k, b, 2]
            f0, f1, f2 = F[k, o], F[k, o + 1], F[k, o + 2]
            Fm[k, o + 3] += d1 * f2 - d2 * f1
            Fm[k, o + 4] += d2 * f0 - d0 * f2
            Fm[k, o + 5] += d0 * f1 - d1 * f0
            if not tangent:
                continue
            # A = -skew(d): the point's translation is x + A phi
            A[0, 0], A[0, 1], A[0, 2] = 0.0, d2, -d1
            A[1, 0], A[1, 1], A[1, 2] = -d2, 0.0, d0
            A[2, 0], A[2, 1], A[2, 2] = d1, -d0, 0.0
            for row in range(12):  # K T: the rotation columns of this end
                v0, v1, v2 = Kk[row, o], Kk[row, o + 1], Kk[row, o + 2]
                for j in range(3):
                    Kk[row, o + 3 + j] += v0 * A[0, j] + v1 * A[1, j] + v2 * A[2, j]
            for col in range(12):  # T^T (K T): its rotation rows
                v0, v1, v2 = Kk[o, col], Kk[o + 1, col], Kk[o + 2, col]
                for j in range(3):
                    Kk[o + 3 + j, col] += A[0, j] * v0 + A[1, j] * v1 + A[2, j] * v2
            df = d0 * f0 + d1 * f1 + d2 * f2
            dv = (d0, d1, d2)
            fv = (f0, f1, f2)
            for i in range(3):
                for j in range(3):
                    Kk[o + 3 + i, o + 3 + j] += dv[i] * fv[j] - (df if i == j else 0.0)
        _scatter(k, dofs, slots, Fm, Kk, tangent, r, data_ff, data_fp)
    nd = Fm.shape[1] // 2  # ndof 6, dim 3 read from the array: literal constants would make numba
    _largest_rows(Fm, nd, nd // 2, largest)  # compile a second specialisation


@njit
def assemble2d(pos, rot, master, offset, moved, alpha0, L0, S, tangent, sg_given, sg_in, dofs, slots,
               r, data_ff, data_fp, Fm, e_out, sig_out, largest):
    """2D: as `assemble3d` with ``rot`` (N,) angles, ``offset`` (E, 2, 2), ``dofs`` (E, 6),
    ``slots`` (E, 36), element data as `flexmb.fe.beam2d_jit`."""
    nE = L0.shape[0]
    xp = np.empty((nE, 2))
    xq = np.empty((nE, 2))
    thp = np.empty(nE)
    thq = np.empty(nE)
    d = np.zeros((nE, 2, 2))
    for k in range(nE):
        for b in range(2):
            n = master[k, b]
            if moved[k, b]:
                c, s = np.cos(rot[n]), np.sin(rot[n])
                d[k, b, 0] = c * offset[k, b, 0] - s * offset[k, b, 1]
                d[k, b, 1] = s * offset[k, b, 0] + c * offset[k, b, 1]
        a, c = master[k, 0], master[k, 1]
        for i in range(2):
            xp[k, i] = pos[a, i] + d[k, 0, i]
            xq[k, i] = pos[c, i] + d[k, 1, i]
        thp[k], thq[k] = rot[a], rot[c]
    F = np.empty((nE, 6))
    K = np.empty((nE if tangent else 1, 6, 6))
    beam2d_jit._kernel(xp, xq, thp, thq, alpha0, L0, S, tangent, sg_given, sg_in, F, K, e_out, sig_out)
    for k in range(nE):
        Kk = K[k] if tangent else K[0]
        for i in range(6):
            Fm[k, i] = F[k, i]
        for b in range(2):
            if not moved[k, b]:
                continue
            o = 3 * b
            d0, d1 = d[k, b, 0], d[k, b, 1]
            f0, f1 = F[k, o], F[k, o + 1]
            Fm[k, o + 2] += d0 * f1 - d1 * f0
            if not tangent:
                continue
            for row in range(6):  # K T: the rotation column of this end (x - d_y phi, y + d_x phi)
                Kk[row, o + 2] += -d1 * Kk[row, o] + d0 * Kk[row, o + 1]
            for col in range(6):  # T^T (K T): its rotation row
                Kk[o + 2, col] += -d1 * Kk[o, col] + d0 * Kk[o + 1, col]
            Kk[o + 2, o + 2] -= d0 * f0 + d1 * f1
        _scatter(k, dofs, slots, Fm, Kk, tangent, r, data_ff, data_fp)
    nd = Fm.shape[1] // 2  # ndof 3, dim 2 from the array: not literals (one specialisation)
    _largest_rows(Fm, nd, nd - 1, largest)


@njit
def compose3d(rot, w, out):
    """``out[n] = exp(skew(w[n])) rot[n]`` (`flexmb.rotations.expm_so3`'s Rodrigues formula, the
    same terms): ``rot`` (N, 3, 3), ``w`` (N, 3) spins [rad]."""
    E = np.empty((3, 3))
    for n in range(rot.shape[0]):
        w0, w1, w2 = w[n, 0], w[n, 1], w[n, 2]
        t = max(np.sqrt(w0 * w0 + w1 * w1 + w2 * w2), 1e-300)
        h = 0.5 * t
        s = np.sin(h) / h
        a = 0.5 * s * s
        b = np.sin(t) / t
        c = np.cos(t)
        E[0, 0], E[0, 1], E[0, 2] = a * w0 * w0 + c, a * w0 * w1 - b * w2, a * w0 * w2 + b * w1
        E[1, 0], E[1, 1], E[1, 2] = a * w1 * w0 + b * w2, a * w1 * w1 + c, a * w1 * w2 - b * w0
        E[2, 0], E[2, 1], E[2, 2] = a * w2 * w0 - b * w1, a * w2 * w1 + b * w0, a * w2 * w2 + c
        for i in range(3):
            for j in range(3):
                out[n, i, j] = E[i, 0] * rot[n, 0, j] + E[i, 1] * rot[n, 1, j] + E[i, 2] * rot[n, 2, j]


@njit
def spin3d(R_to, R_from, out):
    """``out[n] = log(R_to[n] R_from[n]^T)`` (`flexmb.rotations.logm_so3`, angle in [0, pi], the
    axis from the symmetric part within 1e-3 of pi)."""
    R = np.empty((3, 3))
    for n in range(R_to.shape[0]):
        for i in range(3):
            for j in range(3):
                R[i, j] = R_to[n, i, 0] * R_from[n, j, 0] + R_to[n, i, 1] * R_from[n, j, 1] \
                    + R_to[n, i, 2] * R_from[n, j, 2]
        c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
        v0, v1, v2 = 0.5 * (R[2, 1] - R[1, 2]), 0.5 * (R[0, 2] - R[2, 0]), 0.5 * (R[1, 0] - R[0, 1])
        s = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        t = np.arctan2(s, c)
        if t > np.pi - 1e-3:
            k = 0
            for i in range(1, 3):
                if R[i, i] > R[k, k]:  # the largest diagonal entry of the symmetric part
                    k = i
            n0 = 0.5 * (R[0, k] + R[k, 0]) - (c if k == 0 else 0.0)
            n1 = 0.5 * (R[1, k] + R[k, 1]) - (c if k == 1 else 0.0)
            n2 = 0.5 * (R[2, k] + R[k, 2]) - (c if k == 2 else 0.0)
            norm = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            sign = -1.0 if n0 * v0 + n1 * v1 + n2 * v2 < 0.0 else 1.0
            f = sign * t / norm
            out[n, 0], out[n, 1], out[n, 2] = f * n0, f * n1, f * n2
        else:
            f = t / (s if s > 0.0 else 1.0)
            out[n, 0], out[n, 1], out[n, 2] = f * v0, f * v1, f * v2


@njit
def largest_by_kind(v, ndof, dim, out):
    """``out = (max |v_translation|, max |v_rotation|)`` over ``v`` viewed as rows of ``ndof``
    (translations first); 0 for an empty ``v``."""
    out[0] = 0.0
    out[1] = 0.0
    for i in range(v.shape[0]):
        k = 0 if i % ndof < dim else 1
        a = abs(v[i])
        if a > out[k] or a != a:  # NaN wins, as in numpy's max
            out[k] = a


@njit
def _largest_rows(F, ndof, dim, out):
    """`largest_by_kind` of ``F.ravel()`` (F (E, n), rows of whole nodes) without the ravel, whose
    numba implementation (a reshape with its error messages) adds seconds to a first compilation."""
    out[0] = 0.0
    out[1] = 0.0
    for e in range(F.shape[0]):
        for c in range(F.shape[1]):
            k = 0 if c % ndof < dim else 1
            a = abs(F[e, c])
            if a > out[k] or a != a:  # NaN wins, as in numpy's max
                out[k] = a


@njit
def largest_motion(du, n_nodes, ndof, dim, out):
    """``out = (max_n |du_n translation|, max_n |du_n rotation|)`` over the nodes' rows of ``du``."""
    out[0] = 0.0
    out[1] = 0.0
    for n in range(n_nodes):
        t = 0.0
        for i in range(dim):
            t += du[n * ndof + i] * du[n * ndof + i]
        r = 0.0
        for i in range(dim, ndof):
            r += du[n * ndof + i] * du[n * ndof + i]
        if t > out[0] or t != t:
            out[0] = t
        if r > out[1] or r != r:
            out[1] = r
    out[0] = np.sqrt(out[0])
    out[1] = np.sqrt(out[1])
