"""KSD step 1 (Dwarshuis et al. 2020, Sec. 2.1-2.2): the kinematics of the reduced mechanism.

Link poses that satisfy every joint's database constraints and the prescribed motion, by Newton
on the constraint equations; redundant equations of an over-constrained mechanism are removed by
a rank-revealing QR at rest, and a kinematically indeterminate mechanism is refused with its free
motion named. Public because models and studies need the kinematic configuration itself (the
manipulator's end point, Sec. 4.4), not only as a solver's start.
"""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np
import scipy.linalg
from scipy.linalg import lapack

from .. import jit
from ..errors import ConvergenceError, TopologyError, UnsupportedStrategyError
from .geometry import LinkPoses, intended_angle
from .reduced import ReducedMechanism, kernels

__all__ = ["solve_kinematics", "kinematics_in_range", "kinematic_start", "turn_rate", "STEP_ROTATION",
           "kinematics_rates"]

_gesv = lapack.get_lapack_funcs("gesv", (np.zeros(1),))
_COMPONENTS = ("x", "y", "z", "rotation about x", "rotation about y", "rotation about z")


def _describe(red: ReducedMechanism, columns: np.ndarray, vector: np.ndarray) -> str:
    names = list(red.compiled.link_node)
    big = np.flatnonzero(np.abs(vector) > 0.2 * np.abs(vector).max())
    parts = []
    for k in big:
        link, comp = divmod(int(columns[k]), 6)
        label = "rotation" if (red.dim == 2 and comp == 5) else _COMPONENTS[comp]
        parts.append(f"link {names[link]!r} {label} ({vector[k]:+.2f})")
    return ", ".join(parts)


def _hinges_in(red: ReducedMechanism, columns: np.ndarray, vector: np.ndarray) -> str:
    """The hinges a free motion turns, as the end of `_independent_rows`' refusal ('' if none)."""
    if red.hinges is None:
        return ""
    moving = set(columns[np.abs(vector) > 0.2 * np.abs(vector).max()] // 6)
    names = [n for n, (a, b) in zip(red.hinges.names, red.hinges.node) if a in moving or b in moving]
    if not names:
        return ""
    return (f" (hinge {', '.join(map(repr, names))} turns with it: a hinge's rotation that only its spring and the "
            "flexures' stiffness decide is such a motion; KSD's step 1 needs the prescribed motion and the motors "
            "to determine every joint rotation)")


def _independent_rows(red: ReducedMechanism, jac: np.ndarray):
    """Rows of the constraint Jacobian at rest to keep (redundant ones removed, Sec. 2.2)."""
    free = red.free
    if len(free) == 0:  # nothing for the kinematics to find: every joint constraint is redundant
        raise UnsupportedStrategyError(
            "KSD: every link DOF is prescribed, so step 1 (the kinematics under the joints' database constraints) "
            "has no unknown and the prescribed motion generally contradicts those constraints; leave the DOFs the "
            "joints determine free (e.g. prescribe only the rotation) or use method='conventional'")
    scale = np.where(free % 6 < 3, 1.0 / red.length, 1.0)  # unknowns in D0 and rad
    A = np.ascontiguousarray(jac[:, free] / scale)
    rank, null, rows = _rank(A.tobytes(), A.shape)
    if rank < len(free):
        raise TopologyError(
            f"the mechanism is kinematically indeterminate for KSD ({len(free)} unknown link coordinates, "
            f"{rank} independent joint constraints): this motion is free: {_describe(red, free, null)}. "
            "Prescribe it (Mechanism.prescribe) or use method='conventional'" + _hinges_in(red, free, null))
    return rows


@functools.lru_cache(maxsize=256)
def _rank(data: bytes, shape: tuple):
    """Rank, a null vector (or None) and the independent rows of ``A`` (m, n) by SVD and pivoted QR;
    cached on the matrix's bytes: repeated solves of one mechanism decide once, identically."""
    A = np.frombuffer(data).reshape(shape)
    n_free = shape[1]
    if shape[0] == 0:
        return 0, np.eye(n_free)[0], np.zeros(0, dtype=np.int64)
    _, s, vt = np.linalg.svd(A)
    rank = int(np.sum(s > 1e-9 * s[0])) if s.size and s[0] > 0 else 0
    null = vt[rank] if rank < n_free else None
    if rank < n_free or shape[0] == rank:
        return rank, null, np.arange(rank)
    _, _, piv = scipy.linalg.qr(A.T, pivoting=True, mode="economic")
    rows = np.sort(piv[:rank])
    rows.flags.writeable = False  # shared by the cache
    return rank, null, rows


def _norm(v: np.ndarray) -> float:
    """2-norm of a vector (np.linalg.norm's checks cost more than the arithmetic here)."""
    return math.sqrt(float(v @ v))


def _correction(red: ReducedMechanism, A: np.ndarray, r: np.ndarray):
    """Newton correction of the free link coordinates, ``A dz_free = -r``, as increments (6 per
    link); None when ``A`` is singular."""
    *_, x, info = _gesv(A, -r)  # LAPACK directly: np.linalg.solve's wrapper costs more than this solve
    if info != 0:
        return None
    dz = np.zeros(6 * red.n_links)
    dz[red.free] = x
    return dz


#: largest turn [rad] of a joint in one kinematic step, as the prescribed motion and the motors set
#: it (`turn_rate`): the intended rotations are followed through the steps (each changes by less
#: than pi), never wrapped modulo 2 pi
STEP_ROTATION = 0.5 * np.pi


def turn_rate(red: ReducedMechanism) -> float:
    """The fastest a joint turns [rad per unit of the prescribed motion's load factor], as far as
    the prescribed motion tells. Step 1 moves a prescribed link along ``exp(lam W)``; between two
    such links (or one and a fixed link, W = 0) the relative orientation
    ``exp(lam W_a)^T exp(lam W_b)`` turns at exactly ``|W_b - W_a|`` (its derivative is
    ``R_a^T skew(W_b - W_a) R_b``), so a step of ``STEP_ROTATION / rate`` turns such a joint by at
    most a quarter turn; a joint to a free link is bounded by its prescribed link's ``|W|``, a
    hinge's motor by its angle. (The manipulator's joint case at 45 deg: 0.81 rad per unit, one
    step; its link 3 alone turns 1.72 rad, which split it into two steps before.)"""
    lr, W = red._moves[1]
    Wl = np.full((red.n_links, 3), np.nan)
    Wl[lr] = W
    a, b = red.frames.a, red.frames.b
    if red.hinges is not None:
        a, b = np.concatenate([a, red.hinges.node[:, 0]]), np.concatenate([b, red.hinges.node[:, 1]])
    wa, wb = Wl[a], Wl[b]
    known_a, known_b = ~np.isnan(wa[:, 0]), ~np.isnan(wb[:, 0])
    rate = np.where(known_a & known_b, np.linalg.norm(np.nan_to_num(wb - wa), axis=1),
                    np.linalg.norm(np.nan_to_num(wa), axis=1) + np.linalg.norm(np.nan_to_num(wb), axis=1))
    motors = [] if red.hinges is None else np.abs(red.hinges.angle[np.isfinite(red.hinges.angle)])
    return float(max(rate.max(initial=0.0), max(motors, default=0.0)))


def _unwrapped(theta: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """``theta`` (atan2, in (-pi, pi]) continued from ``previous``: the branch nearest to it."""
    return previous + (theta - previous + np.pi) % (2.0 * np.pi) - np.pi


def kinematic_start(red: ReducedMechanism):
    """What step 1 starts from, which depends on the mechanism alone: the rest poses, the
    constraint Jacobian there, the independent equations (redundant ones removed), the intended
    rotations at rest and the fastest joint rotation (`turn_rate`). Kept on ``red`` (built once
    per compiled mechanism, `flexmb.solvers.ksd`): repeated solves decide once, identically."""
    start = getattr(red, "_kinematic_start", None)
    if start is not None and start[-1] is None:  # `ReducedMechanism.with_values`: other prescribed values
        start = red._kinematic_start = start[:-1] + (turn_rate(red),)
    if start is None:
        rest = red.rest()
        _, jac0, theta0, _ = red.constraint_equations(rest, values=False, lam=0.0)
        rows = _independent_rows(red, jac0)
        largest = turn_rate(red)
        for a in (rest.x, rest.R, rest.angle, jac0, theta0):
            a.flags.writeable = False
        start = red._kinematic_start = (rest, jac0, rows, theta0, largest)
    return start


def _compiled_arrays(red: ReducedMechanism) -> dict:
    """What `flexmb.ksd.reduced_jit.kinematics` reads of ``red`` besides the prescribed values, per
    joint in the equations' order (group by group): frames, constraint codes, 1/D0, the linear
    rows' rest values, the symmetric row's directions and the trained functions as padded
    polynomials. Built once per set-up (kept on ``red``; `ReducedMechanism.with_values` shares it)."""
    arrays = getattr(red, "_kinematics_jit", None)
    if arrays is not None:
        return arrays
    from .reduced_jit import CODES

    order = np.concatenate([idx for _, _, idx in red.groups])
    J, m = len(order), len(red.groups[0][1])
    code, inv, rest = np.zeros((J, m), dtype=np.int64), np.zeros(J), np.zeros((J, m))
    nm = np.zeros((J, 3, 2))
    width = max(len(cs.powers) // 2 if cs.fun is not None else 1 for cs in red._sets)
    fun, fpow, fcoef = np.zeros((J, m), dtype=np.bool_), np.zeros((J, width)), np.zeros((J, m, width))
    at = 0
    for (_, cons, idx), cs in zip(red.groups, red._sets):
        s = slice(at, at + len(idx))
        code[s] = [CODES[n] for n in cons]
        inv[s], nm[s] = cs.inv, cs._nm
        if cs.lin is not None:
            rest[s, np.arange(m)[cs.lin]] = cs.lin_rest
        if cs.fun is not None:
            P = len(cs.powers) // 2
            fpow[s, :P] = cs.powers[:P]
            for i, k in enumerate(np.arange(m)[cs.fun]):
                fun[s, k], fcoef[s, k, :P] = True, cs.coef[:P, i]
        at += len(idx)
    fr = red.frames
    c = np.ascontiguousarray
    arrays = red._kinematics_jit = {
        "order": order, "a": c(fr.a[order]), "b": c(fr.b[order]), "s_a": c(fr.s_a[order]), "s_b": c(fr.s_b[order]),
        "P": c(fr.P[order]), "code": code, "inv": inv, "rest": rest, "nm": nm, "fun": fun, "fpow": fpow, "fcoef": fcoef,
        "cols": c(red._cols[order])}
    return arrays


def compiled_constraints(red: ReducedMechanism, poses: LinkPoses):
    """`ReducedMechanism.constraint_equations` (no hinges) through the numba kernel of step 1,
    `flexmb.ksd.reduced_jit.constraints`: values (m,), Jacobian (m, 6 n_links), ``theta`` (J,),
    ``p`` (J, 3) (tests hold it equal to the numpy path and to finite differences)."""
    from .reduced_jit import constraints

    k = _compiled_arrays(red)
    order = k["order"]
    c, jac = np.empty(red.n_equations), np.empty((red.n_equations, 6 * red.n_links))
    theta, p = np.empty(len(order)), np.empty((len(order), 3))
    constraints(np.ascontiguousarray(poses.x, dtype=float), np.ascontiguousarray(poses.R, dtype=float), k["a"],
                k["b"], k["s_a"], k["s_b"], k["P"], k["code"], k["inv"], k["rest"], k["nm"], k["fun"], k["fpow"], k["fcoef"],
                k["cols"], True, c, jac, theta, p)
    out_theta, out_p = np.empty(len(order)), np.empty((len(order), 3))
    out_theta[order], out_p[order] = theta, p
    return c, jac, out_theta, out_p


def _kinematics_call(red: ReducedMechanism) -> tuple:
    """What `_solve_compiled` hands `flexmb.ksd.reduced_jit.kinematics` besides the per-solve
    buffers, gathered once per set-up (kept on ``red``; `ReducedMechanism.with_values` drops it,
    the prescribed values enter): the rest poses and Jacobian (copied per solve: the kernel works
    in them), the arguments from ``path_theta`` to ``cols`` in one tuple, the equations' joint
    order and whether it is the joints' own (one group: no scatter back)."""
    call = getattr(red, "_kinematics_args", None)
    if call is not None:
        return call
    rest, jac0, rows, path_theta, largest = kinematic_start(red)
    k = _compiled_arrays(red)
    order = k["order"]
    (lt, ct, vt), (lr, W) = red._moves
    c = np.ascontiguousarray
    middle = (c(path_theta[order]), float(largest), STEP_ROTATION, rows, red.free, red.prescribed, red.values,
              red.lam_rate, red.X0, c(lt), c(ct), c(vt), c(lr), c(W), k["a"], k["b"], k["s_a"], k["s_b"], k["P"],
              k["code"], k["inv"], k["rest"], k["nm"], k["fun"], k["fpow"], k["fcoef"], k["cols"])
    call = red._kinematics_args = (rest.x, rest.R, rest.angle, jac0, middle, order,
                                   bool(np.array_equal(order, np.arange(len(order)))))
    return call


def _solve_compiled(red: ReducedMechanism, tol: float, max_iter: int, max_rotation: float, stop_beyond_half_turn: bool):
    """`solve_kinematics` through `flexmb.ksd.reduced_jit.kinematics` (no hinges): the same steps in
    one numba call. The kernel keeps
    the residuals of the first 64 ``max_iter`` iterations (the manipulator needs ~5); beyond that
    (a motion of many turns: the 2D pivot turned 300 rad with max_iter=2, 191 iterations) it runs
    again with room for all, so info's ``history`` holds every iteration, as the numpy loop's."""
    x0, R0, angle0, jac0, middle, order, in_order = _kinematics_call(red)
    J = len(order)
    room = 64 * max_iter
    while True:  # deterministic: a second run repeats the first, with a longer history
        x, R, angle = x0.copy(), R0.copy(), angle0.copy()
        c = np.empty(red.n_equations)
        theta, p = np.empty(J), np.empty((J, 3))
        history = np.empty(room)
        status, iterations, res, lam = kernels().kinematics(x, R, angle, jac0.copy(), *middle, tol, max_iter, max_rotation,
                                                  stop_beyond_half_turn, c, theta, p, history)
        if iterations <= room:
            break
        room = iterations
    if status:
        raise _not_converged(lam, res, tol)
    if not in_order:
        theta[order], p[order] = theta.copy(), p.copy()
    return LinkPoses(x, R, angle), theta, p, c, iterations, res, lam, history[:iterations].tolist()


def kinematics_in_range(red: ReducedMechanism, tol: float, stop_beyond_half_turn: bool, lo: np.ndarray,
                        hi: np.ndarray):
    """`solve_kinematics` with its defaults (no hinges, compiled) when it converges to intended
    rotations within ``lo``, ``hi`` (J,) [rad]: ``(poses, theta, p, info)`` and step 2's zeroed
    stiffness (J, 6, 6) and force (J, 6) arrays; None otherwise (the
    caller solves again through `solve_kinematics`, which refuses or warns as it does). One call
    of `flexmb.ksd.reduced_jit.kinematics_in_range`: the same kernel and numbers as `_solve_compiled`."""
    x0, R0, angle0, jac0, middle, order, _ = _kinematics_call(red)
    max_iter = 30
    room = 64 * max_iter
    while True:  # deterministic: a second run repeats the first, with a longer history
        status, iterations, res, lam, within, x, R, angle, c, theta, p, history, K, Fh = kernels().kinematics_in_range(
            x0, R0, angle0, jac0, *middle, tol, max_iter, 0.5, stop_beyond_half_turn, red.n_equations, room, order,
            lo, hi)
        if iterations <= room:
            break
        room = iterations
    if status or not within or lam < 1.0 - 1e-14:
        return None
    return LinkPoses(x, R, angle), theta, p, _info(red, c, iterations, res, lam, None, history.tolist()), K, Fh


def solve_kinematics(red: ReducedMechanism, *, tol: float = 1e-10, max_iter: int = 30, max_rotation: float = 0.5,
                     stop_beyond_half_turn: bool = False):
    """KSD step 1: link poses satisfying all joint constraints and the prescribed motion.

    The prescribed motion is applied in steps that turn no joint by more than `STEP_ROTATION`
    (`turn_rate`) and the intended rotations are followed from step to step, so a prescribed 2 pi + 0.3 rad
    gives 2 pi + 0.3, not 0.3. ``stop_beyond_half_turn``: stop at the first step that turns a
    joint beyond +-pi, outside any trained range (the caller refuses; intermediate steps may
    leave a range the end is in, so that is checked on the result only).
    Returns ``(poses, theta, p, info)``; info has iterations, the fraction of the prescribed
    motion reached (``load_factor``: 1 unless stopped beyond half a turn), the 3D hinges' angles
    (``hinge_angles``, turns counted; None in 2D or without hinges), the equations
    kept/removed and the largest residual of the removed (redundant) equations at the solution.
    With the numba kernels and no hinges the same steps run in one call (`_solve_compiled`).
    """
    if red.hinges is None and jit.enabled():
        poses, theta, p, c, iterations, res, lam, history = _solve_compiled(red, tol, max_iter, max_rotation,
                                                                            stop_beyond_half_turn)
        return poses, theta, p, _info(red, c, iterations, res, lam, None, history)
    rest, jac0, rows, path_theta, largest = kinematic_start(red)  # jac0: at the last accepted poses (predictor)
    free = red.free
    at_free, at_pres = (rows[:, None], free), (rows[:, None], red.prescribed)
    poses, lam, dlam = rest, 0.0, min(1.0, STEP_ROTATION / largest) if largest > 0.0 else 1.0
    iterations, history = 0, []
    hinge_path = red.hinge_angles(rest)  # 3D hinges' angles, turns counted from step to step
    while True:
        target = lam + dlam
        trial = red.with_prescribed(poses, target)
        # linear predictor from the last solution: the free motion that keeps the constraints
        # satisfied to first order under the prescribed increment (a prescribed rotation keeps its axis)
        dz = _correction(red, jac0[at_free], jac0[at_pres] @ (dlam * red.values) + dlam * red.lam_rate[rows])
        if dz is not None:
            trial = trial.moved(dz)
        accepted, prev = False, np.inf
        for _ in range(max_iter):
            c, jac_at, theta, p = red.constraint_equations(trial, jacobian="deferred", lam=target,
                                                           hinge_angles=hinge_path)
            res = _norm(c[rows])
            if not np.isfinite(res) or res > prev:  # Newton must gain in every iteration, else cut the
                break  # step: a large prescribed motion otherwise wanders onto another assembly branch
            if res < tol:
                accepted = True
                break
            prev = res
            jac = jac_at()
            dz = _correction(red, jac[at_free], c[rows])
            if dz is None or np.abs(dz.reshape(-1, 6)[:, 3:]).max() > max_rotation:
                break  # a correction turning a link this far heads for another assembly branch: cut
            trial = trial.moved(dz)
            iterations += 1
            history.append(res)
        if accepted:
            poses, lam = trial, target
            theta = path_theta = _unwrapped(theta, path_theta)
            hinge_path = red.hinge_angles(poses, hinge_path)
            if lam >= 1.0 - 1e-14:
                break
            if stop_beyond_half_turn and np.any(np.abs(theta) > np.pi):
                break  # beyond half a turn no database is trained: no need to go on
            step = STEP_ROTATION / largest if largest > 0.0 else 1.0
            dlam = min(2.0 * dlam, 1.0 - lam, step)
            jac0 = jac_at()
        else:
            dlam *= 0.5
            if dlam < 1e-4:
                raise _not_converged(lam, res, tol)
    return poses, theta, p, _info(red, c, iterations, res, lam, hinge_path, history)


def _not_converged(lam: float, res: float, tol: float) -> ConvergenceError:
    """Step 1's failure, with the last constraint residual against ``tol``: a residual that
    stalls at roundoff (~1e-16..1e-13, lengths over D0 and rad) above a smaller ``tol`` is not the
    database failing to reach the motion (``kinematic_tol=1e-17`` on the manipulator read as if)."""
    reason = (f"the constraint residual stalls at {res:.3g}, roundoff, above kinematic_tol {tol:.3g}: use a "
              "larger kinematic_tol (default 1e-10)" if np.isfinite(res) and res < 1e-12 else
              f"last constraint residual {res:.3g}, kinematic_tol {tol:.3g}: the database constraints cannot reach it")
    return ConvergenceError(f"KSD step 1: the kinematics of the reduced mechanism did not converge beyond {lam:.4g} "
                            f"of the prescribed motion ({reason})", None)


def _info(red: ReducedMechanism, c: np.ndarray, iterations: int, res: float, lam: float, hinge_path, history) -> dict:
    """`solve_kinematics`' info, with a warning where removed (redundant) equations are violated."""
    removed, names = getattr(red, "_removed_rows", None) or (None, None)
    if removed is None:  # the equations `_independent_rows` left out (kept with the set-up)
        keep = np.zeros(len(c), dtype=bool)
        keep[kinematic_start(red)[2]] = True
        removed = np.flatnonzero(~keep)
        names = [red.rows[k] for k in removed]
        red._removed_rows = removed, names
        red._removed_list = removed.tolist()
    worst = 0.0
    if len(removed):  # the removed rows' largest |value|, as np.abs(c[removed]).max() (NaN first)
        cl = c.tolist()
        values = [abs(cl[k]) for k in red._removed_list]
        worst = math.nan if any(v != v for v in values) else max(values)
    if worst > 1e-6:
        k = removed[np.argmax(np.abs(c[removed]))]
        warnings.warn(f"KSD step 1: the mechanism is over-constrained with inconsistent joint constraints: the "
                      f"removed redundant equation {red.rows[k]} is violated by {abs(c[k]):.3g} (lengths over D0, "
                      "rad); the kinematic start and KSD-reduced are approximate there (KSD-full is not affected)",
                      RuntimeWarning, stacklevel=4)
    return {"iterations": iterations, "residual": res, "load_factor": lam, "hinge_angles": hinge_path,
            "equations": len(c), "removed": len(removed),
            "removed_residual": worst,
            "removed_equations": list(names), "history": history}


def kinematics_rates(red: ReducedMechanism, poses: LinkPoses, relative_rates: np.ndarray,
                     prescribed_rates: np.ndarray):
    """Step 1's rates with the design: the intended rotations' ``dtheta`` (J, K) [rad] and node B's
    near positions' ``dp_hat`` (J, 3, K) at step 1's ``poses``, from the joints' relative poses'
    rates at fixed link poses ``relative_rates`` (J, 6, K: ``(dp, omega)``, a placement's) and the
    prescribed link coordinates' ``prescribed_rates`` (n_p, K, on `ReducedMechanism.prescribed`;
    translations [m], spins [rad]). The kept constraint equations ``c(z, p) = 0`` (square on the
    free coordinates, `kinematic_start`) give ``C_f dz_f = -(dc/dp + C_p dz_p)`` (the implicit
    function theorem; the constraints' gradients of `flexmb.ksd.constraints`, exact), then
    ``(dp, omega) = J_rel dz + relative_rates`` and ``dtheta = dtheta/domega . omega``."""
    _, jac, _, _ = red.constraint_equations(poses, jacobian=True, values=False)
    rows = kinematic_start(red)[2]
    p, Rrel, geo = red.frames.relative(poses)
    theta, dth = intended_angle(Rrel)
    K = relative_rates.shape[-1]
    dc = np.concatenate([(grads() @ relative_rates[idx]).reshape(-1, K) for idx, (_, grads) in
                         zip(red._take, (cs.evaluate(p[i], Rrel[i], theta[i], dth[i], deferred=True)
                                         for i, cs in zip(red._take, red._sets)))])
    dz = np.zeros((6 * red.n_links, K))
    dz[red.prescribed] = prescribed_rates
    A = jac[rows]
    dz[red.free] = np.linalg.solve(A[:, red.free], -(dc[rows] + A[:, red.prescribed] @ prescribed_rates))
    total = red.frames.relative_jacobian(geo) @ dz[red._cols] + relative_rates  # (J, 6, K)
    return np.einsum("jc,jck->jk", dth, total[:, 3:]), total[:, :3]
