"""Names of a node's DOF components, shared by the responses."""

from __future__ import annotations

from ..errors import ParameterError

__all__ = ["component_index"]

_COMPONENTS = {2: {"x": 0, "y": 1, "rotation": 2}, 3: {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}}


def component_index(dim: int, component: str, owner: str) -> int:
    """The DOF offset of ``component`` in a node's DOFs (`ParameterError` naming the valid ones)."""
    comps = _COMPONENTS[dim]
    if component not in comps:
        raise ParameterError(f"{owner}: component={component!r}; valid in {dim}D: {', '.join(comps)}")
    return comps[component]
