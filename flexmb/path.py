"""`trace`: the equilibrium path of a mechanism's loads and prescribed motions under a load factor.

Arc-length continuation (`flexmb.solvers.arclength`) through limit points, snap-through and
snap-back, with the stability of every point, the limit and bifurcation points located on the
way (each once, with its multiplicity and critical modes) and, at a bifurcation, the switch onto
the branch the device follows (`flexmb.solvers.branching`); the result is an `EquilibriumPath`, a sequence of
`Solution` s like a `SweepResult`, whose `EquilibriumPath.snap` is the first instability.
"""

from __future__ import annotations

import functools
import time
import warnings

import attrs
import numpy as np

from . import _validate as v
from ._warnings import renamed
from . import accuracy
from .errors import ModelError, ParameterError, UnsupportedStrategyError
from .linear import single_threaded
from .plausibility import check
from .results import Solution
from .solvers.arclength import ArcLength
from .solvers.branching import BRANCHES
from .sweeps import SweepResult
from .table import Table

__all__ = ["trace", "EquilibriumPath", "Critical"]

#: Largest first arc-length step of `trace` (its load-factor increment): the constraint squares
#: the step, and 1e150**2 = 1e300 is near the float range's end (1.8e308); a first step of
#: max_load_factor=1e300 / 20 overflowed there and stopped "at load factor 0" without saying why.
MAX_FIRST_STEP = 1e150

#: The default first step moves no node by more than this fraction of the mechanism's size (nor
#: turns one by more than this [rad]) in the linear response: a 1e12 N reference load on a truss
#: whose limit load is 4e3 N starts at a load factor ~1e-10 instead of 0.05 (5e10 N, where no
#: step converged).
FIRST_MOTION = 0.05


@attrs.frozen(eq=False)
class Critical:
    """A critical point of an `EquilibriumPath`: ``kind`` (``"limit"``: the load factor's extremum;
    ``"bifurcation"``: the stability changes without one), its ``load_factor`` and `Solution`,
    ``arc_length`` from the path's start (the dimensionless metric of `trace`), its
    ``multiplicity`` (the number of eigenvalues of the tangent that vanish there: 2 for the two
    leaves of a symmetric device), whether the path ``switched`` there onto another branch,
    whether it is an ``asymmetric`` bifurcation (its branches leave on both sides of its load
    factor: the critical state is itself unstable, Koiter 1945; known where `trace` sought the
    branches, ``branch != "primary"``), and the critical `modes`."""

    kind: str
    load_factor: float
    solution: Solution = attrs.field(repr=False)
    arc_length: float
    multiplicity: int = 1
    switched: bool = False
    _modes: np.ndarray = attrs.field(default=None, repr=False, alias="modes")
    asymmetric: bool = False
    _tracer: object = attrs.field(default=None, repr=False, alias="tracer")  # the path it was located on

    @property
    def discretisation(self):
        """The estimated discretisation error of the load factor, reactions and displacements here
        (a `flexmb.accuracy.Estimate`, computed on first use: the same critical point on the
        companion mesh, `flexmb.accuracy.critical_estimate`; a `flexmb.DiscretisationWarning`
        when above the accuracy target); None when the estimates are off."""
        return None if accuracy.target() is None else accuracy.critical_estimate(self, self._tracer)

    def __reduce__(self):  # pickled without the path it was located on
        return functools.partial(Critical, modes=self._modes, asymmetric=self.asymmetric), (
            self.kind, self.load_factor, self.solution, self.arc_length, self.multiplicity, self.switched)

    @property
    def modes(self) -> np.ndarray:
        """The critical modes (multiplicity, n_dofs): null vectors of the tangent as increments of
        every finite-element DOF (`Solution.state` order), unit length in the path's metric (a copy)."""
        return np.zeros((0, 0)) if self._modes is None else self._modes.copy()


class EquilibriumPath(SweepResult):
    """The points of a `trace` in path order (a sequence of `Solution` s, the start at load
    factor 0 first), with ``load_factor`` (n,), ``stable`` (n,) bool, ``negative_eigenvalues``
    (n,) int, ``arc_length`` (n,), the located `critical` points, `snap`, ``message`` and
    ``stopped_by`` (``"max_load_factor"``, ``"steps"``, ``"stop"``, ``"failure"`` or
    ``"interrupted"``: Ctrl-C, the points reached kept). `table` (and ``to_csv``) adds the
    columns ``stable``, ``negative_eigenvalues`` and ``arc_length``; the points go to
    `flexmb.export.write_series` and their arrays to `flexmb.plot.plot_force_curve` as they are.
    """

    def __init__(self, solutions, points, critical, message: str, stopped_by: str, tracer=None):
        super().__init__(solutions, np.array([p.lam for p in points]), "load_factor")
        self._negative = np.array([p.negative for p in points], dtype=np.int64)
        self._arc = np.array([p.arc for p in points])
        self.critical = list(critical)
        self.message, self.stopped_by = message, stopped_by
        self._tracer = tracer  # what `crossings` steps with (None: a path that cannot locate)

    @property
    def load_factor(self) -> np.ndarray:
        """Each point's load factor, (n,) (a copy)."""
        return self._values.copy()

    @property
    def negative_eigenvalues(self) -> np.ndarray:
        """Each point's count of negative eigenvalues of the free tangent, (n,) int (a copy)."""
        return self._negative.copy()

    @property
    def stable(self) -> np.ndarray:
        """Whether each point is stable (no negative eigenvalue), (n,) bool (a new array)."""
        return self._negative == 0

    @property
    def arc_length(self) -> np.ndarray:
        """Each point's arc length from the start, (n,) (a copy)."""
        return self._arc.copy()

    @property
    def snap(self) -> Critical | None:
        """The first instability of the path as traced, for its control (what the load factor
        scales): the first critical point that a stable point reaches and past which the path
        (on the branch it follows) is unstable, or which is an asymmetric bifurcation (the
        critical state itself unstable: a perfect Roorda frame's, whose stable branch rises on
        one side while the other falls; its imperfect twin snaps below it, Koiter's 1/2-power
        law); None if the path stays stable. Under load control the device snaps there (a limit
        point, or a bifurcation with no stable branch); under a prescribed motion it follows a
        stable branch where one exists and snaps only where none does (a snap-back)."""
        for c in self.critical:
            before = np.flatnonzero(self._arc < c.arc_length)
            after = np.flatnonzero(self._arc > c.arc_length)
            if len(before) and self._negative[before[-1]] == 0 and (
                    c.asymmetric or (len(after) and self._negative[after[0]] > 0)):
                return c
        return None

    def crossings(self, response, value: float = 0.0) -> list:
        """The points of the path where ``response(solution)`` (a float: a reaction component, a
        displacement) equals ``value``, located between the traced points where it changes sign
        (regula falsi on the arc length, each trial a converged equilibrium, to ``locate_tol``),
        in path order: a list of `Solution` s (e.g. the zero crossings of a force-stroke curve,
        the second stable position of a bistable device)."""
        if not callable(response):
            raise ParameterError(f"EquilibriumPath.crossings: response={response!r} must be a callable response(solution) -> float")
        value = v.finite("EquilibriumPath.crossings", "value", value)
        g = np.array([float(response(s)) for s in self.solutions]) - value
        g[np.abs(g) <= 1e-9 * np.max(np.abs(g), initial=0.0)] = 0.0  # round-off (a reaction at rest)
        out = []
        for k in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0):
            if g[k] == 0.0:
                out.append(self.solutions[k])
            elif g[k + 1] != 0.0 and self._tracer is not None:
                with single_threaded():
                    out.append(self._tracer.crossing(k + 1, response, value, g[k], g[k + 1]))
        if len(g) and g[-1] == 0.0:
            out.append(self.solutions[-1])
        return out

    def __repr__(self) -> str:
        kinds = ", ".join(f"{c.kind}{'' if c.multiplicity == 1 else f' (x{c.multiplicity})'} at "
                          f"{c.load_factor:.6g}" for c in self.critical) or "no critical point"
        return f"EquilibriumPath({len(self)} points, load factor {self.load_factor.min():.6g} ... {self.load_factor.max():.6g}, " \
               f"{kinds}; stopped by {self.stopped_by})"

    def table(self, links=None, points=()) -> Table:
        cols = dict(super().table(links, points))
        extra = {"stable": self.stable, "negative_eigenvalues": self.negative_eigenvalues,
                 "arc_length": self.arc_length}
        keys = list(cols)
        at = keys.index("converged")
        ordered = {k: cols[k] for k in keys[:at]} | extra | {k: cols[k] for k in keys[at:]}
        return Table(ordered)


def trace(mechanism, *, steps: int = 100, arc_length: float | None = None, max_load_factor: float | None = None,
          stop=None, method: str = "conventional", progress: bool | None = None, branch: str = "stable",
          start: Solution | None = None, **options) -> EquilibriumPath:
    """The equilibrium path of ``mechanism``'s loads, prescribed motions and hinge motors scaled by
    a load factor ``lam`` (``lam = 1``: the mechanism as given; the path starts undeformed at 0,
    or at ``start``).

    Arc-length continuation (Crisfield's spherical constraint, `flexmb.solvers.arclength`) follows
    the path through limit points, snap-through and snap-back; the arc length adapts to the
    corrector's iterations. At every point: stability, from the inertia of the symmetric part of
    the free tangent (the negative eigenvalues are counted; with hinges, of the tangent on the
    motions they allow). Limit points (extrema of ``lam``) and bifurcation points (a change of
    stability without one) between two points are located on the path (regula falsi on the arc
    length, to ``locate_tol``) and reported once each in `EquilibriumPath.critical`, with their multiplicity
    and critical modes; `EquilibriumPath.snap` is the first instability.

    Parameters
    ----------
    steps
        Largest number of arc-length steps (100); the located points come on top.
    arc_length
        The first step's arc length, in the dimensionless metric whose first step's length is its
        load-factor increment (default: ``max_load_factor / 20``, or 0.05 without one, smaller
        where the linear response to that load factor would move the mechanism by more than
        `FIRST_MOTION` of its size: a huge reference load starts with a small load factor).
    max_load_factor
        Stop where the path reaches this load factor (the point at exactly this value is
        computed and is the last point). None: no limit.
    stop
        A predicate ``stop(solution) -> bool`` called with every new point; True ends the path
        (that point included). It is tried on the start first, whose answer does not count:
        raising there or returning anything but a bool is refused (`ParameterError`); later, the
        path ends there (``stopped_by="failure"``, the reason in `EquilibriumPath.message`, a UserWarning),
        its points kept.
    method
        ``"conventional"``: the full finite-element model (the only one with a tangent in every
        direction; KSD and the closed forms cannot follow a path).
    progress
        A progress bar on stderr (tqdm; None: only on a terminal).
    branch
        At a bifurcation point (`flexmb.solvers.branching`): ``"stable"`` (default) goes on along
        the branch the device follows: the fewest negative eigenvalues (a stable one where it
        exists), then a growing load factor; ``"primary"`` stays on the path it came along;
        ``"bifurcated"`` leaves it for the best other branch.
    start
        A converged `Solution` of this mechanism's finite-element model (a pre-stressed or
        pre-deformed state, ``method="conventional"``) to start from: the load factor blends
        its equilibrium (``lam = 0``) into the mechanism as given (``lam = 1``): the loads and
        motors by the residual they leave there, the prescribed motions from where it holds them.
    options
        `flexmb.solvers.arclength.ArcLength`'s: ``tol``, ``rtol``, ``max_iter``,
        ``desired_iterations``, ``psi`` (0: cylindrical constraint), ``min_arc``, ``max_arc``,
        ``max_rotation``, ``locate_tol``, ``max_turn``.

    Returns an `EquilibriumPath`. A path that cannot continue (no equilibrium within the smallest arc length)
    ends there: the points reached are kept and `EquilibriumPath.message` says why (``stopped_by="failure"``);
    so does Ctrl-C (``stopped_by="interrupted"``, with a UserWarning).
    """
    owner = "trace"
    strategy = _strategy(owner, method, options)
    steps, max_load_factor, branch = _checked(owner, steps, max_load_factor, progress, stop, branch)
    if arc_length is not None:
        v.positive(owner, "arc_length", arc_length)
    compiled, state = _compiled(owner, mechanism, strategy, start)
    accuracy.prepare(compiled)  # the companion mesh of its critical points' estimates (on request)
    t0 = time.perf_counter()
    with single_threaded():  # small dense eigenproblems per point: one BLAS thread (flexmb.linear)
        tracer = _follow(strategy, compiled, state, stop, max_load_factor, arc_length, steps, branch, progress,
                         start is None)
    _warn_implausible(tracer.sols)
    path = EquilibriumPath(tracer.sols, tracer.points, tracer.critical, tracer.message, tracer.stopped_by, tracer)
    path.interrupted = tracer.stopped_by == "interrupted"
    path.wall_time = time.perf_counter() - t0
    return path


def _follow(strategy, compiled, state, stop, max_load_factor, arc_length, steps, branch, progress,
            undeformed: bool) -> _Tracer:
    """Set the path up at ``state`` (None: undeformed) and follow it (`_Tracer`)."""
    problem = compiled.problem
    metric, t_0, Kff0 = strategy.setup(problem, state)
    _finite_response("trace", strategy, problem, state, Kff0)
    ds0 = _first_step("trace", metric, t_0, arc_length, max_load_factor)
    first = strategy.start(problem, metric, t_0, Kff0, state)
    if max_load_factor is not None and max_load_factor < 0:  # trace towards negative load factors
        first = attrs.evolve(first, direction=-1.0, dlam_ds=-first.dlam_ds)
    tracer = _Tracer(strategy, compiled, problem, metric, stop, max_load_factor)
    tracer.begin(first, "path start: undeformed, load factor 0" if undeformed else
                 "path start: the given solution, load factor 0")
    if not tracer.done:
        tracer.run(ds0, steps, branch, progress, arc_length)
    return tracer


def _strategy(owner: str, method: str, options: dict) -> ArcLength:
    if method != "conventional":
        raise UnsupportedStrategyError(f"{owner}: method={method!r}; path following needs the full finite-element "
                                       "model: method='conventional'")
    try:
        return ArcLength(**options)
    except TypeError as exc:
        raise UnsupportedStrategyError(f"{owner}: {exc}") from None


def _checked(owner: str, steps, max_load_factor, progress, stop, branch):
    """The checked scalar arguments of `trace`: ``(steps, max_load_factor, branch)``."""
    v.integer(owner, "steps", steps, 1)
    if max_load_factor is not None:
        max_load_factor = v.finite(owner, "max_load_factor", max_load_factor)
        if max_load_factor == 0.0:
            raise ParameterError(f"{owner}: max_load_factor=0 is the start; give a non-zero load factor or None")
    if progress is not None:
        v.flag(owner, "progress", progress)
    if stop is not None and not callable(stop):
        raise ParameterError(f"{owner}: stop={stop!r} must be a callable stop(solution) -> bool, or None")
    v.choice(owner, "branch", branch, BRANCHES)
    return steps, max_load_factor, branch


def _compiled(owner: str, mechanism, strategy, start):
    """``(compiled, start state)``: the mechanism's finite-element problem (continued from the
    ``start`` Solution's state, None: undeformed), refused when there is nothing to scale or the
    reference loads are not finite."""
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"{owner}() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    compiled = mechanism.compile(strategy.capability)
    if getattr(compiled.problem, "motion_paths", ()):  # a path scales the motion by the load factor: the line
        compiled = attrs.evolve(compiled, problem=compiled.problem.straight())  # (a prescribe path= leads solves only)
    problem = compiled.problem
    hinges = getattr(problem.model, "hinges", None)
    motors = np.nan_to_num(hinges.angle) if hinges is not None else np.zeros(0)
    _finite_reference(owner, compiled, motors)
    if start is None:
        if not (np.any(problem.loads.force) or np.any(problem.loads.moment) or np.any(problem.values)
                or np.any(motors)):
            raise ModelError(f"{owner}: nothing to scale: the mechanism has no load (apply_force, apply_moment, "
                             "set_actuation with a non-zero value), no non-zero prescribed motion (prescribe) and no "
                             "hinge motor (hinge angle)")
        return compiled, None
    state = _start_state(owner, compiled, start)
    continued = problem.with_motion(problem.values, start=state)  # the prescribed DOFs move on from the state
    offset = problem.residual(state, 1.0)  # what the state leaves unbalanced of the loads and motors as given
    offset[problem.prescribed] = 0.0  # there: the reactions, which the path reports as they are
    continued._offset = offset  # r(u, lam) = r_given(u) - (1 - lam) offset: equilibrium at lam = 0
    if not np.any(offset) and not np.any(continued.values):
        raise ModelError(f"{owner}: nothing to scale from start: the mechanism as given is in equilibrium there "
                         "(change its loads, prescribed motions or motors after solving, then trace)")
    return attrs.evolve(compiled, problem=continued), state


def _start_state(owner: str, compiled, start):
    """The state of the ``start`` Solution, checked against ``compiled``'s model."""
    model = compiled.problem.model
    if not isinstance(start, Solution) or start.state is None:
        raise ParameterError(f"{owner}: start={start!r} must be a flexmb.Solution (of flexmb.solve)")
    if not start.converged:
        raise ParameterError(f"{owner}: start is not converged ({start.message}); trace from a converged Solution")
    other = start.compiled.problem.model
    if getattr(other, "n_dofs", None) != model.n_dofs or not np.array_equal(other.x0, model.x0):
        raise ParameterError(f"{owner}: start is a Solution of another model (method={start.method!r}, "
                             f"{getattr(other, 'n_dofs', '?')} DOFs); solve this mechanism with "
                             "method='conventional' and trace from that")
    return start.state


def _finite_reference(owner: str, compiled, motors: np.ndarray) -> None:
    """Refuse (`ParameterError`) reference loads, prescribed motions or motor angles that are not
    finite, naming where they act."""
    problem = compiled.problem
    names = {n: k for k, n in compiled.link_node.items()}
    loads = problem.loads
    bad = ~np.all(np.isfinite(np.hstack([loads.force, loads.moment])), axis=1)
    if bad.any():
        link = names.get(int(loads.node[np.flatnonzero(bad)[0]]), "?")
        raise ParameterError(f"{owner}: the reference load on link {link!r} is not finite; give finite forces "
                             "and moments (apply_force, apply_moment)")
    if not np.all(np.isfinite(problem.values)) or not np.all(np.isfinite(motors)):
        raise ParameterError(f"{owner}: a prescribed motion or hinge motor angle is not finite")


def _finite_response(owner: str, strategy, problem, state, Kff) -> None:
    """Refuse (`ParameterError`) reference loads whose linear response at the start overflows
    (the path's tangent would be a null vector of the tangent stiffness instead, and no step
    converge: "cannot continue from load factor 0")."""
    from .solvers.arclength import load_tangent

    state = problem.model.initial_state() if state is None else state
    g, _ = load_tangent(problem, state, 0.0)
    try:
        rate = problem.solve_linear(Kff, -g) if len(g) else g
    except (np.linalg.LinAlgError, RuntimeError, ValueError):
        return  # a singular start: the path starts along the null vector
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(rate))):
        raise ParameterError(f"{owner}: the reference load (the loads, prescribed motions and motors at load factor "
                             "1) has a non-finite linear response; scale it down (its size sets the load factor's unit)")


def _first_step(owner: str, metric, t_0, arc_length, max_load_factor) -> float:
    """The first step's arc length (`trace`'s ``arc_length``, checked, or its default: see
    `FIRST_MOTION`; ``t_0`` the unit path tangent at the start)."""
    t, tl = t_0
    if not (np.isfinite(metric.scale) and np.all(np.isfinite(t))):
        raise ParameterError(f"{owner}: the reference load (the loads, prescribed motions and motors at load factor "
                             "1) moves the mechanism by a non-finite amount in the linear response; scale it down")
    if arc_length is not None:
        ds0 = v.positive(owner, "arc_length", arc_length)
    else:
        ds0 = 0.05 * abs(max_load_factor or 1.0)
        # the largest node motion per unit load factor over the size (rotations in rad)
        motion = float(np.max(np.abs(metric.weights() * t))) * metric.scale / tl if tl > 0 else 0.0
        if motion > 0.0:
            ds0 = min(ds0, FIRST_MOTION / motion)
    if ds0 > MAX_FIRST_STEP:  # the arc-length constraint squares the step: 1e154**2 overflows a float
        given = f"arc_length={arc_length!r}" if arc_length is not None else \
            f"max_load_factor={max_load_factor!r} (first step max_load_factor / 20 = {ds0:.3g})"
        raise ParameterError(f"{owner}: {given}: the first step's load-factor increment must be at most "
                             f"{MAX_FIRST_STEP:g} (its square enters the arc-length constraint); give a smaller "
                             "max_load_factor or arc_length (scale the reference loads instead)")
    return ds0


class _Tracer:
    """The loop of `trace`: consumes `ArcLength.follow`'s events into points, solutions and
    critical points, and decides where the path ends (``stopped_by``, ``message``)."""

    def __init__(self, strategy, compiled, problem, metric, stop, max_load_factor):
        self.strategy, self.compiled, self.problem, self.metric = strategy, compiled, problem, metric
        self.stop, self.max_load_factor = stop, max_load_factor
        self.points, self.sols, self.critical = [], [], []
        self.message, self.stopped_by, self.done = "", "steps", False
        self.starts = [None]  # where the step to each point started (a critical point after a switch)
        self._switched = None

    def solution(self, p, message: str) -> Solution:
        return Solution(method="conventional", converged=True, iterations=p.iterations,
                        residual_history=np.array(p.history), load_factor=float(p.lam), steps=1, rejected_steps=0,
                        wall_time={"total": p.wall_time}, message=message, state=p.state, residual=p.residual,
                        compiled=self.compiled, tolerance=self.strategy.tol or self.strategy.rtol,
                        stable=p.negative == 0,
                        stages={"path": {"arc_length": p.arc, "negative_eigenvalues": p.negative,
                                         "eigenvalues_near_zero": p.near.copy(), "direction": p.direction}})

    def begin(self, first, message: str) -> None:
        """The start point; the ``stop`` predicate is tried on it (refused unless it answers a bool;
        its answer there does not end the path: a path of its start alone is no path)."""
        self.points.append(first)
        self.sols.append(self.solution(first, message))
        if self.stop is None:
            return
        try:
            answer = self.stop(self.sols[0])
        except Exception as exc:
            raise ParameterError(f"trace: stop raised {type(exc).__name__}: {exc} on the path's start; "
                                 "stop(solution) must return True or False") from exc
        if not isinstance(answer, (bool, np.bool_)):
            raise ParameterError(f"trace: stop returned {type(answer).__name__} {answer!r} on the path's start; "
                                 "stop(solution) must return True or False (e.g. a comparison of scalars: "
                                 "solution.displacement('S')[1] < -0.01, not a whole array)")

    def run(self, ds0: float, steps: int, branch: str, progress, arc_length) -> None:
        """Follow the path for up to ``steps`` points; Ctrl-C ends it with the points reached."""
        from tqdm.auto import tqdm

        self.message = f"{steps} steps taken"
        bar = tqdm(total=steps, desc="trace", unit="step", leave=False,
                   disable=None if progress is None else not progress)
        s = self.strategy
        try:
            for event in s.follow(self.problem, self.metric, self.points[0], ds0, branch):
                if self.handle(event, ds0, arc_length) or len(self.points) - 1 >= steps:
                    break
                if event[0] == "point":
                    bar.update(1)
                    bar.set_postfix(load_factor=f"{self.points[-1].lam:.4g}")
        except KeyboardInterrupt:
            self.message = (f"interrupted (Ctrl-C) at load factor {self.points[-1].lam:.6g} after "
                            f"{len(self.points) - 1} steps; the points reached are kept")
            self.stopped_by = "interrupted"
            warnings.warn(f"trace: {self.message}", UserWarning, stacklevel=3)
        finally:
            bar.close()

    def handle(self, event, ds0: float, arc_length) -> bool:
        """Take one event of `ArcLength.follow`; True ends the path."""
        if event[0] == "stuck":
            self.message, self.stopped_by = event[1], "failure"
            if len(self.points) == 1:  # not even the first step: say where its size came from
                why = "arc_length" if arc_length is not None else \
                    "the default (max_load_factor / 20 or 0.05, less where the linear response moves far)"
                self.message += (f"; the first step's load-factor increment {ds0:.3g} is {why}: another arc_length "
                                 "(smaller, or larger than roundoff) may start the path")
            return True
        if event[0] == "critical":
            _, kind, p, multiplicity, modes, switched, asymmetric = event
            text = f"{'asymmetric ' if asymmetric else ''}{kind} point at load factor {p.lam:.10g}" + (
                "" if multiplicity == 1 else f" (multiplicity {multiplicity})")
            self.critical.append(Critical(kind, float(p.lam), self.solution(p, text), p.arc, multiplicity,
                                          switched, modes=modes, asymmetric=asymmetric, tracer=self))
            self._switched = p if switched else None
            return False
        _, p, ds = event
        start, self._switched = self._switched or self.points[-1], None
        if start is not self.points[-1]:  # the step left a critical point for another branch: along its chord
            du, dl = self.metric.difference(p.state, start.state), p.lam - start.lam
            n = self.metric.length(du, dl)
            start = attrs.evolve(start, tangent=du / n, tangent_lam=dl / n, direction=1.0, dlam_ds=dl / n)
        if self.max_load_factor is not None and self._reaches(start, p, ds):
            return True
        self.points.append(p)
        self.starts.append(start)
        self.sols.append(self.solution(p, f"equilibrium on the path at load factor {p.lam:.10g}"))
        return self._stops(p)

    def crossing(self, k: int, response, value: float, g_a: float, g_b: float) -> Solution:
        """The point between points ``k - 1`` and ``k`` where ``response`` equals ``value``
        (`EquilibriumPath.crossings`; ``g_a``, ``g_b`` its excess at the ends of the step)."""
        a, b = self.starts[k], self.points[k]
        ds = self.metric.length(self.metric.difference(b.state, a.state), b.lam - a.lam)

        def g(x):
            return float(response(self.solution(x, ""))) - value

        p = self.strategy.locate(self.problem, self.metric, a, ds, g_a, g_b, g)
        if p is None:
            return self.sols[k]
        return self.solution(p, f"{value:g} of the response at load factor {p.lam:.10g}")

    def _reaches(self, a, p, ds: float) -> bool:
        """Whether the step from ``a`` to ``p`` crosses ``max_load_factor``: then the point there
        ends the path."""
        target = self.max_load_factor
        if not ((p.lam - target) * (a.lam - target) <= 0.0 and p.lam != a.lam):
            return False
        s, problem, metric = self.strategy, self.problem, self.metric
        hit = s.locate(problem, metric, a, ds, a.lam - target, p.lam - target, lambda x: x.lam - target)
        if hit is None:
            return False
        hit = s.step(problem, metric, hit, 0.0, fix_lam=target) or hit
        self.points.append(hit)
        self.starts.append(a)
        self.sols.append(self.solution(hit, f"equilibrium on the path at load factor {hit.lam:.10g}"))
        self.message, self.stopped_by = f"reached max_load_factor={target:g}", "max_load_factor"
        return True

    def _stops(self, p) -> bool:
        """Ask the ``stop`` predicate about the newest point; a failing predicate ends the path."""
        if self.stop is None:
            return False
        try:
            answer = self.stop(self.sols[-1])
            if not isinstance(answer, (bool, np.bool_)):
                raise ParameterError(f"returned {type(answer).__name__}, not True or False")
        except Exception as exc:  # the user's predicate failed: keep the points reached, say why
            self.message, self.stopped_by = (f"stop() raised {type(exc).__name__}: {exc} at load factor "
                                             f"{p.lam:.6g}; the points reached are kept"), "failure"
            warnings.warn(f"trace: {self.message}", UserWarning, stacklevel=5)
            return True
        if answer:
            self.message, self.stopped_by = f"stop() at load factor {p.lam:.6g}", "stop"
        return bool(answer)


def _warn_implausible(sols) -> None:
    """The first implausible point warns (strain, yield), as a sweep's solutions do; not its
    stability: a path reports that point by point (`EquilibriumPath.stable`), unstable points are what arc
    length is for."""
    for sol in sols:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check(attrs.evolve(sol, stable=None))
        if caught:
            warnings.warn(f"trace, at load factor {sol.load_factor:.6g}: {caught[0].message}", caught[0].category,
                          stacklevel=3)
            break


#: ``Path``, `EquilibriumPath`'s name until flexmb 0.2 (it shadowed ``pathlib.Path``): warns, kept one release
__getattr__ = renamed("flexmb.path", {"Path": "flexmb.path.EquilibriumPath"})
