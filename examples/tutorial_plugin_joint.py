"""Tutorial: writing a joint plugin, a folded leaf spring (a kind flexmb does not ship).

A folded leaf: two parallel leaves joined at their far ends by a rigid intermediate body, so
node B sits beside node A and the stroke of one leaf length needs half the space. The class
gives flexmb its beam-element model; flexmb supplies the co-rotational elements, the tangent,
the solvers and the properties. Registered in this session with `flexmb.register_joint` (a
package registers it in the `flexmb.joints` entry-point group instead, docs/plugins.md), solved
in a guided stage, checked against beam theory (guided: k = 6 EI/L^3, two clamped-guided leaves
in series) and run through flexmb's conformance kit (`flexmb.testing`).
Run: python examples/tutorial_plugin_joint.py [--quick]   (--quick: the kit's checks skipped)
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import attrs
import numpy as np

import flexmb
from flexmb.joints import INTERNAL, SIDE_A, SIDE_B, JointMesh
from flexmb.joints import validate as v
from flexmb.studies import example_arguments


# --8<-- [start:class]
@attrs.frozen(kw_only=True)
class FoldedLeaf(flexmb.Joint):
    """Folded leaf spring [``folded_leaf``]: leaf 1 from node A along x, a rigid body across,
    leaf 2 back to node B at ``(0, gap[, 0])``; the width along the joint's z axis.

    Parameters
    ----------
    length, thickness, width, gap
        Leaf length, thickness and width, and the distance between the leaves [length]
        (0.05, 5e-4, 0.01, 0.01); ``thickness < length / 10``, ``thickness < gap``.
    E, nu
        Young's modulus [stress] and Poisson's ratio (200e9, 0.3).
    density
        Mass density [mass/length^3] (7800).
    elements
        Beam elements per leaf (12).
    """

    kind: ClassVar[str] = "folded_leaf"
    mesh_parameter: ClassVar[str] = "elements"                 # what refinement multiplies
    parameter_ranges: ClassVar[dict] = {"length": (0.03, 0.08), "thickness": (3e-4, 1e-3)}
    motion_range: ClassVar[float] = 0.05                       # [rad] the kit's intended motions

    length: float = 0.05
    thickness: float = 5e-4
    width: float = 0.01
    gap: float = 0.01
    E: float = 200e9
    nu: float = 0.3
    density: float = 7800.0
    elements: int = 12

    def __attrs_post_init__(self):
        for name in ("length", "thickness", "width", "gap", "E"):
            v.positive(self.kind, name, getattr(self, name))
        v.in_open_range(self.kind, "thickness", self.thickness, 0.0, min(self.length / 10, self.gap))
        v.in_open_range(self.kind, "nu", self.nu, -1.0, 0.5)
        v.nonnegative(self.kind, "density", self.density)
        v.integer(self.kind, "elements", self.elements, 1, v.MAX_ELEMENTS)

    def interface_b(self, dim: int) -> np.ndarray:
        return np.array([0.0, self.gap, 0.0][:dim])

    def mesh(self, dim: int) -> JointMesh:
        n, L, g = self.elements, self.length, self.gap
        s = np.linspace(0.0, L, n + 1)
        leaf1 = np.c_[s, np.zeros(n + 1)]                       # A ... body's lower corner
        leaf2 = np.c_[s[::-1], np.full(n + 1, g)]               # body's upper corner ... B
        points = np.vstack([leaf1, leaf2])
        if dim == 3:
            points = np.c_[points, np.zeros(2 * n + 2)]
        side = np.full(2 * n + 2, INTERNAL)
        side[0], side[-1] = SIDE_A, SIDE_B
        body = np.full(2 * n + 2, -1)
        body[[n, n + 1]] = 0                                    # the two corners: one rigid body
        elements = np.array([(i, i + 1) for i in range(n)] + [(i, i + 1) for i in range(n + 1, 2 * n + 1)])
        section = flexmb.rectangle(self.width, self.thickness, self.E, nu=self.nu, density=self.density)
        ny0 = np.tile([0.0, 1.0, 0.0], (2 * n, 1)) if dim == 3 else None
        return JointMesh(points=points, side=side, elements=elements, sections=(section,) * (2 * n), ny0=ny0,
                         body=body)
# --8<-- [end:class]


# --8<-- [start:use]
flexmb.register_joint("folded_leaf", FoldedLeaf, clobber=True)   # a package: an entry point instead


def stage() -> flexmb.Mechanism:
    """A stage guided by the mechanism (its rotation held), moved along y across the leaves."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("stage", position=(0.0, 0.01))                  # at node B
    m.add_joint("ground", "stage", "folded_leaf", name="fold", elements=12)
    m.prescribe("stage", y=0.0, rotation=0.0)                  # x free: the parasitic drift
    return m
# --8<-- [end:use]


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Stiffness against beam theory and the conformance report; nothing is written."""
    # --8<-- [start:solve]
    joint = FoldedLeaf()
    pushes = np.array([1e-4, 2.5e-3, 5e-3])                    # [m], up to a tenth of the leaf
    result = flexmb.sweep(stage(), pushes, motion=("stage", "y"), progress=False)
    force = np.array([s.reaction("stage")[1] for s in result])            # [N]
    drift = np.array([s.displacement("stage")[0] for s in result])        # [m] along the leaves
    # --8<-- [end:solve]
    EI = joint.E * joint.width * joint.thickness**3 / 12
    k_beam = 6 * EI / joint.length**3                           # two clamped-guided leaves in series
    print(f"{'push [mm]':>9} {'k [N/m]':>9} {'6EI/L^3':>9} {'drift [um]':>10} {'one leaf 0.6d²/L [um]':>22}")
    for d, f, x in zip(pushes, force, drift):
        print(f"{d * 1e3:9.2f} {f / d:9.3f} {k_beam:9.3f} {x * 1e6:10.3f} {0.6 * d**2 / joint.length * 1e6:22.3f}")
    report = None
    if not quick:
        # --8<-- [start:kit]
        class FoldedLeafConformance(flexmb.testing.JointConformance):   # pytest would run it as a test class
            joint_class = FoldedLeaf

        report = flexmb.testing.conformance_report(FoldedLeafConformance)
        # --8<-- [end:kit]
        counts = {status: sum(o[1] == status for o in report.outcomes) for status in ("passed", "failed", "skipped")}
        print(f"conformance kit: {counts['passed']} passed, {counts['failed']} failed, {counts['skipped']} skipped")
    return {"pushes": pushes, "force": force, "drift": drift, "k_beam": k_beam, "report": report}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
