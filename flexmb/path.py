"""`trace`: the equilibrium path of a mechanism's loads and prescribed motions under a load factor.

Arc-length continuation (`flexmb.solvers.arclength`) through limit points, snap-through and
snap-back, with the stability of every point and the limit and bifurcation points located on
the way; the result is a `Path`, a sequence of `Solution` s like a `SweepResult`.
"""

from __future__ import annotations

import time
import warnings

import attrs
import numpy as np

from . import _validate as v
from .errors import ModelError, ParameterError, UnsupportedStrategyError
from .plausibility import check
from .results import Solution
from .solvers.arclength import ArcLength
from .sweeps import SweepResult
from .table import Table

__all__ = ["trace", "Path", "Critical"]

#: Largest first arc-length step of `trace` (its load-factor increment): the constraint squares
#: the step, and 1e150**2 = 1e300 is near the float range's end (1.8e308); a first step of
#: max_load_factor=1e300 / 20 overflowed there and stopped "at load factor 0" without saying why.
MAX_FIRST_STEP = 1e150


@attrs.frozen(eq=False)
class Critical:
    """A critical point of a `Path`: ``kind`` (``"limit"``: the load factor's extremum;
    ``"bifurcation"``: the stability changes without one), its ``load_factor`` and `Solution`,
    and ``arc_length`` from the path's start (the dimensionless metric of `trace`)."""

    kind: str
    load_factor: float
    solution: Solution = attrs.field(repr=False)
    arc_length: float


class Path(SweepResult):
    """The points of a `trace` in path order (a sequence of `Solution` s, the start at load
    factor 0 first), with ``load_factor`` (n,), ``stable`` (n,) bool, ``negative_eigenvalues``
    (n,) int, ``arc_length`` (n,), the located `critical` points, ``message`` and ``stopped_by``
    (``"max_load_factor"``, ``"steps"``, ``"stop"`` or ``"failure"``). `table` (and ``to_csv``)
    adds the columns ``stable``, ``negative_eigenvalues`` and ``arc_length``; the points go to
    `flexmb.export.write_series` and their arrays to `flexmb.plot.plot_force_curve` as they are.
    """

    def __init__(self, solutions, points, critical, message: str, stopped_by: str):
        super().__init__(solutions, np.array([p.lam for p in points]), "load_factor")
        self._negative = np.array([p.negative for p in points], dtype=np.int64)
        self._arc = np.array([p.arc for p in points])
        self.critical = list(critical)
        self.message, self.stopped_by = message, stopped_by

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

    def __repr__(self) -> str:
        kinds = ", ".join(f"{c.kind} at {c.load_factor:.6g}" for c in self.critical) or "no critical point"
        return f"Path({len(self)} points, load factor {self.load_factor.min():.6g} ... {self.load_factor.max():.6g}, " \
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
          stop=None, method: str = "conventional", progress: bool | None = None, **options) -> Path:
    """The equilibrium path of ``mechanism``'s loads, prescribed motions and hinge motors scaled by
    a load factor ``lam`` (``lam = 1``: the mechanism as given; the path starts undeformed at 0).

    Arc-length continuation (Crisfield's spherical constraint, `flexmb.solvers.arclength`) follows
    the path through limit points, snap-through and snap-back; the arc length adapts to the
    corrector's iterations. At every point: stability, from the inertia of the symmetric part of
    the free tangent (the negative eigenvalues are counted; with hinges, of the tangent on the
    motions they allow). Limit points (extrema of ``lam``) and
    bifurcation points (a change of stability without one) between two points are located on the
    path (regula falsi on the arc length, to ``locate_tol``) and reported in `Path.critical`.

    Parameters
    ----------
    steps
        Largest number of arc-length steps (100); the located points come on top.
    arc_length
        The first step's arc length, in the dimensionless metric whose first step's length is its
        load-factor increment (default: ``max_load_factor / 20``, or 0.05 without one).
    max_load_factor
        Stop where the path reaches this load factor (the point at exactly this value is
        computed and is the last point). None: no limit.
    stop
        A predicate ``stop(solution) -> bool`` called with every new point; True ends the path
        (that point included); if it raises, the path ends there (``stopped_by="failure"``, the
        exception in `Path.message`, a UserWarning), its points kept.
    method
        ``"conventional"``: the full finite-element model (the only one with a tangent in every
        direction; KSD and the closed forms cannot follow a path).
    progress
        A progress bar on stderr (tqdm; None: only on a terminal).
    options
        `flexmb.solvers.arclength.ArcLength`'s: ``tol``, ``rtol``, ``max_iter``,
        ``desired_iterations``, ``psi`` (0: cylindrical constraint), ``min_arc``, ``max_arc``,
        ``max_rotation``, ``locate_tol``.

    Returns a `Path`. A path that cannot continue (no equilibrium within the smallest arc length)
    ends there: the points reached are kept and `Path.message` says why (``stopped_by="failure"``).
    """
    from tqdm.auto import tqdm

    owner = "trace"
    if method != "conventional":
        raise UnsupportedStrategyError(f"{owner}: method={method!r}; path following needs the full finite-element "
                                       "model: method='conventional'")
    try:
        strategy = ArcLength(**options)
    except TypeError as exc:
        raise UnsupportedStrategyError(f"{owner}: {exc}") from None
    v.integer(owner, "steps", steps, 1)
    if max_load_factor is not None:
        max_load_factor = v.finite(owner, "max_load_factor", max_load_factor)
        if max_load_factor == 0.0:
            raise ParameterError(f"{owner}: max_load_factor=0 is the start; give a non-zero load factor or None")
    ds0 = (0.05 * abs(max_load_factor or 1.0)) if arc_length is None else v.positive(owner, "arc_length", arc_length)
    if ds0 > MAX_FIRST_STEP:  # the arc-length constraint squares the step: 1e154**2 overflows a float
        given = f"arc_length={arc_length!r}" if arc_length is not None else \
            f"max_load_factor={max_load_factor!r} (first step max_load_factor / 20 = {ds0:.3g})"
        raise ParameterError(f"{owner}: {given}: the first step's load-factor increment must be at most "
                             f"{MAX_FIRST_STEP:g} (its square enters the arc-length constraint); give a smaller "
                             "max_load_factor or arc_length (scale the reference loads instead)")
    if progress is not None:
        v.flag(owner, "progress", progress)
    if stop is not None and not callable(stop):
        raise ParameterError(f"{owner}: stop={stop!r} must be a callable stop(solution) -> bool, or None")
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"{owner}() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    compiled = mechanism.compile(strategy.capability)
    problem = compiled.problem
    hinges = getattr(problem.model, "hinges", None)
    motors = hinges is not None and np.any(np.nan_to_num(hinges.angle))
    if not (np.any(problem.loads.force) or np.any(problem.loads.moment) or np.any(problem.values) or motors):
        raise ModelError(f"{owner}: nothing to scale: the mechanism has no load (apply_force, apply_moment, "
                         "set_actuation with a non-zero value), no non-zero prescribed motion (prescribe) and no "
                         "hinge motor (hinge angle)")
    t0 = time.perf_counter()
    metric, t_0, Kff0 = strategy.setup(problem)
    first = strategy.start(problem, metric, t_0, Kff0)
    if max_load_factor is not None and max_load_factor < 0:  # trace towards negative load factors
        first = attrs.evolve(first, direction=-1.0, dlam_ds=-first.dlam_ds)

    def solution(p, message):
        return Solution(method="conventional", converged=True, iterations=p.iterations,
                        residual_history=np.array(p.history), load_factor=float(p.lam), steps=1, rejected_steps=0,
                        wall_time={"total": p.wall_time}, message=message, state=p.state, residual=p.residual,
                        compiled=compiled, tolerance=strategy.tol or strategy.rtol, stable=p.negative == 0,
                        stages={"path": {"arc_length": p.arc, "negative_eigenvalues": p.negative,
                                         "eigenvalues_near_zero": p.near.copy(), "direction": p.direction}})

    points, sols, critical = [first], [solution(first, "path start: undeformed, load factor 0")], []
    message, stopped_by = f"{steps} steps taken", "steps"
    bar = tqdm(total=steps, desc="trace", unit="step", leave=False, disable=None if progress is None else not progress)
    try:
        n = 0
        for event in strategy.follow(problem, metric, first, ds0):
            if event[0] == "stuck":
                message, stopped_by = event[1], "failure"
                if len(points) == 1:  # not even the first step: say where its size came from
                    message += (f"; the first step's load-factor increment {ds0:.3g} is "
                                f"{'max_load_factor / 20' if arc_length is None else 'arc_length'}: another "
                                "arc_length (smaller, or larger than roundoff) may start the path")
                break
            if event[0] == "critical":
                _, kind, p = event
                critical.append(Critical(kind, float(p.lam), solution(p, f"{kind} point at load factor {p.lam:.10g}"),
                                         p.arc))
                continue
            _, p, ds = event
            a = points[-1]
            if max_load_factor is not None and (p.lam - max_load_factor) * (a.lam - max_load_factor) <= 0.0 \
                    and p.lam != a.lam:
                target = strategy.locate(problem, metric, a, ds, a.lam - max_load_factor, p.lam - max_load_factor,
                                         lambda x: x.lam - max_load_factor)
                if target is not None:
                    fixed = strategy.step(problem, metric, target, 0.0, fix_lam=max_load_factor)
                    target = fixed or target
                    points.append(target)
                    sols.append(solution(target, f"equilibrium on the path at load factor {target.lam:.10g}"))
                    message, stopped_by = f"reached max_load_factor={max_load_factor:g}", "max_load_factor"
                    break
            points.append(p)
            sols.append(solution(p, f"equilibrium on the path at load factor {p.lam:.10g}"))
            n += 1
            bar.update(1)
            bar.set_postfix(load_factor=f"{p.lam:.4g}")
            try:
                stopping = stop is not None and stop(sols[-1])
            except Exception as exc:  # the user's predicate failed: keep the points reached, say why
                message, stopped_by = (f"stop() raised {type(exc).__name__}: {exc} at load factor {p.lam:.6g}; "
                                       "the points reached are kept"), "failure"
                warnings.warn(f"trace: {message}", UserWarning, stacklevel=2)
                break
            if stopping:
                message, stopped_by = f"stop() at load factor {p.lam:.6g}", "stop"
                break
            if n >= steps:
                break
    finally:
        bar.close()
    for sol in sols:  # the first implausible point warns (strain, yield), as a sweep's solutions do
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check(sol)
        if caught:
            warnings.warn(f"trace, at load factor {sol.load_factor:.6g}: {caught[0].message}", caught[0].category,
                          stacklevel=2)
            break
    path = Path(sols, points, critical, message, stopped_by)
    path.wall_time = time.perf_counter() - t0
    return path
