"""Tutorial: a cross-flexure pivot (the planar Table 1 pivot of Dwarshuis et al. 2020, SI units).

Two leaves crossing at their midpoints make a pivot: block B turns about the crossing, held by
the leaves' bending, and drifts a little as it turns. Printed: the moment, the drift of the pivot axis and the
support stiffness over 15...75 deg beside the elastica of the same pivot (flexmb.reference, the
model of Wittrick 1948 solved exactly), and the pivot's intended vibration frequency with a
1 kg block beside sqrt(k/J).
Run: python examples/tutorial_cross_flexure.py [--quick]   (the same numbers either way)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb.reference import cross_spring_pivot
from flexmb.studies import example_arguments

# --8<-- [start:pivot]
pivot = flexmb.CrossFlexure(elements_per_leaf=24)   # Table 1: L = 0.1 m, t = 1 mm, steel
m = flexmb.Mechanism(dim=2)
m.add_link("A", fixed=True)
m.add_link("B", position=pivot.interface_b(2), mass=1.0, inertia=1e-3)   # a 1 kg block [kg, kg m^2]
m.add_joint("A", "B", pivot, name="pivot")
m.prescribe("B", rotation=0.0)                # B's turn is the input; x and y are free
CROSSING = 0.5 * pivot.interface_b(2)         # where the leaves cross, at rest [m]
m.add_point("B", "axis", CROSSING)            # the point of B on the pivot axis
# --8<-- [end:pivot]


def reference(angles: np.ndarray):
    """The elastica of the same pivot: the planar model's inner leaf (w1) and its outer leaf (2 w2)."""
    E, t, L = pivot.material.E, pivot.thickness, pivot.length
    EI = (E * pivot.width_inner * t**3 / 12, E * 2 * pivot.width_outer * t**3 / 12)
    return cross_spring_pivot(angles, length=L, angle=pivot.angle, bending_stiffness=EI), sum(EI)


def main(out: Path | None = None, quick: bool = False) -> dict:
    """The sweep and the frequency; nothing is written, ``quick`` changes nothing."""
    # --8<-- [start:sweep]
    angles = np.radians([15.0, 30.0, 45.0, 60.0, 75.0])
    result = flexmb.sweep(m, angles, motion=("B", "rotation"), progress=False)
    moment = np.array([s.reaction("B")[2] for s in result])              # [N m]
    shift = np.array([s.point("B", "axis") - CROSSING for s in result])   # [m] the axis' drift
    support = np.array([1 / flexmb.compliance(s, "B")[1, 1] for s in result])   # [N/m] along y
    # --8<-- [end:sweep]
    ref, EI = reference(angles)
    k0 = EI / pivot.length                    # the small-angle stiffness [N m/rad]
    print(f"{'angle':>5} {'M [N m]':>9} {'elastica':>9} {'M/(k0 θ)':>8} {'shift x, y [um]':>16} {'elastica':>16} "
          f"{'k_y [N/um]':>10}")
    for a, M, Mr, d, dr, k in zip(angles, moment, ref.moment, shift * 1e6, ref.center_shift * 1e6, support):
        print(f"{np.degrees(a):5.0f} {M:9.4f} {Mr:9.4f} {M / (k0 * a):8.4f} {d[0]:8.1f}, {d[1]:7.1f} {dr[0]:8.1f}, "
              f"{dr[1]:7.1f} "
              f"{k * 1e-6:10.3f}")
    # --8<-- [start:modes]
    at_rest = flexmb.solve(m)
    intended = flexmb.modes(at_rest, n_modes=1, held="fixed").frequencies[0]      # [Hz], the turn released
    J = 1e-3 + 1.0 * (pivot.interface_b(2)[1] / 2) ** 2    # block inertia about the crossing [kg m^2]
    estimate = np.sqrt(k0 / J) / (2 * np.pi)
    # --8<-- [end:modes]
    print(f"intended frequency {intended:.3f} Hz, sqrt(k0/J)/2pi = {estimate:.3f} Hz (k0 = {k0:.3f} N m/rad)")
    return {"angles": angles, "moment": moment, "shift": shift, "support": support, "reference": ref,
            "k0": k0, "intended": intended, "estimate": estimate}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
