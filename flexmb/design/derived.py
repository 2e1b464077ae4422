"""Responses derived from another: the reciprocal (a stiffness from a compliance entry)."""

from __future__ import annotations

import attrs
import numpy as np

from ..errors import ModelError, ParameterError

__all__ = ["reciprocal", "support_stiffness"]


@attrs.frozen
class _Reciprocal:
    response: object

    def __attrs_post_init__(self):
        if not (hasattr(self.response, "value") and hasattr(self.response, "gradient")):
            raise ParameterError(f"reciprocal: {self.response!r} is not a response (flexmb.responses.*)")

    @property
    def name(self) -> str:
        return f"1/{self.response.name}"

    def value(self, solution) -> float:
        x = float(self.response.value(solution))
        if x == 0.0:
            raise ModelError(f"reciprocal: {self.response.name} is zero (no finite reciprocal)")
        return 1.0 / x

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        """``d(1/J)/dp = -J' / J^2``."""
        x = float(self.response.value(sens.solution))
        if x == 0.0:
            raise ModelError(f"reciprocal: {self.response.name} is zero (no derivative of its reciprocal)")
        return -np.asarray(self.response.gradient(sens, method), dtype=float) / (x * x)


def reciprocal(response):
    """``1 / response`` with its gradient ``-J' / J^2`` (e.g. a stiffness from a compliance entry)."""
    return _Reciprocal(response)


def support_stiffness(link: str, component: str, point=None, axes: str = "global", held="prescribed"):
    """The support stiffness [N/m or N m/rad] of ``link``'s point along ``component``: the reciprocal
    of the compliance's diagonal entry (`flexmb.responses.compliance`), i.e. the force per unit
    displacement along it with every other component free to follow (not the stiffness matrix's
    entry, which holds them)."""
    from .eigen import compliance

    return _Reciprocal(compliance(link, component, component, point=point, axes=axes, held=held))
