"""The closed-form linkage residual, tangent terms and Newton loop as numba loops.

The formulas of `flexmb.closed_form.flexures` and `flexmb.closed_form.problem` term by term
(Cammarata et al. 2022, Eqs. 1-28 and A2-A13), one flexure at a time with complex scalars
instead of ~60 numpy calls on arrays of a few flexures (the call overhead dominated the
evaluation: BENCHMARKS.md, Gripper). tests/test_closed_form_jit.py holds both paths equal to 1e-12.

Arrays (F flexures, L loads, N links, n = 3 N DOFs): ``pos`` (N, 2), ``ang`` (N,); the flexure
constants of `FlexureSet` (``fi``, ``fj`` int64; ``s_i``, ``s_j``, ``b_j``, ``b_jc`` (conjugate),
``b_ia_f`` (``-B_i A_f``), ``arm``, ``p_hat`` complex (F,); ``K`` (F, 3, 3); ``nl`` (F,) 0/1);
loads ``ln`` (L,) int64, ``loff``, ``lforce`` complex (L,), ``lmom`` (L,).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit

__all__ = ["evaluate", "newton", "STATUS"]

#: Newton loop outcomes (`newton`'s ``status``).
STATUS = ("converged", "diverged", "max_iter", "singular")


@njit
def evaluate(pos, ang, fi, fj, s_i, s_j, b_j, b_jc, b_ia_f, arm, p_hat, K, nl, ln, loff, lforce, lmom,
             tangent, r, T):
    """Residual ``r`` (n,) and, if ``tangent``, the terms ``T`` (4, n, n): K^I, K^II, K^III and the
    dead loads' stiffness (`flexmb.closed_form.problem.TERMS`); both overwritten."""
    r[:] = 0.0
    if tangent:
        T[:] = 0.0
    psi = np.empty(3)
    w = np.empty(3)
    J = np.zeros((3, 6))
    KJ = np.empty((3, 6))
    for f in range(fi.shape[0]):
        i, j = fi[f], fj[f]
        ei = np.exp(1j * ang[i])
        ej = np.exp(1j * ang[j])
        ai, aj = ei * s_i[f], ej * s_j[f]
        ai_, aj_ = np.conj(ai), np.conj(aj)
        p = (pos[j, 0] + 1j * pos[j, 1]) + aj - (pos[i, 0] + 1j * pos[i, 1]) - ai  # Eq. (4)
        u = np.conj(ei) * p
        x = b_jc[f] * (u - p_hat[f])  # Eqs. (5)-(6)
        psi[0], psi[1], psi[2] = x.real, x.imag, ang[j] - ang[i]  # Eqs. (7)-(8)
        for a in range(3):
            w[a] = K[f, a, 0] * psi[0] + K[f, a, 1] * psi[1] + K[f, a, 2] * psi[2]  # Eq. (1)
        Ft, Mt = w[0] + 1j * w[1], w[2]
        arm_ = np.conj(arm[f] + nl[f] * x)  # Eq. (15) or (17)
        Qj, Qi = ej * b_j[f], ei * b_ia_f[f]
        f_j, f_i = Qj * Ft, Qi * Ft  # Eq. (22) and N_if T w
        r[3 * i] += f_i.real
        r[3 * i + 1] += f_i.imag
        r[3 * i + 2] += (ai_ * f_i).imag - Mt - (arm_ * Ft).imag
        r[3 * j] += f_j.real
        r[3 * j + 1] += f_j.imag
        r[3 * j + 2] += Mt + (aj_ * f_j).imag
        if not tangent:
            continue
        g = b_jc[f] * np.conj(ei)  # Jacobian of psi on [r_i, theta_i, r_j, theta_j] (Eqs. 12-13, 37)
        dti = -1j * b_jc[f] * (u + s_i[f])
        dtj = 1j * g * aj
        J[0, 0], J[1, 0], J[0, 1], J[1, 1] = -g.real, -g.imag, g.imag, -g.real
        J[0, 3], J[1, 3], J[0, 4], J[1, 4] = g.real, g.imag, -g.imag, g.real
        J[0, 2], J[1, 2], J[0, 5], J[1, 5] = dti.real, dti.imag, dtj.real, dtj.imag
        J[2, 2], J[2, 5] = -1.0, 1.0
        for a in range(3):
            for c in range(6):
                KJ[a, c] = K[f, a, 0] * J[0, c] + K[f, a, 1] * J[1, c] + K[f, a, 2] * J[2, c]
        for c in range(6):
            col = 3 * i + c if c < 3 else 3 * j + c - 3
            kf = KJ[0, c] + 1j * KJ[1, c]
            fjc, fic = Qj * kf, Qi * kf
            T[0, 3 * j, col] += fjc.real  # K^I (Eq. A2): link j rows N_fj K J
            T[0, 3 * j + 1, col] += fjc.imag
            T[0, 3 * j + 2, col] += KJ[2, c] + (aj_ * fjc).imag
            T[0, 3 * i, col] += fic.real  # link i rows N_if T K J
            T[0, 3 * i + 1, col] += fic.imag
            T[0, 3 * i + 2, col] += (ai_ * fic).imag - KJ[2, c] - (arm_ * kf).imag
            T[2, 3 * i + 2, col] += nl[f] * (Ft.real * J[1, c] - Ft.imag * J[0, c])  # K^III (Eq. A13)
        T[1, 3 * i, 3 * i + 2] += -f_i.imag  # K^II (Eq. A8): dN/dtheta w
        T[1, 3 * i + 1, 3 * i + 2] += f_i.real
        T[1, 3 * j, 3 * j + 2] += -f_j.imag
        T[1, 3 * j + 1, 3 * j + 2] += f_j.real
    for k in range(ln.shape[0]):  # dead loads: force, moment + (A s) x F, and d/dtheta = (A s).F
        d = ln[k]
        dF = np.exp(-1j * ang[d]) * np.conj(loff[k]) * lforce[k]
        r[3 * d] -= lforce[k].real
        r[3 * d + 1] -= lforce[k].imag
        r[3 * d + 2] -= lmom[k] + dF.imag
        if tangent:
            T[3, 3 * d + 2, 3 * d + 2] += dF.real


@njit
def _solve_in_place(A, b):
    """``b <- A^-1 b`` by Gaussian elimination with partial pivoting (LAPACK getrf/getrs's
    algorithm; ``A`` overwritten); False on an exactly zero pivot (LAPACK's info > 0). Written
    out because numba's ``np.linalg.solve`` costs far more cold compile time than this loop, for
    the 9 x 9 systems of a linkage."""
    n = b.shape[0]
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(A[i, k]) > abs(A[p, k]):
                p = i
        if A[p, k] == 0.0:
            return False
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, n):
            f = A[i, k] / A[k, k]
            for j in range(k + 1, n):
                A[i, j] -= f * A[k, j]
            b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= A[k, j] * b[j]
        b[k] = s / A[k, k]
    return True


@njit
def newton(pos, ang, free, fi, fj, s_i, s_j, b_j, b_jc, b_ia_f, arm, p_hat, K, nl, ln, loff, lforce, lmom,
           mode, K0, tol, max_iter, divergence, history, r):
    """Newton-Raphson from ``pos``, ``ang`` (updated in place; the prescribed DOFs already set),
    `flexmb.solvers.newton.Newton.solve`'s loop: ``mode`` 0 full tangent, 1 K^I only, 2 the
    constant ``K0`` (free x free). Fills ``history`` (max_iter,) and ``r`` (the last residual);
    returns (status index into `STATUS`, iterations, last residual norm, first residual norm)."""
    n = r.shape[0]
    nf = free.shape[0]
    T = np.empty((4, n, n))
    Kf = np.empty((nf, nf))
    rf = np.empty(nf)
    first = -1.0
    it = 0
    while True:
        evaluate(pos, ang, fi, fj, s_i, s_j, b_j, b_jc, b_ia_f, arm, p_hat, K, nl, ln, loff, lforce, lmom,
                 mode != 2, r, T)
        s = 0.0
        for a in range(nf):
            rf[a] = -r[free[a]]
            s += rf[a] * rf[a]
        res = np.sqrt(s)
        if it > 0:
            history[it - 1] = res
        if first < 0.0:
            first = res
        if res < tol:
            return 0, it, res, first
        if not np.isfinite(res) or res > divergence * max(first, tol):
            return 1, it, res, first
        if it == max_iter:
            return 2, it, res, first
        if mode == 2:  # element by element: numba's array assignment compiles its broadcasting checks
            for a in range(nf):
                for b in range(nf):
                    Kf[a, b] = K0[a, b]
        else:
            for a in range(nf):
                for b in range(nf):
                    v = T[0, free[a], free[b]]
                    if mode == 0:  # summed in the order of the numpy path: ((I + II) + III) + load
                        v += T[1, free[a], free[b]]
                        v += T[2, free[a], free[b]]
                        v += T[3, free[a], free[b]]
                    Kf[a, b] = v
        if not _solve_in_place(Kf, rf):
            return 3, it, res, first
        for a in range(nf):
            d = free[a]
            if d % 3 == 2:
                ang[d // 3] += rf[a]
            else:
                pos[d // 3, d % 3] += rf[a]
        it += 1
