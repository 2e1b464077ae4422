"""The 3D co-rotational beam of `flexmb.fe.beam3d` as one numba loop over the elements.

The same formulas, term by term: deformations of Eq. (A.4), ``D`` from (A.9)-(A.10), the
material part ``D^T S D`` and the geometric part ``sum_i sigma_i dD_i/dq`` (see `beam3d` for the
derivation). One pass per element instead of ~60 numpy calls on (E, 12, 12) batches;
tests/test_kernels.py holds both paths equal to 1e-12 in deformed states.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit, run

__all__ = ["internal_force_and_tangent"]


@njit
def _cross(a, b, out, o):
    out[o] = a[1] * b[2] - a[2] * b[1]
    out[o + 1] = a[2] * b[0] - a[0] * b[2]
    out[o + 2] = a[0] * b[1] - a[1] * b[0]


@njit
def _rot_rot(Dm, e, K, wt, row, coef, L0, a, ia, b, ib, second, g):
    """coef * L0 * asin(a . b), a turning with node block ia, b with block ib: its value (added to
    e[row]) and gradient (added to Dm[row]); with ``second``, instead its second derivative times
    ``wt`` added to K."""
    c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    B = np.sqrt(1.0 - c * c)
    g[:] = 0.0
    _cross(a, b, g, ia)
    _cross(b, a, g, ib)
    s = coef * L0 / B
    if not second:
        e[row] += coef * L0 * np.arcsin(c)
        for k in range(12):
            Dm[row, k] += s * g[k]
        return
    s *= wt
    for i in range(3):
        for j in range(3):
            cI = c if i == j else 0.0
            K[ia + i, ia + j] += s * (a[i] * b[j] - cI)
            K[ib + i, ib + j] += s * (b[i] * a[j] - cI)
            K[ia + i, ib + j] += s * (cI - b[i] * a[j])
            K[ib + i, ia + j] += s * (cI - a[i] * b[j])
    w = s * c / (B * B)
    for oi in (ia, ib):  # g is zero outside the two rotation blocks
        for oj in (ia, ib):
            for i in range(oi, oi + 3):
                wg = w * g[i]
                for j in range(oj, oj + 3):
                    K[i, j] += wg * g[j]


@njit
def _rot_chord(Dm, e, K, wt, row, coef, L0, a, ia, nl, P, l, second, g, Pa, aP):
    """coef * L0 * asin(a . nl), a turning with node block ia, nl the chord direction (as
    `_rot_rot`)."""
    c = a[0] * nl[0] + a[1] * nl[1] + a[2] * nl[2]
    B = np.sqrt(1.0 - c * c)
    for i in range(3):
        Pa[i] = (P[i, 0] * a[0] + P[i, 1] * a[1] + P[i, 2] * a[2]) / l
    g[:] = 0.0
    _cross(a, nl, g, ia)
    for i in range(3):
        g[i] = -Pa[i]
        g[6 + i] = Pa[i]
    s = coef * L0 / B
    if not second:
        e[row] = coef * L0 * np.arcsin(c)
        for k in range(12):
            Dm[row, k] = s * g[k]
        return
    s *= wt
    # aP = skew(a) P / l: d(a x nl)/d r_q
    for j in range(3):
        aP[0, j] = (-a[2] * P[1, j] + a[1] * P[2, j]) / l
        aP[1, j] = (a[2] * P[0, j] - a[0] * P[2, j]) / l
        aP[2, j] = (-a[1] * P[0, j] + a[0] * P[1, j]) / l
    for i in range(3):
        for j in range(3):
            cI = c if i == j else 0.0
            K[ia + i, ia + j] += s * (a[i] * nl[j] - cI)
            K[ia + i, 6 + j] += s * aP[i, j]
            K[ia + i, j] += -s * aP[i, j]
            K[6 + i, ia + j] += s * aP[j, i]
            K[i, ia + j] += -s * aP[j, i]
            Hn = -(c * P[i, j] / l + nl[i] * Pa[j] + Pa[i] * nl[j]) / l
            K[i, j] += s * Hn
            K[6 + i, 6 + j] += s * Hn
            K[i, 6 + j] -= s * Hn
            K[6 + i, j] -= s * Hn
    w = s * c / (B * B)
    for oi in (0, ia, 6):  # g is zero on the other node's rotation block
        for oj in (0, ia, 6):
            for i in range(oi, oi + 3):
                wg = w * g[i]
                for j in range(oj, oj + 3):
                    K[i, j] += wg * g[j]


@njit
def _kernel(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent, sg_given, sg_in, F, K, e_out, sig_out):
    nE = L0.shape[0]
    Dm = np.zeros((6, 12))
    e = np.zeros(6)
    nl = np.empty(3)
    # the sections' axes at both ends, rows in the order of the four chord terms below (pz, qz, py, qy)
    V = np.empty((4, 3))
    pz, qz, py, qy = V[0], V[1], V[2], V[3]
    # the helpers' integer and flag arguments read from arrays, not written as constants: numba
    # compiles a helper once per combination of literal arguments (_rot_chord was compiled 8 times)
    # (the torsion row 1 with blocks 3 and 9; the chord rows 2-5 with their signs and blocks; pass 2)
    lay = np.array([1, 3, 9, 0])
    rows, coefs, blocks = np.array([2, 3, 4, 5]), np.array([-1.0, 1.0, 1.0, -1.0]), np.array([3, 9, 3, 9])
    second = np.array([False, True])
    P = np.empty((3, 3))
    SD = np.empty((6, 12))
    sg = np.empty(6)
    g = np.empty(12)
    Pa = np.empty(3)
    aP = np.empty((3, 3))
    nx0 = np.empty(3)
    for k in range(nE):
        Dm[:, :] = 0.0
        e[:] = 0.0
        L0_ = xq[k, 0] - xp[k, 0]
        L1_ = xq[k, 1] - xp[k, 1]
        L2_ = xq[k, 2] - xp[k, 2]
        l = np.sqrt(L0_ * L0_ + L1_ * L1_ + L2_ * L2_)
        nl[0], nl[1], nl[2] = L0_ / l, L1_ / l, L2_ / l
        for i in range(3):
            py[i] = Rp[k, i, 0] * ny0[k, 0] + Rp[k, i, 1] * ny0[k, 1] + Rp[k, i, 2] * ny0[k, 2]
            pz[i] = Rp[k, i, 0] * nz0[k, 0] + Rp[k, i, 1] * nz0[k, 1] + Rp[k, i, 2] * nz0[k, 2]
            qy[i] = Rq[k, i, 0] * ny0[k, 0] + Rq[k, i, 1] * ny0[k, 1] + Rq[k, i, 2] * ny0[k, 2]
            qz[i] = Rq[k, i, 0] * nz0[k, 0] + Rq[k, i, 1] * nz0[k, 1] + Rq[k, i, 2] * nz0[k, 2]
        for i in range(3):
            for j in range(3):
                P[i, j] = (1.0 if i == j else 0.0) - nl[i] * nl[j]
        lk = L0[k]
        Kk = K[k] if tangent else K[0]
        # pass 1: deformations and their gradients D (mode 1: elongation; 2: torsion; 3-6: bending)
        e[0] = l - lk
        for i in range(3):
            Dm[0, i] = -nl[i]
            Dm[0, 6 + i] = nl[i]
        _rot_rot(Dm, e, Kk, 0.0, lay[0], 0.5, lk, pz, lay[1], qy, lay[2], second[0], g)
        _rot_rot(Dm, e, Kk, 0.0, lay[0], -0.5, lk, py, lay[1], qz, lay[2], second[0], g)
        for m in range(4):  # rows 2-5: -asin(pz.n), asin(qz.n), asin(py.n), -asin(qy.n), times L0
            _rot_chord(Dm, e, Kk, 0.0, rows[m], coefs[m], lk, V[m], blocks[m], nl, P, l, second[0], g, Pa, aP)
        # validity (see beam3d): both nodes' axes within 90 degrees of the chord, sections too
        _cross(ny0[k], nz0[k], nx0, lay[3])
        cp = 0.0
        cq = 0.0
        for i in range(3):
            cp += (Rp[k, i, 0] * nx0[0] + Rp[k, i, 1] * nx0[1] + Rp[k, i, 2] * nx0[2]) * nl[i]
            cq += (Rq[k, i, 0] * nx0[0] + Rq[k, i, 1] * nx0[1] + Rq[k, i, 2] * nx0[2]) * nl[i]
        cs = py[0] * qy[0] + py[1] * qy[1] + py[2] * qy[2] + pz[0] * qz[0] + pz[1] * qz[1] + pz[2] * qz[2]
        if not (cp > 0.0 and cq > 0.0 and cs > 0.0):
            e[:] = np.nan
        for i in range(6):
            v = 0.0
            for j in range(6):
                v += S[k, i, j] * e[j]
            sig_out[k, i] = v
            e_out[k, i] = e[i]
        for j in range(12):
            v = 0.0
            for i in range(6):
                v += Dm[i, j] * sig_out[k, i]
            F[k, j] = v
        if not tangent:
            continue
        # pass 2: K = D^T S D + sum_i sg_i d2e_i/dq2, the second derivatives added with their weights
        finite = True
        for i in range(6):
            sg[i] = sg_in[k, i] if sg_given else sig_out[k, i]
            finite = finite and np.isfinite(sg[i])
        if not finite:  # as the numpy path: a NaN stress spoils every entry of the tangent
            Kk[:, :] = np.nan
            continue
        for i in range(6):
            for j in range(12):
                v = 0.0
                for m in range(6):
                    v += S[k, i, m] * Dm[m, j]
                SD[i, j] = v
        for i in range(12):
            for j in range(12):
                v = 0.0
                for m in range(6):
                    v += Dm[m, i] * SD[m, j]
                Kk[i, j] = v
        for i in range(3):
            for j in range(3):
                v = sg[0] * P[i, j] / l
                Kk[i, j] += v
                Kk[6 + i, 6 + j] += v
                Kk[i, 6 + j] -= v
                Kk[6 + i, j] -= v
        _rot_rot(Dm, e, Kk, sg[1], lay[0], 0.5, lk, pz, lay[1], qy, lay[2], second[1], g)
        _rot_rot(Dm, e, Kk, sg[1], lay[0], -0.5, lk, py, lay[1], qz, lay[2], second[1], g)
        for m in range(4):
            _rot_chord(Dm, e, Kk, sg[rows[m]], rows[m], coefs[m], lk, V[m], blocks[m], nl, P, l, second[1], g, Pa, aP)


def internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent=True, geometric_stress=None):
    """`flexmb.fe.beam3d.internal_force_and_tangent`, compiled: same arguments and results."""
    return run(_kernel, (xp, xq, Rp, Rq, ny0, nz0, L0, S), 12, 6, tangent, geometric_stress)
