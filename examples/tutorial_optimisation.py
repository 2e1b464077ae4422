"""Tutorial: a design optimisation (a planar cross-flexure pivot, SI units).

The design: leaf length L and thickness t of a cross-flexure pivot carrying a 1 kg block. The
goal: the highest first parasitic frequency (B's turn held) over a 0.1...0.5 rad stroke, while
the moment that turns it stays below 2 N m anywhere on the stroke. `flexmb.optimize` solves the
stroke as one continuation per design, aggregates each response over it (Kreisselmeier-
Steinhauser) with exact gradients and hands them to SLSQP. Printed: the optimiser's path, the
optimum with its gradients (the KKT conditions: which bound and constraint hold it), and a
brute-force grid of designs that must not beat it.
Run: python examples/tutorial_optimisation.py [--quick]   (the same numbers either way)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb import responses as R
from flexmb.design.optimize import Constraint
from flexmb.design.stroke import Stroke, evaluate_stroke, ks_max, ks_min
from flexmb.studies import example_arguments


# --8<-- [start:design]
def pivot(p: dict) -> flexmb.Mechanism:
    """The design: a function of named floats returning a new mechanism."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, p["L"] * 2**-0.5), mass=1.0, inertia=1e-3)
    m.add_joint("A", "B", "cross_flexure", length=p["L"], thickness=p["t"], elements_per_leaf=4)
    m.prescribe("B", rotation=0.0)
    return m


START = {"L": 0.1, "t": 1e-3}                                # [m]
BOUNDS = {"L": (0.05, 0.15), "t": (5e-4, 1.5e-3)}
STROKE = Stroke([0.1, 0.3, 0.5], motion=("B", "rotation"))   # [rad], solved in order
OBJECTIVE = ks_min(R.frequency(1, held=[("B", "rotation")]))     # the lowest f1 [Hz] over the stroke
MOMENT = ks_max(R.reaction("B", "rotation"))                     # the largest moment [N m]
# --8<-- [end:design]


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Optimise, print the history, the optimum's gradients and the grid; nothing is written,
    ``quick`` changes nothing."""
    # --8<-- [start:optimize]
    result = flexmb.optimize(pivot, START, BOUNDS, objective=OBJECTIVE, maximize=True,
                             constraints=[Constraint(MOMENT, upper=2.0)], stroke=STROKE)
    # --8<-- [end:optimize]
    h = result.history
    moment = [c for c in h.keys() if c.startswith("ks_max") and not c.startswith("margin")][0]
    print(f"{'design':>6} {'L [mm]':>8} {'t [mm]':>8} {'f1 min [Hz]':>11} {'M max [N m]':>11}")
    for i in range(h.n_rows):
        print(f"{i:6d} {h['L'][i] * 1e3:8.3f} {h['t'][i] * 1e3:8.4f} {h['objective'][i]:11.3f} {h[moment][i]:11.4f}")
    print(f"optimum: L = {result.p['L'] * 1e3:.3f} mm, t = {result.p['t'] * 1e3:.4f} mm, f1 >= "
          f"{result.objective:.3f} Hz, feasible: {result.feasible}, {result.solves} solves")
    # --8<-- [start:kkt]
    at = evaluate_stroke(pivot, result.p, [OBJECTIVE, MOMENT], STROKE)      # values and exact gradients
    (dfdL, dfdt), (dMdL, dMdt) = at.jacobian
    mu = dfdt / dMdt                 # the moment constraint's multiplier, from the free parameter t
    nu = mu * dMdL - dfdL            # the bound L >= 50 mm's multiplier
    # --8<-- [end:kkt]
    print(f"gradients at the optimum: df1/dL = {dfdL:.4g} Hz/m, df1/dt = {dfdt:.4g} Hz/m, "
          f"dM/dL = {dMdL:.4g} N, dM/dt = {dMdt:.4g} N")
    print(f"KKT multipliers: moment constraint {mu:.4g} Hz/(N m), lower bound of L {nu:.4g} Hz/m")
    # --8<-- [start:grid]
    n = 6
    best = -np.inf
    for L in np.linspace(*BOUNDS["L"], n):
        for t in np.linspace(*BOUNDS["t"], n):
            ev = evaluate_stroke(pivot, {"L": L, "t": t}, [OBJECTIVE, MOMENT], STROKE, gradient=False)
            if ev.values[1] <= 2.0:
                best = max(best, ev.values[0])
    # --8<-- [end:grid]
    print(f"best feasible design of a {n} x {n} grid: f1 >= {best:.3f} Hz")
    return {"result": result, "jacobian": at.jacobian, "values": at.values, "multipliers": (mu, nu),
            "grid_best": best}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
