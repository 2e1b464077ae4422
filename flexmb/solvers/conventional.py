"""Conventional method: Newton-Raphson on the full model with automatic step control.

Dwarshuis et al. (2020), Appendix B and Fig. 18 (SPACAR's scheme): try the whole load/motion
step; after each iteration judge the residual: above the divergence threshold, halve the step
and start it again from its beginning; between the thresholds, re-linearise and iterate; below
the accuracy threshold, accept the step and take the next (growing it again after easy steps).
That is ``step_control="paper"``; the default adds continuation (`newton_steps`): each step
starts from the extrapolation of the converged path, a corrector that leaves it is rejected.
"""

from __future__ import annotations

import time
from typing import ClassVar

import attrs
import numpy as np
from scipy.sparse.linalg import splu

from .. import _validate as v
from ..errors import ConvergenceError
from ..fe.model import State
from ..linear import single_threaded
from ..problem import StaticProblem
from ..results import Solution

__all__ = ["Conventional", "newton_steps", "is_stable", "STEP_CONTROLS"]

STEP_CONTROLS = ("adaptive", "paper")


def is_stable(K) -> bool:
    """Positive definiteness of the symmetric part of ``K_ff`` from its inertia.

    At an equilibrium under dead loads K_ff is the Hessian of the potential energy restricted to
    the free DOFs: positive definite means a stable equilibrium under the prescribed motion. A
    sparse LU of the symmetric part with diagonal pivots only (SuperLU's symmetric mode) is an
    ``L D L^T`` factorisation of a symmetric permutation, so the signs of the pivots give the
    inertia (Sylvester's law); a dense Cholesky decides when SuperLU had to pivot off the diagonal.
    """
    n = K.shape[0]
    if n == 0:
        return True
    A = (0.5 * (K + K.T)).tocsc()
    try:
        lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:  # exactly singular: not positive definite
        return False
    if np.array_equal(lu.perm_r, lu.perm_c):
        return bool(np.all(lu.U.diagonal() > 0.0))
    try:
        np.linalg.cholesky(A.toarray())
    except np.linalg.LinAlgError:
        return False
    return True


# the options' validators live in `flexmb._validate`; these names stay for `flexmb.solvers.arclength`
positive_float, positive_int, unit_interval, relative_tolerance = (v.positive_option, v.count_option,
                                                                    v.unit_interval_option, v.relative_tolerance_option)


#: The adaptive step control's constants, chosen over the benchmark cases (cross flexure 5-75 deg
#: in 2D and 3D, four-bar 1-5 el./leaf, the 38 manipulator positions; BENCHMARKS.md "Step
#: control", one run): 2392 Newton iterations against 10 057 for Fig. 18 with the paper's tol,
#: every equilibrium within 2.0e-11 (node positions, relative). Extrapolation degree, measured on
#: ten of the cases (iterations): 1 (secant) 4995, 2: 1060, 3 (cubic): 704, 4: 601, 5: 535,
#: 7: 478, 9: 467, 11: 475, 15: 487. Path deviation bound 0.4, measured with the reference
#: stresses (benchmark cases / 25 four-bars of 3-8 el./leaf at d = 0.1-0.35 m): 0.3: 2396 / 552,
#: 0.4: 2392 / 539, 0.55: 2422 / 546, 0.7: 2416 / 534, 1.0: 2419 / 537, none: 2563 / 545; the
#: twin cross flexures of tests/test_continuation.py stay on the small-step path with any of
#: them (before the reference stresses only 0.4 kept them there: 0.7 jumped to 68.8 N m).
#: Reference stresses for at most 4 correctors: 3: 593, 4: 539, 5: 651, 6: 561, until the
#: residual falls below 0.1 of the force scale only: 573 (the 25 four-bars).
RTOL = 1e-9  # default relative tolerance of the last step (`StaticProblem.scaled_residual`)
#: a Newton correction this small (translations over the model length, rotations [rad]) means the
#: state is at the round-off floor: converged
CORRECTION_FLOOR = 1e-13
PATH_POINTS = 10  # converged states the predictor extrapolates from (degree 9)
GROW_BELOW = 4  # a step that converged in fewer iterations doubles the next
SMOOTH_PATH = 0.03  # ... as does one whose corrector moved less than this x the predicted step
SHRINK_ABOVE = 7  # a step that took more iterations shrinks the next to 0.6x
PATH_DEVIATION = 0.4  # a corrector farther from the predicted state than this x the step is rejected
RESTART_RATIO = 0.75  # ... and when halving did not bring it nearer than this x, the predictor restarts
#: the corrector's tangent takes the last converged state's stresses in its geometric part until the
#: scaled residual falls below this (the predicted state's own stresses are the predictor's error)
REFERENCE_STRESS_UNTIL = 0.1
REFERENCE_STRESS_ITERATIONS = 4  # ... and for at most this many correctors, in steps that move
#: prescribed DOFs (under loads alone the predicted state's axial forces are largely the load's:
#: cantilevers of 16 elements at F L^2 / EI = 2-20, 2D and 3D, took 498 iterations with them,
#: 343 without, 331 with Fig. 18; before this corrector the continuation failed on 6 of the 8)
INTERMEDIATE_RTOL = 1e-5
  # relative tolerance of the steps before the last (the last: rtol)
SAME_PATH = 1e-6  # ... unless it is closer than this (translations over the model length, rad): a step
# that predicts no motion (nothing applied) is never rejected for its round-off corrections


@attrs.frozen(kw_only=True)
class Conventional:
    """Full-model Newton-Raphson with step halving [``conventional``].

    Parameters
    ----------
    tol
        Absolute convergence threshold on the 2-norm of the free residual [N, N m] (the paper's
        is 5e-7); None (default): the relative test of ``rtol``.
    rtol
        Relative convergence threshold (used when ``tol`` is None): the free residual, moments
        divided by the model's length (bounding-box diagonal), over the problem's force scale
        (largest element end force or applied load, moments over the length), 1e-9, in (0, 1); or a Newton
        correction (predictor included) below 1e-13 (translations over the model length,
        rotations [rad]): the round-off floor, where the residual cannot fall further. Unit
        free: tested in SI, mm-N-MPa and um-uN-MPa (same answers to 1e-9, same iterations); a
        200-element cantilever under 1 N converges in 5 iterations (the absolute 5e-7 halved
        its step for 361 and gave up), a 10 000-element one at F L^2 / EI = 5 matches the
        elastica to 1e-6 L. The steps before the last converge to 1e-5 only (`INTERMEDIATE_RTOL`),
        so 1e-9 costs 1 % more iterations than 1e-8 on the benchmark cases (when every step
        converged to rtol, 6 %), and a free DOF's reaction of a one-step cross flexure at
        60 deg is 1e-13 N instead of 5e-7 N.
    max_iter
        Iterations allowed per step before the step is halved.
    divergence
        A step is halved when the residual grows by more than this factor between two
        iterations after the first (the paper's eps_max test), or becomes non-finite.
    min_step
        Smallest load-factor step before giving up (converged=False, the step reached reported).
    initial_step
        First load-factor step (1.0: try the whole motion at once, as Fig. 18).
    max_rotation
        A Newton correction that turns any node by more than this [rad] (the predictor excepted)
        cuts the step like a divergence: such a corrector is leaving for another equilibrium
        branch (a 2D cross flexure taken to 55 degrees in one step otherwise folds into a
        40x higher-energy state). ``None`` disables the check. The default 1 rad was measured:
        over 310 cross-flexure and 18 cantilever solves it removed all 4 wrong-branch results and
        cut the iterations from 3589 to 3463 (0.5 rad: 3830, 0.3 rad: 4122).
    raise_on_failure
        Raise `ConvergenceError` instead of returning ``converged=False``.
    step_control
        ``"adaptive"`` (default): continuation: every step after the first starts from the
        polynomial extrapolation (in the load factor) of the last ten converged states,
        rotations as spins on SO(3) continued along the path; in steps that move prescribed
        DOFs the corrector's tangent takes the last converged state's stresses in its geometric
        stiffness until the residual is below
        0.1 of the force scale, for at most 4 correctors (the predicted state's own stresses are
        the predictor's error: a
        straight-line predictor stretches turning leaves, and their spurious axial forces made
        the tangent indefinite and steered Newton onto buckled branches); a corrector that
        moves farther than 0.4x the predicted step from the predicted state (after a linear
        predictor: its translations) is rejected and the step halved (it is heading for another
        branch), and when halving does not bring it nearer the extrapolation restarts from the
        linear predictor; the steps before the last converge to 1e-5 of the force scale; the
        next step doubles after fewer than 4 iterations or a corrector that moved < 3 % of the
        step, shrinks to 0.6x after more than 7. ``"paper"``: Fig. 18 as published (linear predictor, halving, doubling after at most
        4 iterations). Measured over the benchmark cases (BENCHMARKS.md "Step control", against
        Fig. 18 with the paper's tol=5e-7): 2392 against 10 057 iterations; manipulator joint
        case 665 / 3894 (at -45 / 45 deg 47 / 46 against 551 / 494), location case 1457 / 5681,
        four-bar 1-5 el./leaf 90 / 153 (5 el./leaf: 18 / 37, one step), single cross flexures
        180 / 329 (5-75 deg, 2D and 3D, one step each); the same equilibria to 2.0e-11 (node
        positions, relative). Without the reference stresses (before): 3220 iterations,
        four-bar 147, cross flexures 497, and the twin cross flexures of
        tests/test_continuation.py took 85-118 iterations in small steps (2D at 0.5 rad failed);
        now one step of 8-13. Reusing the converged tangent for the first
        corrector from the predicted state was measured and dropped (3x the iterations on the
        manipulator: its stiff elements' forces change too much between the states), as were a
        contraction-rate rejection (+20 %), a line search on the corrector's energy (four-bar:
        44 -> 70), a second-order first predictor from a chord step (the chord grows as the
        step cubed on the four-bar: it sized the first step to 0.01) and the reference stresses
        for a fixed number of correctors (1-10: four-bar 18-52, erratic).
    """

    name: ClassVar[str] = "conventional"
    capability: ClassVar[str] = "fe_model"
    #: joint capabilities every joint must offer, and the mechanism dimensions handled
    needs: ClassVar[tuple[str, ...]] = ("fe_model",)
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    tol: float | None = attrs.field(default=None, validator=attrs.validators.optional(v.positive_option))
    rtol: float = attrs.field(default=RTOL, validator=v.relative_tolerance_option)
    max_iter: int = attrs.field(default=20, validator=v.count_option)
    divergence: float = attrs.field(default=1e3, validator=v.above_one_option)
    min_step: float = attrs.field(default=1e-5, validator=v.unit_interval_option)
    initial_step: float = attrs.field(default=1.0, validator=v.unit_interval_option)
    max_rotation: float | None = attrs.field(default=1.0, validator=attrs.validators.optional(v.positive_option))
    raise_on_failure: bool = attrs.field(default=False, validator=v.flag_option)
    step_control: str = attrs.field(default="adaptive", validator=v.choice_option(STEP_CONTROLS))

    def solve(self, compiled, *, state: State | None = None) -> Solution:
        """Equilibrium of ``compiled`` (a `Compiled` FE model), stepping from ``state`` (default undeformed)."""
        t0 = time.perf_counter()
        problem: StaticProblem = compiled.problem
        state = problem.model.initial_state() if state is None else state
        with single_threaded():
            out = newton_steps(problem, state, tol=self.tol, max_iter=self.max_iter, divergence=self.divergence,
                               min_step=self.min_step, initial_step=self.initial_step, max_rotation=self.max_rotation,
                               control=self.step_control, rtol=self.rtol)
        out["wall_time"]["total"] = time.perf_counter() - t0
        tolerance = out.pop("tolerance", self.tol if self.tol is not None else np.nan)
        sol = Solution(method=self.name, compiled=compiled, tolerance=tolerance, **out)
        if self.raise_on_failure and not sol.converged:
            raise ConvergenceError(sol.message, sol)
        return sol


def _translation(model, du: np.ndarray, length: float) -> float:
    """The largest nodal translation of an increment over ``length``."""
    return model.largest_motion(du)[0] / length


def _size(model, du: np.ndarray, length: float) -> float:
    """Size of an increment: the largest nodal translation over ``length`` or rotation [rad]."""
    translation, rotation = model.largest_motion(du)  # one compiled pass (FEModel.largest_motion)
    return max(translation / length, rotation)


def newton_steps(problem: StaticProblem, state: State, *, tol: float | None, max_iter: int, divergence: float,
                 min_step: float, initial_step: float, lam0: float = 0.0, max_rotation: float | None = 1.0,
                 first_geometric_stress=None, control: str = "adaptive", rtol: float = RTOL) -> dict:
    """Drive ``problem`` from ``state`` at load factor ``lam0`` to 1; returns Solution fields.

    ``control="paper"``: Fig. 18 (linear predictor from the converged tangent, halving, doubling
    after easy steps); ``"adaptive"``: each step after the first starts from the polynomial
    extrapolation of the last converged states (`FEModel.extrapolated_increment`), a corrector that leaves the
    predicted path (`PATH_DEVIATION`) is rejected and the step cut, and the step grows or shrinks
    with the iterations it took and how far its corrector moved.
    ``tol``: absolute threshold on the free residual's 2-norm [N, N m]; None: relative, the
    scaled residual (`StaticProblem.scaled_residual`) below ``rtol``, or a corrector below
    `CORRECTION_FLOOR` (the round-off floor: Newton cannot improve the state further).
    ``first_geometric_stress``: the geometric-stiffness stresses of the first tangent only
    (`StaticProblem.evaluate`), where ``state``'s own are known to be off (KSD step 5)."""
    adaptive = control == "adaptive"
    model = problem.model
    history: list[float] = []
    times = {"assemble": 0.0, "solve": 0.0}
    lam, dlam = lam0, min(initial_step, 1.0 - lam0)
    steps = rejected = 0
    free = problem.free
    path = [(lam, state)]  # converged (load factor, state), the predictor's support
    reference = None  # the generalised stresses of the last converged state (adaptive control)
    last_deviation = None  # the deviation ratio of the last step rejected for leaving the path
    length = problem.model_length

    def finish(converged: bool, message: str, r=None) -> dict:
        if r is None:  # reactions at the last converged state
            r = problem.evaluate(state, lam, tangent=False)[0]
        return dict(converged=converged, iterations=len(history), residual_history=np.array(history),
                    load_factor=lam, steps=steps, rejected_steps=rejected, wall_time=times, state=state,
                    residual=r, message=message)

    if dlam <= 0.0:  # nothing to do but check equilibrium
        r = problem.evaluate(state, 1.0, tangent=False)[0]
        res = float(np.linalg.norm(r[free]))
        history.append(res)
        ok = res < tol if tol is not None else problem.scaled_residual(r[free]) <= rtol
        return finish(ok, "already in equilibrium" if ok else f"residual {res:.3g} above the tolerance", r)
    while True:
        dlam = min(dlam, problem.max_load_step)
        target = lam + dlam
        du_p = problem.prescribed_increment(dlam, lam)
        extrapolate = adaptive and len(path) > 1
        if extrapolate:
            du_pred = model.extrapolated_increment(path, target)
            du_pred[problem.prescribed] = du_p
            trial = model.apply_increment(state, du_pred)
            predicted, moved = _size(model, du_pred, length), np.zeros(model.n_dofs)
        else:
            trial = state
        prev = first = np.inf
        floor = accepted = physical = False
        stalled = deviation = None
        moving = bool(np.any(du_p != 0.0))  # the reference stresses serve steps of prescribed motion only
        accept_rtol = rtol if not adaptive or target >= 1.0 - 1e-14 else max(rtol, INTERMEDIATE_RTOL)
        for it in range(1 if extrapolate else 0, max_iter + 1):
            t = time.perf_counter()
            geometric = first_geometric_stress
            if geometric is None and adaptive and moving and it > 0 and not physical and reference is not None:
                geometric = reference  # held: the stresses themselves, not the iterate's
            r, Kff, Kfp, sigma = problem.evaluate(trial, target, tangent=True, geometric_stress=geometric)
            first_geometric_stress = None
            if reference is None:  # the start state's: its own, or those given for its first tangent
                reference = sigma if geometric is None else (geometric(sigma.copy()) if callable(geometric)
                                                             else np.array(geometric))
            times["assemble"] += time.perf_counter() - t
            rf = r[free]
            if it == 0:
                rhs = -(rf + Kfp @ du_p)
            else:
                res = float(np.linalg.norm(rf))
                history.append(res)
                if not np.isfinite(res) or (it > 1 and res > divergence * prev):
                    break
                scaled = problem.scaled_residual(rf) if tol is None else np.nan
                if (res < tol) if tol is not None else (floor or scaled <= accept_rtol):
                    accepted = True
                    break
                physical = physical or scaled < REFERENCE_STRESS_UNTIL or it >= REFERENCE_STRESS_ITERATIONS
                if tol is not None and it > 2 and res > 0.5 * prev and res < 1e-10 * first:
                    stalled = res  # Newton stopped gaining: roundoff floor of this model
                    break
                if it == 1:
                    first = res
                prev = res
                rhs = -rf
                if it == max_iter:
                    break
            t = time.perf_counter()
            try:
                du_f = problem.solve_linear(Kff, rhs)
            except np.linalg.LinAlgError:
                break
            finally:
                times["solve"] += time.perf_counter() - t
            if not np.all(np.isfinite(du_f)):
                break
            du = problem.full_increment(du_f, du_p if it == 0 else np.zeros_like(du_p))
            floor = _size(model, du, length) <= CORRECTION_FLOOR  # the predictor too: a step with nothing to do
            if it > 0 and max_rotation is not None and model.largest_motion(du)[1] > max_rotation:
                break  # a corrector that turns a node this far has left the branch: cut the step
            if adaptive:
                if it == 0:
                    predicted, moved = _size(model, du, length), np.zeros(model.n_dofs)
                else:
                    moved += du
                    # after a linear predictor, its nodes' rotations are corrected a lot along
                    # rotating leaves (the tangent's straight line stretches them): translations only
                    away = (_size if extrapolate else _translation)(model, moved, length)
                    if away > max(PATH_DEVIATION * predicted, SAME_PATH):
                        deviation = away / predicted
                        break  # the corrector leaves the predicted path (another branch): cut the step
            trial = model.apply_increment(trial, du)
        if accepted:
            state, lam, reference, last_deviation = trial, target, sigma, None
            path = (path + [(lam, state)])[-PATH_POINTS:]
            steps += 1
            if lam >= 1.0 - 1e-14:
                lam = 1.0
                broken = problem.broken_constraints(state)  # "" without hinges
                if broken:
                    return finish(False, f"not converged: {broken}", r)
                if tol is not None:
                    out = finish(True, f"converged: residual {history[-1]:.3g} < tol {tol:.3g} in {steps} steps", r)
                    out["tolerance"] = tol
                else:
                    scaled = problem.scaled_residual(r[free])
                    why = f"the round-off floor: last correction below {CORRECTION_FLOOR:g}" if floor else f"rtol {rtol:g}"
                    out = finish(True, f"converged: residual {history[-1]:.3g}, {scaled:.2g} of the force scale "
                                       f"{problem.force_scale:.3g} ({why}) in {steps} steps", r)
                    out["tolerance"] = max(rtol * problem.force_scale, history[-1])
                stable = problem.positive_definite(Kff)  # from the solver's own analysis, None: cannot tell
                out["stable"] = is_stable(problem.reduced_tangent(Kff)) if stable is None else stable
                if out["stable"] is False:
                    out["message"] += ("; the equilibrium is UNSTABLE (tangent not positive definite): another "
                                       "branch may be the physical one, try initial_step < 1")
                return out
            if adaptive:
                ratio = _size(model, moved, length) / predicted if predicted > 0 else 0.0
                grow = 2.0 if (it < GROW_BELOW or ratio < SMOOTH_PATH) else (0.6 if it > SHRINK_ABOVE else 1.0)
            else:
                grow = 2.0 if it <= 4 else 1.0
            dlam = min(grow * dlam, 1.0 - lam)
        elif stalled is not None:
            return finish(False, f"not converged: the residual stalls at {stalled:.3g}, the roundoff floor of this "
                                 f"model, above tol={tol:.3g}; raise tol or leave it None (relative; load factor "
                                 f"reached {lam:.6g})")
        else:
            rejected += 1
            dlam *= 0.5
            if extrapolate and deviation is not None and last_deviation is not None \
                    and deviation > RESTART_RATIO * last_deviation:
                path = path[-1:]  # halving did not bring the corrector nearer: the extrapolation is off
                deviation = None
            last_deviation = deviation if extrapolate else None
            if dlam < min_step:
                return finish(False, f"not converged: step halved below min_step={min_step:g} at load factor "
                                     f"{lam:.6g} (the last converged step); the residual history shows the failed "
                                     "iterations" + problem.roundoff_hint())

