"""What every response shares: the names of a node's DOF components and the `Response` base."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError, ParameterError

__all__ = ["component_index", "Response"]

_COMPONENTS = {2: {"x": 0, "y": 1, "rotation": 2}, 3: {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}}


def component_index(dim: int, component: str, owner: str) -> int:
    """The DOF offset of ``component`` in a node's DOFs (`ParameterError` naming the valid ones)."""
    comps = _COMPONENTS[dim]
    if component not in comps:
        raise ParameterError(f"{owner}: component={component!r}; valid in {dim}D: {', '.join(comps)}")
    return comps[component]


class Response:
    """Base of the responses that are functions ``J(u, N)`` of the state and the model numbers:
    subclasses give ``value`` and ``partials(sensitivity) -> (dJ/du (n_dofs,), dJ/dN N' (K,))``."""

    name = "response"

    def value(self, solution) -> float:  # pragma: no cover - every subclass defines it
        """The response's value at the converged ``solution``."""
        raise ModelError(f"{type(self).__name__} defines no value")

    def partials(self, sens):  # pragma: no cover - every subclass defines it
        """``(dJ/du (n_dofs,), dJ/dN . dN/dp (K,))`` at the state of ``sens`` (a
        `flexmb.design.adjoint.Sensitivity`): the explicit partial derivatives the adjoint combines."""
        raise ModelError(f"{type(self).__name__} defines no partials")

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        """``dJ/dp`` (K,) through the adjoint or the direct method (`Sensitivity.gradient`)."""
        dJ_du, dJ_dN = self.partials(sens)
        return sens.gradient(dJ_du, dJ_dN, method)
