"""Responses over the range of motion: a design solved at N configurations along its stroke, in
order as one continuation, and aggregates of its responses over them with their gradients.

A `Stroke` names the configurations: prescribed values of one link component (``motion=(link,
component)``, as `flexmb.sweep`), actuation force levels (`Mechanism.set_actuation`), or any
``configure(mechanism, value)`` that changes only prescribed values or loads. Each configuration
is a fresh build of the design changed by its configure step, so the gradient machinery of
`flexmb.design.evaluate` sees a clean model (the model numbers' rates are built once per design
and shared by every configuration; the prescribed values' and loads' rates are taken per
configuration). The solves run in order, each starting from the previous equilibrium
(`StaticProblem.with_motion` / `with_loads` with ``start``: the load factor carries the
prescribed DOFs or the loads from where the previous configuration left them), so a stroke of N
configurations costs one continuation, not N solves from the undeformed state.

Aggregates (`ks_max`, `ks_min`, `mean`, `total`, `at`) turn a response's N values into one:
the Kreisselmeier-Steinhauser function (Kreisselmeier & Steinhauser 1979; Martins & Poon 2005)

    KS_max(x) = m + (s / rho) ln sum_i exp(rho (x_i - m) / s),   m = max_i x_i,

with ``s`` the aggregate's scale (default the mean of ``|x_i|``, so KS is homogeneous in ``x``
and ``rho`` dimensionless) lies between the exact maximum and the maximum plus ``s ln(N) / rho``
(for ``rho = 100`` and N = 11 at most 2.4 % of ``s`` above; far less where one configuration
dominates); ``KS_min(x) = -KS_max(-x)``. Its gradient ``sum_i w_i dx_i/dp`` (softmax weights
``w_i``, plus the scale's own rate) is exact: a smooth stand-in for the non-smooth max, whose
exact value is reported beside it (`StrokeEvaluation.exact`).

The configurations of one design can be spread over an executor (``executor=``: ``"process"``
for an embedded process pool, or any `concurrent.futures.Executor` such as a dask client's, as
`flexmb.parameter_study`): they are split into contiguous chunks, each one continuation in a
worker; only numbers come back (the solutions stay in the workers).
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
import math
import os
import time

import attrs
import numpy as np

from ..errors import ConvergenceError, ModelError, ParameterError
from .evaluate import DesignPoint, Evaluation, _read_only, _responses

__all__ = ["Stroke", "Aggregate", "ks_max", "ks_min", "mean", "total", "at", "StrokeEvaluation", "StrokePoint",
           "evaluate_stroke", "DEFAULT_RHO"]

#: Default KS parameter of the stroke aggregates (dimensionless, with the scale ``s``): the
#: aggregate exceeds the exact extreme by at most ``s ln(N) / 100`` (2.4 % of s at N = 11).
DEFAULT_RHO = 100.0

KINDS = ("ks_max", "ks_min", "mean", "total", "at")

#: A configuration whose weight in an aggregate is below this times the aggregate's largest weight
#: adds less than round-off to its gradient (exp(-30) ~ 1e-13): its gradient is not computed.
NEGLIGIBLE = 1e-13


def _configure_motion(link: str, component: str, mechanism, value) -> None:
    mechanism.prescribe(link, **{component: value})


def _configure_actuation(mechanism, value) -> None:
    act = mechanism.actuation
    if act is None:
        raise ModelError("Stroke: the mechanism has no actuation; declare the stroke's force with "
                         "Mechanism.set_actuation(link, direction), or give motion=(link, component)")
    point = mechanism.link(act["link"]).position + act["offset"]
    mechanism.set_actuation(act["link"], act["direction"], float(value), point=point)


@attrs.frozen(eq=False)
class Stroke:
    """N configurations along a design's range of motion, solved in the given order.

    ``values``: the stroke values, (N,) (or (N, 3) rotation vectors of a 3D link's ``"rotation"``);
    ``motion=(link, component)``: each configuration prescribes that component of the link
    (``"x"``, ``"y"``, ``"z"`` [m], ``"rotation"`` [rad]; as `flexmb.sweep`); ``configure``: a
    function ``configure(mechanism, value)`` that sets one configuration on a fresh build instead
    (it may change prescribed values and loads only; module-level, to run on a process pool).
    Neither: the values are actuation force levels [N] (`Mechanism.set_actuation`). Order the
    values so that neighbours are near (e.g. 0 outwards, or -a .. a): each solve starts from the
    previous equilibrium."""

    values: np.ndarray = attrs.field(converter=_read_only)
    motion: tuple | None = attrs.field(default=None, converter=lambda m: None if m is None else tuple(m))
    configure: object = None

    def __attrs_post_init__(self):
        v = self.values
        if v.ndim not in (1, 2) or len(v) == 0 or not np.all(np.isfinite(v)):
            raise ParameterError(f"Stroke: values must be a non-empty finite (N,) or (N, 3) array, got shape {v.shape}")
        if self.motion is not None and (len(self.motion) != 2 or not all(isinstance(s, str) for s in self.motion)):
            raise ParameterError(f"Stroke: motion={self.motion!r} must be (link, component), e.g. ('B', 'x')")
        if self.motion is not None and self.configure is not None:
            raise ParameterError("Stroke: give motion or configure, not both")
        if self.configure is not None and not callable(self.configure):
            raise ParameterError(f"Stroke: configure must be a function (mechanism, value), got {self.configure!r}")
        if v.ndim == 2 and (self.motion is None or self.motion[1] != "rotation"):
            raise ParameterError("Stroke: (N, 3) values are 3D rotation vectors of motion=(link, 'rotation')")

    def __len__(self) -> int:
        return len(self.values)

    def configure_at(self, i: int):
        """The function ``mechanism -> None`` that sets configuration ``i`` (picklable)."""
        value = self.values[i] if self.values.ndim == 2 else float(self.values[i])
        if self.motion is not None:
            return functools.partial(_configure_motion, self.motion[0], self.motion[1], value=value)
        if self.configure is not None:
            return functools.partial(self.configure, value=value)
        return functools.partial(_configure_actuation, value=value)


def as_stroke(stroke) -> Stroke | None:
    """None (the design's own configuration) or a `Stroke` (refusing anything else)."""
    if stroke is None or isinstance(stroke, Stroke):
        return stroke
    raise ParameterError(f"stroke must be a flexmb.design.stroke.Stroke or None, got {type(stroke).__name__}")


# -- aggregates ----------------------------------------------------------------------------------
def _ks(x: np.ndarray, rho: float, scale: float | None) -> tuple[float, np.ndarray]:
    """KS_max of ``x`` (N,) and its gradient (N,) (the scale's own rate included)."""
    s = float(np.mean(np.abs(x))) if scale is None else float(scale)
    if not s > 0:
        s = 1.0 if scale is None else s  # all values zero: KS in their own unit
        fixed = True
    else:
        fixed = scale is not None
    m = float(np.max(x))
    e = np.exp(rho * (x - m) / s)
    total = float(np.sum(e))
    value = m + s / rho * math.log(total)
    w = e / total  # d KS / d x_i at fixed s
    if not fixed:  # d KS / d s = (KS - sum w x) / s, ds/dx_i = sign(x_i) / N
        w = w + (value - float(w @ x)) / s * np.sign(x) / len(x)
    return value, w


@attrs.frozen
class Aggregate:
    """One number from a response's values over a stroke: ``kind`` one of ``"ks_max"``,
    ``"ks_min"`` (KS with ``rho`` and ``scale``, module notes), ``"mean"``, ``"total"`` (sum),
    ``"at"`` (the value at configuration ``index``). Built by `ks_max`, `ks_min`, `mean`, `total`, `at`."""

    response: object = attrs.field(converter=lambda r: tuple(r) if isinstance(r, list) else r)
    kind: str
    rho: float = DEFAULT_RHO
    scale: float | None = None
    index: int = 0
    plain: bool = False  # a plain response of a one-configuration design: named as the response

    def __attrs_post_init__(self):
        for r in self.responses:
            if not (hasattr(r, "value") and hasattr(r, "gradient")):
                raise ParameterError(f"{self.kind}: {r!r} is not a response (flexmb.responses.*)")
        if self.kind == "at" and len(self.responses) != 1:
            raise ParameterError("at: one response, not several")
        if self.kind not in KINDS:
            raise ParameterError(f"aggregate kind={self.kind!r}; valid: {', '.join(KINDS)}")
        if not (isinstance(self.rho, (int, float)) and math.isfinite(self.rho) and self.rho > 0):
            raise ParameterError(f"{self.kind}: rho={self.rho!r} must be a finite number > 0")
        if self.scale is not None and not (math.isfinite(self.scale) and self.scale > 0):
            raise ParameterError(f"{self.kind}: scale={self.scale!r} must be a finite number > 0")
        if isinstance(self.index, bool) or not isinstance(self.index, (int, np.integer)):
            raise ParameterError(f"at: index={self.index!r} must be an integer")

    @property
    def responses(self) -> tuple:
        """The response(s) aggregated: one, or several aggregated together over the stroke."""
        return tuple(self.response) if isinstance(self.response, (tuple, list)) else (self.response,)

    @property
    def name(self) -> str:
        """The aggregate's name for tables, e.g. ``ks_min(1/compliance(B, y, y), rho=100)``."""
        inner = ", ".join(r.name for r in self.responses)
        inner = inner if len(self.responses) == 1 else f"[{inner}]"
        if self.plain:
            return inner
        if self.kind == "at":
            return f"at({inner}, {self.index})"
        if self.kind in ("mean", "total"):
            return f"{self.kind}({inner})"
        return f"{self.kind}({inner}, rho={self.rho:g})"

    def combine(self, x: np.ndarray) -> tuple[float, np.ndarray, float]:
        """``(aggregate, d aggregate / d x, exact)`` of the values ``x`` over the stroke, (N,) or
        (N, m) for m responses aggregated together (the derivative has x's shape); ``exact`` is the
        max / min the KS stands in for (the aggregate itself for the others)."""
        x = np.asarray(x, dtype=float)
        if x.ndim == 2:
            value, w, exact = self.combine(x.ravel()) if x.shape[1] > 1 or self.kind != "at" else \
                self.combine(x[:, 0])
            return value, w.reshape(x.shape), exact
        n = len(x)
        if self.kind == "ks_max":
            value, w = _ks(x, self.rho, self.scale)
            return value, w, float(np.max(x))
        if self.kind == "ks_min":
            value, w = _ks(-x, self.rho, self.scale)
            return -value, w, float(np.min(x))
        if self.kind == "mean":
            return float(np.mean(x)), np.full(n, 1.0 / n), float(np.mean(x))
        if self.kind == "total":
            return float(np.sum(x)), np.ones(n), float(np.sum(x))
        if not -n <= self.index < n:
            raise ParameterError(f"at: index={self.index} outside the stroke's {n} configurations")
        w = np.zeros(n)
        w[self.index] = 1.0
        return float(x[self.index]), w, float(x[self.index])


def ks_max(response, rho: float = DEFAULT_RHO, scale: float | None = None) -> Aggregate:
    """The largest value of ``response`` over the stroke as the KS aggregate (module notes): at or
    above the exact maximum by at most ``scale ln(N) / rho`` (``scale`` default: mean |value|).
    ``response`` may be a sequence of responses of one unit: the largest of all over the stroke
    (e.g. the three support stiffnesses of a link, N = 3 x configurations)."""
    return Aggregate(response, "ks_max", rho, scale)


def ks_min(response, rho: float = DEFAULT_RHO, scale: float | None = None) -> Aggregate:
    """The smallest value of ``response`` over the stroke as ``-KS_max(-x)``: at or below the exact
    minimum by at most ``scale ln(N) / rho`` (e.g. the minimum support stiffness over a stroke)."""
    return Aggregate(response, "ks_min", rho, scale)


def mean(response) -> Aggregate:
    """The mean of ``response`` over the stroke's configurations."""
    return Aggregate(response, "mean")


def total(response) -> Aggregate:
    """The sum of ``response`` over the stroke's configurations."""
    return Aggregate(response, "total")


def at(response, index: int) -> Aggregate:
    """``response`` at configuration ``index`` of the stroke (0-based, negative from the end)."""
    return Aggregate(response, "at", index=index)


def as_aggregates(items, n: int) -> tuple:
    """``items`` as `Aggregate` s: a plain response is ``at(response, 0)`` when the stroke has one
    configuration, refused otherwise (naming it and the aggregates)."""
    out = []
    for r in ((items,) if hasattr(items, "value") or isinstance(items, Aggregate) else tuple(items)):
        if isinstance(r, Aggregate):
            out.append(r)
        elif n == 1:
            out.append(Aggregate(_responses(r)[0], "at", plain=True))
        else:
            raise ParameterError(f"response {getattr(r, 'name', r)!r} over a stroke of {n} configurations: say how to "
                                 "aggregate it (flexmb.design.stroke.ks_max, ks_min, mean, total or at)")
    if not out:
        raise ParameterError("no responses given")
    return tuple(out)


# -- one design over its stroke --------------------------------------------------------------------
def _strategy(method, options):
    from ..solvers import make_strategy

    return make_strategy(method, dict(options))


def _same_motion(a, b) -> bool:
    """Whether two problems of one model prescribe the same values and rotation chains."""
    return np.array_equal(a.values, b.values) and len(a.rotation_paths) == len(b.rotation_paths) and all(
        np.array_equal(x[0], y[0]) and np.array_equal(x[1], y[1]) for x, y in zip(a.rotation_paths, b.rotation_paths))


def _warm_problem(problem, previous):
    """``problem`` (a configuration's clean problem) started from the ``previous`` configuration's
    equilibrium: its prescribed values and loads carried by the load factor from the previous ones
    (None when both changed: that configuration starts from the undeformed state)."""
    prev_problem = previous.compiled.problem
    same_values = _same_motion(problem, prev_problem)
    same_loads = all(np.array_equal(getattr(problem.loads, f), getattr(prev_problem.loads, f))
                     for f in ("offset", "force", "moment"))
    if same_values and same_loads:
        return problem.continued_from(previous.state)
    if same_loads:
        return problem.with_motion(problem.values, start=previous.state, start_values=prev_problem.values)
    if same_values:
        return problem.with_loads(problem.loads, start=prev_problem.loads)
    return None


def solve_configuration(point: DesignPoint, configure, strategy, previous=None):
    """The equilibrium of ``point``'s build changed by ``configure``, from ``previous`` (a converged
    `Solution` of a neighbouring configuration of the same design) when the strategy takes a start.
    The returned `Solution` belongs to the configuration's own compiled model (its clean problem)."""
    compiled = point.mechanism(configure).compile(getattr(strategy, "capability", "fe_model"))
    problem = None
    if _takes_start(strategy, compiled, previous):
        problem = _warm_problem(compiled.problem, previous)
    if problem is None:
        return strategy.solve(compiled)
    sol = strategy.solve(attrs.evolve(compiled, problem=problem), state=previous.state)
    return attrs.evolve(sol, compiled=compiled)


def _takes_start(strategy, compiled, previous) -> bool:
    from ..sweeps import _warm_starts

    return previous is not None and previous.converged and _warm_starts(strategy) and \
        hasattr(compiled.problem, "rotation_paths")  # the finite-element problem


def solve_from_design(point: DesignPoint, configure, strategy, seed):
    """The equilibrium of ``point``'s configuration from ``seed``, the converged `Solution` of the
    same configuration of a neighbouring design (a continuation in the design space): the seed's
    nodal displacements and rotations carried onto this design's reference positions, then the
    load factor runs from that state's residual to equilibrium (`StaticProblem.continued_from`).
    None when it does not apply (another strategy, other prescribed values or mesh)."""
    compiled = point.mechanism(configure).compile(getattr(strategy, "capability", "fe_model"))
    if not _takes_start(strategy, compiled, seed):
        return None
    problem, before = compiled.problem, seed.compiled.problem
    model, old = problem.model, before.model
    if model.x0.shape != old.x0.shape or model.hinges is not None or not _same_motion(problem, before):
        return None
    state = attrs.evolve(seed.state, positions=model.x0 + (seed.state.positions - old.x0),
                         rotations=seed.state.rotations.copy())
    sol = strategy.solve(attrs.evolve(compiled, problem=problem.continued_from(state)), state=state)
    return attrs.evolve(sol, compiled=compiled)


@attrs.frozen(eq=False)
class StrokeEvaluation:
    """Aggregated responses of one design over its stroke and their gradients.

    ``names`` (K parameters), ``responses`` (R aggregate names), ``values`` (R,), ``exact`` (R,):
    the exact extreme (max / min) a KS aggregate stands in for (the value itself otherwise),
    ``jacobian`` (R, K) or None; per configuration: ``configuration_values`` (N, M) of the M
    distinct responses named ``base`` and ``configuration_jacobians`` (N, M, K) or None;
    ``solutions`` (N `flexmb.Solution` s, None when solved on an executor), ``solves`` (the
    equilibrium solves made), ``iterations`` (their Newton iterations), ``times`` [s]."""

    names: tuple
    responses: tuple
    values: np.ndarray = attrs.field(converter=_read_only)
    exact: np.ndarray = attrs.field(converter=_read_only)
    jacobian: np.ndarray | None = attrs.field(converter=lambda a: None if a is None else _read_only(a))
    base: tuple = ()
    configuration_values: np.ndarray = attrs.field(default=np.zeros((0, 0)), converter=_read_only)
    configuration_jacobians: np.ndarray | None = attrs.field(
        default=None, converter=lambda a: None if a is None else _read_only(a))
    solutions: tuple | None = attrs.field(default=None, repr=False)
    solves: int = 0
    iterations: int = 0
    times: dict = attrs.field(factory=dict)

    #: ``{parameter: d aggregate / dp}`` of one aggregate (by position or name)
    gradient = Evaluation.gradient


def _base_responses(aggregates) -> tuple[tuple, list]:
    """The distinct responses under ``aggregates`` (equal definitions shared) and, per aggregate,
    the indices of its responses among them."""
    base, where = [], []
    for a in aggregates:
        idx = []
        for r in a.responses:
            j = next((j for j, b in enumerate(base) if b is r or (type(b) is type(r) and b == r)), None)
            if j is None:
                j = len(base)
                base.append(r)
            idx.append(j)
        where.append(idx)
    return tuple(base), where


class StrokePoint:
    """One design at parameter values ``p`` over a stroke: solved on the first `values` call (one
    continuation), gradients on the first `jacobian` call from the kept solutions (no new solve).
    The unit that `flexmb.design.optimize` caches per design. On an executor the solutions stay
    in the workers: ``eager=True`` computes the gradients with the values (one pass), otherwise
    a later `jacobian` call solves the stroke again. ``seed``: the converged solutions of a
    neighbouring design over the same stroke; each configuration is first solved from its seed
    (`solve_from_design`), and from the previous configuration where that fails."""

    def __init__(self, build, p, aggregates, stroke=None, *, bounds=None, method: str = "conventional",
                 mode: str = "auto", executor=None, chunks: int | None = None, eager: bool = False, seed=None,
                 **options):
        self.point = DesignPoint(build, p, bounds)
        self.names = self.point.names
        self.stroke = as_stroke(stroke)
        n = 1 if self.stroke is None else len(self.stroke)
        self.aggregates = as_aggregates(aggregates, n)
        self.base, self._where = _base_responses(self.aggregates)
        self.method, self.mode, self.options = method, mode, dict(options)
        self.executor, self.chunks, self.eager, self.seed = executor, chunks, eager, seed
        self.solutions = None
        self.solves = self.iterations = 0
        self.times = {"solve": 0.0, "responses": 0.0, "gradient": 0.0}
        self._values = self._jacobians = None
        self._rows: dict = {}  # (configuration, distinct response) -> gradient (K,)

    def _configure(self, i: int):
        return None if self.stroke is None else self.stroke.configure_at(i)

    def _solve(self) -> list:
        strategy = _strategy(self.method, self.options)
        sols, previous = [], None
        n = 1 if self.stroke is None else len(self.stroke)
        seed = self.seed if self.seed is not None and len(self.seed) == n else [None] * n
        for i in range(n):
            t0 = time.perf_counter()
            sol = self._attempt(solve_from_design, strategy, i, seed[i]) if seed[i] is not None else None
            if sol is None or not sol.converged:
                sol = self._attempt(solve_configuration, strategy, i, previous)
            self.times["solve"] += time.perf_counter() - t0
            if not sol.converged:
                where = "" if self.stroke is None else f" at stroke value {self.stroke.values[i].tolist()} (configuration {i})"
                raise ConvergenceError(f"the design at {self.point.design.values}{where} did not converge "
                                       f"({sol.message})", sol)
            sols.append(sol)
            previous = sol
        return sols

    def _attempt(self, how, strategy, i: int, start):
        """One solve of configuration ``i`` by ``how`` from ``start`` (counted), or None."""
        sol = how(self.point, self._configure(i), strategy, start)
        if sol is not None:
            self.solves += 1
            self.iterations += int(sol.iterations)
        return sol

    def _evaluate(self, i: int, gradient: bool):
        return self.point.evaluate(self.base, configure=self._configure(i), solution=self.solutions[i],
                                   method=self.method, gradient=gradient, mode=self.mode)

    def configuration_values(self) -> np.ndarray:
        """(N, M) the distinct responses' values per configuration (solving on first need)."""
        if self._values is None:
            if self.executor is not None and self.executor != "serial":
                self._parallel(gradient=self.eager)
            else:
                self.solutions = self._solve()
                t0 = time.perf_counter()
                self._values = np.array([self._evaluate(i, False).values for i in range(len(self.solutions))])
                self.times["responses"] += time.perf_counter() - t0
        return self._values

    def configuration_jacobians(self) -> np.ndarray:
        """(N, M, K) the distinct responses' gradients per configuration (from the kept solutions)."""
        if self._jacobians is None:
            if self.executor is not None and self.executor != "serial":
                self._parallel(gradient=True)
            else:
                n, m = self.configuration_values().shape
                self._gradient_rows({i: range(m) for i in range(n)})
                self._jacobians = np.array([[self._rows[i, j] for j in range(m)] for i in range(n)])
        return self._jacobians

    def _gradient_rows(self, needed: dict) -> None:
        """The gradients of the distinct responses ``needed[i]`` at each configuration ``i`` (kept)."""
        t0 = time.perf_counter()
        for i, js in needed.items():
            missing = [j for j in js if (i, j) not in self._rows]
            if missing:
                ev = self.point.evaluate([self.base[j] for j in missing], configure=self._configure(i),
                                         solution=self.solutions[i], method=self.method, gradient=True,
                                         mode=self.mode)
                self._rows.update({(i, j): row for j, row in zip(missing, ev.jacobian)})
        self.times["gradient"] += time.perf_counter() - t0

    def _parallel(self, gradient: bool) -> None:
        n = len(self.stroke) if self.stroke is not None else 1
        vals, jacs, solves, iters, times = _run_chunks(self, n, gradient)
        self._values = vals
        if gradient:
            self._jacobians = jacs
        self.solves += solves
        self.iterations += iters
        for k, t in times.items():
            self.times[k] = self.times.get(k, 0.0) + t

    def values(self) -> tuple[np.ndarray, np.ndarray]:
        """The aggregates' values (R,) and their exact extremes (R,)."""
        x = self.configuration_values()
        out = [a.combine(x[:, js]) for a, js in zip(self.aggregates, self._where)]
        return np.array([o[0] for o in out]), np.array([o[2] for o in out])

    def jacobian(self) -> np.ndarray:
        """(R, K) the aggregates' gradients ``sum_i w_i dx_i/dp``, from the configurations whose
        weight ``w_i`` in some aggregate exceeds `NEGLIGIBLE` times that aggregate's largest
        (the others add below round-off: a KS aggregate far from its extreme, an ``at``)."""
        x = self.configuration_values()
        weights = [a.combine(x[:, js])[1] for a, js in zip(self.aggregates, self._where)]  # (N, m) each
        if self._jacobians is not None or self.solutions is None:  # all known, or solved on an executor
            J = self.configuration_jacobians()
            return np.array([np.einsum("nm,nmk->k", w, J[:, js, :]) for w, js in zip(weights, self._where)])
        needed: dict = {}
        for w, js in zip(weights, self._where):
            for i, c in zip(*np.nonzero(np.abs(w) > NEGLIGIBLE * np.max(np.abs(w)))):
                needed.setdefault(int(i), set()).add(js[c])
        self._gradient_rows({i: sorted(j) for i, j in sorted(needed.items())})
        K = len(self.names)
        return np.array([sum((w[i, c] * self._rows[i, j] for i in range(len(w)) for c, j in enumerate(js)
                              if (i, j) in self._rows), np.zeros(K)) for w, js in zip(weights, self._where)])

    def evaluation(self, gradient: bool = True) -> StrokeEvaluation:
        """The `StrokeEvaluation` of this design (its gradients too unless ``gradient=False``)."""
        if gradient:  # on an executor: values and gradients in one pass of the workers
            self.configuration_jacobians()
        values, exact = self.values()
        jac = self.jacobian() if gradient else None
        return StrokeEvaluation(self.names, tuple(a.name for a in self.aggregates), values, exact, jac,
                                tuple(r.name for r in self.base), self.configuration_values(),
                                self._jacobians if gradient else None,
                                None if self.solutions is None else tuple(self.solutions), self.solves,
                                self.iterations,
                                dict(self.times, rates=self.times.get("rates", 0.0) + self.point.rates_time))


# -- on an executor --------------------------------------------------------------------------------
def _chunk_job(design, stroke, indices, base, method, mode, gradient, options):
    """A worker's part: one continuation over ``indices`` of the stroke; numbers only."""
    sub = attrs.evolve(stroke, values=stroke.values[list(indices)])
    sp = StrokePoint(design, None, [mean(tuple(base))], sub, method=method, mode=mode, **options)
    vals = sp.configuration_values()
    jacs = sp.configuration_jacobians() if gradient else None
    return vals, jacs, sp.solves, sp.iterations, dict(sp.times, rates=sp.point.rates_time)


def _chunks(n: int, parts: int) -> list[list[int]]:
    parts = max(1, min(n, parts))
    bounds = np.linspace(0, n, parts + 1).round().astype(int)
    return [list(range(a, b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


def _run_chunks(sp: StrokePoint, n: int, gradient: bool):
    from ..study import _check_picklable

    own = isinstance(sp.executor, str)
    if own and sp.executor != "process":
        raise ParameterError(f"executor={sp.executor!r}; valid: None or 'serial', 'process' or a "
                             "concurrent.futures.Executor")
    if sp.stroke is None:
        raise ParameterError("executor: a design without a stroke has one configuration; nothing to spread")
    workers = sp.chunks or (os.cpu_count() or 1)
    parts = _chunks(n, workers)
    job = functools.partial(_chunk_job, sp.point.design, sp.stroke, base=sp.base, method=sp.method, mode=sp.mode,
                            gradient=gradient, options=sp.options)
    if own or isinstance(sp.executor, cf.ProcessPoolExecutor):
        _check_picklable(job)
    pool = cf.ProcessPoolExecutor(max_workers=len(parts)) if own else sp.executor
    try:
        futures = [pool.submit(job, idx) for idx in parts]
        results = [f.result() for f in futures]
    finally:
        if own:
            pool.shutdown(wait=True, cancel_futures=True)
    vals = np.concatenate([r[0] for r in results])
    jacs = np.concatenate([r[1] for r in results]) if gradient else None
    times = {}
    for r in results:
        for k, t in r[4].items():
            times[k] = times.get(k, 0.0) + t
    return vals, jacs, sum(r[2] for r in results), sum(r[3] for r in results), times


def evaluate_stroke(build, p, responses, stroke=None, *, bounds=None, method: str = "conventional",
                    gradient: bool = True, mode: str = "auto", executor=None, chunks: int | None = None,
                    **options) -> StrokeEvaluation:
    """Aggregated responses of the design ``build`` at ``p`` over ``stroke`` (a `Stroke`; None:
    the design's own configuration), with their gradients.

    ``responses``: aggregates (`ks_max`, `ks_min`, `mean`, `total`, `at`) of `flexmb.responses`
    (a plain response is allowed when the stroke has one configuration); ``method``,
    ``mode`` and the solver's ``options`` as in `flexmb.design.DesignPoint.evaluate`;
    ``executor``: None or ``"serial"`` (this process), ``"process"`` (an embedded process pool of
    ``chunks`` workers, default the CPU count) or a `concurrent.futures.Executor` (e.g. a dask
    client's ``get_executor()``): the stroke split into ``chunks`` contiguous continuations.
    Example (the minimum support stiffness over a +-5 mm stroke)::

        stroke = Stroke(np.linspace(-5, 5, 11), motion=("stage", "x"))
        ev = evaluate_stroke(build, p, [ks_max(R.compliance("stage", "y", "y"))], stroke)
    """
    sp = StrokePoint(build, p, responses, stroke, bounds=bounds, method=method, mode=mode, executor=executor,
                     chunks=chunks, **options)
    return sp.evaluation(gradient)

