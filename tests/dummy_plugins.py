"""Fabricated joint plugins for `tests/test_registry.py` (the pattern of xarray's ``tests/test_plugins.py``).

Entry points such as ``EntryPoint("dummy", "tests.dummy_plugins:Good", "flexmb.joints")`` point here.

* `Good`: the smallest valid `flexmb.Joint`: one straight beam element from node A (origin) to
  node B at ``(length, 0[, 0])``, shear deformation switched off (``ky = kz = inf``) so its
  small-load tip deflection is exactly the Euler-Bernoulli cantilever ``P L^3 / (3 E I)``.
* `NotAJoint`: a class with the right method names that does not subclass `flexmb.Joint`.
* `not_a_class`: a function, not a class at all.
"""

from __future__ import annotations

import math
from typing import ClassVar

import attrs
import numpy as np

from flexmb.joints import SIDE_A, SIDE_B, Joint, JointMesh
from flexmb.sections import Section

__all__ = ["Good", "NotAJoint", "not_a_class"]


@attrs.frozen(kw_only=True)
class Good(Joint):
    """One straight Euler-Bernoulli beam element [``dummy``]: a minimal third-party joint.

    Parameters
    ----------
    length
        Length [m] (0.1).
    width, thickness
        Rectangular cross-section [m] (0.02, 1e-3); width along the joint frame's z axis.
    E, G
        Young's and shear modulus [Pa] (200e9, 76.9e9).
    """

    kind: ClassVar[str] = "dummy"

    length: float = 0.1
    width: float = 0.02
    thickness: float = 1e-3
    E: float = 200e9
    G: float = 76.9e9

    @property
    def Iz(self) -> float:
        """Compliant second moment of area ``w t^3 / 12`` [m^4] (bending in the xy-plane)."""
        return self.width * self.thickness**3 / 12.0

    def interface_b(self, dim: int) -> np.ndarray:
        b = np.zeros(dim, dtype=np.result_type(self.length))  # complex where length is (a complex-step build)
        b[0] = self.length
        return b

    def mesh(self, dim: int) -> JointMesh:
        w, t = self.width, self.thickness
        section = Section(E=self.E, G=self.G, A=w * t, Iy=t * w**3 / 12.0, Iz=self.Iz,
                          It=w * t**3 / 3.0, ky=math.inf, kz=math.inf)  # thin-strip torsion constant
        return JointMesh(
            points=np.stack([np.zeros(dim), self.interface_b(dim)]),
            side=np.array([SIDE_A, SIDE_B]),
            elements=np.array([[0, 1]]),
            sections=(section,),
            ny0=np.array([[0.0, 1.0, 0.0]]) if dim == 3 else None,  # local y (thickness) along global y
        )


class NotAJoint:
    """Looks like a joint (``kind``, ``interface_b``, ``mesh``) but does not subclass `flexmb.Joint`."""

    kind = "not_a_joint"

    def interface_b(self, dim: int) -> np.ndarray:
        return np.zeros(dim)

    def mesh(self, dim: int):
        raise NotImplementedError


def not_a_class(**params):
    """A factory function: entry points must name a `flexmb.Joint` subclass, not a callable."""
    return Good(**params)
