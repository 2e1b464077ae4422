"""Large-stroke spatial flexure hinge [``three_x_infinity``] for the manipulator of Dwarshuis et al.
(2020), Sec. 4.4 (their Fig. 1 / Fig. 14 joint, whose dimensions are not available to us).

flexmb's parametric design keeps the two principles the paper's joint is built on, with simpler
parts: flexures combined *in parallel* so that each stage constrains exactly five directions
(a three-leaf cross flexure, as Fig. 6), and ``stages`` such stages stacked *in series* along
the rotation axis, so each leaf bends by only ``1/stages`` of the joint's rotation. Successive
stages are turned upside down and share their connector blocks, which are rigid intermediate
bodies of the joint (exact rigid constraints, `JointMesh.body`). All leaf crossings lie on the
joint's z axis, so the stages turn about one common axis.
"""

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

__all__ = ["ThreeXInfinity"]


@attrs.frozen(kw_only=True, cache_hash=True)
class ThreeXInfinity(MaterialJoint):
    """Stacked cross-flexure hinge [``three_x_infinity``] for +-45 deg about its z axis.

    Geometry, in the joint frame (interface node A at the origin, rotation about z):

    * stage ``k = 0 .. stages-1`` is a three-leaf cross flexure centred at ``z_k = k * pitch``,
      ``pitch = width_inner + 2 (width_outer + gap) + stage_gap``: an inner leaf of width
      ``width_inner`` from ``(-c, -s, z_k)`` to ``(c, s, z_k)`` and two outer leaves of width
      ``width_outer`` from ``(c, -s, z_k +- zo)`` to ``(-c, s, z_k +- zo)``, with
      ``c, s = length/2 (cos angle, sin angle)`` and ``zo = width_inner/2 + gap + width_outer/2``;
      all leaves cross on the z axis;
    * the connector block at ``y = -s`` of stage 0 belongs to side A, the one at ``y = +-s`` of
      the last stage to side B; between them the blocks of stages ``k`` and ``k + 1`` on the same
      side (``+s`` after even ``k``, ``-s`` after odd ``k``) form one rigid intermediate body;
    * interface node B sits on the axis at ``(0, 0, (stages - 1) pitch)``.

    The leaves' width is along z and their thickness in the plane of motion.

    Parameters (defaults: the flexmb design of docs/manipulator.md, steel as in Sec. 4.4)
    --------------------------------------------------------------------------
    length
        Leaf length [length] (0.03).
    angle
        Leaf angle to the joint's x axis [rad], in (0, pi/2) (pi/4).
    thickness
        Leaf thickness [length] (0.45e-3, Sec. 4.4), less than ``length / 10``.
    width_inner, width_outer
        Leaf widths [length] (0.010, 0.005).
    gap
        Clearance between the inner and outer leaves along z [length] (1e-3).
    stage_gap
        Clearance between successive stages along z [length] (2e-3).
    stages
        Number of stages in series, 2 to 100 (3).
    material
        A `flexmb.Material` or a named one (default: steel, E = 200e9, G = 76.9e9, density 7800,
        SI, as Sec. 4.4); its ``yield_stress``, when given, makes a solve whose peak normal stress
        exceeds it warn (`flexmb.PlausibilityWarning`).
    E, G, nu, density, yield_stress
        The material's values one by one (see `flexmb.joints.MaterialJoint`).
    elements_per_leaf
        Beam elements per leaf, 1 or more (24: 216 flexible elements for 3 stages; the accuracy
        target of 1 %, `flexmb.accuracy`). Measured (turned 45 deg under a 10 N axial load,
        converged-mesh reference by Richardson from 16/32/64 el./leaf,
        ``benchmarks/bench_discretisation.py``): buckling multiplier +26 / +3.4 / +1.9 / +0.50 %,
        axial support stiffness +10.4 / +0.64 / +0.36 / +0.09 %, drift of node B off the axis
        +5.6 / +0.35 / +0.20 / +0.05 % at 3 / 12 / 16 / 32 el./leaf (24: about +0.85, +0.16,
        +0.09 %, order 2). The manipulator of the paper (`flexmb.models.manipulator`)
        keeps 3, the mesh of the shipped database's EOB table; the database holds 3 and 24
        (KSD on another mesh needs ``flexmb train three_x_infinity --elements N``).

    The rigid intermediate bodies carry no mass of their own (only the leaves' ends attached to
    them); give a mechanism's links their mass with `flexmb.Mechanism.add_link`.
    """

    kind: ClassVar[str] = "three_x_infinity"
    dims: ClassVar[tuple[int, ...]] = (3,)
    parameter_ranges: ClassVar[dict] = {"length": (0.02, 0.05), "thickness": (3e-4, 6e-4)}
    motion_range: ClassVar[float] = math.radians(45.0)
    mesh_parameter: ClassVar[str] = "elements_per_leaf"
    #: Sec. 4.4: 19 rotations from -45 to 45 deg, fourth-order polynomials throughout.
    training: ClassVar[dict] = {"range_deg": (-45.0, 45.0), "step_deg": 5.0, "element_powers": (1, 2, 3, 4),
                                "constraint_powers": (0, 1, 2, 3, 4), "length_powers": (2, 4)}

    length: float = 0.03
    angle: float = math.pi / 4
    thickness: float = 0.45e-3
    width_inner: float = 0.010
    width_outer: float = 0.005
    gap: float = 1e-3
    stage_gap: float = 2e-3
    stages: int = 3
    elements_per_leaf: int = 24

    def __attrs_post_init__(self):
        owner = "three_x_infinity"
        super().__attrs_post_init__()
        check_leaves(owner, self, ("length", "thickness", "width_inner", "width_outer"))
        v.integer(owner, "stages", self.stages, 2, 100)
        for name in ("gap", "stage_gap"):
            if v.real(v.finite(owner, name, getattr(self, name))) < 0:
                raise ParameterError(f"{owner}: {name}={getattr(self, name)!r} m must be >= 0")
        if not v.real(self.pitch) > 0:
            raise ParameterError(f"{owner}: the stages must not coincide (pitch {self.pitch!r} m must be > 0)")

    @property
    def pitch(self) -> float:
        """Distance between successive stages along z [length]."""
        return self.width_inner + 2 * (self.width_outer + self.gap) + self.stage_gap

    @property
    def flexible_elements(self) -> int:
        """Number of beam elements: 3 leaves x ``stages`` x ``elements_per_leaf``."""
        return 3 * self.stages * self.elements_per_leaf

    def interface_b(self, dim: int) -> np.ndarray:
        self._require_3d(dim)
        return np.array([0.0, 0.0, (self.stages - 1) * self.pitch])

    def _require_3d(self, dim: int) -> None:
        if dim != 3:
            raise ParameterError(f"three_x_infinity: a spatial joint; dim={dim!r} must be 3")

    def element_count(self, dim: int) -> int:
        """Beam elements of `mesh` (known without meshing)."""
        return self.flexible_elements

    def mesh(self, dim: int) -> JointMesh:
        self._require_3d(dim)
        n, K = self.elements_per_leaf, self.stages
        c, s = 0.5 * self.length * v.cos(self.angle), 0.5 * self.length * v.sin(self.angle)
        zo = 0.5 * self.width_inner + self.gap + 0.5 * self.width_outer
        # rigid intermediate bodies first, each by its reference point on the block between two stages
        pts = [np.array([0.0, s if k % 2 == 0 else -s, (k + 0.5) * self.pitch]) for k in range(K - 1)]
        side, body = [INTERNAL] * (K - 1), list(range(K - 1))
        elems, secs, ny = [], [], []

        def block(k: int, upper: bool):
            """(side, body) of stage k's block at y = +s (upper) or -s."""
            start_side = k % 2 == 0  # even stages start at y = -s
            is_start = upper != start_side
            b = k - 1 if is_start else k  # intermediate body index between stages b and b + 1
            if b < 0:
                return SIDE_A, -1
            if b >= K - 1:
                return SIDE_B, -1
            return INTERNAL, b

        i = np.arange(n + 1)[:, None]
        pts = [np.array(pts).reshape(-1, 3)]
        for k in range(K):
            z = k * self.pitch
            for x0, dz, width in ((-c, 0.0, self.width_inner), (c, zo, self.width_outer), (c, -zo, self.width_outer)):
                a, b = np.array([x0, -s, z + dz]), np.array([-x0, s, z + dz])
                elems.append(sum(map(len, pts)) + np.arange(n))
                pts.append(a + (b - a) * i / n)  # the points a + (b - a) i / n, i = 0 ... n
                (side_a, body_a), (side_b, body_b) = block(k, upper=False), block(k, upper=True)
                side += [side_a] + [INTERNAL] * (n - 1) + [side_b]
                body += [body_a] + [-1] * (n - 1) + [body_b]
                secs += [rectangle(width, self.thickness, self.E, self.G, self.density, yield_stress=self.yield_stress)] * n
                ny.append(np.repeat(np.cross([0.0, 0.0, 1.0], (b - a) / self.length)[None], n, axis=0))
        first = np.concatenate(elems)
        return JointMesh(points=np.concatenate(pts), side=np.array(side), elements=np.stack([first, first + 1], axis=1),
                         sections=tuple(secs), ny0=np.concatenate(ny), body=np.array(body))

    def database_key(self) -> dict:
        """Kinematic data depend on the in-plane leaf geometry over the axis distance (scaled out
        by D0 = (stages - 1) pitch), the number of stages and the mesh."""
        D0 = (self.stages - 1) * self.pitch
        return {"angle": round(float(self.angle), 12), "length_ratio": round(self.length / D0, 9),
                "stages": int(self.stages), "elements_per_leaf": int(self.elements_per_leaf)}
