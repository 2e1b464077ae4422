"""Tutorial: a parallel guide and a double-parallelogram stage (mm, N, MPa; spring steel).

Two leaf springs make a parallel guide: a stage that translates, stiff along the leaves and soft
across them, but whose stage drops as the leaves bend (the parasitic shortening, 0.6 d^2/L per
leaf). Two guides in series, the second hanging back from an intermediate body, make a double
parallelogram: half the stiffness, and the drops cancel. Printed: stiffness, drop and support
stiffness of both, beside the closed forms (beam theory; Awtar et al. 2007 for the support).
Run: python examples/tutorial_parallel_guide.py [--quick]   (the same numbers either way)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb.studies import example_arguments

# --8<-- [start:data]
UNITS = "mm-N-MPa"           # lengths in mm, forces in N, stresses in MPa (flexmb.units)
L, T, W = 40.0, 0.3, 8.0     # leaf length, thickness, width [mm]
LEAF = dict(length=L, thickness=T, width=W, material="spring_steel",   # E = 196 500 MPa here
            elements=24)     # beam elements per leaf: parasitic quantities within 0.2 %
STROKE = 4.0                 # [mm], a tenth of the leaf length
# --8<-- [end:data]


# --8<-- [start:guide]
def parallel_guide() -> flexmb.Mechanism:
    """A stage on two upright leaves 30 mm apart; the stage's x is the motion asked for."""
    m = flexmb.Mechanism(dim=2, units=UNITS)
    m.add_link("ground", fixed=True)
    m.add_link("stage", position=(0.0, L))
    for side, x in (("left", -15.0), ("right", 15.0)):
        m.add_joint("ground", "stage", "leaf_spring", name=side, origin=(x, 0.0), rotation=np.pi / 2, **LEAF)
    m.prescribe("stage", x=0.0)          # x held at 0 for now; y and the rotation are free
    return m
# --8<-- [end:guide]


# --8<-- [start:double]
def double_parallelogram() -> flexmb.Mechanism:
    """Outer leaves carry an intermediate body up; inner leaves carry the stage back down."""
    m = flexmb.Mechanism(dim=2, units=UNITS)
    m.add_link("ground", fixed=True)
    m.add_link("body", position=(0.0, L))        # the intermediate body: free
    m.add_link("stage", position=(0.0, 0.0))
    for side, x in (("outer left", -20.0), ("outer right", 20.0)):
        m.add_joint("ground", "body", "leaf_spring", name=side, origin=(x, 0.0), rotation=np.pi / 2, **LEAF)
    for side, x in (("inner left", -8.0), ("inner right", 8.0)):
        m.add_joint("stage", "body", "leaf_spring", name=side, origin=(x, 0.0), rotation=np.pi / 2, **LEAF)
    m.prescribe("stage", x=0.0)
    return m
# --8<-- [end:double]


# --8<-- [start:measure]
def measure(mechanism: flexmb.Mechanism, d: float) -> dict:
    """Push the stage by ``d`` [mm]: force, stiffness, drop and the support stiffness there."""
    mechanism.prescribe("stage", x=d)
    solution = flexmb.solve(mechanism)
    force = solution.reaction("stage")[0]                      # [N] the actuation force along x
    drop = -solution.displacement("stage")[1]                  # [mm] parasitic motion along y
    support = 1.0 / flexmb.compliance(solution, "stage")[1, 1]   # [N/mm] along y, x held
    return {"force": force, "stiffness": force / d, "drop": drop, "support": support}
# --8<-- [end:measure]


# --8<-- [start:closed]
def closed_forms(n_leaves_in_series: int, d: float) -> dict:
    """Beam theory for the guide (n = 1) and the double parallelogram (n = 2) at stroke d."""
    E = flexmb.material("spring_steel", UNITS).E
    A, I = W * T, W * T**3 / 12
    k_leaf = 12 * E * I / L**3                            # a clamped-guided leaf
    leaf_axial = L / (E * A) + d**2 * L / (700 * E * I)  # Awtar's beam constraint model, per leaf
    return {"stiffness": 2 * k_leaf / n_leaves_in_series,
            "drop": 0.6 * d**2 / L if n_leaves_in_series == 1 else 0.0,
            "support": 2 / leaf_axial if n_leaves_in_series == 1 else float("nan")}
# --8<-- [end:closed]


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Both mechanisms at a small push (0.05 mm, the linear stiffness) and at the full stroke,
    beside the closed forms; nothing is written (``out`` unused), ``quick`` changes nothing."""
    results = {}
    print(f"{'mechanism':22} {'d [mm]':>7} {'k [N/mm]':>9} {'beam':>9} {'drop [mm]':>10} {'0.6d²/L':>9} "
          f"{'k_y [N/mm]':>11} {'BCM':>9}")
    for label, build, n in (("parallel guide", parallel_guide, 1), ("double parallelogram", double_parallelogram, 2)):
        m = build()
        for d in (0.05, STROKE):
            r, c = measure(m, d), closed_forms(n, d)
            results[label, d] = (r, c)
            bcm = f"{c['support']:9.2f}" if np.isfinite(c["support"]) else f"{'-':>9}"
            print(f"{label:22} {d:7.2f} {r['stiffness']:9.5f} {c['stiffness']:9.5f} {r['drop']:10.6f} "
                  f"{c['drop']:9.6f} {r['support']:11.2f} {bcm}")
    return {"results": results}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
