"""The designer's quantities of "accuracy by default" (`flexmb.accuracy`) on mechanisms no paper
holds, each built as a user would, on the joints' default meshes unless ``n`` (elements per
leaf) is given: tests/test_accuracy.py checks them against converged-mesh references and
benchmarks/bench_accuracy.py times them.

1. `parallel_guide`: two leaves in mm, N, MPa; the parasitic shortening and the support stiffness
   along the leaves at 10 % stroke.
2. `stage`: a folded double-parallelogram stage in mm, N, MPa; the stage's support stiffness
   across the stroke at full stroke (5 mm).
3. `pivot`: a 3D cross flexure (SI) turned 15 deg carrying a 0.3 kg block under an axial load of a
   quarter of its buckling load; the first three frequencies and the buckling multiplier.
4. `bistable`: a chevron of two inclined leaves (mm, N, MPa) whose shuttle is guided across; the
   snap force, the first instability of the force-controlled path (`flexmb.EquilibriumPath.snap`: a limit point).
"""

from __future__ import annotations

import math

import numpy as np

from ..joints.cross_flexure import CrossFlexure
from ..joints.leaf_spring import LeafSpring
from ..linearised import buckling, compliance
from ..mechanism import Mechanism
from ..modal import modes
from ..path import trace

__all__ = ["parallel_guide", "guide_quantities", "stage", "stage_quantities", "pivot", "pivot_quantities",
           "bistable", "snap", "snap_force", "CASES", "STEEL_MM"]

#: Steel in mm, N, MPa, tonne/mm^3.
STEEL_MM = {"E": 210000.0, "G": 80769.0, "density": 7.85e-9}


def _mesh(n: int | None, name: str = "elements") -> dict:
    return {} if n is None else {name: n}


def parallel_guide(n: int | None = None) -> Mechanism:
    """Two leaves 40 x 8 x 0.2 mm, 20 mm apart, from the base to a stage pushed 4 mm across them."""
    m = Mechanism(dim=2)
    m.add_link("base", fixed=True)
    m.add_link("stage", position=(40.0, 10.0))
    for name, y in (("lower", 0.0), ("upper", 20.0)):
        m.add_joint("base", "stage", LeafSpring(length=40.0, thickness=0.2, width=8.0, **STEEL_MM, **_mesh(n)),
                    name=name, origin=(0.0, y))
    m.prescribe("stage", y=4.0)
    return m


def guide_quantities(sol) -> dict:
    """The stage's parasitic shortening [mm] (its displacement along the leaves) and its support
    stiffness along them [N/mm] (1 / C_xx, the stroke held)."""
    return {"shortening": float(sol.displacement("stage")[0]),
            "support_stiffness": float(1.0 / compliance(sol, "stage")[0, 0])}


def stage(n: int | None = None, stroke: float = 5.0) -> Mechanism:
    """A folded double-parallelogram stage: outer leaves 60 x 10 x 0.5 mm from the ground at
    x = +-20 mm up to the intermediate body, inner leaves from it down to the stage at +-15 mm;
    the stage's x prescribed (``stroke`` [mm])."""
    m = Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("intermediate", position=(0.0, 60.0))
    m.add_link("stage", position=(0.0, 0.0))
    leaf = dict(length=60.0, thickness=0.5, width=10.0, **STEEL_MM, **_mesh(n))
    for s in (-1, 1):
        m.add_joint("ground", "intermediate", LeafSpring(**leaf), origin=(s * 20.0, 0.0), rotation=math.pi / 2,
                    name=f"outer{s:+d}")
        m.add_joint("stage", "intermediate", LeafSpring(**leaf), origin=(s * 15.0, 0.0), rotation=math.pi / 2,
                    name=f"inner{s:+d}")
    m.prescribe("stage", x=stroke)
    return m


def stage_quantities(sol) -> dict:
    """The stage's support stiffness across the stroke [N/mm] (1 / C_yy) and the stroke force [N]."""
    return {"support_stiffness": float(1.0 / compliance(sol, "stage")[1, 1]),
            "force": float(sol.reaction("stage")[0])}


def pivot(n: int | None = None) -> Mechanism:
    """A 3D cross flexure (leaves 60 mm long, 0.4 mm thick, 20 and 2 x 10 mm wide, at 40 deg to
    the base; steel, SI) turned 15 deg about its axis, carrying a 0.3 kg block (inertia 2e-4,
    2e-4, 3e-4 kg m^2) pressed by 60 N along the pivot's axis (y)."""
    joint = CrossFlexure(length=0.06, thickness=0.4e-3, width_inner=0.02, width_outer=0.01,
                         angle=math.radians(40.0), **_mesh(n, "elements_per_leaf"))
    m = Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3), mass=0.3, inertia=np.diag([2e-4, 2e-4, 3e-4]))
    m.add_joint("A", "B", joint, name="pivot")
    m.prescribe("B", rotation=(0.0, 0.0, math.radians(15.0)))
    m.apply_force("B", (0.0, -60.0, 0.0))
    return m


def pivot_quantities(sol) -> dict:
    """The first three natural frequencies [Hz] and the buckling multiplier of the axial load."""
    f = modes(sol, n_modes=3).frequencies
    return {"f1": float(f[0]), "f2": float(f[1]), "f3": float(f[2]), "buckling": float(buckling(sol)[0])}


def bistable(n: int | None = None, force: float = 40.0) -> Mechanism:
    """A chevron bistable: two leaves 30 x 5 x 0.6 mm inclined at 3 deg from anchors 2 x 29.96 mm
    apart up to a shuttle guided across them (its x and rotation held), pushed down by a dead
    ``force`` [N] (mm, N, MPa)."""
    th = math.radians(3.0)
    m = Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("shuttle", position=(0.0, 30.0 * math.sin(th)))
    leaf = dict(length=30.0, thickness=0.6, width=5.0, **STEEL_MM, **_mesh(n))
    m.add_joint("ground", "shuttle", LeafSpring(**leaf), origin=(-30.0 * math.cos(th), 0.0), rotation=th, name="left")
    m.add_joint("ground", "shuttle", LeafSpring(**leaf), origin=(30.0 * math.cos(th), 0.0), rotation=math.pi - th,
                name="right")
    m.prescribe("shuttle", x=0.0, rotation=0.0)
    m.apply_force("shuttle", (0.0, -force))
    return m


def snap(mechanism):
    """The first instability (`flexmb.EquilibriumPath.snap`, a `flexmb.Critical`) of ``mechanism`` (a
    `bistable`), its path traced by `flexmb.trace` until the shuttle has crossed the anchors' line;
    its ``discretisation`` is the estimate of the snap load factor's mesh error."""
    rise = mechanism.links["shuttle"].position[1]
    path = trace(mechanism, steps=300, arc_length=0.05, progress=False,
                 stop=lambda s: -s.displacement("shuttle")[1] > 1.2 * rise)
    return path.snap


def snap_force(mechanism, force: float = 40.0) -> tuple[float, str]:
    """The snap force [N] of ``mechanism`` (a `bistable` under ``force``): its `snap` load factor
    times ``force``, and that point's kind (``"limit"``: the snap-through)."""
    point = snap(mechanism)
    return float(point.load_factor * force), point.kind


#: case -> (builder, quantities of a solution) for the solved cases (the bistable is traced)
CASES = {"parallel_guide": (parallel_guide, guide_quantities), "stage": (stage, stage_quantities),
         "pivot": (pivot, pivot_quantities)}
