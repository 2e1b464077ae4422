"""The planar co-rotational beam of `flexmb.fe.beam2d` as one numba loop over the elements.

The same formulas term by term (see `beam2d`); tests/test_kernels.py holds both paths equal to
1e-12 in deformed states.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit, run

__all__ = ["internal_force_and_tangent"]


@njit
def _kernel(xp, xq, thp, thq, alpha0, L0, S, tangent, sg_given, sg_in, F, K, e_out, sig_out):
    D = np.zeros((3, 6))
    SD = np.empty((3, 6))
    e = np.empty(3)
    for k in range(L0.shape[0]):
        Lx = xq[k, 0] - xp[k, 0]
        Ly = xq[k, 1] - xp[k, 1]
        l = np.hypot(Lx, Ly)
        nx, ny = Lx / l, Ly / l
        mx, my = -ny, nx  # n turned by +90 degrees
        beta = np.arctan2(Ly, Lx)
        a = beta - alpha0[k] - thp[k]
        psi_p = np.arctan2(np.sin(a), np.cos(a))
        a = beta - alpha0[k] - thq[k]
        psi_q = np.arctan2(np.sin(a), np.cos(a))
        lk = L0[k]
        e[0], e[1], e[2] = l - lk, lk * psi_p, -lk * psi_q
        D[:, :] = 0.0
        D[0, 0], D[0, 1], D[0, 3], D[0, 4] = -nx, -ny, nx, ny
        gx, gy = mx / l, my / l  # gradient of the chord angle beta with respect to r_q
        D[1, 0], D[1, 1], D[1, 3], D[1, 4] = -lk * gx, -lk * gy, lk * gx, lk * gy
        D[1, 2] = -lk
        D[2, 0], D[2, 1], D[2, 3], D[2, 4] = lk * gx, lk * gy, -lk * gx, -lk * gy
        D[2, 5] = lk
        for i in range(3):
            sig_out[k, i] = S[k, i, 0] * e[0] + S[k, i, 1] * e[1] + S[k, i, 2] * e[2]
            e_out[k, i] = e[i]
        for j in range(6):
            F[k, j] = D[0, j] * sig_out[k, 0] + D[1, j] * sig_out[k, 1] + D[2, j] * sig_out[k, 2]
        if not tangent:
            continue
        Kk = K[k]
        for i in range(3):
            for j in range(6):
                SD[i, j] = S[k, i, 0] * D[0, j] + S[k, i, 1] * D[1, j] + S[k, i, 2] * D[2, j]
        for i in range(6):
            for j in range(6):
                Kk[i, j] = D[0, i] * SD[0, j] + D[1, i] * SD[1, j] + D[2, i] * SD[2, j]
        s0 = sg_in[k, 0] if sg_given else sig_out[k, 0]
        s1 = sg_in[k, 1] if sg_given else sig_out[k, 1]
        s2 = sg_in[k, 2] if sg_given else sig_out[k, 2]
        n = (nx, ny)
        m = (mx, my)
        for i in range(2):
            for j in range(2):
                Hl = m[i] * m[j] / l  # d2|L|/dL2
                Hb = -(n[i] * m[j] + m[i] * n[j]) / (l * l)  # d2 beta/dL2
                v = s0 * Hl + (s1 - s2) * lk * Hb
                Kk[i, j] += v
                Kk[3 + i, 3 + j] += v
                Kk[i, 3 + j] -= v
                Kk[3 + i, j] -= v


def internal_force_and_tangent(xp, xq, thp, thq, alpha0, L0, S, tangent=True, geometric_stress=None):
    """`flexmb.fe.beam2d.internal_force_and_tangent`, compiled: same arguments and results."""
    return run(_kernel, (xp, xq, thp, thq, alpha0, L0, S), 6, 3, tangent, geometric_stress)
