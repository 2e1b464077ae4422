"""Circular curved-beam flexure [``curved_beam``] (Cammarata et al. 2022, Sec. 2, Eq. 2; planar)."""

from __future__ import annotations

import math
from typing import ClassVar

import attrs
import numpy as np

from .. import _validate as v
from ..errors import ParameterError
from ..sections import rectangle
from ..units import check_size
from ._base import FLEXURE_MODELS, INTERNAL, SIDE_A, SIDE_B, UNSET, ClosedForm, JointMesh, MaterialJoint

__all__ = ["CurvedBeam"]


@attrs.frozen(kw_only=True, cache_hash=True)
class CurvedBeam(MaterialJoint):
    """Circular curved-beam flexure [``curved_beam``], planar mechanisms only.

    An arc of radius ``radius`` and characteristic (arc) angle ``angle`` from node A (origin of
    the joint frame, tangent along +x) turning counter-clockwise about its centre ``(0, radius)``
    to node B. Units are whatever the user keeps consistent (SI by default; the gripper of the
    paper uses mm and uN, so ``E`` in uN/mm^2).

    Parameters
    ----------
    radius
        Arc radius r_f (> 0).
    angle
        Arc angle theta_f [rad], in (0, 2 pi).
    material, E
        A `flexmb.Material` (or a named one), or Young's modulus ``E``: one is required.
    width, height
        Cross-section: ``width`` (b, out of plane) x ``height`` (h, in-plane), so EI = E b h^3 / 12.
    G, nu
        Shear modulus for the finite-element model, or Poisson's ratio (default with ``E`` alone:
        ``G = E / 2.6``, Poisson 0.3).
    density, yield_stress
        The material's density (7800 with ``E`` alone: steel in kg/m^3; in the model's units:
        mass per length cubed, e.g. g/mm^3 with mm and uN, where 1 uN s^2/mm = 1 g), >= 0, and
        yield stress (optional: a solve whose peak normal stress exceeds it warns,
        `flexmb.PlausibilityWarning`). See `flexmb.joints.MaterialJoint`.
    elements
        Straight co-rotational beam elements along the arc in the finite-element model (16).
        Measured evidence for the default (a 90 deg steel arc, r = 30 mm, end turned 10 deg
        under a 1 N side load, converged-mesh reference by Richardson from 64/128/256 elements,
        ``benchmarks/bench_discretisation.py``): end drift -0.04 %, support stiffness +0.23 %,
        moment +0.08 %, first frequency +0.11 %, buckling +0.45 % at 16 elements.
    model
        Wrench model of the closed form (``method="newton"``): ``"linear"`` (Eq. 15, balance in
        the undeformed configuration) or ``"partial-nonlinear"`` (Eq. 17, the end displacement
        in the moment arm; default). The finite-element model (``method="conventional"``) is
        always fully non-linear.

    Notes
    -----
    `compliance` is the closed form of Eq. (2) (bending only: no axial or shear compliance), in
    the paper's end-section frame; `mesh` is flexmb's own fully non-linear model of the same arc.

    Both closed-form models are kept as published, and neither balances globally: the end force
    turns with the end link and the clamp force with the clamp link (Eqs. 20a, 22), so one
    flexure's forces on its two links differ by about |F| phi. Measured on the gripper at
    F_2y = 50 uN: the joint forces on all links sum to 10.6 uN (linear) and 9.5 uN (partial
    non-linear), about 20 % of the load (`Solution.imbalance`). For the same reason the result
    depends on which link is side A (the clamped first section): a leaf cantilever under a 6 N
    tip load turns 0.3395 rad declared ground -> tip and 0.3692 rad declared tip -> ground (FE:
    0.3444). The gripper follows the paper (each arc counter-clockwise from the first body).
    """

    kind: ClassVar[str] = "curved_beam"
    dims: ClassVar[tuple[int, ...]] = (2,)
    parameter_ranges: ClassVar[dict] = {"radius": (0.02, 0.1), "angle": (0.5, 3.0), "E": (1e9, 2e11), "width": (2e-3, 2e-2),
                         "height": (2e-4, 2e-3)}
    motion_range: ClassVar[float] = 0.3
    mesh_parameter: ClassVar[str] = "elements"

    default_material: ClassVar = None

    radius: float
    angle: float
    width: float
    height: float
    material: object = None
    elements: int = 16
    model: str = "partial-nonlinear"

    def __attrs_post_init__(self):
        owner = "curved_beam"
        if self.material is None and self._density is UNSET:
            object.__setattr__(self, "_density", 7800.0)  # E alone: steel's density, as before
        super().__attrs_post_init__()
        for name in ("radius", "width", "height"):
            v.positive(owner, name, getattr(self, name))
        v.in_open_range(owner, "angle", self.angle, 0.0, 2 * math.pi, " rad")
        check_size(owner, self.E, self.radius, what="radius", stacklevel=4, rules=("GPa",))
        v.integer(owner, "elements", self.elements, 1, v.MAX_ELEMENTS)
        v.choice(owner, "model", self.model, FLEXURE_MODELS)
        if not v.real(self.height) < v.real(self.radius):
            raise ParameterError(f"{owner}: height={self.height!r} must be < radius={self.radius!r} (a slender arc)")
        try:
            rectangle(self.width, self.height, self.E, self.shear_modulus, yield_stress=self.yield_stress)
        except ParameterError as exc:
            raise ParameterError(f"{owner}: width={self.width!r}, height={self.height!r}, E={self.E!r}: {exc}") from None

    @staticmethod
    def default_shear(E: float) -> float:
        """G with ``E`` alone: E / 2.6 (Poisson's ratio 0.3)."""
        return E / 2.6

    @property
    def shear_modulus(self) -> float:
        """G in the model's units (the material's)."""
        return self.G

    @property
    def bending_stiffness(self) -> float:
        """EI = E b h^3 / 12."""
        return self.E * self.width * self.height**3 / 12.0

    def arc_points(self, n: int) -> np.ndarray:
        """``n + 1`` points along the arc from A to B in the joint frame, shape (n + 1, 2)."""
        phi = np.linspace(0.0, self.angle, n + 1)
        return self.radius * np.stack([np.sin(phi), 1.0 - np.cos(phi)], axis=1)

    def interface_b(self, dim: int) -> np.ndarray:
        return self.arc_points(1)[1]

    def element_count(self, dim: int) -> int:
        """Beam elements of `mesh` (known without meshing)."""
        return self.elements

    def mesh(self, dim: int) -> JointMesh:
        n = self.elements
        side = np.full(n + 1, INTERNAL)
        side[0], side[-1] = SIDE_A, SIDE_B
        sec = rectangle(self.width, self.height, self.E, self.shear_modulus, self.density,
                        yield_stress=self.yield_stress)
        return JointMesh(points=self.arc_points(n), side=side,
                         elements=np.stack([np.arange(n), np.arange(1, n + 1)], axis=1), sections=(sec,) * n)

    @classmethod
    def through(cls, center, start, end, *, rtol: float = 2e-3, **params) -> tuple[CurvedBeam, dict]:
        """The arc about ``center`` running counter-clockwise from ``start`` (on the A-side link) to
        ``end`` (B side), and the placement for `Mechanism.add_joint` (Table 1 style input).

        Returns ``(joint, placement)``; use ``m.add_joint(a, b, joint, **placement)``. The radius is
        ``|start - center|``; ``|end - center|`` must agree within ``rtol`` (relative), else a
        `ParameterError` says by how much. ``params`` go to the constructor (E, width, height, ...).
        """
        c, p0, p1 = (v.vector("curved_beam", n, x, 2) for n, x in (("center", center), ("start", start), ("end", end)))
        r0, r1 = v.norms(np.stack([p0 - c, p1 - c]))  # complex (the complex step): sqrt(d . d), not the modulus
        if not v.real(r0) > 0:
            raise ParameterError("curved_beam: start coincides with the hinge centre")
        if abs(v.real(r1 - r0)) > rtol * v.real(r0):
            raise ParameterError(
                f"curved_beam: end is {r1:.6g} from the hinge centre but start is {r0:.6g}: the attachment "
                f"points are inconsistent with one radius by {r1 - r0:+.3g} ({(r1 - r0) / r0:+.2%}; tolerance {rtol:.1%})")
        a0 = v.atan2(*(p0 - c)[::-1])
        a1 = v.atan2(*(p1 - c)[::-1])
        angle = a1 - a0
        if v.is_complex(angle):  # the complex step: the real part wrapped, the imaginary part kept
            angle = complex(angle.real % (2 * math.pi), angle.imag)
        else:
            angle = angle % (2 * math.pi)
        joint = cls(radius=r0 if v.is_complex(r0) else float(r0), angle=angle, **params)
        # joint frame: node A at start, +x along the counter-clockwise tangent there
        return joint, {"origin": p0, "rotation": a0 + math.pi / 2}

    def compliance(self) -> np.ndarray:
        """C_f of Eq. (2): end displacement/rotation per end wrench, other end clamped (3, 3).

        In the paper's end-section frame: x along the end tangent, y along the radius, so that for
        r_f -> inf at r_f theta_f = L it tends to the straight cantilever
        ``diag(0, L^3/3, L) / EI`` with the ``L^2/2`` coupling.
        """
        r, t = self.radius, self.angle
        one_c = 2.0 * math.sin(0.5 * t) ** 2  # 1 - cos t without cancellation
        C = np.array([
            [r**3 / 4 * _c00(t), r**3 / 2 * one_c**2, r**2 * _t_minus_sin(t)],
            [0.0, r**3 / 4 * _two_t_minus_sin2t(t), r**2 * one_c],
            [0.0, 0.0, r * t],
        ])
        C = np.triu(C) + np.triu(C, 1).T
        return C / self.bending_stiffness

    def stiffness(self) -> np.ndarray:
        """K_f = C_f^-1 (3, 3), in the frame of `compliance`.

        A bending-only arc stiffens without bound as the angle shrinks (C_11 ~ r^3 theta^5 / 20:
        Eq. 2 has no axial compliance), so below about 1e-3 rad K_f is too ill-conditioned to use
        and a `ParameterError` says so.
        """
        C = v.computed("curved_beam", "closed-form compliance (Eq. 2)", self.compliance)
        cond = np.linalg.cond(C)
        if not cond < 1e13:
            raise ParameterError(f"curved_beam: angle={self.angle!r} rad is too small for the bending-only closed form "
                                 f"of Eq. (2) (compliance condition number {cond:.1e}); use angle > ~1e-3 rad or a "
                                 "leaf_spring, which has axial compliance")
        return np.linalg.inv(C)

    def closed_form(self, dim: int) -> ClosedForm:
        """K_f in the end frame at B (Eq. 16: A_f = rot(theta_f), d_f = r [sin, 1 - cos] theta_f)."""
        return ClosedForm(self.stiffness(), self.interface_b(2), self.angle, self.model)


_SERIES_BELOW = 0.5  # rad: below it the closed forms cancel; the series converge fast


def _series(t: float, first: int, coefficient) -> float:
    """sum over odd k >= first of coefficient(k) t^k / k! (to double precision for t < 0.5)."""
    total, k = 0.0, first
    term = t**k / math.factorial(k)
    while k < first + 30:
        total += coefficient(k) * term
        term *= t * t / ((k + 1) * (k + 2))
        k += 2
    return total


def _c00(t: float) -> float:
    """6 t + sin 2t - 8 sin t = t^5/5 - t^7/42 + ... (Eq. 2, C_11 / (r^3/4))."""
    if t >= _SERIES_BELOW:
        return 6 * t + math.sin(2 * t) - 8 * math.sin(t)
    return _series(t, 5, lambda k: (-1) ** ((k - 1) // 2) * (2**k - 8))


def _two_t_minus_sin2t(t: float) -> float:
    """2 t - sin 2t = 8 t^3/3! - 32 t^5/5! + ..."""
    if t >= _SERIES_BELOW:
        return 2 * t - math.sin(2 * t)
    return _series(t, 3, lambda k: (-1) ** ((k + 1) // 2) * 2**k)


def _t_minus_sin(t: float) -> float:
    """t - sin t = t^3/3! - t^5/5! + ..."""
    if t >= _SERIES_BELOW:
        return t - math.sin(t)
    return _series(t, 3, lambda k: (-1) ** ((k + 1) // 2))
