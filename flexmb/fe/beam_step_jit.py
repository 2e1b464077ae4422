"""The beams' element rows under a complex step, compiled: what `flexmb.design.partials` differentiates.

A row is one element moved along one direction: its master nodes' positions and rotations turned by
``i h du`` (``x + i h dx``, ``R + i h skew(dphi) R``; 2D: the angle ``theta + i h dtheta``), its end
offsets, frames, length and local stiffness by ``i h`` times their rates. The row's complex internal
force and tangent in its master nodes' DOFs (the end offsets' levers and their geometric block, as
`flexmb.fe.model.FEModel.transfer` and ``_lever``) come out in one pass: their imaginary parts over
``h`` are the directional derivatives to round-off (Squire & Trapp 1998). The element formulas are
those of `flexmb.fe.beam3d_jit` (its helpers, compiled again for complex arrays: numba specialises
per type, the float kernels are untouched) and of `flexmb.fe.beam2d` (the chord's angle and length
continued analytically: `flexmb.fe.beam2d.hypot_atan2`). The numpy path (`flexmb.design.partials`
with the kernels off) computes the same rows; tests/test_design_step_kernels.py holds both equal.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .beam3d_jit import _cross, _rot_chord, _rot_rot

__all__ = ["rows_3d", "rows_2d", "mass_rows_3d", "mass_rows_2d"]

#: `flexmb.fe.beam3d_jit`'s layout of the helpers' calls: the torsion row and its blocks, the chord
#: rows 2-5 with their signs and blocks, the two passes (read from arrays: one compiled helper each)
_LAYOUT = (np.array([1, 3, 9, 0]), np.array([2, 3, 4, 5]), np.array([-1.0, 1.0, 1.0, -1.0]), np.array([3, 9, 3, 9]),
           np.array([False, True]))


@njit
def _lever_3d(K, d, F, tangent, material, n, work):
    """In place: the point wrenches ``F`` (2 n) and tangent ``K`` (2 n, 2 n) of a row moved to the
    master nodes through the current offsets ``d`` (2, 3): ``T^T K T`` with the levers ``T`` (blocks
    ``-skew(d)`` from the rotations to the translations), moments ``m + d x f``, and (unless
    ``material``) the offsets' geometric blocks ``d f^T - (d.f) I`` on the rotations."""
    A, G, mom = work  # A_i = -skew(d_i)
    for i in range(2):
        A[i, 0, 0], A[i, 1, 1], A[i, 2, 2] = 0.0, 0.0, 0.0
        A[i, 0, 1], A[i, 0, 2], A[i, 1, 2] = d[i, 2], -d[i, 1], d[i, 0]
        A[i, 1, 0], A[i, 2, 0], A[i, 2, 1] = -d[i, 2], d[i, 1], -d[i, 0]
    for i in range(2):
        f = F[i * n:i * n + 3]
        df = d[i, 0] * f[0] + d[i, 1] * f[1] + d[i, 2] * f[2]
        for a in range(3):
            for b in range(3):
                G[i, a, b] = d[i, a] * f[b] - (df if a == b else 0.0)
    if tangent:
        for j in range(2):  # K T: the rotation columns gain K[:, translations] A_j
            for r in range(2 * n):
                for b in range(3):
                    v = 0.0
                    for c in range(3):
                        v += K[r, j * n + c] * A[j, c, b]
                    K[r, j * n + 3 + b] += v
        for i in range(2):  # T^T (K T): the rotation rows gain A_i^T (K T)[translations, :]
            for c in range(2 * n):
                for a in range(3):
                    v = 0.0
                    for m in range(3):
                        v += A[i, m, a] * K[i * n + m, c]
                    K[i * n + 3 + a, c] += v
        if not material:
            for i in range(2):
                for a in range(3):
                    for b in range(3):
                        K[i * n + 3 + a, i * n + 3 + b] += G[i, a, b]
    for i in range(2):
        _cross(d[i], F[i * n:i * n + 3], mom, 0)
        for a in range(3):
            F[i * n + 3 + a] += mom[a]


@njit
def _material(D, S, e, sig, F, K, SD, tangent):
    """``sigma = S e``, ``F = D^T sigma`` and (``tangent``) the material part ``K = D^T S D`` of one
    element (``D`` (modes, dofs))."""
    n, m = D.shape
    for i in range(n):
        v = 0.0 * S[0, 0]
        for j in range(n):
            v += S[i, j] * e[j]
        sig[i] = v
    for j in range(m):
        v = 0.0 * S[0, 0]
        for i in range(n):
            v += D[i, j] * sig[i]
        F[j] = v
    if not tangent:
        return
    for i in range(n):
        for j in range(m):
            v = 0.0 * S[0, 0]
            for k in range(n):
                v += S[i, k] * D[k, j]
            SD[i, j] = v
    for i in range(m):
        for j in range(m):
            v = 0.0 * S[0, 0]
            for k in range(n):
                v += D[k, i] * SD[k, j]
            K[i, j] = v


@njit
def _valid_3d(Rp, Rq, nx0, nl, V) -> bool:
    """`flexmb.fe.beam3d`'s validity, judged on the real parts: both nodes' axes ``R nx0`` within 90
    degrees of the chord ``nl``, the end sections (``V``: pz, qz, py, qy) within 90 degrees."""
    cp, cq, cs = 0.0, 0.0, 0.0
    for i in range(3):
        cp += ((Rp[i, 0] * nx0[0] + Rp[i, 1] * nx0[1] + Rp[i, 2] * nx0[2]) * nl[i]).real
        cq += ((Rq[i, 0] * nx0[0] + Rq[i, 1] * nx0[1] + Rq[i, 2] * nx0[2]) * nl[i]).real
        cs += (V[2, i] * V[3, i] + V[0, i] * V[1, i]).real
    return cp > 0.0 and cq > 0.0 and cs > 0.0


@njit
def _element_3d(xp, xq, Rp, Rq, ny0, nz0, lk, S, tangent, material, F, K, e, sig, w):
    """One 3D element (complex): ``F`` (12), ``K`` (12, 12) when ``tangent``, ``e``, ``sig`` (6) as
    `flexmb.fe.beam3d_jit` (``material``: ``K = D^T S D`` alone); ``w`` work arrays."""
    Dm, nl, V, P, SD, g, Pa, aP, nx0 = w
    lay, rows, coefs, blocks, second = _LAYOUT
    Dm[:, :] = 0.0
    e[:] = 0.0
    L = xq - xp
    l = np.sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2])  # analytic: sqrt(L.L), no modulus
    for i in range(3):
        nl[i] = L[i] / l
        V[2, i] = Rp[i, 0] * ny0[0] + Rp[i, 1] * ny0[1] + Rp[i, 2] * ny0[2]  # (pz, qz, py, qy)
        V[0, i] = Rp[i, 0] * nz0[0] + Rp[i, 1] * nz0[1] + Rp[i, 2] * nz0[2]
        V[3, i] = Rq[i, 0] * ny0[0] + Rq[i, 1] * ny0[1] + Rq[i, 2] * ny0[2]
        V[1, i] = Rq[i, 0] * nz0[0] + Rq[i, 1] * nz0[1] + Rq[i, 2] * nz0[2]
    for i in range(3):
        for j in range(3):
            P[i, j] = (1.0 if i == j else 0.0) - nl[i] * nl[j]
    e[0] = l - lk
    for i in range(3):
        Dm[0, i] = -nl[i]
        Dm[0, 6 + i] = nl[i]
    _rot_rot(Dm, e, K, 0.0, lay[0], 0.5, lk, V[0], lay[1], V[3], lay[2], second[0], g)
    _rot_rot(Dm, e, K, 0.0, lay[0], -0.5, lk, V[2], lay[1], V[1], lay[2], second[0], g)
    for m in range(4):
        _rot_chord(Dm, e, K, 0.0, rows[m], coefs[m], lk, V[m], blocks[m], nl, P, l, second[0], g, Pa, aP)
    _cross(ny0, nz0, nx0, lay[3])
    if not _valid_3d(Rp, Rq, nx0, nl, V):
        e[:] = np.nan
    _material(Dm, S, e, sig, F, K, SD, tangent)
    if not tangent or material:
        return
    for i in range(3):
        for j in range(3):
            v = sig[0] * P[i, j] / l
            K[i, j] += v
            K[6 + i, 6 + j] += v
            K[i, 6 + j] -= v
            K[6 + i, j] -= v
    _rot_rot(Dm, e, K, sig[1], lay[0], 0.5, lk, V[0], lay[1], V[3], lay[2], second[1], g)
    _rot_rot(Dm, e, K, sig[1], lay[0], -0.5, lk, V[2], lay[1], V[1], lay[2], second[1], g)
    for m in range(4):
        _rot_chord(Dm, e, K, sig[rows[m]], rows[m], coefs[m], lk, V[m], blocks[m], nl, P, l, second[1], g, Pa, aP)


@njit
def _rows_3d(x, R, du, s, ds, ny0, dny0, nz0, dnz0, L0, dL0, S, dS, h, tangent, material, F, K, e, sig):
    ih = 1j * h
    w = (np.zeros((6, 12), dtype=np.complex128), np.zeros(3, dtype=np.complex128),
         np.zeros((4, 3), dtype=np.complex128), np.zeros((3, 3), dtype=np.complex128),
         np.zeros((6, 12), dtype=np.complex128), np.zeros(12, dtype=np.complex128),
         np.zeros(3, dtype=np.complex128), np.zeros((3, 3), dtype=np.complex128), np.zeros(3, dtype=np.complex128))
    Rc = np.zeros((2, 3, 3), dtype=np.complex128)
    xe = np.zeros((2, 3), dtype=np.complex128)
    d = np.zeros((2, 3), dtype=np.complex128)
    ny, nz, Sc = np.zeros(3, dtype=np.complex128), np.zeros(3, dtype=np.complex128), np.zeros((6, 6), dtype=np.complex128)
    lev = (np.zeros((2, 3, 3), dtype=np.complex128), np.zeros((2, 3, 3), dtype=np.complex128),
           np.zeros(3, dtype=np.complex128))
    for b in range(L0.shape[0]):
        _moved_ends_3d(x[b], R[b], du[b], s[b], ds[b], ih, Rc, d, xe)
        for a in range(3):
            ny[a], nz[a] = ny0[b, a] + ih * dny0[b, a], nz0[b, a] + ih * dnz0[b, a]
        for a in range(6):
            for c in range(6):
                Sc[a, c] = S[b, a, c] + ih * dS[b, a, c]
        Kb = K[b] if tangent else K[0]
        _element_3d(xe[0], xe[1], Rc[0], Rc[1], ny, nz, L0[b] + ih * dL0[b], Sc, tangent, material, F[b], Kb, e[b],
                    sig[b], w)
        _lever_3d(Kb, d, F[b], tangent, material, 6, lev)


@njit
def _element_2d(xp, xq, thp, thq, alpha0, lk, S, tangent, material, F, K, e, sig, D, SD):
    """One planar element (complex), as `flexmb.fe.beam2d` with `hypot_atan2` and the angle's wrap
    continued analytically (the real parts wrapped, the imaginary parts carried)."""
    Lx, Ly = xq[0] - xp[0], xq[1] - xp[1]
    l = np.sqrt(Lx * Lx + Ly * Ly)
    r2 = Lx.real * Lx.real + Ly.real * Ly.real
    beta = np.arctan2(Ly.real, Lx.real) + 1j * (Lx.real * Ly.imag - Ly.real * Lx.imag) / r2
    nx, ny = Lx / l, Ly / l
    mx, my = -ny, nx
    psi = np.zeros(2, dtype=np.complex128)
    for i, th in enumerate((thp, thq)):
        a = beta - alpha0 - th
        psi[i] = a - (a.real - np.arctan2(np.sin(a.real), np.cos(a.real)))
    e[0], e[1], e[2] = l - lk, lk * psi[0], -lk * psi[1]
    D[:, :] = 0.0
    D[0, 0], D[0, 1], D[0, 3], D[0, 4] = -nx, -ny, nx, ny
    gx, gy = mx / l, my / l
    D[1, 0], D[1, 1], D[1, 3], D[1, 4] = -lk * gx, -lk * gy, lk * gx, lk * gy
    D[1, 2] = -lk
    D[2, 0], D[2, 1], D[2, 3], D[2, 4] = lk * gx, lk * gy, -lk * gx, -lk * gy
    D[2, 5] = lk
    _material(D, S, e, sig, F, K, SD, tangent)
    if not tangent or material:
        return
    n, m = (nx, ny), (mx, my)
    for i in range(2):
        for j in range(2):
            v = sig[0] * m[i] * m[j] / l - (sig[1] - sig[2]) * lk * (n[i] * m[j] + m[i] * n[j]) / (l * l)
            K[i, j] += v
            K[3 + i, 3 + j] += v
            K[i, 3 + j] -= v
            K[3 + i, j] -= v


@njit
def _rows_2d(x, th, du, s, ds, alpha0, dalpha0, L0, dL0, S, dS, h, tangent, material, F, K, e, sig):
    ih = 1j * h
    D, SD = np.zeros((3, 6), dtype=np.complex128), np.zeros((3, 6), dtype=np.complex128)
    xe = np.zeros((2, 2), dtype=np.complex128)
    d = np.zeros((2, 2), dtype=np.complex128)
    t = np.zeros(2, dtype=np.complex128)
    for b in range(L0.shape[0]):
        for i in range(2):
            t[i] = th[b, i] + ih * du[b, i, 2]
            c, sn = np.cos(t[i]), np.sin(t[i])
            sx, sy = s[b, i, 0] + ih * ds[b, i, 0], s[b, i, 1] + ih * ds[b, i, 1]
            d[i, 0], d[i, 1] = c * sx - sn * sy, sn * sx + c * sy
            for a in range(2):
                xe[i, a] = x[b, i, a] + ih * du[b, i, a] + d[i, a]
        Kb = K[b] if tangent else K[0]
        _element_2d(xe[0], xe[1], t[0], t[1], alpha0[b] + ih * dalpha0[b], L0[b] + ih * dL0[b], S[b] + ih * dS[b],
                    tangent, material, F[b], Kb, e[b], sig[b], D, SD)
        Fb = F[b]
        G = np.zeros(2, dtype=np.complex128)
        for i in range(2):  # moments d x f, the geometric block -(d.f), the levers (0, 2) = -d_y, (1, 2) = d_x
            G[i] = -(d[i, 0] * Fb[3 * i] + d[i, 1] * Fb[3 * i + 1])
            Fb[3 * i + 2] += d[i, 0] * Fb[3 * i + 1] - d[i, 1] * Fb[3 * i]
        if not tangent:
            continue
        for i in range(2):  # K T: column 3i+2 gains -d_y K[:, 3i] + d_x K[:, 3i+1]
            for r in range(6):
                Kb[r, 3 * i + 2] += -d[i, 1] * Kb[r, 3 * i] + d[i, 0] * Kb[r, 3 * i + 1]
        for i in range(2):  # T^T (K T): row 3i+2 likewise
            for c in range(6):
                Kb[3 * i + 2, c] += -d[i, 1] * Kb[3 * i, c] + d[i, 0] * Kb[3 * i + 1, c]
            if not material:
                Kb[3 * i + 2, 3 * i + 2] += G[i]


@njit
def _mass_out(L, T, n, out, V, W, contracted):
    """``out = T^T L T`` (`_congruence`), or with ``contracted`` the form ``(T V)^T L (T W)`` (a, c)."""
    if not contracted:
        _congruence(L, T, n, out)
        return
    na, nc = V.shape[1], W.shape[1]
    TV = np.zeros((2 * n, na), dtype=np.complex128)
    TW = np.zeros((2 * n, nc), dtype=np.complex128)
    for I in range(2):
        for r in range(n):
            for m in range(n):
                t = T[I, r, m]
                if t != 0.0:
                    for c in range(na):
                        TV[I * n + r, c] += t * V[I * n + m, c]
                    for c in range(nc):
                        TW[I * n + r, c] += t * W[I * n + m, c]
    for c in range(nc):
        for r in range(2 * n):
            v = 0.0j
            for m in range(2 * n):
                v += L[r, m] * TW[m, c]
            for a in range(na):
                out[a, c] += TV[r, a] * v


@njit
def _congruence(L, T, n, out):
    """``out = T^T L T`` (2 n, 2 n) for the block-diagonal ``T`` of the two ends' blocks ``T[0]``,
    ``T[1]`` (n, n)."""
    tmp = np.zeros((2 * n, 2 * n), dtype=np.complex128)
    for J in range(2):
        for r in range(2 * n):
            for b in range(n):
                v = 0.0j
                for c in range(n):
                    v += L[r, J * n + c] * T[J, c, b]
                tmp[r, J * n + b] = v
    for I in range(2):
        for a in range(n):
            for c in range(2 * n):
                v = 0.0j
                for m in range(n):
                    v += T[I, m, a] * tmp[I * n + m, c]
                out[I * n + a, c] = v


@njit
def _mass_rows_3d(x, R, du, s, ds, ny0, dny0, local, dlocal, h, M, V, W, contracted):
    ih = 1j * h
    Rc = np.zeros((2, 3, 3), dtype=np.complex128)
    xe = np.zeros((2, 3), dtype=np.complex128)
    d = np.zeros((2, 3), dtype=np.complex128)
    lam = np.zeros((3, 3), dtype=np.complex128)
    T = np.zeros((2, 6, 6), dtype=np.complex128)
    for b in range(local.shape[0]):
        _moved_ends_3d(x[b], R[b], du[b], s[b], ds[b], ih, Rc, d, xe)
        _frame_3d(xe, Rc, ny0[b] + ih * dny0[b], lam)
        for i in range(2):  # T_i = blk(lam) (I, -skew(d_i); 0, I)
            T[i, :, :] = 0.0
            for a in range(3):
                for c in range(3):
                    T[i, a, c] = T[i, 3 + a, 3 + c] = lam[a, c]
                T[i, a, 3] = lam[a, 2] * d[i, 1] - lam[a, 1] * d[i, 2]  # lam (-skew(d)): columns e_k x d
                T[i, a, 4] = lam[a, 0] * d[i, 2] - lam[a, 2] * d[i, 0]
                T[i, a, 5] = lam[a, 1] * d[i, 0] - lam[a, 0] * d[i, 1]
        _mass_out(local[b] + ih * dlocal[b], T, 6, M[b], V[b if contracted else 0], W[b if contracted else 0],
                  contracted)


@njit
def _moved_ends_3d(x, R, du, s, ds, ih, Rc, d, xe):
    """The two ends of one row moved by ``i h du``: rotations ``Rc``, current offsets ``d = Rc s``
    (``s + i h ds``) and points ``xe = x + i h dx + d``."""
    for i in range(2):
        w0, w1, w2 = du[i, 3], du[i, 4], du[i, 5]
        for k in range(3):  # R + i h skew(dphi) R: column k gains dphi x R[:, k]
            r0, r1, r2 = R[i, 0, k], R[i, 1, k], R[i, 2, k]
            Rc[i, 0, k] = r0 + ih * (w1 * r2 - w2 * r1)
            Rc[i, 1, k] = r1 + ih * (w2 * r0 - w0 * r2)
            Rc[i, 2, k] = r2 + ih * (w0 * r1 - w1 * r0)
        for a in range(3):
            d[i, a] = (Rc[i, a, 0] * (s[i, 0] + ih * ds[i, 0]) + Rc[i, a, 1] * (s[i, 1] + ih * ds[i, 1])
                       + Rc[i, a, 2] * (s[i, 2] + ih * ds[i, 2]))
            xe[i, a] = x[i, a] + ih * du[i, a] + d[i, a]


@njit
def _frame_3d(xe, Rc, ny0, lam):
    """`flexmb.fe.mass`'s co-rotated frame (rows: chord, mean section y, their cross), analytic."""
    ex = xe[1] - xe[0]
    ex = ex / np.sqrt(ex[0] * ex[0] + ex[1] * ex[1] + ex[2] * ex[2])
    y = np.zeros(3, dtype=np.complex128)
    for a in range(3):
        for c in range(3):
            y[a] += (Rc[0, a, c] + Rc[1, a, c]) * ny0[c]
    y = y - (y[0] * ex[0] + y[1] * ex[1] + y[2] * ex[2]) * ex
    for _ in range(2):  # normalised twice, as `flexmb.fe.mass._frames_3d`
        y = y / np.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    for a in range(3):
        lam[0, a], lam[1, a] = ex[a], y[a]
    _cross(ex, y, lam[2], 0)


@njit
def _mass_rows_2d(x, th, du, s, ds, local, dlocal, h, M, V, W, contracted):
    ih = 1j * h
    d = np.zeros((2, 2), dtype=np.complex128)
    xe = np.zeros((2, 2), dtype=np.complex128)
    T = np.zeros((2, 3, 3), dtype=np.complex128)
    for b in range(local.shape[0]):
        for i in range(2):
            t = th[b, i] + ih * du[b, i, 2]
            c, sn = np.cos(t), np.sin(t)
            sx, sy = s[b, i, 0] + ih * ds[b, i, 0], s[b, i, 1] + ih * ds[b, i, 1]
            d[i, 0], d[i, 1] = c * sx - sn * sy, sn * sx + c * sy
            for a in range(2):
                xe[i, a] = x[b, i, a] + ih * du[b, i, a] + d[i, a]
        Lx, Ly = xe[1, 0] - xe[0, 0], xe[1, 1] - xe[0, 1]
        beta = np.arctan2(Ly.real, Lx.real) + 1j * (Lx.real * Ly.imag - Ly.real * Lx.imag) / (Lx.real**2 + Ly.real**2)
        cb, sb = np.cos(beta), np.sin(beta)
        for i in range(2):  # T_i = [[rot2(beta)^T, 0], [0, 1]] (I, lever (-d_y, d_x))
            T[i, 0, 0], T[i, 0, 1], T[i, 1, 0], T[i, 1, 1] = cb, sb, -sb, cb
            T[i, 0, 2] = -cb * d[i, 1] + sb * d[i, 0]
            T[i, 1, 2] = sb * d[i, 1] + cb * d[i, 0]
            T[i, 2, 0], T[i, 2, 1], T[i, 2, 2] = 0.0, 0.0, 1.0
        _mass_out(local[b] + ih * dlocal[b], T, 3, M[b], V[b if contracted else 0], W[b if contracted else 0],
                  contracted)


def mass_rows_3d(x, R, du, s, ds, ny0, dny0, local, dlocal, h: float, V=None, W=None) -> np.ndarray:
    """Complex element mass matrices (B, 12, 12) in global axes and master DOFs of B 3D rows
    (`flexmb.fe.mass.element_mass` of each element moved along its direction: `rows_3d`'s arguments,
    ``local`` (B, 12, 12) the local mass with its rate ``dlocal``); with ``V`` (B, 12, a) and ``W``
    (B, 12, c), each row's form ``V_b^T M_b W_b`` (B, a, c) instead (no matrix formed)."""
    return _mass_call(_mass_rows_3d, 12, (x, R, du, s, ds, ny0, dny0, local, dlocal), h, V, W)


def mass_rows_2d(x, th, du, s, ds, local, dlocal, h: float, V=None, W=None) -> np.ndarray:
    """`mass_rows_3d` in the plane (B, 6, 6): master angles ``th`` (B, 2), ``du`` (B, 2, 3)."""
    return _mass_call(_mass_rows_2d, 6, (x, th, du, s, ds, local, dlocal), h, V, W)


def _mass_call(kernel, n: int, arrays, h, V, W) -> np.ndarray:
    """Run a mass kernel: the blocks (B, n, n), or the forms (B, a, c) with ``V``, ``W``."""
    B, contracted = len(arrays[-2]), V is not None
    if contracted:
        V, W = _f(V), _f(W)
        M = np.zeros((B, V.shape[2], W.shape[2]), dtype=np.complex128)
    else:
        M, V, W = np.zeros((B, n, n), dtype=np.complex128), np.zeros((1, n, 1)), np.zeros((1, n, 1))
    kernel(*(_f(a) for a in arrays), float(h), M, V, W, contracted)
    return M


def _outputs(B: int, n: int, modes: int, tangent: bool):
    c = np.complex128
    return (np.zeros((B, 2 * n), dtype=c), np.zeros((B if tangent else 1, 2 * n, 2 * n), dtype=c),
            np.zeros((B, modes), dtype=c), np.zeros((B, modes), dtype=c))


def _f(a):
    return np.ascontiguousarray(a, dtype=float)


def rows_3d(x, R, du, s, ds, ny0, dny0, nz0, dnz0, L0, dL0, S, dS, h: float, tangent: bool = True,
            material: bool = False):
    """Complex ``F`` (B, 12) and ``K`` (B, 12, 12) (None without ``tangent``) in master DOFs, ``e``
    and ``sigma`` (B, 6) of B 3D rows (module notes): master nodes' positions ``x`` (B, 2, 3) and
    rotations ``R`` (B, 2, 3, 3), their motion ``du`` (B, 2, 6) (translations, spins), end offsets
    ``s`` (B, 2, 3), frames ``ny0``, ``nz0`` (B, 3), ``L0`` (B,), ``S`` (B, 6, 6), each with its
    rate ``d...``; ``h`` the step; ``material``: the material tangent ``T^T D^T S D T`` alone."""
    F, K, e, sig = _outputs(len(L0), 6, 6, tangent)
    _rows_3d(_f(x), _f(R), _f(du), _f(s), _f(ds), _f(ny0), _f(dny0), _f(nz0), _f(dnz0), _f(L0), _f(dL0), _f(S),
             _f(dS), float(h), bool(tangent), bool(material), F, K, e, sig)
    return F, (K if tangent else None), e, sig


def rows_2d(x, th, du, s, ds, alpha0, dalpha0, L0, dL0, S, dS, h: float, tangent: bool = True,
            material: bool = False):
    """`rows_3d` in the plane: master nodes' positions ``x`` (B, 2, 2) and angles ``th`` (B, 2),
    motion ``du`` (B, 2, 3), offsets ``s`` (B, 2, 2), ``alpha0`` (B,), ``L0`` (B,), ``S`` (B, 3, 3)
    with their rates; results (B, 6), (B, 6, 6), (B, 3)."""
    F, K, e, sig = _outputs(len(L0), 3, 3, tangent)
    _rows_2d(_f(x), _f(th), _f(du), _f(s), _f(ds), _f(alpha0), _f(dalpha0), _f(L0), _f(dL0), _f(S), _f(dS),
             float(h), bool(tangent), bool(material), F, K, e, sig)
    return F, (K if tangent else None), e, sig
