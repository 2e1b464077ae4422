"""The exception hierarchy: every error flexmb raises on purpose is a `FlexmbError`."""

from __future__ import annotations

__all__ = [
    "FlexmbError",
    "ModelError",
    "ParameterError",
    "TopologyError",
    "UnknownJointError",
    "InvalidJointClassError",
    "UnsupportedStrategyError",
    "ConvergenceError",
    "DatabaseError",
    "MissingExtraError",
    "ConvergenceWarning",
    "DiscretisationWarning",
    "PlausibilityWarning",
    "ExtrapolationWarning",
    "AccuracyError",
    "AccuracyWarning",
]


class FlexmbError(Exception):
    """Root of every error flexmb raises on purpose."""


class ModelError(FlexmbError, ValueError):
    """A mechanism, link, joint or load is defined inconsistently."""


class ParameterError(ModelError):
    """A parameter is outside its valid range (the message names it and the range)."""


class TopologyError(ModelError):
    """The mechanism graph is not solvable as connected (no ground, loose links, loops on a link)."""


class UnknownJointError(ModelError, KeyError):
    """A joint name that no installed plugin provides."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else ""


class InvalidJointClassError(ModelError, TypeError):
    """Something registered as a joint plugin is not a `flexmb.Joint` subclass."""


class UnsupportedStrategyError(FlexmbError):
    """A solver strategy was asked for something the model (or a joint) does not offer."""


class ConvergenceError(FlexmbError):
    """Raised only on request (``raise_on_failure=True``); otherwise ``Solution.converged`` is False."""

    def __init__(self, message: str, solution=None):
        super().__init__(message)
        self.solution = solution


class DatabaseError(FlexmbError):
    """A joint database file is missing, corrupted, stale (trained on another mesh or format), or
    was asked for data it does not hold."""


class AccuracyError(FlexmbError):
    """An approximate strategy's estimated error is above the tolerance asked for (KSD-reduced with
    ``strict_error=True``, `flexmb.ksd.estimate`); ``solution`` holds the answer refused."""

    def __init__(self, message: str, solution=None):
        super().__init__(message)
        self.solution = solution


class AccuracyWarning(UserWarning):
    """An approximate strategy's estimated error is above the tolerance (KSD-reduced's
    ``error_tol``, `flexmb.ksd.estimate`): the answer is returned, but is off by more than asked."""


class ExtrapolationWarning(UserWarning):
    """A joint database was queried outside its trained range (the polynomial is extrapolated)."""


class ConvergenceWarning(UserWarning):
    """A solve returned ``converged=False``: its numbers are those of the last converged load step
    (or NaN), not the answer to the load asked for."""


class PlausibilityWarning(UserWarning):
    """An input or a converged answer outside what the model represents: strains beyond the
    elastic range of a linear-elastic beam, a stress above the given yield stress, a modulus that
    looks like another unit, a parasitic motion the closed-form model does not have."""


class DiscretisationWarning(UserWarning):
    """A result's estimated discretisation error exceeds the accuracy target (`flexmb.accuracy`):
    its mesh is too coarse for it; shown once per kind of result and mesh."""


class MissingExtraError(FlexmbError, ImportError):
    """An optional feature was used without its extra installed (the message names the
    ``pip install 'flexmb[...]'`` command): plots need ``plot``, VTK export ``export``,
    dask-distributed sweeps ``dask``."""


def require(module: str, extra: str, feature: str):
    """Import and return ``module``, or raise `MissingExtraError` naming ``extra``."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(f"{feature} needs {module.split('.')[0]}: "
                                f"python -m pip install 'flexmb[{extra}]'") from exc
