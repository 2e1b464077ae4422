"""Kinematically Started Deformation (KSD) method, Dwarshuis et al. (2020), Section 2.

1. Kinematics of the reduced mechanism (one node per link) with the database constraints of
   every joint and the prescribed motion (Newton; redundant equations of an over-constrained
   mechanism removed by a rank-revealing QR at rest; a kinematically indeterminate mechanism is
   refused with its free motion named).
2. An EOB per joint at the intended rotation found in step 1 (`flexmb.ksd.eob`).
3. Craig-Bampton condensation of each EOB on its interface nodes (Eq. 2.5) and Newton on the
   equilibrium of the reduced mechanism.
4. Internal displacements of each joint from its interface displacements (Eq. 2.6).
5. Newton on the full finite-element model from that start: the conventional method's equations,
   so the converged configuration is the conventional one (``ksd-full`` only). Step 4's node
   positions are exact to first order; along a leaf their second-order error (micrometres)
   times the axial stiffness gives axial forces up to 15x the converged ones (four-bar, 5
   elements per leaf: 2456 N against 169 N) while the EOB's are within 1.4 N. The first
   tangent's geometric stiffness therefore takes the joint elements' axial forces from the EOBs.

``ksd-reduced`` stops after step 4.
"""

from __future__ import annotations

import warnings
from typing import ClassVar

import attrs
import numpy as np

from ..errors import ConvergenceError, DatabaseError, ExtrapolationWarning
from .. import jit
from ..ksd.geometry import ACTIVE, LinkPoses, rz
from ..ksd.linearisation import ReducedSolution
from ..ksd.kinematics import _gesv, _norm, kinematics_in_range, solve_kinematics
from ..ksd.estimate import DEFAULT_TOLERANCE, check, estimate_at
from ..ksd.provenance import files
from ..ksd.reduced import ReducedMechanism, kernels, reduced_mechanism, setup_key
from .._timing import Stopwatch
from ..linear import single_threaded
from ..fe.model import State
from ..results import Solution
from .. import _validate as v
from .conventional import newton_steps

__all__ = ["KSDReduced", "KSDFull", "solve_kinematics"]  # solve_kinematics: flexmb.ksd.kinematics, re-exported

def _requested(red: ReducedMechanism) -> str:
    """The prescribed link rotations, as asked for ([rad]; 3D: rotation vectors)."""
    names = list(red.compiled.link_node)
    lr, W = red._moves[1]
    parts = [f"link {names[k]!r} rotation " + (f"{w[2]:.6g} rad" if red.dim == 2 else f"{np.round(w, 6).tolist()} rad")
             for k, w in zip(lr, W) if np.any(w)]
    return ", ".join(parts) or "no prescribed rotation"


def _check_range(red: ReducedMechanism, theta: np.ndarray, strict: bool, reached: float = 1.0) -> None:
    """Refuse or warn of an intended joint rotation outside its trained range; ``reached``: the
    fraction of the prescribed motion step 1 reached (it stops beyond half a turn): the message
    then names the requested motion and where step 1 stopped, not only that angle."""
    for tpl, _, idx in red.groups:
        lo, hi = tpl.data.range
        for j in idx:
            if not lo - 1e-9 <= theta[j] <= hi + 1e-9:  # 1e-9 rad: the kinematic solve's roundoff
                trained = (f"outside its trained range [{np.degrees(lo):.1f}, {np.degrees(hi):.1f}] deg of "
                           f"{tpl.data.path}")
                head = f"joint {red.joint_names[j]!r} ({tpl.data.kind}): the requested motion ({_requested(red)}) turns it"
                beyond = max(lo - theta[j], theta[j] - hi)  # [rad]: at 2 decimals 45 + 1e-6 rad reads 45.00 deg
                msg = (f"{head} to {np.degrees(theta[j]):.2f} deg, {beyond:.2g} rad {trained}" if reached >= 1.0 - 1e-14 else
                       f"{head} {trained}: step 1 stopped at {np.degrees(theta[j]):.2f} deg, {100 * reached:.3g} % of "
                       "the way")
                if strict:
                    raise DatabaseError(msg + " (KSD cannot extrapolate the joint database; use "
                                              "method='conventional' or retrain with `flexmb train --range`)")
                warnings.warn(msg + "; the database fits are extrapolated", ExtrapolationWarning, stacklevel=4)


def _check_reachable(red: ReducedMechanism) -> None:
    """`_reachable`, decided once per set-up (it depends on the mechanism alone)."""
    verdict = getattr(red, "_reachable", None)
    if verdict is None:
        try:
            _reachable(red)
            verdict = ""
        except DatabaseError as exc:
            verdict = str(exc)
        red._reachable = verdict
    if verdict:
        raise DatabaseError(verdict)


def _reachable(red: ReducedMechanism) -> None:
    """Refuse (`DatabaseError`) a prescribed rotation component larger than the trained ranges of
    all joints together plus a full turn: no joint rotations within their ranges reach it, and
    step 1 would grind through thousands of load steps first (a prescribed 1e300 rad: minutes).
    Nearer rotations are left to step 1, which names the joint out of its range. A hinge's motor
    adds its angle; a hinge without one turns freely (no bound)."""
    reach = sum(max(abs(lo), abs(hi)) * len(idx) for tpl, _, idx in red.groups for lo, hi in [tpl.data.range])
    if red.hinges is not None:
        motors = red.hinges.angle
        if not np.all(np.isfinite(motors)):
            return
        reach += float(np.abs(motors).sum())
    comp = red.prescribed % 6
    rot = np.abs(np.asarray(red.values, dtype=float)[comp >= 3])
    if rot.size and rot.max() > reach + 2 * np.pi:
        raise DatabaseError(f"KSD: a prescribed rotation of {rot.max():.6g} rad is beyond the trained ranges of all the "
                            f"mechanism's joints together and a full turn ({reach:.4g} + 2 pi rad), so outside its trained "
                            "range; use method='conventional' or retrain with `flexmb train --range` (data: "
                            f"{', '.join(sorted({str(tpl.data.path) for tpl, _, _ in red.groups}))})")


_TOL_TEXT: dict = {}  # tolerances as messages print them (a float's formatting, once)


@attrs.frozen(kw_only=True)
class _KSD:
    """Kinematically Started Deformation method (Dwarshuis et al. 2020).

    Parameters
    ----------
    tol
        Convergence threshold on the free residual 2-norm [N, N m] of the reduced mechanism
        (step 3) and of the full model (step 5); 5e-7 as the paper.
    max_iter
        Newton iterations allowed in step 3 (and per step in step 5).
    kinematic_tol
        Threshold on the dimensionless constraint residual of step 1 (lengths over D0, rad).
    strict_range
        Refuse (`DatabaseError`) an intended joint rotation outside the trained range; with
        False the fits are extrapolated with an `ExtrapolationWarning`.
    database
        Folder of joint database files (default: the shipped data).
    divergence, min_step, max_rotation
        Step control of step 5, as `Conventional`.
    raise_on_failure
        Raise `ConvergenceError` instead of returning ``converged=False``.
    error_tol
        KSD-reduced: the relative error above which its answer is flagged, estimated from the full
        model at the answer (`flexmb.ksd.estimate`; ``Solution.stages["estimate"]``): an
        `AccuracyWarning`, or with ``strict_error`` an `AccuracyError`. Default 0.01 (1 %); None:
        no estimate (it costs one assembly and one solve of the full model). KSD-full records the
        estimate of its step 1-4 start.
    strict_error
        Refuse (`AccuracyError`) a KSD-reduced answer whose estimated error is above ``error_tol``.
    """

    name: ClassVar[str] = ""
    full: ClassVar[bool] = False
    solution_type: ClassVar[type] = Solution
    capability: ClassVar[str] = "fe_model"
    #: joint capabilities every joint must offer, and the mechanism dimensions handled
    needs: ClassVar[tuple[str, ...]] = ("fe_model", "database")
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    tol: float = attrs.field(default=5e-7, validator=v.positive_option)
    max_iter: int = attrs.field(default=20, validator=v.count_option)
    kinematic_tol: float = attrs.field(default=1e-10, validator=v.positive_option)
    strict_range: bool = attrs.field(default=True, validator=v.flag_option)
    database: str | None = attrs.field(default=None, validator=v.folder_option)
    divergence: float = attrs.field(default=1e3, validator=v.above_one_option)
    min_step: float = attrs.field(default=1e-5, validator=v.unit_interval_option)
    max_rotation: float | None = attrs.field(default=1.0, validator=attrs.validators.optional(v.positive_option))
    raise_on_failure: bool = attrs.field(default=False, validator=v.flag_option)
    error_tol: float | None = attrs.field(default=DEFAULT_TOLERANCE,
                                          validator=attrs.validators.optional(v.positive_option))
    strict_error: bool = attrs.field(default=False, validator=v.flag_option)

    def share_setup(self, base, compiled) -> None:
        """Give ``compiled`` (``base`` with other prescribed values: a motion sweep's value) the
        set-up of ``base`` moved to its values (`ReducedMechanism.with_values`), built once on
        ``base``; nothing when ``compiled`` differs otherwise. In a sweep step 1 from rest (~12
        constraint evaluations) is then most of each value's time."""
        moved = reduced_mechanism(base, self.database).with_values(compiled)
        if moved is not None:
            compiled.derived[setup_key(self.database)] = moved

    def solve(self, compiled) -> Solution:
        if self._compiled_path(compiled):  # no BLAS call but the direct EOBs', which enter it themselves
            sol = self._solve(compiled)  # (entering it is a visible share of a small solve)
        else:
            with single_threaded():  # small dense systems throughout (flexmb.linear.single_threaded)
                sol = self._solve(compiled)
        return sol if self.full else check(sol, self.error_tol, self.strict_error)  # its estimated error

    def _compiled_path(self, compiled) -> bool:
        """Whether steps 1-4 run as compiled stages (`flexmb.ksd.reduced_jit`): KSD-reduced with the
        numba kernels and no hinges (those keep the numpy loops)."""
        return not self.full and jit.enabled() and getattr(compiled.problem.model, "hinges", None) is None

    def _solve(self, compiled) -> Solution:
        watch, stages = Stopwatch(), {}
        times = watch.times
        red = reduced_mechanism(compiled, self.database)
        stages["setup"] = {"files": files(red)}  # which database file each joint's data came from
        watch.lap("setup")

        if self.strict_range:
            _check_reachable(red)
        compiled_path = self._compiled_path(compiled)  # steps 2-4 as arrays, compiled
        plan = red.tabulated_plan() if compiled_path and not self.full else None
        step1 = None if plan is None else kinematics_in_range(red, self.kinematic_tol, self.strict_range, *plan[1:3])
        if step1 is not None:  # in range and on the tables: steps 2-4 from prepared arguments
            return self._tabulated_steps(compiled, red, plan, step1, stages, watch)
        try:
            poses, theta, p_hat, info = solve_kinematics(red, tol=self.kinematic_tol, stop_beyond_half_turn=self.strict_range)
        except ConvergenceError as exc:  # step 1 failed: a non-converged Solution, as every strategy
            watch.lap("kinematics")
            watch.total()
            sol = self.solution_type.failed(self.name, compiled, f"{self.name}: {exc}", times, stages)
            if self.raise_on_failure:
                raise ConvergenceError(sol.message, sol) from None
            return sol
        _check_range(red, theta, self.strict_range, info["load_factor"])
        stages["kinematics"] = {**info, "theta": theta.copy(), "p_hat": p_hat.copy()}  # flexmb.ksd.reduced_model.near
        watch.lap("kinematics")

        K, Fh, eobs, tabulated = red.condensed_joints(theta, p_hat, lookup=not self.full, compiled=compiled_path)
        R_hat = rz(theta)
        stages["eob"] = {"joints": len(theta), "tabulated": tabulated}  # step 2: EOBs built, of them looked up
        if not self.full:  # step 2's EOBs, kept for flexmb.ksd.reduced_model.near (not rebuilt)
            stages["eob"]["near"] = (red, eobs, K, Fh)
        watch.lap("eob")
        return self._steps_3_4(compiled, red, poses, K, Fh, p_hat, R_hat, eobs, info, stages, watch)

    def _tabulated_steps(self, compiled, red, plan, step1, stages, watch) -> Solution:
        """Steps 2-4 of KSD-reduced with every joint tabulated and in range
        (`ReducedMechanism.tabulated_plan`), from step 1's ``(poses, theta, p_hat, info)``: the kernels of the general
        numba path (`flexmb.ksd.reduced_jit`: `eob_lookup` per group, `reduced_newton`,
        `internal`) with their outputs allocated inside (`eob_lookup_new`, `reduced_newton_near`,
        `internal_state`): the same numbers with ~25 fewer numpy calls per solve, each slow after
        other work has evicted the caches."""
        times = watch.times
        groups, _, _, frames, loads, nodes, reference, dofs = plan
        kernel = kernels()
        poses, theta, p_hat, info, K, Fh = step1
        stages["kinematics"] = {**info, "theta": theta, "p_hat": p_hat}  # fresh arrays, read below only
        watch.lap("kinematics")
        J = len(theta)
        eobs, out = [], []
        for idx, head, (root, powers, ocoef, emb), ni, dim in groups:  # (recover, x_int, R_int, a_int) per group
            out.append(kernel.eob_lookup_new(*head, theta, p_hat, idx, root, powers, ocoef, emb, K, Fh, ni, dim))
            eobs.append([out[-1][0], out[-1][1], out[-1][2 if dim == 3 else 3]])
        stages["eob"] = {"joints": J, "tabulated": J, "near": (red, eobs, K, Fh)}
        watch.lap("eob")
        x, R, angle = poses.x, poses.R, poses.angle  # step 1's, fresh: moved in place
        ok3, it, history, r3, R_hat = kernel.reduced_newton_near(x, R, angle, *frames, K, Fh, p_hat, np.cos(theta),
                                                                  np.sin(theta), *loads, self.tol, self.max_iter,
                                                                  self.divergence)
        hist3 = history.tolist()
        stages["reduced"] = {"iterations": it, "residual": hist3[-1] if hist3 else np.nan, "converged": ok3,
                             "history": hist3}
        watch.lap("reduced")
        pos, rot, ang, reaction = kernel.internal_state(x, R, angle, *frames, p_hat, R_hat, tuple(g[0] for g in groups),
                                                        nodes, *zip(*out), ACTIVE[red.dim], red.dim, *reference, r3,
                                                        *dofs)
        watch.lap("internal")
        for key in ("setup", "kinematics", "eob", "reduced", "internal"):
            stages.setdefault(key, {})["time"] = times[key]
        stages["setup"]["database"] = red.folder
        watch.total()
        sol = ReducedSolution(method=self.name, converged=ok3, iterations=info["iterations"] + it, residual_history=history,
                       load_factor=1.0, steps=1, rejected_steps=0, wall_time=times, message=self._message(ok3, hist3),
                       state=State(pos, ang if red.dim == 2 else rot), residual=reaction, compiled=compiled,
                       tolerance=self.tol, stable=None, stages=stages)
        if self.raise_on_failure and not ok3:
            raise ConvergenceError(sol.message, sol)
        return sol

    def _message(self, ok3: bool, hist3: list) -> str:
        """KSD-reduced's `Solution.message` from step 3's outcome and residuals."""
        last = hist3[-1] if hist3 else np.nan
        tol = _TOL_TEXT.get(self.tol)
        if tol is None:
            tol = f"{self.tol:.3g}"
            if len(_TOL_TEXT) < 64:
                _TOL_TEXT[self.tol] = tol
        msg = (f"KSD-reduced: reduced mechanism in equilibrium, residual {last:.3g} < tol {tol}"
               if ok3 else f"KSD-reduced: step 3 did not converge (residual {last:.3g} after {len(hist3)} "
                           "iterations; a singular or diverging reduced tangent: the unintended deformation may "
                           "be too large for the linearised joints, use method='ksd-full' or 'conventional')")
        if not ok3 and len(hist3) >= self.max_iter and np.all(np.isfinite(hist3)):  # ran out, not diverged
            msg = (f"KSD-reduced: step 3 did not converge in max_iter={self.max_iter} iterations (residual "
                   f"{last:.3g}, smallest {min(hist3):.3g}, tol {self.tol:.3g}): raise max_iter, or tol if the "
                   "residual stalls at the roundoff of the joints' forces")
        return msg

    def _steps_3_4(self, compiled, red, poses, K, Fh, p_hat, R_hat, eobs, info, stages, watch):
        """Steps 3 and 4 (and 5 for ``ksd-full``) from step 2's ``eobs``, ``K``, ``Fh``; the `Solution`."""
        times = watch.times
        poses3, ok3, hist3, r3, mu, angles = self._reduced(red, poses, K, Fh, p_hat, R_hat, info["hinge_angles"])
        stages["reduced"] = {"iterations": len(hist3), "residual": hist3[-1] if hist3 else np.nan,
                             "converged": ok3, "history": hist3}
        watch.lap("reduced")

        state, q_nodes = red.internal_nodes(poses3, eobs, p_hat, R_hat, mu, angles, displacements=self.full)
        watch.lap("internal")
        for key in ("setup", "kinematics", "eob", "reduced", "internal"):  # setup: kept per compiled model
            stages.setdefault(key, {})["time"] = times[key]
        stages["setup"]["database"] = red.folder  # the solution's properties read the same data

        if not self.full:
            watch.total()
            sol = ReducedSolution(method=self.name, converged=ok3, iterations=info["iterations"] + len(hist3),
                           residual_history=np.array(hist3), load_factor=1.0, steps=1, rejected_steps=0,
                           wall_time=times, message=self._message(ok3, hist3), state=state,
                           residual=red.reaction_vector(r3),
                           compiled=compiled, tolerance=self.tol, stable=None, stages=stages)
        else:
            # from the step-4 state: the whole way first; if that fails, halve along the homotopy
            # r(u) - (1 - lam) r(u_start), whose lam = 0 equilibrium is the KSD start
            problem = compiled.problem
            # the kept problem's sparsity pattern and LDL^T analysis, built once on it so that every
            # solve's continued copy shares them (flexmb.problem: copies share what their original
            # computed first)
            problem._pattern, problem._tangent_solver  # noqa: B018 (built on first access)
            start = problem.continued_from(state)
            geometric = red.eob_axial_stress(eobs, q_nodes)
            if self.error_tol is not None:  # the error of the step 1-4 start
                stages["estimate"] = estimate_at(compiled, state, red.reaction_vector(r3), geometric, self.error_tol)
            out = newton_steps(start, state, tol=self.tol, max_iter=self.max_iter, divergence=self.divergence,
                               min_step=self.min_step, initial_step=1.0, max_rotation=self.max_rotation,
                               first_geometric_stress=geometric,
                               control="paper")  # measured: the continuation's path-deviation bound
            # stops step 5 of the manipulator's location case at -45 deg (load factor 0.157), and
            # step 5 converges in its first step on every other benchmark case: Fig. 18 kept here
            out.pop("tolerance", None)
            watch.lap("full")
            stages["full"] = {"iterations": out["iterations"], "time": times["full"],
                              "residual": float(out["residual_history"][-1]) if out["iterations"] else np.nan,
                              "converged": out["converged"]}
            inner = out.pop("wall_time")
            times.update({f"full_{k}": v for k, v in inner.items()})
            watch.total()
            out["iterations"] += info["iterations"] + len(hist3)
            out["message"] = "KSD-full: " + ("" if ok3 else "step 3 did not converge, step 5 started from its last "
                                                          "iterate; ") + out["message"]
            sol = Solution(method=self.name, compiled=compiled, tolerance=self.tol, wall_time=times, stages=stages,
                           **out)
        if self.raise_on_failure and not sol.converged:
            raise ConvergenceError(sol.message, sol)
        return sol

    def _reduced(self, red, poses, K, Fh, p_hat, R_hat, hinge_angles=None):
        """Step 3: Newton on the reduced mechanism's unknowns (`ReducedMechanism.step3_unknowns`:
        the links' free coordinates; with hinges their multipliers too, which start at zero, and
        the 3D hinges' angles ``hinge_angles`` from step 1 follow the iterates). Returns poses,
        converged, history, the links' residual and the hinges' multipliers and angles (None
        without hinges)."""
        hinged = red.hinges is not None
        if not hinged and jit.enabled():  # the same loop in one call (flexmb.ksd.reduced_jit.reduced_newton)
            return self._reduced_compiled(red, poses, K, Fh, p_hat, R_hat)
        free = red.step3_unknowns()
        at_free = (free[:, None], free)
        mu = np.zeros(red.hinges.n_rows) if hinged else None
        angles = hinge_angles if hinged else None
        history, prev = [], np.inf
        r, Kr = red.step3_residual(poses, mu, angles, K, Fh, p_hat, R_hat)
        res = _norm(r[free])
        for _ in range(self.max_iter):
            if res < self.tol and history:
                break
            *_, x, info = _gesv(Kr()[at_free], -r[free])  # LAPACK directly (np.linalg.solve's checks cost more)
            if info != 0:
                break
            poses, mu, angles = red.step3_moved(poses, mu, angles, x)
            r, Kr = red.step3_residual(poses, mu, angles, K, Fh, p_hat, R_hat)
            prev, res = res, _norm(r[free])
            history.append(res)
            # as the conventional method: the divergence test starts after the first correction
            if not np.isfinite(res) or (len(history) > 1 and res > self.divergence * prev):
                break
        n = 6 * red.n_links
        return poses, res < self.tol, history, r[:n] if hinged else r, mu, angles

    def _reduced_compiled(self, red, poses, K, Fh, p_hat, R_hat):
        """`_reduced` without hinges through `flexmb.ksd.reduced_jit.reduced_newton` (the numpy loop's
        calls otherwise)."""
        x, R, angle = poses.x, poses.R, poses.angle  # step 1's, fresh per solve: moved in place
        if not (x.flags.writeable and R.flags.writeable and angle.flags.writeable):  # the rest poses (kept)
            x, R, angle = x.copy(), R.copy(), angle.copy()
        fr = red.frames
        history, r = np.empty(self.max_iter), np.empty(6 * red.n_links)
        ok, it, _ = kernels().reduced_newton(x, R, angle, fr.a, fr.b, fr.s_a, fr.s_b, fr.P, K, Fh, p_hat, R_hat, red._cols,
                                   red.load_node, red.load_offset, red.load_force, red.load_moment, red.free,
                                   self.tol, self.max_iter, self.divergence, history, r)
        return LinkPoses(x, R, angle), bool(ok), history[:it].tolist(), r, None, None


@attrs.frozen(kw_only=True)
class KSDReduced(_KSD):
    __doc__ = "KSD steps 1-4 [``ksd-reduced``]: the reduced mechanism with EOB joints.\n" + _KSD.__doc__
    name: ClassVar[str] = "ksd-reduced"
    full: ClassVar[bool] = False
    #: the solution kind: linearised on the reduced mechanism (`flexmb.ksd.linearisation`)
    solution_type: ClassVar[type] = ReducedSolution


@attrs.frozen(kw_only=True)
class KSDFull(_KSD):
    __doc__ = "KSD steps 1-5 [``ksd-full``]: converges to the conventional method's solution.\n" + _KSD.__doc__
    name: ClassVar[str] = "ksd-full"
    full: ClassVar[bool] = True
