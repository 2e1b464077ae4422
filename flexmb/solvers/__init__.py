"""Solver strategies and the `solve` front door."""

from __future__ import annotations

from ..errors import ModelError, ParameterError, UnsupportedStrategyError
from .conventional import Conventional

__all__ = ["solve", "STRATEGIES", "Conventional"]

STRATEGIES = {Conventional.name: Conventional}


def solve(mechanism, method: str | object = "conventional", **options):
    """Static equilibrium of ``mechanism`` with strategy ``method`` (a name or a strategy instance).

    Options go to the strategy's constructor (e.g. ``tol``, ``max_iter``, ``raise_on_failure``).
    The mechanism is not modified. Returns a `flexmb.Solution`.
    """
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
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"solve() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    return strategy.solve(mechanism.compile())
