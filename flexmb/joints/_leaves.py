"""Checks shared by the joints made of straight rectangular leaves (`CrossFlexure`, `ThreeXInfinity`)."""

from __future__ import annotations

import math

from .. import _validate as v
from ..errors import ParameterError
from ..sections import rectangle
from ..units import check_size

__all__ = ["check_leaves"]


def check_leaves(owner: str, joint, names, widths=("width_inner", "width_outer")) -> None:
    """Checks shared by joints made of straight leaves: the parameters ``names`` positive, the
    leaf ``angle`` in (0, pi/2) rad, ``elements_per_leaf`` >= 1, slender leaves
    (``thickness < length / 10``) and representable rectangular sections of the ``widths``."""
    for name in names:
        v.positive(owner, name, getattr(joint, name))
    v.in_open_range(owner, "angle", joint.angle, 0.0, math.pi / 2, " rad")
    check_size(owner, joint.E, joint.length, stacklevel=5, rules=("GPa",))  # "mm": at add_joint, in its units
    v.integer(owner, "elements_per_leaf", joint.elements_per_leaf, 1, v.MAX_ELEMENTS)
    if not v.real(joint.thickness) < v.real(joint.length) / 10:
        raise ParameterError(f"{owner}: thickness={joint.thickness!r} m is not slender for length={joint.length!r} m "
                             f"(valid range: thickness < length/10 = {v.real(joint.length) / 10:g} m)")
    for wname in widths:  # derived quantities must be representable (extreme magnitudes overflow)
        try:
            rectangle(getattr(joint, wname), joint.thickness, joint.E, joint.G, yield_stress=joint.yield_stress)
        except ParameterError as exc:
            raise ParameterError(f"{owner}: {wname}={getattr(joint, wname)!r} m, thickness={joint.thickness!r} m, "
                                 f"E={joint.E!r} Pa, G={joint.G!r} Pa: {exc}") from None
