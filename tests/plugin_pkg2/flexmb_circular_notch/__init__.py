"""A right circular notch hinge as a third-party flexmb joint: the worked example of
docs/plugins.md ("Writing your own joint"), installed in the test run through its entry point.

The notch is a beam of variable thickness ``t(x) = t + 2R - 2 sqrt(R^2 - (x - R)^2)`` over
``0 <= x <= 2R`` (Paros & Weisbord 1965's right circular hinge cut from a blank ``t + 2R`` thick),
clamped in the links at both ends. Its elements crowd where it is thinnest, each element's
stiffness is the exact average of its variable section, and its stresses are recovered at the
section where it is thinnest, with a node at the throat.
"""

from __future__ import annotations

import math
from typing import ClassVar

import attrs
import numpy as np
from scipy.optimize import brentq

import flexmb
from flexmb.joints import INTERNAL, SIDE_A, SIDE_B, JointMesh
from flexmb.joints import validate as v
from flexmb.sections import Section, rectangle, shear_coefficient_rectangle, torsion_constant_rectangle

__all__ = ["CircularNotch"]

#: Gauss-Legendre points per element for the section averages (the thickness is smooth within an element)
_GAUSS = np.polynomial.legendre.leggauss(8)


@attrs.frozen(kw_only=True)
class CircularNotch(flexmb.Joint):
    """Right circular notch hinge [``circular_notch``] from node A (origin) to node B at ``(2 radius, 0[, 0])``.

    Parameters
    ----------
    radius
        Notch radius R [m] (5e-3); the hinge is 2R long.
    thickness
        Thickness t at the throat [m] (5e-4), below ``radius``.
    width
        Width b along the joint's z axis [m] (1e-2).
    E, G
        Young's and shear modulus [Pa] (200e9, 76.9e9); or ``nu`` instead of ``G``.
    density
        Mass density [kg/m^3] (7800), >= 0.
    yield_stress
        Yield stress [Pa], optional: a solve that exceeds it at the throat warns.
    elements
        Beam elements, even (a node at the throat), at least 2 (20); they crowd at the throat.
    """

    kind: ClassVar[str] = "circular_notch"
    mesh_parameter: ClassVar[str] = "elements"
    parameter_ranges: ClassVar[dict] = {"radius": (2e-3, 1e-2), "thickness": (2e-4, 1e-3)}
    motion_range: ClassVar[float] = 0.1
    training: ClassVar[dict] = {"range_deg": (-6.0, 6.0), "step_deg": 0.5}

    radius: float = 5e-3
    thickness: float = 5e-4
    width: float = 1e-2
    E: float = 200e9
    G: float | None = None
    nu: float | None = None
    density: float = 7800.0
    yield_stress: float | None = None
    elements: int = 20

    def __attrs_post_init__(self):
        owner = self.kind
        G = v.shear_modulus(owner, self.E, self.G, self.nu, 76.9e9)
        object.__setattr__(self, "G", v.positive(owner, "G", G))  # stored as G, nu then reads None
        object.__setattr__(self, "nu", None)
        for name in ("radius", "thickness", "width", "E"):
            v.positive(owner, name, getattr(self, name))
        v.nonnegative(owner, "density", self.density)
        if self.yield_stress is not None:
            v.positive(owner, "yield_stress", self.yield_stress)
        v.integer(owner, "elements", self.elements, 2, v.MAX_ELEMENTS)
        if self.elements % 2:
            raise flexmb.ParameterError(f"{owner}: elements={self.elements!r} must be even (a node at the throat)")
        if not self.thickness < self.radius:
            raise flexmb.ParameterError(f"{owner}: thickness={self.thickness!r} m must be below radius="
                                        f"{self.radius!r} m (a notch thinner at its throat than its radius)")
        v.modulus_units(owner, self.E, 2 * self.radius)

    def interface_b(self, dim: int) -> np.ndarray:
        b = np.zeros(dim)
        b[0] = 2.0 * self.radius
        return b

    def element_count(self, dim: int) -> int:
        return self.elements

    def database_key(self) -> dict:
        """B's path over D0 = 2R and the elements' rotations depend on t/R and the mesh only:
        lengths scale out, the width and the moduli hardly matter (bending dominates)."""
        return {"thickness_ratio": round(self.thickness / self.radius, 12), "elements": int(self.elements)}

    def profile(self, x) -> np.ndarray:
        """Thickness t(x) [m] at ``x`` in [0, 2R] along the hinge."""
        R = self.radius
        return self.thickness + 2.0 * R - 2.0 * np.sqrt(np.maximum(R * R - (np.asarray(x) - R) ** 2, 0.0))

    def nodes(self) -> np.ndarray:
        """Node positions x [m] (elements + 1,): ``x - R = R sinh(a s) / sinh(a)`` over even steps of
        s in [-1, 1], ``a`` chosen so that the throat's elements are ``4 sqrt(R t) / elements``
        long (sqrt(R t): where the thickness has doubled), uniform when that is longer."""
        R, n = self.radius, self.elements
        target = 2.0 * math.sqrt(self.thickness / R)  # a / sinh(a): the throat's spacing over uniform
        a = brentq(lambda a: a / math.sinh(a) - target, 1e-9, 50.0) if target < 1.0 else 0.0
        s = np.linspace(-1.0, 1.0, n + 1)
        x = R + R * (np.sinh(a * s) / math.sinh(a) if a > 0 else s)
        x[0], x[n // 2], x[-1] = 0.0, R, 2.0 * R  # exactly: the ends and the throat
        return x

    def mesh(self, dim: int) -> JointMesh:
        x = self.nodes()
        n = self.elements
        pts = np.zeros((n + 1, dim))
        pts[:, 0] = x
        side = np.full(n + 1, INTERNAL)
        side[0], side[-1] = SIDE_A, SIDE_B
        stiffness = tuple(self._averaged(x[i], x[i + 1]) for i in range(n))
        thinnest = np.minimum(self.profile(x[:-1]), self.profile(x[1:]))  # the element's end nearer the throat
        recovery = tuple(rectangle(self.width, float(t), self.E, self.G, self.density, yield_stress=self.yield_stress)
                         for t in thinnest)
        return JointMesh(points=pts, side=side, elements=np.column_stack([np.arange(n), np.arange(1, n + 1)]),
                         sections=stiffness, stress_sections=recovery,
                         ny0=np.tile([0.0, 1.0, 0.0], (n, 1)) if dim == 3 else None)

    def _averaged(self, x0: float, x1: float) -> Section:
        """The element's section from x0 to x1: each compliance integrated over the element
        (Gauss-Legendre), so the element has the exact axial, shear, bending and torsional
        compliance of its variable section under a uniform force, moment or torque, and the
        density scaled so that its mass per length is the true mean."""
        xi, w = _GAUSS
        x = 0.5 * (x0 + x1) + 0.5 * (x1 - x0) * xi
        t, b, w = self.profile(x), self.width, 0.5 * w  # weights over [0, 1]
        t_h = 1.0 / np.sum(w / t)  # harmonic mean: axial, shear and stiff-direction bending
        t_i = np.sum(w / t**3) ** (-1.0 / 3.0)  # compliant bending: harmonic mean of t^3
        It = 1.0 / np.sum(w / np.array([torsion_constant_rectangle(b, ti) for ti in t]))
        k = shear_coefficient_rectangle(self.E / (2.0 * self.G) - 1.0)
        return Section(E=self.E, G=self.G, A=b * t_h, Iy=t_h * b**3 / 12.0, Iz=b * t_i**3 / 12.0, It=It, ky=k, kz=k,
                       ymax=0.5 * t_i, zmax=0.5 * b, density=self.density * float(np.sum(w * t)) / t_h,
                       yield_stress=self.yield_stress)
