"""Tutorial: the spatial manipulator of Dwarshuis et al. (2020, Sec. 4.4) with KSD.

Three large-stroke `three_x_infinity` hinges carry three links; the end point is moved to where
all three joints turn by the same angle (the paper's location case). The conventional method
solves the full finite-element model by continuation; KSD (Kinematically Started Deformation)
starts from the joints' trained kinematics: `ksd-reduced` stops at the reduced mechanism of
Element Orientation based Bodies (steps 1-4), `ksd-full` finishes with Newton on the full model
(step 5). Printed: the end point's reaction and the joints' positions by each strategy, their
differences to the conventional answer and the iterations.
Run: python examples/tutorial_manipulator.py [--quick]   (--quick: 30 deg only; else -30 and 30)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb.studies import example_arguments

METHODS = ("conventional", "ksd-full", "ksd-reduced")


def compare(rotation: float) -> dict:
    """The three strategies at one position: reactions, node positions and iterations."""
    # --8<-- [start:solve]
    m = flexmb.models.manipulator("location", rotation)      # 3 el./leaf: the shipped KSD database
    solutions = {method: flexmb.solve(m, method=method) for method in METHODS}
    # --8<-- [end:solve]
    ref = solutions["conventional"]
    rows = {}
    for method, s in solutions.items():
        force = s.reaction("link3")[:3]                          # [N] the end point's reaction
        rows[method] = {
            "force": force,
            "force error": np.linalg.norm(force - ref.reaction("link3")[:3]) / np.linalg.norm(ref.reaction("link3")[:3]),
            "position error": np.max(np.abs(s.node_positions() - ref.node_positions())),   # [m]
            "iterations": s.iterations}
    return rows


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print the comparison at 30 deg (and -30 deg unless ``quick``); nothing is written."""
    results = {}
    print(f"{'deg':>4} {'method':>12} {'end-point reaction [N]':>30} {'force error [%]':>15} "
          f"{'node error [um]':>15} {'iterations':>10}")
    for deg in (30.0,) if quick else (-30.0, 30.0):
        results[deg] = rows = compare(np.radians(deg))
        for method, r in rows.items():
            f = r["force"]
            print(f"{deg:4.0f} {method:>12} {f[0]:9.4f} {f[1]:9.4f} {f[2]:9.4f} {r['force error'] * 100:15.3f} "
                  f"{r['position error'] * 1e6:15.3f} {r['iterations']:10d}")
    return {"results": results}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
