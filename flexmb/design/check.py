"""The public gradient checker: a Taylor test and central differences of plain solves.

Taylor test (Farrell et al. 2013, SIAM J. Sci. Comput. 35(4) C369; as pyadjoint's
``taylor_test``): for a direction ``dp`` and steps ``eps_i = h0 / 2^i``, the remainder
``|J(p + eps dp) - J(p) - eps grad(J) . dp|`` falls as ``eps^2`` when the gradient is right and as
``eps`` when it is not; the rates ``log(r_i / r_(i-1)) / log(eps_i / eps_(i-1))`` over at least four
halvings must be 2. Central differences of plain solves are the second check, per parameter.
Both re-solve the design: they are checks, never the way a gradient is computed.
"""

from __future__ import annotations

import math

import attrs
import numpy as np

from ..errors import ParameterError
from .evaluate import DesignPoint, _read_only

__all__ = ["TaylorResult", "GradientCheck", "taylor_test", "central_differences", "check_gradient"]

#: Remainders below this times the response's size are at the solves' round-off (their default
#: relative tolerance is 1e-9): the response is linear in the direction there (a load's reaction)
#: or constant, and the rate is not defined. The same floor bounds the central differences' noise.
ROUND_OFF = 1e-10


@attrs.frozen(eq=False)
class TaylorResult:
    """A Taylor test's steps ``eps``, ``remainders``, ``rates`` (len(eps) - 1) and its ``rate``
    (the smallest, as pyadjoint reports; NaN where the rates miss 2 but every remainder is
    round-off: a response linear in the direction); ``ok`` when every rate is within ``tolerance``
    of 2, or all remainders are round-off; ``first`` the
    first-order differences ``|J(p + eps dp) - J(p)|``, which fall as ``eps``."""

    eps: np.ndarray = attrs.field(converter=_read_only)
    remainders: np.ndarray = attrs.field(converter=_read_only)
    first: np.ndarray = attrs.field(converter=_read_only)
    rates: np.ndarray = attrs.field(converter=_read_only)
    rate: float
    ok: bool
    value: float
    directional: float
    tolerance: float

    def __str__(self) -> str:
        rows = [f"  eps={e:.3e}  remainder={r:.3e}" for e, r in zip(self.eps, self.remainders)]
        return "\n".join([f"Taylor test: rates {np.round(self.rates, 3).tolist()} (expected 2 +- {self.tolerance}) "
                          f"{'ok' if self.ok else 'FAILED'}"] + rows)


@attrs.frozen(eq=False)
class GradientCheck:
    """`check_gradient`'s result: the ``taylor`` test, the ``gradient`` checked and the central
    differences ``central`` ({parameter: value}, at the step of `CHECK_STEPS` that agrees best),
    ``errors`` per parameter (scaled: ``|g - g_cd| s / max_j |g_j s_j|`` with the parameters'
    scales ``s``), the ``agreement`` asked for, ``ok`` (both checks pass; a parameter agrees within
    ``agreement`` or where ``|g - g_cd| s`` is within the differences' own round-off, `ROUND_OFF`
    ``|J| / relative_step``, e.g. a response that does not depend on it), which parameters agreed
    by ``round_off`` and the relative ``step`` of each parameter's differences."""

    taylor: TaylorResult
    gradient: dict
    central: dict
    errors: dict
    ok: bool
    agreement: float
    #: {parameter: True where gradient and differences differ by no more than the differences' round-off}
    round_off: dict = attrs.field(factory=dict)
    #: {parameter: the relative step of the central differences shown}
    step: dict = attrs.field(factory=dict)

    def __str__(self) -> str:
        rows = [f"  {k}: gradient {self.gradient[k]:.9g}  central differences {self.central[k]:.9g}  "
                f"(step {self.step.get(k, math.nan):g}) error {self.errors[k]:.2e}"
                f"{' (within round-off)' if self.round_off.get(k) else ''}"
                for k in self.gradient]
        good = all(e <= self.agreement or self.round_off.get(k) for k, e in self.errors.items())
        return "\n".join([str(self.taylor), f"central differences (agreement {self.agreement:g}): "
                          f"{'ok' if good else 'FAILED'}"] + rows)


def _scales(point: DesignPoint) -> np.ndarray:
    return np.array([q.step / 1e-5 for q in point.design.parameters])


def _value(point: DesignPoint, p: dict, response, options: dict) -> float:
    from .evaluate import DesignPoint as _DP

    other = _DP(point.design.at(p))
    return float(other.evaluate(response, gradient=False, **options).values[0])


def _gradient(point, response, gradient, options) -> tuple[float, np.ndarray]:
    if gradient is None:
        ev = point.evaluate(response, **options)
        return float(ev.values[0]), ev.jacobian[0]
    value = float(point.evaluate(response, gradient=False, **options).values[0])
    g = gradient(point.design.values) if callable(gradient) else gradient
    missing = [k for k in point.names if k not in g]
    if missing:
        raise ParameterError(f"gradient to check lacks parameter(s) {missing}")
    return value, np.array([float(g[k]) for k in point.names])


def taylor_test(build, p, response, direction=None, *, h0: float = 1e-2, halvings: int = 4, tolerance: float = 0.1,
                seed: int = 0, gradient=None, bounds=None, **options) -> TaylorResult:
    """Taylor test of ``response``'s gradient of the design ``build`` at ``p``.

    ``direction``: {parameter: dp} (default: random, each component between 0.5 and 1 times the
    parameter's scale, random sign); steps ``h0 / 2^i`` for i = 0 .. ``halvings`` (>= 4);
    ``gradient``: a gradient to check ({parameter: dJ/dp} or a function of ``p`` returning one)
    instead of flexmb's own; ``options`` go to the solves (``method``, ``rtol`` ...). Returns a
    `TaylorResult`."""
    if isinstance(halvings, bool) or not isinstance(halvings, int) or halvings < 4:
        raise ParameterError(f"taylor_test: halvings={halvings!r} must be an integer >= 4")
    point = DesignPoint(build, p, bounds)
    names = point.names
    if direction is None:
        rng = np.random.default_rng(seed)
        dp = _scales(point) * rng.uniform(0.5, 1.0, len(names)) * rng.choice([-1.0, 1.0], len(names))
    else:
        unknown = [k for k in direction if k not in names]
        if unknown:
            raise ParameterError(f"taylor_test: direction names unknown parameter(s) {unknown}; parameters: {list(names)}")
        dp = np.array([float(direction.get(k, 0.0)) for k in names])
    value, g = _gradient(point, response, gradient, options)
    slope = float(g @ dp)
    eps = h0 / 2.0 ** np.arange(halvings + 1)
    base = point.design.values
    rem, first = [], []
    for e in eps:
        q = {k: base[k] + e * d for k, d in zip(names, dp)}
        J = _value(point, q, response, options)
        rem.append(abs(J - value - e * slope))
        first.append(abs(J - value))
    rem = np.array(rem)
    rates = np.log(rem[1:] / rem[:-1]) / np.log(eps[1:] / eps[:-1]) if np.all(rem > 0) else \
        np.full(halvings, np.nan)
    floor = ROUND_OFF * max(abs(value), float(np.max(first)), 1e-300)
    converging = bool(np.all(np.abs(rates - 2.0) <= tolerance))
    exact = not converging and bool(np.all(rem <= floor))  # round-off only: a linear response, no rate
    return TaylorResult(eps, rem, first, rates, math.nan if exact else float(np.nanmin(rates)), converging or exact,
                        value, slope, tolerance)


def central_differences(build, p, response, *, relative_step: float = 1e-4, bounds=None, **options) -> dict:
    """``{parameter: (J(p + h e_k) - J(p - h e_k)) / 2h}`` by plain solves, ``h`` = ``relative_step``
    times the parameter's scale (`flexmb.design.Parameter.scale`)."""
    point = DesignPoint(build, p, bounds)
    base = point.design.values
    out = {}
    for k, s in zip(point.names, _scales(point)):
        h = relative_step * s
        J = [_value(point, {**base, k: base[k] + sign * h}, response, options) for sign in (1.0, -1.0)]
        out[k] = (J[0] - J[1]) / (2.0 * h)
    return out


#: Relative steps (times the parameters' scales) of `check_gradient`'s central differences. The
#: smaller is truncation-exact (~1e-8 relative) but carries the solves' round-off divided by the
#: step; the larger the opposite. Measured (FLEXMB_KERNELS=numpy): a KSD-full buckling multiplier
#: (tol 1e-8 N) scatters by 1.4e-10 of its value between neighbouring designs, so its placement
#: derivative (exactly 0 by symmetry; adjoint -1.9e-7) reads -1.07 at 1e-4 and 0.04 at 1e-3; the
#: manipulator's reaction (rtol 1e-11) reads -2.4e-5 / -7.6e-7 for an adjoint 8e-9. A correct
#: gradient agrees with the differences at one of the steps; a wrong one (the mutation tests of
#: tests/test_design_gradients.py) with neither.
CHECK_STEPS = (1e-4, 1e-3)


def check_gradient(build, p, response, *, agreement: float = 1e-6, tolerance: float = 0.1, gradient=None,
                   bounds=None, relative_step=CHECK_STEPS, **options) -> GradientCheck:
    """Taylor test (rates 2 +- ``tolerance``) and agreement with central differences (``agreement``,
    scaled as in `GradientCheck`) of ``response``'s gradient of the design ``build`` at ``p``
    (flexmb's own, or ``gradient`` given as in `taylor_test`). ``relative_step``: one step or
    several (`CHECK_STEPS`); a parameter agrees if it agrees at one of them. Returns a
    `GradientCheck`; its ``ok`` says whether both pass (``str()`` it for a report)."""
    taylor = taylor_test(build, p, response, tolerance=tolerance, gradient=gradient, bounds=bounds, **options)
    point = DesignPoint(build, p, bounds)
    value, g = _gradient(point, response, gradient, options)
    s = _scales(point)
    steps = tuple(np.atleast_1d(np.asarray(relative_step, dtype=float)))
    tried = []
    for h in steps:  # each step: (diff, err, agree, round-off) per parameter
        cd = central_differences(build, p, response, relative_step=h, bounds=bounds, **options)
        c = np.array([cd[k] for k in point.names])
        noise = ROUND_OFF * abs(value) / h  # the differences' round-off, scaled as g s
        size = max(float(np.max(np.abs(g * s))), float(np.max(np.abs(c * s))), 1e-300)
        diff = np.abs(g - c) * s
        tried.append((c, diff / size, (diff / size <= agreement) | (diff <= noise), diff <= noise))
    best = [min(range(len(steps)), key=lambda i: (not tried[i][2][j], tried[i][1][j])) for j in range(len(point.names))]
    pick = lambda field, j: tried[best[j]][field][j]  # noqa: E731
    names = point.names
    return GradientCheck(taylor, {k: float(x) for k, x in zip(names, g)},
                         {k: float(pick(0, j)) for j, k in enumerate(names)},
                         {k: float(pick(1, j)) for j, k in enumerate(names)},
                         bool(taylor.ok and all(pick(2, j) for j in range(len(names)))), agreement,
                         {k: bool(pick(3, j)) for j, k in enumerate(names)},
                         {k: steps[best[j]] for j, k in enumerate(names)})
