"""Conventional method: Newton-Raphson on the full model with automatic step control.

Dwarshuis et al. (2020), Appendix B and Fig. 18 (SPACAR's scheme): try the whole load/motion
step; after each iteration judge the residual: above the divergence threshold, halve the step
and start it again from its beginning; between the thresholds, re-linearise and iterate; below
the accuracy threshold, accept the step and take the next (growing it again after easy steps).
That is ``step_control="paper"``; the default adds continuation (`newton_steps`): each step
starts from the extrapolation of the converged path (with its tangent at the last converged
state), a corrector that leaves it is rejected, and the first step is as long as its linear
predictor allows without stretching the elements.
"""

from __future__ import annotations

from typing import ClassVar

import attrs
import numpy as np
from scipy.sparse.linalg import splu

from .. import _validate as v
from ..errors import ConvergenceError
from ..fe.model import State
from .._timing import Stopwatch
from ..linear import single_threaded
from ..problem import StaticProblem
from ..results import Solution

__all__ = ["Conventional", "newton_steps", "is_stable", "STEP_CONTROLS", "PaperControl", "AdaptiveControl",
           "Corrector", "Report"]

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
#: a linear predictor (the first step's) that changes an element's chord by more than this fraction
#: of its length is scaled back before any iteration, in steps of prescribed motion (its straight
#: lines stretch turning leaves by theta^2 / 2; the step to ~sqrt(this / stretch), 0.1-0.7x). With
#: the tangent predictor (Newton iterations; four-bar d = 0.3 m at 5/10/20 el./leaf; single cross
#: flexures 3 / 6 el./leaf, 5-75 deg every 10, 2D and 3D; manipulator joint and location at
#: +-15/45 deg): 0.03: 21/21/22, 142 / 180, 334; 0.1: 23/22/24, 120 / 152, 338; 0.3: 19/23/25,
#: 102 / 134, 388; none: 18/32/28, 96 / 108, 392; before both (neither): 18/47/43, 96 / 109, 549.
PREDICTOR_STRETCH = 0.1
RATE_STEP = 1e-4  # the load-factor difference of the path rate's prescribed motion (central) and loads
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
        polynomial extrapolation (in the load factor) of the last ten converged states and the
        path's tangent at the last (Hermite: `StaticProblem.path_rate`, one solve with the last
        tangent per step), rotations as spins on SO(3) continued along the path; in steps that
        move prescribed DOFs, a linear predictor (the first step's) that changes an element's
        chord by more than 10 % of its length is scaled back before any iteration
        (`PREDICTOR_STRETCH`); in steps that move prescribed
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
        for a fixed number of correctors (1-10: four-bar 18-52, erratic). The tangent predictor
        and the first step's stretch bound (benchmarks/bench_meshes.py): four-bar at
        5/10/20/40 el./leaf 23/22/24/24 iterations (before 18/47/43/43: each step started from
        a residual of 1e5-2e7 N, the first one was cut and the secant extrapolation rejected),
        manipulator joint case at -45/45 deg 29/34 (47/46), location case 89/89 (148/123) on a
        straight end-point line (joint 3 to 56 deg and back: steps of ~0.07-0.14), 45/39 along the
        kinematic path `flexmb.models.manipulator` prescribes (`Mechanism.prescribe`'s ``path``,
        the same equilibrium); single cross
        flexures turned by more than ~25 deg now take 2-3 steps (3 el./leaf, 5-75 deg: 120
        iterations against 96).
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
        watch = Stopwatch()
        problem: StaticProblem = compiled.problem
        state = problem.model.initial_state() if state is None else state
        with single_threaded():
            out = newton_steps(problem, state, tol=self.tol, max_iter=self.max_iter, divergence=self.divergence,
                               min_step=self.min_step, initial_step=self.initial_step, max_rotation=self.max_rotation,
                               control=self.step_control, rtol=self.rtol)
        out["wall_time"]["total"] = watch.total()
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
    translation, rotation = model.largest_motion(du)  # one numba pass (FEModel.largest_motion)
    return max(translation / length, rotation)


def newton_steps(problem: StaticProblem, state: State, *, tol: float | None, max_iter: int, divergence: float,
                 min_step: float, initial_step: float, lam0: float = 0.0, max_rotation: float | None = 1.0,
                 first_geometric_stress=None, control: str = "adaptive", rtol: float = RTOL) -> dict:
    """Drive ``problem`` from ``state`` at load factor ``lam0`` to 1; returns Solution fields.

    Load steps in a loop: the step control (`PaperControl` for ``control="paper"``, Fig. 18:
    linear predictor from the converged tangent, halving, doubling after easy steps, the prescribed
    motion on straight lines, `StaticProblem.straight`;
    `AdaptiveControl` for ``"adaptive"``: each step after the first starts from the polynomial
    extrapolation of the last converged states and the path's tangent at the last,
    `FEModel.extrapolated_increment`, a first step whose linear predictor stretches the elements
    is shortened before any iteration (`AdaptiveControl.predictor_cut`), a corrector that
    leaves the predicted path, `PATH_DEVIATION`, is rejected and the step cut, and the step grows
    or shrinks with the iterations it took and how far its corrector moved) predicts each step,
    `Corrector` iterates it, and `Report` says how the run ended.
    ``tol``: absolute threshold on the free residual's 2-norm [N, N m]; None: relative, the
    scaled residual (`StaticProblem.scaled_residual`) below ``rtol``, or a corrector below
    `CORRECTION_FLOOR` (the round-off floor: Newton cannot improve the state further).
    ``first_geometric_stress``: the geometric-stiffness stresses of the first tangent only
    (`StaticProblem.evaluate`), where ``state``'s own are known to be off (KSD step 5)."""
    if control != "adaptive":  # Fig. 18 as published: the prescribed motion on straight lines
        problem = problem.straight() if hasattr(problem, "straight") else problem
    steps = (AdaptiveControl if control == "adaptive" else PaperControl)(problem, state, lam0)
    report = Report(problem, tol, rtol)
    corrector = Corrector(problem, tol=tol, rtol=rtol, max_iter=max_iter, divergence=divergence,
                          max_rotation=max_rotation, history=report.history, times=report.watch,
                          first_geometric_stress=first_geometric_stress)
    dlam = min(initial_step, 1.0 - lam0)
    if dlam <= 0.0:  # nothing to do but check equilibrium
        return report.at_rest(state, lam0)
    while True:
        dlam = min(dlam, problem.max_load_step)
        step = corrector.run(steps, dlam, cut=dlam > min_step)
        if step.accepted:
            steps.accept(step)
            report.steps += 1
            if steps.lam >= 1.0 - 1e-14:
                steps.lam = 1.0
                return report.converged(steps.state, step)
            dlam = min(steps.growth(step) * dlam, 1.0 - steps.lam)
        elif step.stalled is not None:
            return report.stalled(steps.state, steps.lam, step.stalled)
        else:
            if step.cut is not None:  # the linear predictor strained the elements: shorter (not below
                dlam = max(dlam * step.cut, min_step)  # min_step: that one is iterated), not rejected
            else:
                report.rejected += 1
                dlam *= 0.5
                steps.reject(step)
            if dlam < min_step:
                return report.failed(steps.state, steps.lam, min_step)


class PaperControl:
    """Dwarshuis et al. (2020) Fig. 18's step control: the linear predictor (the converged
    tangent's first correction from the last converged state), halving a failed step, doubling
    after a step of at most 4 iterations. Holds the run's converged state and load factor."""

    adaptive = False

    def __init__(self, problem: StaticProblem, state: State, lam: float):
        self.problem, self.model, self.state, self.lam = problem, problem.model, state, lam

    def predict(self, target: float, du_p: np.ndarray):
        """The corrector's start for load factor ``target`` (prescribed increment ``du_p``) and
        whether it is extrapolated (then its first iteration is a correction, not a predictor)."""
        return self.state, False

    def accept_rtol(self, rtol: float, target: float) -> float:
        """The relative tolerance a step to ``target`` is accepted at: ``rtol`` for every step."""
        return rtol

    def geometric_stress(self, it: int, moving: bool, physical: bool):
        """The stresses of the tangent's geometric part at iteration ``it`` (None: the iterate's own)."""
        return None

    def evaluated(self, sigma, geometric) -> None:
        """The first evaluation's stresses, where the control keeps them."""

    def left_path(self, it: int, du: np.ndarray, extrapolated: bool):
        """None, or how far (over the predicted step) the corrector has left the predicted path."""
        return None

    def predictor_cut(self, predicted: State):
        """None, or the factor to scale a step whose linear predictor gave ``predicted`` by."""
        return None

    def accept(self, step) -> None:
        """``step`` converged: its state and load factor are the run's."""
        self.state, self.lam = step.trial, step.target

    def growth(self, step) -> float:
        """The next step's size over this one's after ``step`` was accepted."""
        return 2.0 if step.it <= 4 else 1.0

    def reject(self, step) -> None:
        """Bookkeeping after ``step`` was rejected (its load step halved)."""


class AdaptiveControl(PaperControl):
    """The continuation (``step_control="adaptive"``, `Conventional`'s notes): each step after the
    first starts from the extrapolation of the last `PATH_POINTS` converged states and the path's
    tangent at the last (`StaticProblem.path_rate`); a linear predictor that stretches an element by
    more than `PREDICTOR_STRETCH` shortens its step before any iteration; in steps that
    move prescribed DOFs the corrector's tangent takes the last converged state's stresses for its
    geometric part (`REFERENCE_STRESS_UNTIL`, `REFERENCE_STRESS_ITERATIONS`); a corrector farther
    than `PATH_DEVIATION` x the predicted step from the predicted state is rejected (and when
    halving does not bring it `RESTART_RATIO` nearer, the extrapolation restarts); the steps before
    the last converge to `INTERMEDIATE_RTOL`; the next step grows or shrinks with the iterations."""

    adaptive = True

    def __init__(self, problem: StaticProblem, state: State, lam: float):
        super().__init__(problem, state, lam)
        self.path = [(lam, state)]  # converged (load factor, state), the predictor's support
        self.reference = None  # the generalised stresses of the last converged state
        self.last_deviation = None  # the deviation ratio of the last step rejected for leaving the path
        self.length = problem.model_length
        self.predicted = self.moved = None
        self.rate = None  # the path's derivative at the last converged state (`StaticProblem.path_rate`)
        #: the tangent predictor and the stretch bound serve prescribed motion (under loads alone
        #: neither helped: cantilevers 12 -> 12-32 iterations, an axially pulled rod lost its path)
        self.moving = bool(np.any(problem.prescribed_increment(RATE_STEP, lam) != 0.0))

    def predict(self, target: float, du_p: np.ndarray):
        model = self.model
        if len(self.path) <= 1:
            return self.state, False
        du_pred = model.extrapolated_increment(self.path, target, self.rate)
        du_pred[self.problem.prescribed] = du_p
        self.predicted, self.moved = _size(model, du_pred, self.length), np.zeros(model.n_dofs)
        return model.apply_increment(self.state, du_pred), True

    def accept_rtol(self, rtol: float, target: float) -> float:
        """``rtol`` for the last step, `INTERMEDIATE_RTOL` (when looser) before it."""
        return rtol if target >= 1.0 - 1e-14 else max(rtol, INTERMEDIATE_RTOL)

    def geometric_stress(self, it: int, moving: bool, physical: bool):
        if moving and it > 0 and not physical and self.reference is not None:
            return self.reference  # held: the stresses themselves, not the iterate's
        return None

    def evaluated(self, sigma, geometric) -> None:
        if self.reference is None:  # the start state's: its own, or those given for its first tangent
            self.reference = sigma if geometric is None else (geometric(sigma.copy()) if callable(geometric)
                                                              else np.array(geometric))

    def left_path(self, it: int, du: np.ndarray, extrapolated: bool):
        model = self.model
        if it == 0:
            self.predicted, self.moved = _size(model, du, self.length), np.zeros(model.n_dofs)
            return None
        self.moved += du
        # after a linear predictor, its nodes' rotations are corrected a lot along rotating
        # leaves (the tangent's straight line stretches them): translations only
        away = (_size if extrapolated else _translation)(model, self.moved, self.length)
        if away > max(PATH_DEVIATION * self.predicted, SAME_PATH):
            return away / self.predicted  # the corrector leaves the predicted path (another branch)
        return None

    def predictor_cut(self, predicted: State):
        """Scale a linear predictor that stretches an element by more than `PREDICTOR_STRETCH` back
        to that stretch (it grows as the step squared along turning elements)."""
        if not self.moving:
            return None
        stretch = self.model.largest_stretch(self.state, predicted)
        if not stretch > PREDICTOR_STRETCH:  # NaN: the corrector's evaluation rejects it
            return None
        return min(0.7, max(0.1, float(np.sqrt(PREDICTOR_STRETCH / stretch))))

    def accept(self, step) -> None:
        """As `PaperControl.accept`; its stresses become the reference, its state joins the path."""
        super().accept(step)
        self.reference, self.last_deviation = step.sigma, None
        self.rate = self._rate(step)
        self.path = (self.path + [(self.lam, self.state)])[-PATH_POINTS:]

    def _rate(self, step):
        """The path's derivative at ``step``'s converged state from its last tangent (None where
        that is singular, or without prescribed motion): the tangent predictor's slope
        (`StaticProblem.path_rate`)."""
        if not self.moving:
            return None
        with np.errstate(all="ignore"):
            try:
                rate = self.problem.path_rate(step.trial, step.target, step.r, step.Kff, step.Kfp, RATE_STEP)
            except np.linalg.LinAlgError:
                return None
        return rate if np.all(np.isfinite(rate)) else None

    def growth(self, step) -> float:
        ratio = _size(self.model, self.moved, self.length) / self.predicted if self.predicted > 0 else 0.0
        return 2.0 if (step.it < GROW_BELOW or ratio < SMOOTH_PATH) else (0.6 if step.it > SHRINK_ABOVE else 1.0)

    def reject(self, step) -> None:
        deviation = step.deviation
        if step.extrapolated and deviation is not None and self.last_deviation is not None \
                and deviation > RESTART_RATIO * self.last_deviation:
            self.path = self.path[-1:]  # halving did not bring the corrector nearer: the extrapolation is off
            deviation = None
        self.last_deviation = deviation if step.extrapolated else None


@attrs.define
class Step:
    """What one load step's corrector left (`Corrector.run`)."""

    target: float
    extrapolated: bool
    trial: State = None
    accepted: bool = False
    stalled: float | None = None  # the residual where Newton stopped gaining (absolute tol only)
    deviation: float | None = None  # how far the corrector left the predicted path (adaptive)
    it: int = 0  # the last iteration
    cut: float | None = None  # the step's scale the control asked for before iterating (its linear predictor)
    floor: bool = False  # the last correction was at the round-off floor
    r: np.ndarray | None = None
    Kff: object = None
    Kfp: object = None
    sigma: np.ndarray | None = None


class Corrector:
    """Newton iterations of one load step from the step control's prediction: accepted at the
    tolerance (``tol`` absolute, else ``rtol`` relative or the round-off floor), given up on a
    residual that grows by ``divergence`` after the first correction or is not finite, on a
    singular tangent, at ``max_iter``, on a correction that turns a node by more than
    ``max_rotation`` [rad] (the predictor excepted: leaving for another branch) or, as the
    control decides, on a corrector that leaves the predicted path. Times assembly and solves."""

    def __init__(self, problem: StaticProblem, *, tol, rtol, max_iter, divergence, max_rotation, history, times,
                 first_geometric_stress=None):
        self.problem, self.model = problem, problem.model
        self.tol, self.rtol, self.max_iter, self.divergence = tol, rtol, max_iter, divergence
        self.max_rotation, self.history, self.watch = max_rotation, history, times
        self.first_geometric_stress = first_geometric_stress  # the first tangent's only
        self.length = problem.model_length

    def run(self, control: PaperControl, dlam: float, cut: bool = True) -> Step:
        """One load step of size ``dlam`` from the control's converged state, predicted by it
        (``cut``: the control may shorten it before iterating, `PaperControl.predictor_cut`)."""
        problem = self.problem
        target = control.lam + dlam
        du_p = problem.prescribed_increment(dlam, control.lam)
        trial, extrapolated = control.predict(target, du_p)
        step = Step(target, extrapolated, trial)
        prev = first = np.inf
        physical = False
        moving = bool(np.any(du_p != 0.0))  # the reference stresses serve steps of prescribed motion only
        accept_rtol = control.accept_rtol(self.rtol, target)
        for it in range(1 if extrapolated else 0, self.max_iter + 1):
            step.it = it
            Kfp = self._evaluate(step, control, moving, physical)
            rf = step.r[problem.free]
            if it == 0:
                rhs = -(rf + Kfp @ du_p)
            else:
                res = float(np.linalg.norm(rf))
                self.history.append(res)
                if not np.isfinite(res) or (it > 1 and res > self.divergence * prev):
                    break
                scaled = problem.scaled_residual(rf) if self.tol is None else np.nan
                if (res < self.tol) if self.tol is not None else (step.floor or scaled <= accept_rtol):
                    step.accepted = True
                    break
                physical = physical or scaled < REFERENCE_STRESS_UNTIL or it >= REFERENCE_STRESS_ITERATIONS
                if self.tol is not None and it > 2 and res > 0.5 * prev and res < 1e-10 * first:
                    step.stalled = res  # Newton stopped gaining: roundoff floor of this model
                    break
                if it == 1:
                    first = res
                prev = res
                rhs = -rf
                if it == self.max_iter:
                    break
            du = self._correction(step, rhs, du_p if it == 0 else np.zeros_like(du_p))
            if du is None:
                break
            if self._advance(step, control, it, du, cut):
                break
        return step

    def _advance(self, step: Step, control: PaperControl, it: int, du: np.ndarray, cut: bool) -> bool:
        """Apply the correction ``du`` of iteration ``it`` to the step's iterate, or stop the step
        (True): a corrector that turns a node by more than ``max_rotation`` has left the branch,
        one the control finds off the predicted path is heading for another (both cut the step);
        a linear predictor the control finds straining the elements (`predictor_cut`) asks for a
        shorter step before any iteration (when ``cut``)."""
        if it > 0 and self.max_rotation is not None and self.model.largest_motion(du)[1] > self.max_rotation:
            return True
        step.deviation = control.left_path(it, du, step.extrapolated)
        if step.deviation is not None:
            return True
        step.trial = self.model.apply_increment(step.trial, du)
        step.cut = control.predictor_cut(step.trial) if it == 0 and cut else None
        return step.cut is not None

    def _evaluate(self, step: Step, control: PaperControl, moving: bool, physical: bool):
        """Residual, tangent and stresses at the step's iterate (on ``step``; returns the
        free-prescribed tangent block), the geometric stiffness from the stresses the control
        holds or, the first time only, from ``first_geometric_stress``."""
        with self.watch.adding("assemble"):
            geometric = self.first_geometric_stress
            if geometric is None:
                geometric = control.geometric_stress(step.it, moving, physical)
            step.r, step.Kff, step.Kfp, step.sigma = self.problem.evaluate(step.trial, step.target, tangent=True,
                                                                           geometric_stress=geometric)
            self.first_geometric_stress = None
            control.evaluated(step.sigma, geometric)
        return step.Kfp

    def _correction(self, step: Step, rhs: np.ndarray, du_p: np.ndarray):
        """The Newton correction on all DOFs (prescribed: ``du_p``), None where the tangent is
        singular or the solve not finite; marks the round-off floor on ``step``."""
        problem = self.problem
        with self.watch.adding("solve"):
            try:
                du_f = problem.solve_linear(step.Kff, rhs)
            except np.linalg.LinAlgError:
                return None
        if not np.all(np.isfinite(du_f)):
            return None
        du = problem.full_increment(du_f, du_p)
        step.floor = _size(self.model, du, self.length) <= CORRECTION_FLOOR  # the predictor too: nothing to do
        return du


class Report:
    """The end of a `newton_steps` run as `flexmb.Solution` fields: converged or why not, the
    residual history, steps taken and rejected, the wall time per phase, the stability of a
    converged equilibrium."""

    def __init__(self, problem: StaticProblem, tol, rtol):
        self.problem, self.tol, self.rtol = problem, tol, rtol
        self.history: list[float] = []
        self.watch = Stopwatch({"assemble": 0.0, "solve": 0.0})
        self.steps = self.rejected = 0

    def _fields(self, converged: bool, message: str, state: State, lam: float, r=None) -> dict:
        if r is None:  # reactions at the last converged state
            r = self.problem.evaluate(state, lam, tangent=False)[0]
        return dict(converged=converged, iterations=len(self.history), residual_history=np.array(self.history),
                    load_factor=lam, steps=self.steps, rejected_steps=self.rejected, wall_time=self.watch.times,
                    state=state, residual=r, message=message)

    def at_rest(self, state: State, lam: float) -> dict:
        """Nothing to step (``lam``, the start, is already 1): whether ``state`` is in equilibrium
        at load factor 1."""
        problem, tol = self.problem, self.tol
        r = problem.evaluate(state, 1.0, tangent=False)[0]
        res = float(np.linalg.norm(r[problem.free]))
        self.history.append(res)
        ok = res < tol if tol is not None else problem.scaled_residual(r[problem.free]) <= self.rtol
        return self._fields(ok, "already in equilibrium" if ok else f"residual {res:.3g} above the tolerance",
                            state, lam, r)

    def converged(self, state: State, step: Step) -> dict:
        """Load factor 1 reached: converged (unless a hinge's constraint broke), with the
        tolerance met and the equilibrium's stability from the last tangent."""
        problem, tol, rtol, r, history = self.problem, self.tol, self.rtol, step.r, self.history
        broken = problem.broken_constraints(state)  # "" without hinges
        if broken:
            return self._fields(False, f"not converged: {broken}", state, 1.0, r)
        if tol is not None:
            out = self._fields(True, f"converged: residual {history[-1]:.3g} < tol {tol:.3g} in {self.steps} steps",
                               state, 1.0, r)
            out["tolerance"] = tol
        else:
            scaled = problem.scaled_residual(r[problem.free])
            why = f"the round-off floor: last correction below {CORRECTION_FLOOR:g}" if step.floor else f"rtol {rtol:g}"
            out = self._fields(True, f"converged: residual {history[-1]:.3g}, {scaled:.2g} of the force scale "
                                     f"{problem.force_scale:.3g} ({why}) in {self.steps} steps", state, 1.0, r)
            out["tolerance"] = max(rtol * problem.force_scale, history[-1])
        stable = problem.positive_definite(step.Kff)  # from the solver's own analysis, None: cannot tell
        out["stable"] = is_stable(problem.reduced_tangent(step.Kff)) if stable is None else stable
        if out["stable"] is False:
            out["message"] += ("; the equilibrium is UNSTABLE (tangent not positive definite): another "
                               "branch may be the physical one, try initial_step < 1")
        return out

    def stalled(self, state: State, lam: float, res: float) -> dict:
        """Not converged: the residual ``res`` stopped falling above the absolute ``tol``."""
        return self._fields(False, f"not converged: the residual stalls at {res:.3g}, the roundoff floor of this "
                                   f"model, above tol={self.tol:.3g}; raise tol or leave it None (relative; load "
                                   f"factor reached {lam:.6g})", state, lam)

    def failed(self, state: State, lam: float, min_step: float) -> dict:
        """Not converged: the step was halved below ``min_step``."""
        return self._fields(False, f"not converged: step halved below min_step={min_step:g} at load factor "
                                   f"{lam:.6g} (the last converged step); the residual history shows the failed "
                                   "iterations" + self.problem.roundoff_hint(), state, lam)
