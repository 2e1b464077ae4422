"""Straight leaf spring [``leaf_spring``]: the simplest flexure, and the cantilever of the beam benchmarks."""

from __future__ import annotations

from typing import ClassVar

import attrs
import numpy as np

from .. import _validate as v
from ..errors import ParameterError, UnsupportedStrategyError
from ..materials import KEYWORDS, STEEL
from ..sections import Section, rectangle
from ..units import check_size
from ._base import FLEXURE_MODELS, INTERNAL, SIDE_A, SIDE_B, UNSET, ClosedForm, JointMesh, MaterialJoint

__all__ = ["LeafSpring"]


@attrs.frozen(kw_only=True, cache_hash=True)
class LeafSpring(MaterialJoint):
    """Straight leaf spring [``leaf_spring``] from node A (origin) to node B at ``(length, 0[, 0])``.

    Clamped in the links at both ends; the width lies along the joint frame's z axis, so its
    compliant bending is in the xy-plane (about z).

    Parameters
    ----------
    length
        Length [length] (0.1).
    width, thickness
        Cross-section [length] (0.02, 1e-3); ``thickness < length``.
    material
        A `flexmb.Material` or a named one (default: steel, E = 200e9, G = 76.9e9, density 7800,
        SI); its ``yield_stress``, when given, makes a solve whose peak normal stress exceeds it
        warn (`flexmb.PlausibilityWarning`).
    E, G, nu, density, yield_stress
        The material's values one by one (see `flexmb.joints.MaterialJoint`).
    elements
        Number of beam elements, 1 or more (12). Measured evidence for the default (a parallel
        guide of two 0.1 m leaves 1 mm thick pushed 10 mm, converged-mesh reference by
        Richardson from 16/32/64 elements, ``benchmarks/bench_discretisation.py``): parasitic
        drop -5.0 / -0.55 %, support stiffness along the leaves +7.4 / +0.5 %, actuation force
        +0.34 / +0.04 % at 4 / 12 elements; 5 Newton iterations either way (the time: BENCHMARKS.md, Cost of
        the new defaults).
    section
        Optional `Section` that replaces the rectangle (e.g. to switch off shear with ``ky = kz = inf``);
        its own material (``E``, ``G``, ``density``, ``yield_stress``) and sizes then apply: a
        different one given here as well (or a ``width``/``thickness`` beside a section that is no
        rectangle) is refused (it would be ignored).
    model
        Wrench model of the planar closed form (``method="newton"``, see `ClosedForm`).
    """

    kind: ClassVar[str] = "leaf_spring"
    parameter_ranges: ClassVar[dict] = {"length": (0.05, 0.2), "width": (0.01, 0.04), "thickness": (5e-4, 2e-3)}
    motion_range: ClassVar[float] = 0.5
    mesh_parameter: ClassVar[str] = "elements"

    length: float = 0.1
    width: float = 0.02
    thickness: float = 1e-3
    elements: int = 12
    section: Section | None = None
    model: str = "partial-nonlinear"

    def __attrs_post_init__(self):
        owner = "leaf_spring"
        given = {"E", "G", "density", "yield_stress"} if self.material is not STEEL else \
            {"G" if k == "nu" else k for k in KEYWORDS if getattr(self, f"_{k}") is not UNSET}
        super().__attrs_post_init__()
        for name in ("length", "width", "thickness"):
            v.positive(owner, name, getattr(self, name))
        v.integer(owner, "elements", self.elements, 1, v.MAX_ELEMENTS)
        v.choice(owner, "model", self.model, FLEXURE_MODELS)
        if self.section is not None and not isinstance(self.section, Section):
            raise ParameterError(f"{owner}: section must be a flexmb.Section, got {type(self.section).__name__}")
        check_size(owner, self.E if self.section is None else self.section.E, self.length, stacklevel=4,
                   rules=("GPa",))  # "mm" at add_joint, where the units are known
        thickness = self.thickness if self.section is None else \
            None if self.section.ymax is None else 2 * self.section.ymax  # the section's, where it has one
        if thickness is not None and v.real(thickness) >= v.real(self.length):
            raise ParameterError(f"{owner}: thickness={thickness!r} m{'' if self.section is None else ' (section)'} "
                                 f"must be < length={self.length!r} m")
        if self.section is not None:  # the section's material and shape apply: different ones given here are lost
            self._check_section(owner, given)
        try:
            self.cross_section()  # overflow/underflow or inconsistent moduli raise here
        except ParameterError as exc:
            raise ParameterError(f"{owner}: width={self.width!r} m, thickness={self.thickness!r} m, E={self.E!r} Pa, "
                                 f"G={self.G!r} Pa: {exc}") from None

    def _check_section(self, owner: str, given: set) -> None:
        """Refuse material values (``given``: those passed, other than the default steel's) and sizes
        beside ``section`` that differ from the section's: they would be ignored."""
        default = {f.name: f.default for f in attrs.fields(type(self))}
        clash = [f"{n}={getattr(self, n)!r} (section: {getattr(self.section, n)!r})"
                 for n in ("E", "G", "density", "yield_stress")
                 if n in given and getattr(self, n) not in (getattr(STEEL, n), getattr(self.section, n))]
        if clash:
            raise ParameterError(f"{owner}: {', '.join(clash)}: the section's material applies; give it in the "
                                 "section (e.g. flexmb.rectangle(..., density=)) or leave it out here")
        s = self.section  # a rectangle's half-sizes: ymax = thickness / 2, zmax = width / 2
        sizes = {"width": 2 * s.zmax, "thickness": 2 * s.ymax} if s.shape == "rectangle" else {}
        clash = [f"{n}={getattr(self, n)!r} (section: {sizes[n]!r})" if n in sizes else
                 f"{n}={getattr(self, n)!r} (section: a {s.shape or 'general'} section, A={s.A!r})"
                 for n in ("width", "thickness") if getattr(self, n) != default[n]
                 and not (n in sizes and np.isclose(v.real(getattr(self, n)), v.real(sizes[n]), rtol=1e-12, atol=0.0))]
        if clash:
            raise ParameterError(f"{owner}: {', '.join(clash)}: the section's shape applies; give the sizes in "
                                 "the section (flexmb.rectangle(width, thickness, ...)) or leave them out here")

    def interface_b(self, dim: int) -> np.ndarray:
        b = np.zeros(dim, dtype=v.real_or_complex(self.length))  # complex: the complex step
        b[0] = self.length
        return b

    def cross_section(self) -> Section:
        """The leaf's `Section`: ``section`` if given, else the ``width`` x ``thickness`` rectangle [length]."""
        return self.section or rectangle(self.width, self.thickness, self.E, self.G, self.density,
                                         yield_stress=self.yield_stress)

    def element_count(self, dim: int) -> int:
        """Beam elements of `mesh` (known without meshing)."""
        return self.elements

    def mesh(self, dim: int) -> JointMesh:
        n = self.elements
        pts = np.outer(np.linspace(0.0, 1.0, n + 1), self.interface_b(dim))
        side = np.full(n + 1, INTERNAL)
        side[0], side[-1] = SIDE_A, SIDE_B
        ny = np.tile([0.0, 1.0, 0.0], (n, 1)) if dim == 3 else None
        return JointMesh(points=pts, side=side, elements=np.stack([np.arange(n), np.arange(1, n + 1)], 1),
                         sections=(self.cross_section(),) * n, ny0=ny)

    def compliance(self) -> np.ndarray:
        """Planar end compliance of the clamped leaf (3, 3) [m/N, 1/N, 1/(N m)]: axial ``L/EA``,
        Timoshenko bending ``L^3/(3 EI) + L/(k G A)``, ``L^2/(2 EI)``, ``L/EI`` (in-plane, ``Iz``)."""
        s, L = self.cross_section(), self.length
        EI = s.E * s.Iz
        return np.array([[L / (s.E * s.A), 0.0, 0.0],
                         [0.0, L**3 / (3 * EI) + L / (s.ky * s.G * s.A), L**2 / (2 * EI)],
                         [0.0, L**2 / (2 * EI), L / EI]])

    def closed_form(self, dim: int) -> ClosedForm:
        """The leaf as a constant-stiffness flexure (planar only): end frame at B, not rotated."""
        if dim != 2:
            raise UnsupportedStrategyError("leaf_spring: the closed-form model is planar (dim=2) only")
        K = v.computed("leaf_spring", "closed-form stiffness", lambda: np.linalg.inv(self.compliance()))
        return ClosedForm(K, self.interface_b(2), 0.0, self.model)
