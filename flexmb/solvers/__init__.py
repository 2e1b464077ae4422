"""Solver strategies and the `solve` front door."""

from __future__ import annotations

from ..compiled import compiled_for
from ..errors import ModelError, ParameterError, UnsupportedStrategyError
from ..plausibility import check
from .conventional import Conventional
from .ksd import KSDFull, KSDReduced
from .newton import Newton

__all__ = ["solve", "make_strategy", "STRATEGIES", "Conventional", "Newton", "KSDReduced", "KSDFull"]

STRATEGIES = {cls.name: cls for cls in (Conventional, Newton, KSDReduced, KSDFull)}
#: the built-in strategies' default instances (frozen attrs values, shared by every solve that gives no
#: options: their validators ran once, not per KSD-reduced solve)
_DEFAULTS: dict = {}
_BUILT_IN = frozenset(STRATEGIES.values())


def solve(mechanism, method: str | object = "conventional", **options):
    """Static equilibrium of ``mechanism`` with strategy ``method`` (a name or a strategy instance).

    ``"conventional"``: Newton with step control on the full finite-element model;
    ``"newton"``: the closed-form linkage model of planar constant-stiffness flexures
    (Cammarata et al. 2022) with ``tangent="full" | "first-term" | "constant"``;
    ``"ksd-reduced"`` / ``"ksd-full"``: the Kinematically Started Deformation method with the
    joint database and EOBs (Dwarshuis et al. 2020), steps 1-4 / 1-5.
    Options go to the strategy's constructor (e.g. ``tol``, ``max_iter``, ``raise_on_failure``);
    every method's options are listed below. ``max_iter`` counts Newton iterations per load step
    (conventional, ksd-full's step 5) or per solve (newton; ksd's step 3); `Solution.iterations`
    is the total. The mechanism is not modified; its compiled model is kept for the next solve
    while it stays unchanged (`flexmb.compiled.compiled_for`). Returns a `flexmb.Solution`.
    """
    strategy = make_strategy(method, options)
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"solve() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    solution = strategy.solve(compiled_for(mechanism, getattr(strategy, "capability", "fe_model")))
    check(solution)  # a ConvergenceWarning or PlausibilityWarning where the answer misleads
    return solution


def make_strategy(method: str | object, options: dict):
    """A strategy instance from a name and constructor options (or an instance without options)."""
    if isinstance(method, str):
        try:
            cls = STRATEGIES[method]
        except KeyError:
            raise UnsupportedStrategyError(
                f"unknown method {method!r}; available: {', '.join(sorted(STRATEGIES))}") from None
        if not options and cls in _BUILT_IN:
            strategy = _DEFAULTS.get(cls)
            if strategy is None:
                strategy = _DEFAULTS[cls] = cls()
            return strategy
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


def _first_sentence(text: str) -> str:
    import re

    text = " ".join(text.split())
    end = re.search(r"(?<!Fig)(?<!Eq)(?<!e\.g)(?<!i\.e)\. (?=[A-Z`(\"])", text)
    return text if end is None else text[:end.start() + 1]


def options_doc(cls) -> list[tuple[str, object, str]]:
    """``(option, default, first sentence of its description)`` of a strategy class, read from
    its attrs fields and the Parameters section of its docstring."""
    import attrs

    lines = (cls.__doc__ or "").splitlines()
    described, names, body = {}, None, []
    for line in lines + ["    X"]:  # a sentinel flushes the last entry
        if line.startswith("    ") and not line.startswith("     ") and line.strip():
            if names:
                for n in names:
                    described[n] = _first_sentence(" ".join(body))
            names, body = [n.strip() for n in line.split(",")], []
        elif line.startswith("        ") and names is not None:
            body.append(line.strip())
    return [(f.name, f.default, described.get(f.name, "")) for f in attrs.fields(cls)]


def _options_section() -> str:
    out = ["", "    Options by method (``option=default``: what it sets):", ""]
    for name, cls in STRATEGIES.items():
        out.append(f"    ``{name}`` (`flexmb.solvers.{cls.__name__}`):")
        out.append("")
        for opt, default, text in options_doc(cls):
            out.append(f"    - ``{opt}={default!r}``: {text}".rstrip(": "))
        out.append("")
    return "\n".join(out)


solve.__doc__ += _options_section()
