"""Cross-flexure pivot [``cross_flexure``] (Dwarshuis et al. 2020, Figs. 3 and 6, Table 1)."""

from __future__ import annotations

import math
from typing import ClassVar

import attrs
import numpy as np

from .. import _validate as v
from ..errors import ParameterError
from ..sections import rectangle
from ._leaves import check_leaves
from ._base import INTERNAL, SIDE_A, SIDE_B, JointMesh, MaterialJoint

__all__ = ["CrossFlexure"]


@attrs.frozen(kw_only=True, cache_hash=True)
class CrossFlexure(MaterialJoint):
    """Cross-flexure pivot [``cross_flexure``].

    Leaf springs of length ``length`` crossing at their midpoints, clamped in two rigid connector
    blocks; interface node A (origin of the joint frame) and B at the block centres, B at
    ``(0, length sin(angle))``. The intended motion is the rotation of B about z.

    * ``dim=3``: the three-leaf cross flexure of Fig. 6 / Table 1: an inner leaf of width
      ``width_inner`` along ``(cos a, sin a, 0)`` at z = 0 and two outer leaves of width
      ``width_outer`` along ``(-cos a, sin a, 0)`` at ``z = +-(width_inner/2 + gap + width_outer/2)``
      (Fig. 6 does not give this spacing; ``gap`` [length] is the clearance between the leaves).
    * ``dim=2``: the planar cross flexure of Fig. 3: the inner leaf and one leaf of width
      ``2 width_outer`` standing for the outer pair, so the in-plane model matches the 3D one.

    Parameters (defaults: Table 1)
    ------------------------------
    length
        Leaf length L [length] (0.1).
    angle
        Leaf angle alpha to the joint's x axis [rad], in (0, pi/2) (pi/4).
    thickness
        Leaf thickness t [length], less than ``length / 10`` (1e-3).
    width_inner, width_outer
        Leaf widths w1, w2 [length] (0.04, 0.02).
    material
        A `flexmb.Material` or a named one (default: the steel of Table 1, E = 200e9, G = 76.9e9,
        density 7800, SI); its ``yield_stress``, when given, makes a solve whose peak normal
        stress exceeds it warn (`flexmb.PlausibilityWarning`).
    E, G, nu, density, yield_stress
        The material's values one by one (see `flexmb.joints.MaterialJoint`): they complete the
        default material, or replace those of ``material``.
    elements_per_leaf
        Beam elements per leaf, 1 or more (24: the accuracy target of 1 %, `flexmb.accuracy`, met
        with a margin). Measured (converged-mesh references by Richardson from 16/32/64 or
        32/64/128 el./leaf, ``benchmarks/bench_accuracy.py``, ``bench_discretisation.py``): a 3D
        pivot turned 15 deg under an axial load at a quarter of its buckling load: buckling
        multiplier +3.3 / +0.82 / +0.57 %, first frequency +1.1 / +0.29 / +0.20 % at 10 / 20 / 24
        el./leaf; Table 1's pivot at 20 deg: buckling +3.2 / +1.25 / +0.31 %, centre shift +0.50 /
        +0.20 / +0.05 % at 10 / 16 / 32. Table 1 and the four-bar of the paper use 1-5 (`flexmb.models`
        states them); the shipped database holds 1-5, 10 and 24. The estimate every result
        carries (``.discretisation``) says how far another mesh is off.
    gap
        Clearance between inner and outer leaves along z [length] (0).
    """

    kind: ClassVar[str] = "cross_flexure"
    parameter_ranges: ClassVar[dict] = {"length": (0.05, 0.2), "angle": (0.4, 1.2), "thickness": (5e-4, 2e-3)}
    motion_range: ClassVar[float] = 1.0
    mesh_parameter: ClassVar[str] = "elements_per_leaf"

    length: float = 0.1
    angle: float = math.pi / 4
    thickness: float = 1e-3
    width_inner: float = 0.04
    width_outer: float = 0.02
    elements_per_leaf: int = 24
    gap: float = 0.0

    def __attrs_post_init__(self):
        owner = "cross_flexure"
        super().__attrs_post_init__()
        check_leaves(owner, self, ("length", "thickness", "width_inner", "width_outer"))
        if v.real(v.finite(owner, "gap", self.gap)) < 0:
            raise ParameterError(f"{owner}: gap={self.gap!r} m must be >= 0")
        # the mesh's points are start + ((end - start) k) / n, k <= n, on every leaf: finite when its
        # ends and n times its span are (checked without meshing, on every joint's construction)
        with np.errstate(over="ignore", invalid="ignore"):
            ends = np.array([(a, b, (b - a) * self.elements_per_leaf) for a, b, _ in self.leaves(3)])
        if not np.all(np.isfinite(ends)):
            raise ParameterError(f"{owner}: length={self.length!r} m gives non-finite node coordinates")

    def interface_b(self, dim: int) -> np.ndarray:
        b = np.zeros(dim, dtype=v.real_or_complex((self.length, self.angle)))  # complex: the complex step
        b[1] = self.length * v.sin(self.angle)
        return b

    def leaves(self, dim: int) -> list[tuple[np.ndarray, np.ndarray, float]]:
        """(start, end, width) of every leaf in the joint frame; start on block A."""
        L, a = self.length, self.angle
        c, s = 0.5 * L * v.cos(a), 0.5 * L * v.sin(a)
        zo = 0.5 * self.width_inner + self.gap + 0.5 * self.width_outer
        dtype = v.real_or_complex((c, s, zo))  # complex numbers: the complex step of flexmb.design

        def leaf(x0: float, z: float):
            start, end = np.zeros(dim, dtype=dtype), np.zeros(dim, dtype=dtype)
            start[0], end[0], end[1] = x0, -x0, 2 * s
            if dim == 3:
                start[2] = end[2] = z
            return start, end

        if dim == 2:
            return [(*leaf(-c, 0.0), self.width_inner), (*leaf(c, 0.0), 2 * self.width_outer)]
        return [
            (*leaf(-c, 0.0), self.width_inner),
            (*leaf(c, zo), self.width_outer),
            (*leaf(c, -zo), self.width_outer),
        ]

    def element_count(self, dim: int) -> int:
        """Beam elements of `mesh` (known without meshing): `leaves` has 2 leaves in 2D, 3 in 3D."""
        return (2 if dim == 2 else 3) * self.elements_per_leaf

    def mesh(self, dim: int) -> JointMesh:
        n = self.elements_per_leaf
        k = np.arange(n + 1)[:, None]
        leaf_side = np.full(n + 1, INTERNAL)
        leaf_side[0], leaf_side[n] = SIDE_A, SIDE_B
        pts, secs, ny = [], [], []
        for start, end, width in self.leaves(dim):
            pts.append(start + (end - start) * k / n)  # the points start + (end - start) k / n, k = 0 ... n
            sec = rectangle(width, self.thickness, self.E, self.G, self.density, yield_stress=self.yield_stress)
            secs += [sec] * n
            if dim == 3:
                ex = (end - start) / self.length  # every leaf has length L by construction
                ny.append(np.repeat(np.cross([0.0, 0.0, 1.0], ex)[None], n, axis=0))  # width along z, thickness in-plane
        first = (n + 1) * np.arange(len(pts))[:, None] + np.arange(n)  # each leaf's elements (k, k + 1)
        return JointMesh(
            points=np.concatenate(pts),
            side=np.tile(leaf_side, len(pts)),
            elements=np.stack([first.ravel(), first.ravel() + 1], axis=1),
            sections=tuple(secs),
            ny0=np.concatenate(ny) if dim == 3 else None,
        )

    def database_key(self) -> dict:
        """Kinematic data depend on the leaf angle and the mesh (Sec. 2.1, Eq. 2.1); lengths are
        scaled out (positions over D0) and widths and thickness hardly matter (Sec. 4.1)."""
        return {"angle": round(float(self.angle), 12), "elements_per_leaf": int(self.elements_per_leaf)}

    def kinematic_constraints(self, dim: int) -> tuple[str, ...]:
        """2D: B's offsets x(theta), y(theta) (Eq. 2.1); 3D: the five constraints of Sec. 4.1 (no z
        offset, no tilt about x and y, A and B turned symmetrically about the line AB, D/D0 of Eq. 4.1)."""
        return ("x", "y") if dim == 2 else ("z", "tilt_x", "tilt_y", "symmetric", "length")

    @property
    def second_moment(self) -> float:
        """I = (w1 + 2 w2) t^3 / 12 [length^4], Eq. (4.4)."""
        return (self.width_inner + 2 * self.width_outer) * self.thickness**3 / 12.0
