"""`value_and_grad` and `evaluate`: responses of a design and their gradients at a converged state.

One `DesignPoint` per design and parameter values keeps what does not depend on the configuration
(the build, the model numbers' rates); each configuration (the design's own, or one changed by a
``configure(mechanism)`` function: another prescribed position or load level) is solved once,
linearised once (`flexmb.design.adjoint.Sensitivity`: one factorisation), and every response's
gradient is read from it.
"""

from __future__ import annotations

import copy
import time

import attrs
import numpy as np

from ..boundary import boundary
from ..errors import ConvergenceError, ParameterError, UnsupportedStrategyError
from ..ksd.linearisation import ReducedSolution
from ..linear import single_threaded
from .adjoint import STRATEGIES, Sensitivity, full_model
from .builds import model_rates
from .parameters import ModelRates, as_design, model_numbers

__all__ = ["Evaluation", "DesignPoint", "evaluate", "value_and_grad"]

MODES = ("auto", "adjoint", "direct")


def _read_only(a) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.flags.writeable = False
    return out


@attrs.frozen(eq=False)
class Evaluation:
    """Responses of one configuration of a design and their gradients.

    ``names``: the parameters (K,); ``responses``: the responses' names (R,); ``values`` (R,);
    ``jacobian`` (R, K) (None without gradients); ``solution``: the converged `flexmb.Solution`;
    ``times`` [s]: ``"solve"``, ``"rates"`` (this call's part of the model numbers' rates: the
    builds' differences on a design's first gradient, shared by its configurations), ``"gradient"``."""

    names: tuple
    responses: tuple
    values: np.ndarray = attrs.field(converter=_read_only)
    jacobian: np.ndarray | None = attrs.field(converter=lambda a: None if a is None else _read_only(a))
    solution: object = attrs.field(repr=False)
    times: dict = attrs.field(factory=dict)

    def gradient(self, response: int | str = 0) -> dict:
        """``{parameter: dJ/dp}`` of one response (by position or name)."""
        i = self.responses.index(response) if isinstance(response, str) else int(response)
        if self.jacobian is None:
            raise ParameterError("this evaluation was made without gradients (gradient=False)")
        return {k: float(g) for k, g in zip(self.names, self.jacobian[i])}


def _responses(responses) -> tuple:
    items = (responses,) if hasattr(responses, "value") else tuple(responses)
    for r in items:
        if not (hasattr(r, "value") and hasattr(r, "gradient")):
            raise ParameterError(f"{r!r} is not a response (flexmb.responses.*: value and gradient)")
    if not items:
        raise ParameterError("no responses given")
    return items


class _Configured(ModelRates):
    """`ModelRates` whose boundary fields (prescribed values, loads) come from the perturbed
    mechanisms after ``configure``."""

    BOUNDARY = ("values", "load_offset", "load_force", "load_moment")

    def __init__(self, base: ModelRates, configure, compiled):
        super().__init__(base.design, compiled, base._builds)
        self._base, self._configure = base, configure

    @property
    def shared(self) -> dict:
        """The base's cache: what does not depend on the configuration is kept once per design."""
        return self._base.shared

    def rate(self, field: str) -> np.ndarray:
        if field not in self.BOUNDARY:
            return self._base.rate(field)
        if field not in self._cache:
            self._boundary_rates()
        return self._cache[field]

    def compiled_numbers(self, field: str) -> np.ndarray:
        if field not in self.BOUNDARY:
            return self._base.compiled_numbers(field)
        return super().compiled_numbers(field)

    def _boundary_rates(self) -> None:
        """The boundary fields' rates: ``configure`` on a copy of each parameter's builds (its
        complex-step mechanism, or the real ones of its central differences), their boundaries
        combined (`flexmb.design.builds.ParameterBuild.combine`). A ``configure`` that cannot carry
        a complex step (a ``TypeError``, numpy's ``ComplexWarning``: ``float()`` of a position)
        takes central differences of the build for that parameter (`ModelRates.fallback`); one that
        drops it silently (``.real``, ``abs()``) is caught along the design's check direction
        (`ModelRates.direction`), and then every parameter takes them."""
        base = {f: model_numbers(self.compiled, f) for f in self.BOUNDARY}
        out = {f: np.zeros((len(self.names),) + np.shape(base[f])) for f in self.BOUNDARY}
        for k, b in enumerate(self._builds):
            try:
                rows = self._combined(b, k, base)
            except _DropsStep:
                rows = self._combined(self._base.fallback(k), k, base)
            for f in self.BOUNDARY:
                out[f][k] = rows[f]
        if not self._direction_agrees(out, base):
            for k in range(len(self.names)):
                rows = self._combined(self._base.fallback(k), k, base)
                for f in self.BOUNDARY:
                    out[f][k] = rows[f]
        for f in self.BOUNDARY:
            out[f].flags.writeable = False
            self._cache[f] = out[f]

    def _combined(self, build, k: int, base: dict) -> dict:
        """``{field: rate}`` of the boundary fields of parameter ``k``'s ``build`` after ``configure``."""
        from .builds import COMPLEX_STEP

        if build.method == COMPLEX_STEP:  # one mechanism: its imaginary parts over the step
            ((_, mech, _),) = build.points
            out = self._configured(mech, k, base)
            return {f: (np.imag(v) / build.h if np.iscomplexobj(v) else np.zeros(np.shape(v))) for f, v in out.items()}
        seen = {}

        def read(mech, f):
            if id(mech) not in seen:
                seen[id(mech)] = self._configured(mech, k, base)
            return seen[id(mech)][f]

        return {f: build.combine(lambda mech, _, f=f: read(mech, f)) for f in self.BOUNDARY}

    def _direction_agrees(self, out: dict, base: dict) -> bool:
        """Whether the boundary rates ``out`` agree along the design's check direction with central
        differences of its real builds after ``configure`` (`flexmb.design.builds.agrees`)."""
        from .builds import agrees

        if self._base.direction is None:
            return True
        d, points = self._base.direction
        configured = [(w, self._configured(mech, None, base)) for w, mech in points]
        return all(agrees(sum(w * np.real(c[f]) for w, c in configured), np.tensordot(d, out[f], axes=1),
                          float(np.abs(base[f]).max(initial=0.0))) for f in self.BOUNDARY)

    def _configured(self, mech, k, base: dict) -> dict:
        """The boundary fields of ``configure`` applied to a copy of ``mech`` (parameter ``k``'s build;
        `_DropsStep` where a complex one cannot pass)."""
        import warnings

        from .. import _validate as v

        mech = _copy_mechanism(mech)  # a copy: configure may add loads, and the builds serve every configuration
        with warnings.catch_warnings(), v.complex_step():
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
            try:
                self._configure(mech)
                _, vals, loads, _ = boundary(mech, self.compiled.link_node)
            except (TypeError, np.exceptions.ComplexWarning) as exc:
                raise _DropsStep() from exc
        out = dict(zip(self.BOUNDARY, (vals, loads.offset, loads.force, loads.moment)))
        for f, value in out.items():
            if np.shape(value) != np.shape(base[f]):
                which = "the design's" if k is None else f"parameter {self.names[k]!r}'s"
                raise ParameterError(f"configure: the configured mechanism's {f} differ in shape between the design "
                                     f"and {which} build; configure may set prescribed values and loads, the same "
                                     "ones for every design")
        return out


class _DropsStep(Exception):
    """``configure`` cannot carry a complex step (its cause: the ``TypeError`` or ``ComplexWarning``)."""


def _copy_mechanism(mech):
    """A copy of a `flexmb.Mechanism` that its methods can change without touching ``mech``: its
    graph (links, joints, placements: `Mechanism.add_link`, `add_joint`, `fix`), loads (`apply_force`,
    `apply_moment`, `clear_loads`), prescribed motions (`prescribe`) and points (`add_point`) in new
    containers, their immutable items shared (``copy.deepcopy`` took over a hundred times longer on the 3D
    hinge's builds). Another class of mechanism is deep-copied."""
    if not all(hasattr(mech, k) for k in ("graph", "_loads", "_prescribed", "_points")):
        return copy.deepcopy(mech)
    out = copy.copy(mech)
    out.graph = mech.graph.copy()
    out._loads = list(mech._loads)
    out._prescribed = {k: dict(v) for k, v in mech._prescribed.items()}
    out._points = dict(mech._points)
    return out


class DesignPoint:
    """A design at parameter values ``p``: its mechanism and, on first need, the rates of its
    model's numbers (`flexmb.design.builds.model_rates`, shared by every configuration)."""

    def __init__(self, build, p=None, bounds=None):
        self.design = as_design(build, p, bounds)
        self.names = self.design.names
        self._rates = None
        self._built = None  # one build of the design, copied for each configuration (`_configured`)
        self.rates_time = 0.0

    def rates(self, compiled) -> ModelRates:
        """The model numbers' rates about the design's own compiled model (built once)."""
        if self._rates is None:
            t0 = time.perf_counter()
            base = compiled if compiled is not None else self.design.mechanism().compile("fe_model")
            self._rates = model_rates(self.design, base)
            self.rates_time = time.perf_counter() - t0
        return self._rates

    def mechanism(self, configure=None):
        """A new mechanism of the design, changed by ``configure(mechanism)`` if given."""
        mech = self.design.mechanism()
        if configure is not None:
            configure(mech)
        return mech

    def _configured(self, configure):
        """The design's mechanism changed by ``configure``: a copy (`_copy_mechanism`) of one build of
        the design kept for this (the build is a function of ``p``: a copy is another build)."""
        if self._built is None:
            self._built = self.design.mechanism()
        mech = _copy_mechanism(self._built)
        configure(mech)
        return mech

    def evaluate(self, responses, *, configure=None, solution=None, method: str = "conventional",
                 gradient: bool = True, mode: str = "auto", **options) -> Evaluation:
        """Solve the configuration (or take the converged ``solution`` of it) and evaluate
        ``responses`` with their gradients (``mode``: ``"adjoint"``, ``"direct"`` or ``"auto"``:
        adjoint while there are fewer responses of the adjoint kind than parameters)."""
        from ..solvers import solve

        items = _responses(responses)
        if mode not in MODES:
            raise ParameterError(f"mode={mode!r}; valid: {', '.join(MODES)}")
        t0 = time.perf_counter()
        if solution is None:
            solution = solve(self.mechanism(configure), method=method, **options)
        t1 = time.perf_counter()
        if not solution.converged:
            raise ConvergenceError(f"the design at {self.design.values} did not converge ({solution.message}); "
                                   "no responses or gradients of an unconverged state", solution)
        if not (full_model(solution) or _reduced(solution)):  # refused naming the method and each parameter's kind
            if gradient:
                Sensitivity(solution, self.rates(None))
            raise UnsupportedStrategyError(f"design responses with method {solution.method!r}: available for "
                                           f"{', '.join(STRATEGIES)} (the full finite-element equilibrium)")
        with single_threaded():  # small dense LAPACK (modes, factorisations): threads only wait for a busy core
            return self._evaluate(items, solution, configure, gradient, mode, t1 - t0)

    def _evaluate(self, items, solution, configure, gradient, mode, t_solve) -> Evaluation:
        values = np.array([r.value(solution) for r in items], dtype=float)
        times = {"solve": t_solve}
        if not gradient:
            return Evaluation(self.names, tuple(r.name for r in items), values, None, solution, times)
        t2 = time.perf_counter()
        # the rates are taken about fresh compiles (totals from the undeformed state: a warm-started
        # solution's problem holds increments of its prescribed values)
        rates = self.rates(None)
        if configure is not None:
            rates = _Configured(rates, configure, self._configured(configure).compile("fe_model"))
        t3 = time.perf_counter()
        _same_model(rates.compiled, solution, self.design.values)
        sens = _sensitivity(solution, rates, items)
        if mode == "auto":
            mode = "direct" if len(items) > len(self.names) else "auto"
        jac = np.array([r.gradient(sens, mode) for r in items], dtype=float).reshape(len(items), len(self.names))
        times.update(rates=t3 - t2, gradient=time.perf_counter() - t3)
        return Evaluation(self.names, tuple(r.name for r in items), values, jac, solution, times)


def _same_model(compiled, solution, values) -> None:
    """Refuse a ``solution`` that is not of the design's (configured) mechanism: another structure or
    other reference numbers (another design, or the same one at other parameters)."""
    from .parameters import structure

    mine, theirs = compiled.problem.model, solution.compiled.problem.model
    a, b = structure(compiled), structure(solution.compiled)
    same = all(np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray) else a[k] == b[k]
               for k in a if k != "prescribed DOFs")
    same = same and mine.x0.shape == theirs.x0.shape and np.array_equal(mine.x0, theirs.x0) and \
        np.array_equal(mine.elements.L0, theirs.elements.L0) and np.array_equal(mine.elements.S, theirs.elements.S)
    if not same:
        raise ParameterError(f"the solution given is not one of the design at {values} (its model's structure or "
                             "reference numbers differ): pass a solve of DesignPoint.mechanism(configure)")


def _reduced(solution) -> bool:
    """Whether ``solution`` is KSD-reduced's solution kind (`flexmb.ksd.linearisation.ReducedSolution`)."""
    return isinstance(solution, ReducedSolution)


def _sensitivity(solution, rates, items):
    """The linearisation of ``solution`` for the responses ``items``: `Sensitivity` of the full
    model; a KSD-reduced solution's `flexmb.design.reduced.ReducedSensitivity` (loads only)."""
    if not _reduced(solution):
        return Sensitivity(solution, rates)
    from .reduced import ReducedSensitivity

    sens = ReducedSensitivity(solution, rates)
    for r in items:
        sens.check_response(r)
    return sens


def evaluate(build, p, responses, *, bounds=None, **options) -> Evaluation:
    """Responses of the design ``build`` (a function ``p -> Mechanism`` or a `Design`) at ``p`` (a
    dict name -> float) with their gradients; options as in `DesignPoint.evaluate` (``method``,
    ``mode``, ``configure``, ``gradient``, the solver's options)."""
    return DesignPoint(build, p, bounds).evaluate(responses, **options)


def value_and_grad(build, p, response, **options):
    """``(value, {parameter: dJ/dp})`` of one response (`flexmb.responses`) of the design ``build``
    at ``p``, solved with ``method`` (default ``"conventional"``; ``"ksd-full"`` too). Example::

        value, grad = flexmb.value_and_grad(build, {"t": 1e-3, "L": 0.1},
                                            flexmb.responses.reaction("B", "rz"))
    """
    ev = evaluate(build, p, response, **options)
    return float(ev.values[0]), ev.gradient(0)
