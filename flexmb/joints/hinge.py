"""Ideal revolute joint [``hinge``]: a pin, a pin support, a pseudo-rigid-body pivot or a motor."""

from __future__ import annotations

import math
from typing import ClassVar

import attrs
import numpy as np

from .. import _validate as v
from ._base import Joint

__all__ = ["Hinge"]


@attrs.frozen(kw_only=True, cache_hash=True)
class Hinge(Joint):
    """Ideal revolute joint [``hinge``] at the joint frame's origin, turning about its z axis.

    The two links share the joint origin and, in 3D, the joint frame's z axis, exactly, at any
    rotation (constraint equations with Lagrange multipliers, `flexmb.fe.ideal`). The relative
    rotation about the axis is free, resisted by the torsional spring ``k``, or driven by a motor.
    A pin support is a hinge to a fixed link. Placed with
    ``m.add_joint(a, b, "hinge", origin=..., rotation=...)`` (``rotation`` turns the frame's z axis
    in 3D; in 2D the axis is the plane's normal).

    Parameters
    ----------
    k
        Torsional stiffness [moment/rad] (0: a free pin), >= 0: the moment ``k theta`` of the relative
        rotation ``theta`` of B from A (pseudo-rigid-body models); ``theta`` counts turns past pi in
        3D as in 2D (the solution tracks it along its increments).
    angle
        Motor: the relative rotation [rad] of B from A about the axis, reached at load factor 1
        (ramped with the load factor like `Mechanism.prescribe`), or ``None`` (no motor). The
        motor's moment is the hinge's reaction.
    """

    kind: ClassVar[str] = "hinge"
    motion_range: ClassVar[float] = 1.0
    #: the conformance kit's joint mechanism (B on A through the hinge alone) needs a spring: a free
    #: pin there is a free motion, refused
    parameter_ranges: ClassVar[dict] = {"k": (0.5, 50.0)}

    k: float = 0.0
    angle: float | None = None

    def __attrs_post_init__(self):
        v.nonnegative("hinge", "k", self.k)
        if self.angle is not None:
            v.finite("hinge", "angle", self.angle)  # bools and NaN raise ParameterError
            if abs(self.angle) > 2.0 * math.pi:  # allowed (a motor may wind), but often degrees
                import warnings

                from ..errors import PlausibilityWarning

                warnings.warn(f"hinge: angle={self.angle!r} rad is {abs(self.angle) / (2 * math.pi):.3g} turns; angles "
                              f"are in radians (for {self.angle!r} degrees give {math.radians(self.angle):.6g})",
                              PlausibilityWarning, stacklevel=3)

    @property
    def capabilities(self) -> frozenset[str]:
        return frozenset({"ideal"})

    def interface_b(self, dim: int) -> np.ndarray:
        """Node B coincides with node A at the joint origin."""
        return np.zeros(dim)

    @property
    def motor(self) -> float:
        """Motor angle [rad] at load factor 1, NaN without a motor."""
        return math.nan if self.angle is None else float(self.angle)
