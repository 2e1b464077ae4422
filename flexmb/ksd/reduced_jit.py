"""Compiled KSD kernels of the reduced mechanism: step 3's equilibrium residual and tangent in one
pass, the joints' relative poses (steps 1, 3 and 4) and their intended rotations (step 1); and
whole stages, each one call (with ~850 Python calls per solve the call overhead was
most of KSD-reduced's time): step 1's kinematic solve (`kinematics`), step 2's tabulated
condensation (`eob_lookup`), step 3's Newton loop (`reduced_newton`) and step 4 (`internal`).

The same formulas as `flexmb.ksd.reduced.ReducedMechanism.equilibrium` (the numpy path, kept and
tested equal to 1e-12 in tests/test_kernels.py), written term by term over the J joints instead of numpy's
~60 calls on (J, 3, 3) stacks.
"""

from __future__ import annotations

import numpy as np

from ..closed_form.linkage_jit import _solve_in_place
from ..fe.model_jit import compose3d
from ..jit import njit

__all__ = ["equilibrium", "relative", "intended_angle", "constraints", "kinematics", "kinematics_in_range",
           "reduced_newton", "bspline",
           "eob_lookup", "internal", "reduced_newton_near", "eob_lookup_new", "internal_state"]


@njit
def _skew(v, out):
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -v[2], v[1]
    out[1, 0], out[1, 1], out[1, 2] = v[2], 0.0, -v[0]
    out[2, 0], out[2, 1], out[2, 2] = -v[1], v[0], 0.0


@njit
def near_offset(p, Rrel, p_hat, R_hat, j, Q, xi):
    """Joint ``j``'s node B from its near pose in the joint frame: ``Q = R_rel R_hat^T`` (3, 3) and
    ``xi`` (6,) = (``p - p_hat``, the axial vector of ``Q``: `flexmb.rotations.unskew`)."""
    for i in range(3):
        xi[i] = p[j, i] - p_hat[j, i]
        for k in range(3):
            Q[i, k] = Rrel[j, i, 0] * R_hat[j, k, 0] + Rrel[j, i, 1] * R_hat[j, k, 1] + Rrel[j, i, 2] * R_hat[j, k, 2]
    xi[3], xi[4], xi[5] = 0.5 * (Q[2, 1] - Q[1, 2]), 0.5 * (Q[0, 2] - Q[2, 0]), 0.5 * (Q[1, 0] - Q[0, 1])


@njit
def equilibrium(p, Rrel, F_all, Ft_all, rb_all, ra_all, K, Fh, p_hat, R_hat, cols, load_at, loads, tangent, r, T):
    """Adds the joints' wrenches on their links and minus the loads to ``r`` (6 n_links,), and with
    ``tangent`` the joints' 12 x 12 blocks to ``T`` (6 n_links, 6 n_links). The joints' relative
    poses ``p`` (J, 3), ``Rrel``, frame axes ``F_all`` and their transposes ``Ft_all`` (J, 3, 3) (as
    `relative` gives them: its ``F`` and ``Ft`` enter as numpy's path uses them) and arms ``rb_all``, ``ra_all``
    (J, 3) from `relative`; condensed stiffness ``K`` (J, 6, 6) and force ``Fh`` (J, 6) about the
    near pose ``p_hat``, ``R_hat``; ``cols`` (J, 12) the DOFs of links a then b; ``loads`` (L,) on
    the residual entries ``load_at``."""
    F = np.empty((3, 3))
    Q = np.empty((3, 3))
    xi = np.empty(6)
    w = np.empty(6)
    f, mB, rb, ra = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    Sf, SmB, Srb, Sra = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    C = np.zeros((6, 12))
    Jr = np.empty((6, 12))
    dw = np.empty((6, 12))
    D = np.empty((2, 3, 12))
    dm = np.empty((2, 3, 12))
    blocks = np.empty((12, 12))
    Dq = np.empty((3, 3))
    tmp = np.empty((3, 12))
    for j in range(len(cols)):
        for i in range(3):
            rb[i], ra[i] = rb_all[j, i], ra_all[j, i]
            for k in range(3):
                F[i, k] = F_all[j, i, k]
        near_offset(p, Rrel, p_hat, R_hat, j, Q, xi)  # Q = R_rel R_hat^T
        for i in range(6):
            acc = 0.0
            for k in range(6):
                acc += K[j, i, k] * xi[k]
            w[i] = acc + Fh[j, i]
        for i in range(3):  # force and moment on B in global axes
            f[i] = F[i, 0] * w[0] + F[i, 1] * w[1] + F[i, 2] * w[2]
            mB[i] = F[i, 0] * w[3] + F[i, 1] * w[4] + F[i, 2] * w[5]
        mb = (mB[0] + rb[1] * f[2] - rb[2] * f[1], mB[1] + rb[2] * f[0] - rb[0] * f[2],
              mB[2] + rb[0] * f[1] - rb[1] * f[0])  # about link b's and link a's reference points
        ma = (mB[0] + ra[1] * f[2] - ra[2] * f[1], mB[1] + ra[2] * f[0] - ra[0] * f[2],
              mB[2] + ra[0] * f[1] - ra[1] * f[0])
        for i in range(3):
            r[cols[j, 6 + i]] += f[i]
            r[cols[j, 9 + i]] += mb[i]
            r[cols[j, i]] -= f[i]
            r[cols[j, 3 + i]] -= ma[i]
        if not tangent:
            continue
        _skew(f, Sf)
        _skew(mB, SmB)
        _skew(rb, Srb)
        _skew(ra, Sra)
        # d(p, omega) / d(dx_a, dphi_a, dx_b, dphi_b) = diag(F^T, F^T) [[-I, skew(ra), I, -skew(rb)], [0, -I, 0, I]]
        for i in range(3):
            for k in range(3):
                C[i, k] = -1.0 if i == k else 0.0
                C[i, 3 + k] = Sra[i, k]
                C[i, 6 + k] = 1.0 if i == k else 0.0
                C[i, 9 + k] = -Srb[i, k]
                C[3 + i, 3 + k] = -1.0 if i == k else 0.0
                C[3 + i, 9 + k] = 1.0 if i == k else 0.0
        for h in range(2):
            for i in range(3):
                for c in range(12):
                    Jr[3 * h + i, c] = (Ft_all[j, i, 0] * C[3 * h, c] + Ft_all[j, i, 1] * C[3 * h + 1, c]
                                        + Ft_all[j, i, 2] * C[3 * h + 2, c])
        tr = Q[0, 0] + Q[1, 1] + Q[2, 2]
        for i in range(3):  # d unskew(Q) / d omega = (trace(Q) I - Q) / 2
            for k in range(3):
                Dq[i, k] = 0.5 * ((tr if i == k else 0.0) - Q[i, k])
        for i in range(3):
            for c in range(12):
                tmp[i, c] = Dq[i, 0] * Jr[3, c] + Dq[i, 1] * Jr[4, c] + Dq[i, 2] * Jr[5, c]
        for i in range(3):  # Jr[3:] = tmp, element by element (no array assignment: slow to compile)
            for c in range(12):
                Jr[3 + i, c] = tmp[i, c]
        for i in range(6):
            for c in range(12):
                acc = 0.0
                for k in range(6):
                    acc += K[j, i, k] * Jr[k, c]
                dw[i, c] = acc
        for h in range(2):  # d(f, mB) = F d(w); F turns with link a
            for i in range(3):
                for c in range(12):
                    D[h, i, c] = F[i, 0] * dw[3 * h, c] + F[i, 1] * dw[3 * h + 1, c] + F[i, 2] * dw[3 * h + 2, c]
        for i in range(3):
            for k in range(3):
                D[0, i, 3 + k] -= Sf[i, k]
                D[1, i, 3 + k] -= SmB[i, k]
        # d(mB + r x f) = dmB + skew(r) df - skew(f) dr about b and a, with
        # d(rb) = (0, 0, 0, -skew(rb)) and d(ra) = (-I, 0, I, -skew(rb))
        for i in range(3):
            for c in range(12):
                dm[0, i, c] = D[1, i, c] + Srb[i, 0] * D[0, 0, c] + Srb[i, 1] * D[0, 1, c] + Srb[i, 2] * D[0, 2, c]
                dm[1, i, c] = D[1, i, c] + Sra[i, 0] * D[0, 0, c] + Sra[i, 1] * D[0, 1, c] + Sra[i, 2] * D[0, 2, c]
        for i in range(3):
            for k in range(3):
                fr = Sf[i, 0] * Srb[0, k] + Sf[i, 1] * Srb[1, k] + Sf[i, 2] * Srb[2, k]
                dm[0, i, 9 + k] += fr
                dm[1, i, 9 + k] += fr
                dm[1, i, k] += Sf[i, k]
                dm[1, i, 6 + k] -= Sf[i, k]
        for i in range(3):  # rows: on a (force, moment), on b
            for c in range(12):
                blocks[i, c] = -D[0, i, c]
                blocks[3 + i, c] = -dm[1, i, c]
                blocks[6 + i, c] = D[0, i, c]
                blocks[9 + i, c] = dm[0, i, c]
        for i in range(12):
            for c in range(12):
                T[cols[j, i], cols[j, c]] += blocks[i, c]
    for i in range(len(load_at)):
        r[load_at[i]] -= loads[i]


@njit
def relative(x, R, a, b, s_a, s_b, P, p, Rrel, F, rb, ra):
    """`flexmb.ksd.geometry.JointFrames.relative` term by term: fills node B's position ``p``
    (J, 3) and rotation ``Rrel`` (J, 3, 3) in the joint frame, the frame axes ``F = R_a P``, the arms
    ``rb`` from link b and ``ra`` from link a (J, 3)."""
    RPb = np.empty((3, 3))
    d = np.empty(3)
    for j in range(len(a)):
        ia, ib = a[j], b[j]
        for i in range(3):
            arm_a = R[ia, i, 0] * s_a[j, 0] + R[ia, i, 1] * s_a[j, 1] + R[ia, i, 2] * s_a[j, 2]
            rb[j, i] = R[ib, i, 0] * s_b[j, 0] + R[ib, i, 1] * s_b[j, 1] + R[ib, i, 2] * s_b[j, 2]
            d[i] = (x[ib, i] + rb[j, i]) - (x[ia, i] + arm_a)
            ra[j, i] = (x[ib, i] + rb[j, i]) - x[ia, i]
            for k in range(3):
                F[j, i, k] = R[ia, i, 0] * P[j, 0, k] + R[ia, i, 1] * P[j, 1, k] + R[ia, i, 2] * P[j, 2, k]
                RPb[i, k] = R[ib, i, 0] * P[j, 0, k] + R[ib, i, 1] * P[j, 1, k] + R[ib, i, 2] * P[j, 2, k]
        for i in range(3):
            p[j, i] = d[0] * F[j, 0, i] + d[1] * F[j, 1, i] + d[2] * F[j, 2, i]
            for k in range(3):
                Rrel[j, i, k] = F[j, 0, i] * RPb[0, k] + F[j, 1, i] * RPb[1, k] + F[j, 2, i] * RPb[2, k]


@njit
def intended_angle(R, theta, dtheta):
    """`flexmb.ksd.geometry.intended_angle` term by term for ``R`` (J, 3, 3): fills ``theta`` (J,)
    and ``dtheta`` (J, 3)."""
    for j in range(R.shape[0]):
        s, c = R[j, 1, 0] - R[j, 0, 1], R[j, 0, 0] + R[j, 1, 1]
        n = s * s + c * c
        theta[j] = np.arctan2(s, c)
        dtheta[j, 0] = (c * -R[j, 2, 0] - s * -R[j, 2, 1]) / n
        dtheta[j, 1] = (c * -R[j, 2, 1] - s * R[j, 2, 0]) / n
        dtheta[j, 2] = (c * c + s * s) / n  # (c ds_z - s dc_z) / n with ds_z = c, dc_z = -s


# -- step 1: the whole kinematic solve -----------------------------------------------------------

#: constraint codes of `kinematics` (`flexmb.ksd.constraints.NAMES` order)
CODES = {"x": 0, "y": 1, "z": 2, "tilt_x": 3, "tilt_y": 4, "symmetric": 5, "length": 6}


@njit
def _norm_at(v, at):
    acc = 0.0
    for i in range(len(at)):
        acc += v[at[i]] * v[at[i]]
    return np.sqrt(acc)


@njit
def _correction(A, r, rows, cols, n_dofs, dz):
    """`flexmb.ksd.kinematics._correction`: ``A[rows][:, cols] x = -r[rows]`` into ``dz`` (n_dofs,)
    on ``cols`` (zero elsewhere); False when singular."""
    n = len(cols)
    M = np.empty((n, n))
    x = np.empty(n)
    for i in range(n):
        x[i] = -r[rows[i]]
        for k in range(n):
            M[i, k] = A[rows[i], cols[k]]
    ok = _solve_in_place(M, x)
    for i in range(n_dofs):
        dz[i] = 0.0
    if ok:
        for i in range(n):
            dz[cols[i]] = x[i]
    return ok


@njit
def _move(x, R, angle, dz):
    """`flexmb.ksd.geometry.LinkPoses.moved` in place."""
    n = x.shape[0]
    w = np.empty((n, 3))
    for l in range(n):
        for i in range(3):
            x[l, i] += dz[6 * l + i]
            w[l, i] = dz[6 * l + 3 + i]
        angle[l] += dz[6 * l + 5]
    out = np.empty((n, 3, 3))
    compose3d(R, w, out)
    _copy3(out, R)


@njit
def _copy3(src, dst):
    """``dst[:] = src`` for (n, 3, 3) arrays, element by element: numba's array assignment brings
    its broadcasting checks and their error messages, seconds of a first compilation."""
    for l in range(src.shape[0]):
        for i in range(3):
            for j in range(3):
                dst[l, i, j] = src[l, i, j]


@njit
def _copy_poses(x, R, angle, x_to, R_to, angle_to):
    """``x_to[:], R_to[:], angle_to[:] = x, R, angle`` element by element (as `_copy3`)."""
    for l in range(x.shape[0]):
        for i in range(x.shape[1]):
            x_to[l, i] = x[l, i]
        angle_to[l] = angle[l]
    _copy3(R, R_to)


@njit
def _prescribe(x, R, angle, X0, lt, ct, vt, lr, W, lam):
    """`flexmb.ksd.reduced.ReducedMechanism.with_prescribed` in place."""
    for i in range(len(lt)):
        x[lt[i], ct[i]] = X0[lt[i], ct[i]] + lam * vt[i]
    if len(lr):  # element by element, no array expressions (their broadcasting compiles for seconds)
        w = np.empty((len(lr), 3))
        out = np.empty((len(lr), 3, 3))
        eye = np.zeros((len(lr), 3, 3))
        for i in range(len(lr)):
            eye[i, 0, 0] = eye[i, 1, 1] = eye[i, 2, 2] = 1.0
            for q in range(3):
                w[i, q] = lam * W[i, q]
        compose3d(eye, w, out)
        for i in range(len(lr)):
            for q in range(3):
                for t in range(3):
                    R[lr[i], q, t] = out[i, q, t]
            angle[lr[i]] = w[i, 2]


@njit
def constraints(x, R, a, b, s_a, s_b, P, code, inv, rest, nm, fun, fpow, fcoef, cols, jacobian, c, jac, theta, p):
    """All joints' kinematic constraints (`flexmb.ksd.reduced.ReducedMechanism.constraint_equations`
    without hinges, `flexmb.ksd.constraints.ConstraintSet.evaluate` term by term): values ``c``
    (J m,) and, with ``jacobian``, ``jac`` (J m, 6 n_links) (overwritten), the intended rotations
    ``theta`` (J,) and positions ``p`` (J, 3). Per joint and row: ``code`` (`CODES`), ``inv`` 1/D0,
    ``rest`` the linear rows' rest value, ``nm`` (J, 3, 2) the symmetric row's (n0, m0)/D0,
    ``fun`` (J, m) whether the row subtracts a trained function, its powers ``fpow`` (J, P) and
    coefficients ``fcoef`` (J, m, P)."""
    J, m = code.shape
    Rrel, F, rb, ra = np.empty((J, 3, 3)), np.empty((J, 3, 3)), np.empty((J, 3)), np.empty((J, 3))
    relative(x, R, a, b, s_a, s_b, P, p, Rrel, F, rb, ra)
    dth = np.empty((J, 3))
    intended_angle(Rrel, theta, dth)
    if jacobian:
        jac[:] = 0.0
    g = np.empty(6)
    gF, gW = np.empty(3), np.empty(3)
    NP = fpow.shape[1]
    tp, td = np.empty(NP), np.empty(NP)
    for j in range(J):
        for q in range(NP):  # theta's powers, and those of the derivative
            tp[q] = theta[j] ** fpow[j, q]
            td[q] = theta[j] ** max(fpow[j, q] - 1.0, 0.0)
        h = 0.5 * theta[j]
        ch, sh = np.cos(h), np.sin(h)
        pq0 = p[j, 0] * nm[j, 0, 0] + p[j, 1] * nm[j, 1, 0] + p[j, 2] * nm[j, 2, 0]
        pq1 = p[j, 0] * nm[j, 0, 1] + p[j, 1] * nm[j, 1, 1] + p[j, 2] * nm[j, 2, 1]
        for k in range(m):
            row = j * m + k
            kind = code[j, k]
            for i in range(6):
                g[i] = 0.0
            if kind <= 2:  # p_c / D0 minus its rest value
                val = p[j, kind] * inv[j] - rest[j, k]
                g[kind] = inv[j]
            elif kind <= 4:  # tilt: component of R e_z, gradient (R e_z) x e_c
                cc = kind - 3
                val = Rrel[j, cc, 2]
                if cc == 0:
                    g[4], g[5] = Rrel[j, 2, 2], -Rrel[j, 1, 2]
                else:
                    g[3], g[5] = -Rrel[j, 2, 2], Rrel[j, 0, 2]
            elif kind == 5:  # symmetric: p . n(theta / 2) / D0
                val = ch * pq0 + sh * pq1
                for i in range(3):
                    g[i] = ch * nm[j, i, 0] + sh * nm[j, i, 1]
                    g[3 + i] = 0.5 * (ch * pq1 - sh * pq0) * dth[j, i]
            else:  # length
                r = np.sqrt(p[j, 0] * p[j, 0] + p[j, 1] * p[j, 1] + p[j, 2] * p[j, 2])
                val = r * inv[j] - 1.0
                for i in range(3):
                    g[i] = p[j, i] * (inv[j] / r)
            f, df = 0.0, 0.0
            if fun[j, k]:
                for q in range(NP):
                    f += fcoef[j, k, q] * tp[q]
                    df += fcoef[j, k, q] * fpow[j, q] * td[q]
            c[row] = val - f
            if not jacobian:
                continue
            for i in range(3):
                g[3 + i] -= df * dth[j, i]
            # d(p, omega) / d(links) = diag(F^T, F^T) [[-I, skew(ra), I, -skew(rb)], [0, -I, 0, I]]
            for i in range(3):
                gF[i] = F[j, i, 0] * g[0] + F[j, i, 1] * g[1] + F[j, i, 2] * g[2]
                gW[i] = F[j, i, 0] * g[3] + F[j, i, 1] * g[4] + F[j, i, 2] * g[5]
            xa = (gF[1] * ra[j, 2] - gF[2] * ra[j, 1], gF[2] * ra[j, 0] - gF[0] * ra[j, 2],
                  gF[0] * ra[j, 1] - gF[1] * ra[j, 0])
            xb = (rb[j, 1] * gF[2] - rb[j, 2] * gF[1], rb[j, 2] * gF[0] - rb[j, 0] * gF[2],
                  rb[j, 0] * gF[1] - rb[j, 1] * gF[0])
            for i in range(3):
                jac[row, cols[j, i]] += -gF[i]
                jac[row, cols[j, 3 + i]] += xa[i] - gW[i]
                jac[row, cols[j, 6 + i]] += gF[i]
                jac[row, cols[j, 9 + i]] += xb[i] + gW[i]


@njit
def kinematics(x, R, angle, jac0, path_theta, largest, step_rotation, rows, free, prescribed, values, lam_rate,
               X0, lt, ct, vt, lr, W, a, b, s_a, s_b, P, code, inv, rest, nm, fun, fpow, fcoef, cols,
               tol, max_iter, max_rotation, stop_beyond_half_turn, c, theta, p, history):
    """`flexmb.ksd.kinematics.solve_kinematics` without hinges, the same steps: ``x``, ``R``,
    ``angle`` start at rest and end at the solution, ``jac0`` the Jacobian at rest (overwritten),
    ``path_theta`` the intended rotations at rest; fills ``c``, ``theta``, ``p`` and ``history``
    (iterations' residuals, at most its length). Returns (status, iterations, residual, load
    factor): status 0 converged, 1 failed (the step fell below 1e-4 of the motion)."""
    n_dofs = jac0.shape[1]
    nL = x.shape[0]
    xt, Rt, at_ = x.copy(), R.copy(), angle.copy()
    dz = np.zeros(n_dofs)
    rhs = np.empty(jac0.shape[0])
    jac = np.empty_like(jac0)
    path = path_theta.copy()
    lam, dlam = 0.0, 1.0
    if largest > 0.0:
        dlam = min(1.0, step_rotation / largest)
    iterations, res = 0, np.inf
    while True:
        target = lam + dlam
        _copy_poses(x, R, angle, xt, Rt, at_)
        _prescribe(xt, Rt, at_, X0, lt, ct, vt, lr, W, target)
        for i in range(len(rhs)):  # predictor: jac0[:, pres] (dlam values) + dlam lam_rate
            acc = dlam * lam_rate[i]
            for k in range(len(prescribed)):
                acc += jac0[i, prescribed[k]] * (dlam * values[k])
            rhs[i] = acc
        if _correction(jac0, rhs, rows, free, n_dofs, dz):
            _move(xt, Rt, at_, dz)
        accepted, prev = False, np.inf
        for _ in range(max_iter):
            constraints(xt, Rt, a, b, s_a, s_b, P, code, inv, rest, nm, fun, fpow, fcoef, cols, True, c, jac, theta, p)
            res = _norm_at(c, rows)
            if not np.isfinite(res) or res > prev:
                break
            if res < tol:
                accepted = True
                break
            prev = res
            ok = _correction(jac, c, rows, free, n_dofs, dz)
            turn = 0.0
            for l in range(nL):
                for i in range(3, 6):
                    turn = max(turn, abs(dz[6 * l + i]))
            if not ok or turn > max_rotation:
                break
            _move(xt, Rt, at_, dz)
            if iterations < len(history):
                history[iterations] = res
            iterations += 1
        if accepted:
            _copy_poses(xt, Rt, at_, x, R, angle)
            lam = target
            beyond = False
            for j in range(len(theta)):
                theta[j] = path[j] + (theta[j] - path[j] + np.pi) % (2.0 * np.pi) - np.pi
                path[j] = theta[j]
                beyond = beyond or abs(theta[j]) > np.pi
            if lam >= 1.0 - 1e-14:
                break
            if stop_beyond_half_turn and beyond:
                break
            step = step_rotation / largest if largest > 0.0 else 1.0
            dlam = min(2.0 * dlam, 1.0 - lam, step)
            for i in range(jac.shape[0]):  # the predictor's, at the accepted poses
                for k in range(jac.shape[1]):
                    jac0[i, k] = jac[i, k]
        else:
            dlam *= 0.5
            if dlam < 1e-4:
                return 1, iterations, res, lam
    return 0, iterations, res, lam


@njit
def kinematics_in_range(x0, R0, angle0, jac0, path_theta, largest, step_rotation, rows, free, prescribed, values,
                        lam_rate, X0, lt, ct, vt, lr, W, a, b, s_a, s_b, P, code, inv, rest, nm, fun, fpow, fcoef,
                        cols, tol, max_iter, max_rotation, stop_beyond_half_turn, n_equations, room, order, lo, hi):
    """`kinematics` from the rest poses ``x0``, ``R0``, ``angle0`` and Jacobian ``jac0`` (read, not
    changed) with its outputs allocated here (a solve's Python wrapper made ten numpy calls for
    them, each slow after other work has evicted the caches), the intended rotations and
    positions put back in the joints' ``order``, and whether every rotation lies within ``lo``,
    ``hi`` (J,). Returns (status, iterations, residual, load factor, within, x, R, angle, c,
    theta, p, history (iterations, at most room), and step 2's zeroed stiffness (J, 6, 6) and
    force (J, 6), allocated with the rest)."""
    x, R, angle = x0.copy(), R0.copy(), angle0.copy()
    J = len(order)
    c, th, pp, history = np.empty(n_equations), np.empty(J), np.empty((J, 3)), np.empty(room)
    status, iterations, res, lam = kinematics(x, R, angle, jac0.copy(), path_theta, largest, step_rotation, rows, free,
                                              prescribed, values, lam_rate, X0, lt, ct, vt, lr, W, a, b, s_a, s_b, P,
                                              code, inv, rest, nm, fun, fpow, fcoef, cols, tol, max_iter,
                                              max_rotation, stop_beyond_half_turn, c, th, pp, history)
    theta, p = np.empty(J), np.empty((J, 3))
    within = True
    for i in range(J):
        j = order[i]
        theta[j] = th[i]
        for q in range(3):
            p[j, q] = pp[i, q]
    for j in range(J):
        within = within and lo[j] <= theta[j] <= hi[j]
    return (status, iterations, res, lam, within, x, R, angle, c, theta, p, history[:min(iterations, room)].copy(),
            np.zeros((J, 6, 6)), np.zeros((J, 6)))


# -- step 3: Newton on the reduced mechanism -------------------------------------------------------

@njit
def _evaluate(x, R, a, b, s_a, s_b, P, K, Fh, p_hat, R_hat, cols, load_node, load_offset, load_force, load_moment,
              r, T):
    """Step 3's residual ``r`` and tangent ``T`` at the poses (`flexmb.ksd.reduced.ReducedMechanism.equilibrium`):
    `relative`, the loads (turned with their links at their offsets) and `equilibrium`."""
    J, L = len(a), len(load_node)
    p, Rrel, F, Ft, rb, ra = (np.empty((J, 3)), np.empty((J, 3, 3)), np.empty((J, 3, 3)), np.empty((J, 3, 3)),
                              np.empty((J, 3)), np.empty((J, 3)))
    relative(x, R, a, b, s_a, s_b, P, p, Rrel, F, rb, ra)
    for j in range(J):
        for i in range(3):
            for k in range(3):
                Ft[j, i, k] = F[j, k, i]
    loads, load_at = np.empty(6 * L), np.empty(6 * L, dtype=np.int64)
    d = np.empty((L, 3))
    for l in range(L):
        n = load_node[l]
        for i in range(3):
            d[l, i] = R[n, i, 0] * load_offset[l, 0] + R[n, i, 1] * load_offset[l, 1] + R[n, i, 2] * load_offset[l, 2]
        f = load_force[l]
        for i in range(3):
            loads[6 * l + i] = f[i]
        loads[6 * l + 3] = load_moment[l, 0] + (d[l, 1] * f[2] - d[l, 2] * f[1])
        loads[6 * l + 4] = load_moment[l, 1] + (d[l, 2] * f[0] - d[l, 0] * f[2])
        loads[6 * l + 5] = load_moment[l, 2] + (d[l, 0] * f[1] - d[l, 1] * f[0])
        for i in range(6):
            load_at[6 * l + i] = 6 * n + i
    r[:] = 0.0
    T[:] = 0.0
    equilibrium(p, Rrel, F, Ft, rb, ra, K, Fh, p_hat, R_hat, cols, load_at, loads, True, r, T)
    Sf, Sd = np.empty((3, 3)), np.empty((3, 3))
    for l in range(L):  # d(d x f)/dphi of a load at an offset point: -skew(f) skew(d)
        _skew(load_force[l], Sf)
        _skew(d[l], Sd)
        n = 6 * load_node[l] + 3
        for i in range(3):
            for k in range(3):
                T[n + i, n + k] -= Sf[i, 0] * Sd[0, k] + Sf[i, 1] * Sd[1, k] + Sf[i, 2] * Sd[2, k]


@njit
def reduced_newton(x, R, angle, a, b, s_a, s_b, P, K, Fh, p_hat, R_hat, cols, load_node, load_offset, load_force,
                   load_moment, free, tol, max_iter, divergence, history, r):
    """`flexmb.solvers.ksd.KSDReduced._reduced` without hinges, the same loop: Newton on the
    equilibrium of the reduced mechanism from the poses ``x``, ``R``, ``angle`` (updated in place).
    Fills ``history`` (max_iter,) and ``r`` (the links' last residual); returns (converged,
    iterations, last residual norm)."""
    n = r.shape[0]
    T = np.empty((n, n))
    dz = np.empty(n)
    _evaluate(x, R, a, b, s_a, s_b, P, K, Fh, p_hat, R_hat, cols, load_node, load_offset, load_force, load_moment, r, T)
    res = _norm_at(r, free)
    it = 0
    for _ in range(max_iter):
        if res < tol and it > 0:
            return True, it, res
        if not _correction(T, r, free, free, n, dz):
            break
        _move(x, R, angle, dz)
        _evaluate(x, R, a, b, s_a, s_b, P, K, Fh, p_hat, R_hat, cols, load_node, load_offset, load_force, load_moment,
                  r, T)
        prev, res = res, _norm_at(r, free)
        history[it] = res
        it += 1
        # as the conventional method: the divergence test starts after the first correction
        if not np.isfinite(res) or (it > 1 and res > divergence * prev):
            break
    return res < tol, it, res


@njit
def reduced_newton_near(x, R, angle, a, b, s_a, s_b, P, K, Fh, p_hat, cos, sin, cols, load_node, load_offset, load_force,
                        load_moment, free, tol, max_iter, divergence):
    """`reduced_newton` with node B's near rotations ``R_hat`` built here from ``cos``, ``sin`` of the
    intended rotations (J,) (`flexmb.ksd.geometry.rz`'s entries: the same numbers) and the outputs
    allocated here. Returns (converged, iterations, history (iterations,), the links' residual,
    R_hat)."""
    J = len(cos)
    R_hat = np.zeros((J, 3, 3))
    for j in range(J):
        R_hat[j, 0, 0], R_hat[j, 0, 1], R_hat[j, 1, 0], R_hat[j, 1, 1], R_hat[j, 2, 2] = cos[j], -sin[j], sin[j], cos[j], 1.0
    history, r = np.empty(max_iter), np.empty(6 * x.shape[0])
    ok, it, _ = reduced_newton(x, R, angle, a, b, s_a, s_b, P, K, Fh, p_hat, R_hat, cols, load_node, load_offset,
                               load_force, load_moment, free, tol, max_iter, divergence, history, r)
    return ok, it, history[:it].copy(), r, R_hat


# -- step 2: the tabulated condensation ------------------------------------------------------------

@njit
def deboor_basis(t, k, n, xi, h, hh):
    """The ``k + 1`` non-zero B-spline basis values of degree ``k`` on knots ``t`` at ``xi`` into
    ``h`` (``hh``: scratch of the same size), by de Boor's recursion (scipy's ``_deBoor_D``);
    returns the interval ``l`` with ``t[l] <= xi < t[l + 1]`` among the ``n`` coefficients' (the
    last one closed, outside the base interval the end pieces): ``h[i]`` multiplies coefficient
    ``l - k + i``. Shared by `bspline` and `flexmb.ksd.reduced_model_jit.bspline_rows`."""
    l = k
    while l < n - 1 and xi >= t[l + 1]:
        l += 1
    h[0] = 1.0
    for d in range(1, k + 1):
        for i in range(d):
            hh[i] = h[i]
        h[0] = 0.0
        for i in range(1, d + 1):
            xb, xa = t[l + i], t[l + i - d]
            if xb == xa:
                h[i] = 0.0
                continue
            w = hh[i - 1] / (xb - xa)
            h[i - 1] += w * (xb - xi)
            h[i] = w * (xi - xa)
    return l


@njit
def bspline(t, c, k, x, out):
    """``out[j] = sum_i B_i(x[j]) c[i]``: a B-spline of degree ``k`` on knots ``t`` with coefficients
    ``c`` (n, m) at ``x`` (J,) (`deboor_basis`)."""
    n = len(t) - k - 1
    h, hh = np.empty(k + 1), np.empty(k + 1)
    for j in range(len(x)):
        l = deboor_basis(t, k, n, x[j], h, hh)
        for q in range(c.shape[1]):
            out[j, q] = 0.0
        for i in range(k + 1):
            row = l - k + i
            for q in range(c.shape[1]):
                out[j, q] += h[i] * c[row, q]


@njit
def eob_lookup(t, c, k, theta_all, b_all, at, root, powers, ocoef, emb, K, Fh, recover, x_int, R_int, a_int):
    """`flexmb.ksd.eob_table.Lookup.__call__` and step 2's use of it in one pass, for Jg joints:
    the spline (`bspline`) at their ``theta_all[at]`` split as `flexmb.database.eob_format.NAMES`
    (K_T, F0, G, RK, r0, rG, P0), node B's near position ``b_all[at, :dim]`` in the terms linear in
    it; ``at`` (Jg,) the joints' indices. Fills their rows of ``K`` (J, 6, 6) and ``Fh`` (J, 6) on
    the active components ``emb`` (the rest untouched),
    ``recover`` (Jg, n_i nd, nd + 1), the internal nodes' near positions ``x_int`` (Jg, n_i, dim)
    and orientations (`flexmb.ksd.eob.EOBTemplate.orientations`, the internal nodes' polynomial
    ``powers``, ``ocoef``): matrices ``R_int`` (Jg, n_i, 3, 3) in 3D, angles ``a_int`` (Jg, n_i) in 2D."""
    J, dim = len(at), x_int.shape[2]
    nd, ni = len(emb), x_int.shape[1]
    theta, b_pos = np.empty(J), np.empty((J, dim))
    for j in range(J):
        theta[j] = theta_all[at[j]]
        for q in range(dim):
            b_pos[j, q] = b_all[at[j], q]
    v = np.empty((J, c.shape[1]))
    bspline(t, c, k, theta, v)
    eye = np.zeros((ni, 3, 3))
    w = np.empty((ni, 3))  # a joint's internal rotation vectors (a copy: numba's reshape would compile for seconds)
    tp = np.empty(len(powers))
    for i in range(ni):
        eye[i, 0, 0] = eye[i, 1, 1] = eye[i, 2, 2] = 1.0
    for j in range(J):
        for i in range(nd):
            for q in range(nd):
                K[at[j], emb[i], emb[q]] = v[j, i * nd + q]
        s = nd * nd
        g = s + nd
        for i in range(nd):  # F0 + G b (numpy's order: the product first)
            acc = 0.0
            for q in range(dim):
                acc += v[j, g + i * dim + q] * b_pos[j, q]
            Fh[at[j], emb[i]] = v[j, s + i] + acc
        s = g + nd * dim
        m = ni * nd
        r0, rG = s + m * nd, s + m * nd + m
        for i in range(m):
            for q in range(nd):
                recover[j, i, q] = v[j, s + i * nd + q]
            acc = 0.0
            for q in range(dim):
                acc += v[j, rG + i * dim + q] * b_pos[j, q]
            recover[j, i, nd] = v[j, r0 + i] + acc
        s = rG + m * dim
        for i in range(ni):
            for q in range(dim):
                x_int[j, i, q] = v[j, s + i * dim + q] + (b_pos[j, q] if root[i] == 1 else 0.0)
        comp = 1 if dim == 2 else 3
        for q in range(len(powers)):
            tp[q] = theta[j] ** powers[q]
        for i in range(ni * comp):  # the internal nodes' orientations: polynomials in theta
            v[j, i] = 0.0
        for q in range(len(powers)):
            for i in range(ni * comp):
                v[j, i] += tp[q] * ocoef[q, i]
        if dim == 2:
            for i in range(ni):
                a_int[j, i] = v[j, i]
        else:
            for i in range(ni):
                for q in range(3):
                    w[i, q] = v[j, 3 * i + q]
            compose3d(eye, w, R_int[j])


@njit
def eob_lookup_new(t, c, k, theta_all, b_all, at, root, powers, ocoef, emb, K, Fh, ni, dim):
    """`eob_lookup` with the group's outputs allocated here: returns ``recover``, ``x_int``,
    ``R_int`` ((0, 0, 3, 3) in 2D) and ``a_int`` ((0, 0) in 3D)."""
    nd, Jg = len(emb), len(at)
    recover, x_int = np.empty((Jg, ni * nd, nd + 1)), np.empty((Jg, ni, dim))
    R_int = np.empty((Jg, ni, 3, 3)) if dim == 3 else np.empty((0, 0, 3, 3))
    a_int = np.empty((Jg, ni)) if dim == 2 else np.empty((0, 0))
    eob_lookup(t, c, k, theta_all, b_all, at, root, powers, ocoef, emb, K, Fh, recover, x_int, R_int, a_int)
    return recover, x_int, R_int, a_int


# -- step 4: the internal nodes ----------------------------------------------------------------------

@njit
def internal(x, R, angle, a, b, s_a, s_b, P, p_hat, R_hat, joints, nodes, recover, x_int, R_int, a_int, emb, dim,
             pos, rot, ang):
    """Step 4 (Eq. 2.6) for one group of joints and `flexmb.ksd.reduced.ReducedMechanism.fe_state`'s
    placing of them: node B's displacement from its near pose in the joint frame (``p - p_hat``,
    ``unskew(R_rel R_hat^T)``), the internal nodes' ``q_i = -recover [q_B, 1]`` added to their near
    poses (``x_int``; ``R_int`` turned by the spins in 3D, ``a_int`` plus the angle in 2D), turned
    into global axes by the joint frame: positions into ``pos`` (N, dim), rotations into ``rot``
    (N, 3, 3) in 3D or angles into ``ang`` (N,) in 2D, at FE ``nodes`` (Jg, n_i) of ``joints`` (Jg,)."""
    Jall = len(a)
    p, Rrel, F, rb, ra = np.empty((Jall, 3)), np.empty((Jall, 3, 3)), np.empty((Jall, 3, 3)), np.empty((Jall, 3)), np.empty((Jall, 3))
    relative(x, R, a, b, s_a, s_b, P, p, Rrel, F, rb, ra)
    nd, ni = len(emb), x_int.shape[1]
    xi6, xiB, xi, o = np.empty(6), np.empty(6), np.empty((ni, nd)), np.empty(3)
    Q, tmp = np.empty((3, 3)), np.empty((3, 3))
    spin, Rl = np.empty((ni, 3)), np.empty((ni, 3, 3))
    for g in range(len(joints)):
        j = joints[g]
        near_offset(p, Rrel, p_hat, R_hat, j, Q, xi6)
        for i in range(nd):
            xiB[i] = xi6[emb[i]]
        ia = a[j]
        for i in range(3):  # the joint frame's origin o_A = x_a + R_a s_a
            o[i] = x[ia, i] + R[ia, i, 0] * s_a[j, 0] + R[ia, i, 1] * s_a[j, 1] + R[ia, i, 2] * s_a[j, 2]
        for n in range(ni):
            for i in range(nd):
                row = n * nd + i
                acc = recover[g, row, nd]
                for q in range(nd):
                    acc += recover[g, row, q] * xiB[q]
                xi[n, i] = -acc
            node = nodes[g, n]
            for i in range(dim):
                acc = o[i]
                for q in range(dim):
                    acc += F[j, i, q] * (x_int[g, n, q] + xi[n, q])
                pos[node, i] = acc
            if dim == 2:
                ang[node] = angle[ia] + (a_int[g, n] + xi[n, 2])
            else:
                spin[n] = xi[n, 3:]
        if dim == 2:
            continue
        compose3d(R_int[g], spin, Rl)
        for n in range(ni):
            node = nodes[g, n]
            for i in range(3):  # F Rl P^T
                for k in range(3):
                    tmp[i, k] = F[j, i, 0] * Rl[n, 0, k] + F[j, i, 1] * Rl[n, 1, k] + F[j, i, 2] * Rl[n, 2, k]
            for i in range(3):
                for k in range(3):
                    rot[node, i, k] = tmp[i, 0] * P[j, k, 0] + tmp[i, 1] * P[j, k, 1] + tmp[i, 2] * P[j, k, 2]


@njit
def internal_state(x, R, angle, a, b, s_a, s_b, P, p_hat, R_hat, joints, nodes, recover, x_int, R_int, a_int, emb, dim,
                   x0, rot0, ang0, r, fe_dofs, emb_dofs, n_dofs):
    """Step 4 for every group of joints (tuples ``joints`` ... ``a_int``, one entry per group, as
    `internal` takes them) and `flexmb.ksd.reduced.ReducedMechanism.fe_state_compiled`'s state:
    the nodes from their reference positions ``x0`` (N, dim) and orientations (``rot0`` (N, 3, 3)
    in 3D, ``ang0`` (N,) in 2D; the other empty), the links' from ``x``, ``R``, ``angle``; and
    `ReducedMechanism.reaction_vector` of the links' residual ``r``. Returns positions, rotations
    (3D), angles (2D) and the reaction vector (n_dofs,)."""
    nL = x.shape[0]
    pos, rot, ang = x0.copy(), rot0.copy(), ang0.copy()
    for l in range(nL):
        for i in range(dim):
            pos[l, i] = x[l, i]
        if dim == 2:
            ang[l] = angle[l]
        else:
            for i in range(3):
                for q in range(3):
                    rot[l, i, q] = R[l, i, q]
    for g in range(len(joints)):
        if x_int[g].shape[1] == 0:
            continue
        internal(x, R, angle, a, b, s_a, s_b, P, p_hat, R_hat, joints[g], nodes[g], recover[g], x_int[g], R_int[g],
                 a_int[g], emb, dim, pos, rot, ang)
    reaction = np.zeros(n_dofs)
    for i in range(len(fe_dofs)):
        reaction[fe_dofs[i]] = r[emb_dofs[i]]
    return pos, rot, ang, reaction
