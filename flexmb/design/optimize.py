"""`optimize`: a design optimisation driver over scipy.optimize, IPOPT (cyipopt) and MMA (nlopt),
with flexmb's design gradients, a history, failure handling and Ctrl-C.

The optimisers see scaled variables ``x = (p - lower) / (upper - lower)`` in [0, 1], the
objective divided by its magnitude at the start and each constraint as its relative margin
``(limit - value) / |limit|`` (>= 0 when met), so their tolerances mean the same for every
design. A design is evaluated once per parameter values (`StrokePoint`: the solves of its
stroke, then its gradients from the same solutions on the first request): an optimiser that asks
for the objective, then the constraints, then their gradients at one point costs one
continuation and one set of gradients.

A design whose solve fails (no convergence, a build the joint refuses, a singular tangent) does
not end the run: it is recorded in the history with its error and returned to the optimiser
*penalised* (the worst objective met so far plus 1, i.e. plus the start's magnitude, and every
constraint violated by its limit), so a line search (SLSQP, IPOPT) or a trust region
(trust-constr, COBYLA, MMA) steps back from it; its gradient is that of the last design that
converged. Ctrl-C stops the run and returns the best design so far with the history.

Optimisers (``optimizer=``): ``"slsqp"`` and ``"trust-constr"`` (scipy), ``"ipopt"`` (the
``ipopt`` extra, cyipopt), ``"mma"`` (the ``nlopt`` extra, Svanberg's MMA as nlopt's LD_MMA);
derivative-free for baselines: ``"cobyla"``, ``"nelder-mead"`` (bounds only).
"""

from __future__ import annotations

import math
import time
from collections import OrderedDict

import attrs
import numpy as np

from ..errors import MissingExtraError, ParameterError, UnsupportedStrategyError, require
from ..table import Table
from .parameters import as_design
from .stroke import StrokePoint, as_aggregates, as_stroke

__all__ = ["Constraint", "OptimizationResult", "optimize", "OPTIMIZERS", "GRADIENTS", "FEASIBLE"]

#: The optimisers by name: whether they use gradients, and the extra that provides them.
OPTIMIZERS = {"slsqp": (True, None), "trust-constr": (True, None), "ipopt": (True, "ipopt"), "mma": (True, "nlopt"),
              "cobyla": (False, None), "nelder-mead": (False, None)}
#: How gradients are computed: flexmb's design gradients (adjoint / direct), central differences
#: of plain solves (a reference for benchmarks), or none (derivative-free optimisers).
GRADIENTS = ("adjoint", "central", "none")
#: A constraint's relative margin down to -FEASIBLE counts as met (the optimisers' own tolerance).
FEASIBLE = 1e-6
#: Central differences of plain solves: the step in the scaled variables (a 1e-4 part of the box).
CENTRAL_STEP = 1e-4
#: Designs whose solutions are kept (the last few and the best); older ones keep their numbers only.
KEEP = 4


@attrs.frozen
class Constraint:
    """``lower <= response <= upper`` (either may be None; the response a `flexmb.responses` one or
    a stroke aggregate, `flexmb.design.stroke`); ``name`` for the history (default from the response)."""

    response: object
    upper: float | None = None
    lower: float | None = None
    name: str | None = None

    def __attrs_post_init__(self):
        if self.upper is None and self.lower is None:
            raise ParameterError(f"Constraint on {getattr(self.response, 'name', self.response)!r}: give upper or lower")
        for side in ("upper", "lower"):
            x = getattr(self, side)
            if x is not None and (isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x)):
                raise ParameterError(f"Constraint {side}={x!r} must be a finite number")

    def sides(self) -> list[tuple[str, float]]:
        """``[("<=", upper), (">=", lower)]`` for the sides given."""
        return [(s, float(v)) for s, v in (("<=", self.upper), (">=", self.lower)) if v is not None]



@attrs.frozen(eq=False)
class OptimizationResult:
    """The best design found and how it was found.

    ``p`` the best parameters; ``objective`` its objective (the aggregate's value) and
    ``objective_exact`` (the exact extreme a KS aggregate stands in for); ``constraints`` {name:
    value}; ``feasible``; ``solutions`` the best design's `flexmb.Solution` s (one per stroke
    configuration); ``history`` a `flexmb.Table`, one row per design evaluated (parameters,
    objective, constraint values and margins, gradient norm, cumulative solves, Newton
    iterations and time, ``error`` for a failed design); ``evaluations``, ``solves`` (equilibrium
    solves, those of central differences included), ``iterations`` (the optimiser's),
    ``time`` [s]; ``success``, ``message``, ``interrupted`` (Ctrl-C); ``raw``: the optimiser's own result."""

    p: dict
    objective: float
    objective_exact: float
    constraints: dict
    feasible: bool
    solutions: tuple | None = attrs.field(repr=False)
    history: Table = attrs.field(repr=False)
    evaluations: int
    solves: int
    iterations: int
    time: float
    success: bool
    message: str
    interrupted: bool = False
    optimizer: str = ""
    gradient: str = ""
    raw: object = attrs.field(default=None, repr=False)


class _Entry:
    """One design evaluated: its `StrokePoint`, scaled objective and margins, gradients, history row."""

    def __init__(self, point, row: dict):
        self.point, self.row = point, row
        self.f = self.c = self.df = self.dc = None
        self.failed = False


def _failure_kinds(exc: BaseException) -> bool:
    """Whether ``exc`` is a design that failed (recorded, penalised) rather than a mistake in the
    set-up (raised): unsupported strategies and missing extras are mistakes."""
    return isinstance(exc, Exception) and not isinstance(exc, (UnsupportedStrategyError, MissingExtraError))


class _Problem:
    """The scaled problem the optimisers see, with the cache, the history and the progress bar."""

    def __init__(self, design, lower, upper, aggregates, sign, constraints, stroke, gradient, point_options, bar):
        self.design, self.lower, self.upper = design, lower, upper
        self.names = design.names
        # aggregates: the objective's first; constraints: (index among the aggregates, side, limit, label)
        self.aggregates, self.sign, self.constraints = aggregates, sign, constraints
        self.stroke, self.gradient, self.options, self.bar = stroke, gradient, point_options, bar
        self.cache: OrderedDict = OrderedDict()
        self.rows: list[dict] = []
        self.solves = self.newton = self.iterations = 0
        self.t0 = time.perf_counter()
        self.f0 = None
        self.worst = 0.0
        self.last_good = None
        self.best = None
        self.labels = None
        self.warm_start, self.seed = False, None

    # -- parameters
    def params(self, x) -> dict:
        x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
        return {k: float(lo + xi * (hi - lo)) for k, lo, hi, xi in zip(self.names, self.lower, self.upper, x)}

    def point(self, p: dict) -> StrokePoint:
        seed = self.seed if self.warm_start else None
        return StrokePoint(self.design.build, p, self.aggregates, self.stroke, bounds=self._bounds(), seed=seed,
                           **self.options)

    def _bounds(self) -> dict:
        """The parameters' bounds for the build's difference step, 1 % of the box wider than the box:
        a central difference at a design on a bound (a one-sided one adds round-off, ~1e-11, to the
        rates of numbers that do not change, which a prescribed rotation chain refuses)."""
        pad = 0.01 * (self.upper - self.lower)
        return {k: (lo - d, hi + d) for k, lo, hi, d in zip(self.names, self.lower, self.upper, pad)}

    # -- evaluation
    def freeze_scales(self, x0) -> StrokePoint:
        """The start's point, solved, with the KS aggregates' default scales fixed at the start's
        mean |value| (a fixed scale keeps KS smooth and decouples the configurations: those far
        from the extreme need no gradient). Errors at the start are raised."""
        sp = self.point(self.params(x0))
        x = sp.configuration_values()
        frozen = tuple(attrs.evolve(a, scale=float(np.mean(np.abs(x[:, js]))) or 1.0)
                       if a.kind in ("ks_max", "ks_min") and a.scale is None else a
                       for a, js in zip(self.aggregates, sp._where))
        self.aggregates = sp.aggregates = frozen
        return sp

    def entry(self, x, point: StrokePoint | None = None) -> _Entry:
        p = self.params(x)
        key = tuple(p.values())
        if key in self.cache:
            self.cache.move_to_end(key)
            return self.cache[key]
        e = _Entry(point or self.point(p), dict(p))
        self.cache[key] = e
        self.rows.append(e.row)
        try:
            values, exact = e.point.values()
        except KeyboardInterrupt:
            self._count(e)
            e.failed, e.row["error"] = True, "KeyboardInterrupt: interrupted during this design"
            self._scaled_failure(e)
            raise
        except Exception as exc:
            if not _failure_kinds(exc) or self.f0 is None:
                self.rows.pop()
                del self.cache[key]
                raise
            self._fail(e, exc)
        else:
            self._scale(e, values, exact)
            if e.point.solutions is not None:
                self.seed = tuple(e.point.solutions)
        self._count(e)
        self._forget()
        return e

    def _count(self, e: _Entry) -> None:
        self.solves += e.point.solves
        self.newton += e.point.iterations
        e.row.update(solves=self.solves, newton_iterations=self.newton, time=time.perf_counter() - self.t0)

    def _scale(self, e: _Entry, values, exact) -> None:
        if self.f0 is None:
            self.f0 = abs(values[0]) if values[0] != 0 else 1.0
            self.labels = [label for *_, label in self.constraints]
        e.f = self.sign * values[0] / self.f0
        e.c = np.array([self._margin(values[j], side, limit) for j, side, limit, _ in self.constraints])
        self.worst = max(self.worst, e.f)
        e.row.update(objective=values[0], objective_exact=exact[0])
        for (j, *_), label, m in zip(self.constraints, self.labels, e.c):
            e.row[f"{label}"] = values[j]
            e.row[f"margin {label}"] = m
        feasible = bool(np.all(e.c >= -FEASIBLE))
        e.row.update(feasible=feasible, error="")
        if self.best is None or _better(e, self.best):
            self.best = e

    @staticmethod
    def _margin(value, side, limit) -> float:
        size = abs(limit) if limit != 0 else 1.0
        return (limit - value) / size if side == "<=" else (value - limit) / size

    def _fail(self, e: _Entry, exc: Exception) -> None:
        e.failed = True
        e.row["error"] = f"{type(exc).__name__}: {exc}"
        self._scaled_failure(e)

    def _scaled_failure(self, e: _Entry) -> None:
        e.f = self.worst + 1.0
        e.c = -np.ones(len(self.constraints))
        e.row.update(objective=math.nan, objective_exact=math.nan, feasible=False)

    def _forget(self) -> None:
        """Drop the solutions of designs evaluated long ago (their numbers stay)."""
        for k, (key, e) in enumerate(reversed(self.cache.items())):
            if k >= KEEP and e is not self.best and e.point.solutions is not None and e.df is not None:
                e.point.solutions = None

    def gradients(self, x) -> _Entry:
        e = self.entry(x)
        if e.df is not None:
            return e
        if e.failed:
            src = self.last_good or e
            e.df = np.zeros(len(self.names)) if src.df is None else src.df
            e.dc = np.zeros((len(self.constraints), len(self.names))) if src.dc is None else src.dc
            return e
        J = self._jacobian(e, x)
        span = self.upper - self.lower
        e.df = self.sign * J[0] * span / self.f0
        e.dc = np.array([(-1.0 if side == "<=" else 1.0) * J[j] * span / (abs(limit) if limit != 0 else 1.0)
                         for j, side, limit, _ in self.constraints]).reshape(len(self.constraints), len(self.names))
        e.row["gradient_norm"] = float(np.linalg.norm(e.df))
        self.last_good = e
        self._tick()
        return e

    def _jacobian(self, e: _Entry, x) -> np.ndarray:
        if self.gradient == "adjoint":
            t0 = time.perf_counter()
            J = e.point.jacobian()
            e.row["gradient_time"] = time.perf_counter() - t0
            return J
        return self._central(e, x)

    def _central(self, e: _Entry, x) -> np.ndarray:
        """Central differences of plain solves in the scaled variables, per parameter unit."""
        x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
        cols = []
        for k in range(len(x)):
            vals = []
            for s in (1.0, -1.0):
                xk = x.copy()
                xk[k] += s * CENTRAL_STEP
                sp = self.point(self.params(xk))
                try:
                    vals.append(sp.values()[0])
                finally:
                    self.solves += sp.solves
                    self.newton += sp.iterations
            cols.append((vals[0] - vals[1]) / (2 * CENTRAL_STEP * (self.upper[k] - self.lower[k])))
        e.row.update(solves=self.solves, newton_iterations=self.newton, time=time.perf_counter() - self.t0)
        return np.array(cols).T

    def _tick(self) -> None:
        self.iterations += 1
        if self.bar is not None:
            best = self.best
            self.bar.update(1)
            if best is not None and not best.failed:
                self.bar.set_postfix(objective=f"{best.row['objective']:.6g}", feasible=best.row["feasible"])

    # -- what the optimisers call
    def f(self, x):
        e = self.entry(x)
        if self.gradient == "none":
            self._tick()
        return e.f

    def c(self, x):
        return self.entry(x).c

    def df(self, x):
        return self.gradients(x).df

    def dc(self, x):
        return self.gradients(x).dc

    def table(self) -> Table:
        columns = {"evaluation": np.arange(len(self.rows))}
        keys = list(self.names) + ["objective", "objective_exact"]
        for label in self.labels or []:
            keys += [label, f"margin {label}"]
        keys += ["feasible", "gradient_norm", "gradient_time", "solves", "newton_iterations", "time", "error"]
        for k in keys:
            default = "" if k == "error" else (False if k == "feasible" else math.nan)
            columns[k] = [r.get(k, default) for r in self.rows]
        return Table(columns)


def _better(a: _Entry, b: _Entry) -> bool:
    """Whether design ``a`` is better than ``b``: feasible before infeasible, then the objective
    (feasible) or the largest violation (infeasible)."""
    if a.failed or b.failed:
        return not a.failed
    fa, fb = bool(np.all(a.c >= -FEASIBLE)), bool(np.all(b.c >= -FEASIBLE))
    if fa != fb:
        return fa
    if fa:
        return a.f < b.f
    return float(np.min(a.c)) > float(np.min(b.c))


# -- the optimisers ----------------------------------------------------------------------------------
def _scipy(prob: _Problem, x0, name, max_iter, tol, options):
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    n, m = len(x0), len(prob.constraints)
    if name == "slsqp":
        cons = [{"type": "ineq", "fun": prob.c, "jac": prob.dc}] if m else []
        opts = {"maxiter": max_iter, "ftol": tol, **options}
        return minimize(prob.f, x0, jac=prob.df, method="SLSQP", bounds=[(0.0, 1.0)] * n, constraints=cons,
                        options=opts)
    if name == "trust-constr":
        cons = [NonlinearConstraint(prob.c, 0.0, np.inf, jac=prob.dc)] if m else []
        opts = {"maxiter": max_iter, "gtol": tol, "xtol": tol, **options}
        return minimize(prob.f, x0, jac=prob.df, method="trust-constr", bounds=Bounds(np.zeros(n), np.ones(n)),
                        constraints=cons, options=opts)
    if name == "cobyla":
        box = [{"type": "ineq", "fun": (lambda x, i=i: x[i])} for i in range(n)] + \
              [{"type": "ineq", "fun": (lambda x, i=i: 1.0 - x[i])} for i in range(n)]
        cons = ([{"type": "ineq", "fun": prob.c}] if m else []) + box
        opts = {"maxiter": max_iter, "tol": tol, "rhobeg": 0.1, **options}
        return minimize(prob.f, x0, method="COBYLA", constraints=cons, options=opts)
    opts = {"maxiter": max_iter, "xatol": tol, "fatol": tol, **options}
    return minimize(prob.f, x0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(x0), options=opts)


def _ipopt(prob: _Problem, x0, name, max_iter, tol, options):
    cyipopt = require("cyipopt", "ipopt", "optimizer='ipopt'")
    cons = [{"type": "ineq", "fun": prob.c, "jac": prob.dc}] if prob.constraints else []
    opts = {"max_iter": max_iter, "tol": tol, "hessian_approximation": "limited-memory", "print_level": 0,
            "sb": "yes", **options}
    return cyipopt.minimize_ipopt(prob.f, x0, jac=prob.df, bounds=[(0.0, 1.0)] * len(x0), constraints=cons,
                                  options=opts)


class _NloptResult(dict):
    __getattr__ = dict.get


def _mma(prob: _Problem, x0, name, max_iter, tol, options):
    nlopt = require("nlopt", "nlopt", "optimizer='mma'")
    n, m = len(x0), len(prob.constraints)
    opt = nlopt.opt(nlopt.LD_MMA, n)
    opt.set_lower_bounds(np.zeros(n))
    opt.set_upper_bounds(np.ones(n))

    def objective(x, grad):
        if grad.size:
            grad[:] = prob.df(x)
        return float(prob.f(x))

    def constraints(result, x, grad):  # nlopt: fc(x) <= 0
        if grad.size:
            grad[:] = -prob.dc(x)
        result[:] = -prob.c(x)

    opt.set_min_objective(objective)
    if m:
        opt.add_inequality_mconstraint(constraints, np.full(m, FEASIBLE))
    opt.set_maxeval(max_iter)
    opt.set_ftol_rel(tol)
    opt.set_xtol_rel(options.pop("xtol_rel", tol))
    for key, value in options.items():
        opt.set_param(key, value)
    x = opt.optimize(np.asarray(x0, dtype=float))
    code = opt.last_optimize_result()
    return _NloptResult(x=x, success=code > 0, message=f"nlopt MMA result code {code}", nit=opt.get_numevals())


RUNNERS = {"slsqp": _scipy, "trust-constr": _scipy, "cobyla": _scipy, "nelder-mead": _scipy, "ipopt": _ipopt,
           "mma": _mma}


# -- the entry point ---------------------------------------------------------------------------------
def _checked_bounds(design, bounds) -> tuple[np.ndarray, np.ndarray]:
    """Finite (lower, upper) per parameter from ``bounds`` or the design's own (naming any missing)."""
    bounds = dict(bounds or {})
    stray = [k for k in bounds if k not in design.names]
    if stray:
        raise ParameterError(f"optimize: bounds for unknown design parameter(s) {stray}; parameters: "
                             f"{list(design.names)}")
    lower, upper = [], []
    for q in design.parameters:
        lo, hi = bounds.get(q.name, (q.lower, q.upper))
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ParameterError(f"optimize: design parameter {q.name!r} needs finite bounds lower < upper, got "
                                 f"({lo!r}, {hi!r})")
        if not lo <= q.value <= hi:
            raise ParameterError(f"optimize: design parameter {q.name!r}={q.value!r} outside its bounds ({lo!r}, {hi!r})")
        lower.append(float(lo))
        upper.append(float(hi))
    return np.array(lower), np.array(upper)


def _checked_choice(optimizer: str, gradient: str | None) -> str:
    if optimizer not in OPTIMIZERS:
        raise ParameterError(f"optimize: optimizer={optimizer!r}; valid: {', '.join(OPTIMIZERS)}")
    uses, extra = OPTIMIZERS[optimizer]
    if extra is not None:
        require({"ipopt": "cyipopt", "nlopt": "nlopt"}[extra], extra, f"optimizer={optimizer!r}")
    gradient = ("adjoint" if uses else "none") if gradient is None else gradient
    if gradient not in GRADIENTS:
        raise ParameterError(f"optimize: gradient={gradient!r}; valid: {', '.join(GRADIENTS)}")
    if uses and gradient == "none":
        raise ParameterError(f"optimize: optimizer {optimizer!r} needs gradients; gradient='adjoint' or 'central'")
    if not uses and gradient != "none":
        raise ParameterError(f"optimize: optimizer {optimizer!r} is derivative-free; gradient={gradient!r} is unused")
    return gradient


def _constraint_list(constraints, n_configurations: int):
    """Aggregates of the constraints and ``(index among the aggregates, side, limit, label)`` per side."""
    items, sides = [], []
    for k, c in enumerate(constraints):
        if not isinstance(c, Constraint):
            raise ParameterError(f"optimize: constraint {k} is {c!r}; give flexmb.design.optimize.Constraint("
                                 "response, upper=..., lower=...)")
        items.append(as_aggregates(c.response, n_configurations)[0])
        both = len(c.sides()) > 1
        for side, limit in c.sides():
            label = f"{items[-1].name} {side} {limit:g}" if c.name is None else \
                (f"{c.name} ({side} {limit:g})" if both else c.name)
            sides.append((k + 1, side, limit, label))
    return tuple(items), sides


def optimize(build, p0, bounds=None, *, objective, maximize: bool = False, constraints=(), stroke=None,
             optimizer: str = "slsqp", gradient: str | None = None, max_iter: int = 100, tol: float = 1e-6,
             method: str = "conventional", mode: str = "auto", executor=None, chunks: int | None = None,
             progress: bool | None = None, warm_start: bool = False, optimizer_options: dict | None = None,
             **solve_options) -> OptimizationResult:
    """Optimise the design ``build`` (a function ``p -> Mechanism`` or a `flexmb.design.Design`)
    from ``p0`` (a dict name -> float) within ``bounds`` ({name: (lower, upper)}, finite, for every
    parameter not bounded by its `Design`).

    ``objective``: a response (`flexmb.responses`) or, with a ``stroke``
    (`flexmb.design.stroke.Stroke`), an aggregate over it (`ks_min`, `ks_max`, `mean`, `total`,
    `at`); minimised, or maximised with ``maximize=True``. ``constraints``: `Constraint` s.
    ``optimizer``: ``"slsqp"``, ``"trust-constr"``, ``"ipopt"``, ``"mma"``, ``"cobyla"``,
    ``"nelder-mead"`` (module notes); ``gradient``: ``"adjoint"`` (default for the gradient-based
    ones), ``"central"`` (differences of plain solves, as a reference) or ``"none"``;
    ``max_iter``: the optimiser's iterations (COBYLA, Nelder-Mead, MMA: evaluations); ``tol``
    the optimiser's tolerance on the scaled problem; ``optimizer_options`` go to it.
    ``method``, ``mode``, ``executor``, ``chunks`` and the solver's options as in
    `flexmb.design.stroke.evaluate_stroke`. ``warm_start``: solve each design from the last
    design's converged states (`flexmb.design.stroke.solve_from_design`: a continuation in the
    design space, falling back to the plain solve where it fails); False: every design solved as
    `flexmb.solve` would (plain solves, as a derivative-free baseline's). ``progress``: a progress
    bar of the iterations on stderr (tqdm; None = only on a terminal).

    Returns an `OptimizationResult` (the best design, its solutions and the history). Example::

        result = flexmb.optimize(build, {"t": 1e-3, "L": 0.1}, {"t": (5e-4, 2e-3), "L": (0.05, 0.2)},
                                 objective=R.frequency(1, held=[("B", "rz")]), maximize=True,
                                 constraints=[Constraint(R.stress(), upper=300e6)])
    """
    from tqdm.auto import tqdm

    design = as_design(build, p0)
    gradient = _checked_choice(optimizer, gradient)
    lower, upper = _checked_bounds(design, bounds)
    stroke = as_stroke(stroke)
    n_conf = 1 if stroke is None else len(stroke)
    obj = as_aggregates(objective, n_conf)[0]
    aggregates, sides = _constraint_list(constraints, n_conf)
    if optimizer == "nelder-mead" and sides:
        raise ParameterError("optimize: optimizer 'nelder-mead' takes bounds only, no constraints; use 'cobyla'")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ParameterError(f"optimize: max_iter={max_iter!r} must be an integer >= 1")
    options = dict(method=method, mode=mode, executor=executor, chunks=chunks, eager=gradient == "adjoint", **solve_options)
    bar = tqdm(total=max_iter, desc=f"optimize ({optimizer})", unit="it", leave=False,
               disable=None if progress is None else not progress)
    prob = _Problem(design, lower, upper, (obj,) + aggregates, -1.0 if maximize else 1.0, sides, stroke, gradient,
                    options, bar)
    prob.warm_start = bool(warm_start)
    x0 = (np.array([design.values[k] for k in design.names]) - lower) / (upper - lower)
    try:
        return _run(prob, x0, optimizer, max_iter, tol, dict(optimizer_options or {}))
    finally:
        bar.close()


def _run(prob: _Problem, x0, optimizer, max_iter, tol, options) -> OptimizationResult:
    """Evaluate the start (its errors are raised: nothing to optimise), run the optimiser, and
    gather the result (also after Ctrl-C)."""
    prob.entry(x0, prob.freeze_scales(x0))
    if prob.gradient != "none":
        prob.gradients(x0)
    raw, interrupted = None, False
    try:
        raw = RUNNERS[optimizer](prob, x0, optimizer, max_iter, tol, options)
        message, success = str(getattr(raw, "message", "")), bool(getattr(raw, "success", False))
    except KeyboardInterrupt:
        interrupted, message, success = True, "interrupted (Ctrl-C): the best design so far", False
    return _result(prob, raw, message, success, interrupted, optimizer)


def _result(prob: _Problem, raw, message, success, interrupted, optimizer) -> OptimizationResult:
    best = prob.best
    sols = best.point.solutions
    if sols is None and not interrupted:  # solved on an executor, or forgotten: solve the best design again
        again = prob.point(dict((k, best.row[k]) for k in prob.names))
        again.executor = None
        again.values()
        prob.solves += again.solves
        sols = again.solutions
    labels = prob.labels or []
    cons = {label: float(best.row[label]) for label in labels}
    iterations = int(getattr(raw, "nit", 0) or prob.iterations) if raw is not None else prob.iterations
    return OptimizationResult(
        {k: float(best.row[k]) for k in prob.names}, float(best.row["objective"]), float(best.row["objective_exact"]),
        cons, bool(best.row["feasible"]), None if sols is None else tuple(sols), prob.table(), len(prob.rows),
        prob.solves, iterations, time.perf_counter() - prob.t0, success, message, interrupted, optimizer,
        prob.gradient, raw)

