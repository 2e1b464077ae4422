"""Solver strategies and the `solve` front door."""

from __future__ import annotations

from ..errors import ModelError, ParameterError, UnsupportedStrategyError
from .conventional import Conventional
from .ksd import KSDFull, KSDReduced
from .newton import Newton

__all__ = ["solve", "make_strategy", "STRATEGIES", "Conventional", "Newton", "KSDReduced", "KSDFull"]

STRATEGIES = {cls.name: cls for cls in (Conventional, Newton, KSDReduced, KSDFull)}


def solve(mechanism, method: str | object = "conventional", **options):
    """Static equilibrium of ``mechanism`` with strategy ``method`` (a name or a strategy instance).

    ``"conventional"``: Newton with step control on the full finite-element model;
    ``"newton"``: the closed-form linkage model of planar constant-stiffness flexures
    (Cammarata et al. 2022) with ``tangent="full" | "first-term" | "constant"``;
    ``"ksd-reduced"`` / ``"ksd-full"``: the Kinematically Started Deformation method with the
    joint database and EOBs (Dwarshuis et al. 2020), steps 1-4 / 1-5.
    Options go to the strategy's constructor (e.g. ``tol``, ``max_iter``, ``raise_on_failure``).
    The mechanism is not modified. Returns a `flexmb.Solution`.
    """
    strategy = make_strategy(method, options)
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"solve() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    return strategy.solve(mechanism.compile(getattr(strategy, "capability", "fe_model")))


def make_strategy(method: str | object, options: dict):
    """A strategy instance from a name and constructor options (or an instance without options)."""
    if isinstance(method, str):
        try:
            cls = STRATEGIES[method]
        except KeyError:
            raise UnsupportedStrategyError(
                f"unknown method {method!r}; available: {', '.join(sorted(STRATEGIES))}") from None
        try:
            strategy = cls(**options)
        except TypeError as exc:
            raise UnsupportedStrategyError(f"method {method!r}: {exc}") from None
        except ValueError as exc:  # attrs validators of the options
            raise ParameterError(f"method {method!r}: invalid option: {exc}") from None
    elif not callable(getattr(method, "solve", None)):
        raise UnsupportedStrategyError(
            f"method must be a name ({', '.join(sorted(STRATEGIES))}) or a strategy object, got {method!r}")
    else:
        if options:
            raise UnsupportedStrategyError("options are given with a method name, not with a strategy instance")
        strategy = method
    return strategy
