"""`value_and_grad` and `evaluate`: responses of a design and their gradients at a converged state.

One `DesignPoint` per design and parameter values keeps what does not depend on the configuration
(the build, the model numbers' rates); each configuration (the design's own, or one changed by a
``configure(mechanism)`` function: another prescribed position or load level) is solved once,
linearised once (`flexmb.design.adjoint.Sensitivity`: one factorisation), and every response's
gradient is read from it.
"""

from __future__ import annotations

import time

import attrs
import numpy as np

from ..boundary import boundary
from ..errors import ConvergenceError, ParameterError, UnsupportedStrategyError
from .adjoint import STRATEGIES, Sensitivity
from .parameters import ModelRates, as_design, model_numbers, model_rates

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
    ``times`` [s]: ``"solve"``, ``"rates"`` (the build's differences, shared by a design's
    configurations), ``"gradient"``."""

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
        self._cache = {k: v for k, v in base._cache.items() if k not in self.BOUNDARY}

    def rate(self, field: str) -> np.ndarray:
        if field not in self.BOUNDARY:
            return self._base.rate(field)
        if field not in self._cache:
            self._boundary_rates()
        return self._cache[field]

    def _boundary_rates(self) -> None:
        link_node = self.compiled.link_node

        def numbers(mech):
            _, vals, loads, _ = boundary(mech, link_node)
            return {"values": vals, "load_offset": loads.offset, "load_force": loads.force,
                    "load_moment": loads.moment}

        base = {f: model_numbers(self.compiled, f) for f in self.BOUNDARY}
        out = {f: np.zeros((len(self.names),) + np.shape(base[f])) for f in self.BOUNDARY}
        for k, (_, h) in enumerate(self._builds):
            for w, mech in self._base._mechanisms[k]:
                if mech is not None:
                    self._configure(mech)
                nums = base if mech is None else numbers(mech)
                for f in self.BOUNDARY:
                    out[f][k] += w * np.asarray(nums[f], dtype=float) / h
        for f in self.BOUNDARY:
            out[f].flags.writeable = False
            self._cache[f] = out[f]


class DesignPoint:
    """A design at parameter values ``p``: its mechanism and, on first need, the rates of its
    model's numbers (`flexmb.design.parameters.model_rates`, shared by every configuration)."""

    def __init__(self, build, p=None, bounds=None):
        self.design = as_design(build, p, bounds)
        self.names = self.design.names
        self._rates = None
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
        if solution.method not in STRATEGIES:  # refused naming the method (and, with gradients, each parameter's kind)
            if gradient:
                Sensitivity(solution, self.rates(None))
            raise UnsupportedStrategyError(f"design responses with method {solution.method!r}: available for "
                                           f"{', '.join(STRATEGIES)} (the full finite-element equilibrium)")
        values = np.array([r.value(solution) for r in items], dtype=float)
        times = {"solve": t1 - t0}
        if not gradient:
            return Evaluation(self.names, tuple(r.name for r in items), values, None, solution, times)
        t2 = time.perf_counter()
        rates = self.rates(None if configure is not None else solution.compiled)
        if configure is not None:
            rates = _Configured(rates, configure, solution.compiled)
        t3 = time.perf_counter()
        sens = Sensitivity(solution, rates)
        if mode == "auto":
            mode = "direct" if len(items) > len(self.names) else "auto"
        jac = np.array([r.gradient(sens, mode) for r in items], dtype=float).reshape(len(items), len(self.names))
        times.update(rates=self.rates_time + (t3 - t2), gradient=time.perf_counter() - t3)
        return Evaluation(self.names, tuple(r.name for r in items), values, jac, solution, times)


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
