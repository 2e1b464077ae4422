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

    def value(self, solution) -> float:
        """The response's value at a converged `flexmb.Solution` (a subclass defines it)."""
        raise ModelError(f"{type(self).__name__} defines no value")

    def partials(self, sens):
        """``(dJ/du (n_dofs,), dJ/dN N' (K,))`` at the sensitivity's state: the derivative with respect
        to the state (rotations per spin) and the model numbers' part per parameter (a subclass
        defines it)."""
        raise ModelError(f"{type(self).__name__} defines no partials")

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        """``dJ/dp`` (K,) through the adjoint or the direct method (`Sensitivity.gradient`)."""
        dJ_du, dJ_dN = self.partials(sens)
        return sens.gradient(dJ_du, dJ_dN, method)
