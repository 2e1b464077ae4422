"""The three_x_infinity hinge over its stroke of +-45 deg (Naves et al. 2017's objective): the
first parasitic frequency, its ratio to the intended mode's frequency, and the critical
compressive force along the joint axis (A -> B).

Steel leaves (7800 kg/m^3, the joint's defaults: 30 mm long, 0.45 mm thick, 3 stages), link A
fixed, block B of 50 g with inertia diag(3.3e-6) kg m^2 about its centre (node B; a 20 mm steel
cube). B's orientation is prescribed to the turn and swept with continuation
(`flexmb.sweep(..., properties=...)`); then

* f1, f2: the parasitic frequencies, B's rotation about z held and B otherwise free (the
  prescription's reactions stay dead loads);
* the intended mode: the first frequency with the turn released too (``held="fixed"``);
* F_cr: the critical force along the axis from `flexmb.buckling` about the turned, unloaded
  state (``base``; the multiplier scales only a 1 N increment), B's turn held.

At 3, 5 and 10 elements per leaf. Run: python examples/three_x_infinity_range.py [--quick]
(--quick: 3 el./leaf at -45, 0, 45 deg)
"""

from __future__ import annotations

import numpy as np

import flexmb
from flexmb.studies import example_arguments

ANGLES_DEG = (-45.0, -30.0, -15.0, 0.0, 15.0, 30.0, 45.0)
ELEMENTS = (3, 5, 10)
BLOCK_MASS, BLOCK_INERTIA = 0.05, 3.3e-6  # [kg], [kg m^2]


def hinge(elements_per_leaf: int = 5, force: float = 0.0) -> flexmb.Mechanism:
    """The hinge with block B, B's orientation prescribed (turned by `flexmb.sweep`), pushed
    towards A along the joint axis by ``force`` [N]."""
    joint = flexmb.ThreeXInfinity(elements_per_leaf=elements_per_leaf, density=7800.0)
    axis = joint.interface_b(3) / np.linalg.norm(joint.interface_b(3))
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3), mass=BLOCK_MASS, inertia=BLOCK_INERTIA * np.eye(3))
    m.add_joint("A", "B", joint, name="hinge")
    m.prescribe("B", rotation=(0.0, 0.0, 0.0))
    if force:
        m.apply_force("B", -force * axis)
    return m


def run(angles=ANGLES_DEG, elements=ELEMENTS) -> dict:
    """``{n: Table}`` with columns ``B.rotation_z`` [rad], ``f1``, ``f2`` [Hz] (parasitic),
    ``intended`` [Hz], ``ratio`` (f1 / intended), ``F_cr`` [N]."""
    out = {}
    turns = np.radians(np.asarray(angles, dtype=float))
    values = np.column_stack([np.zeros_like(turns), np.zeros_like(turns), turns])
    for n in elements:
        unloaded = flexmb.sweep(hinge(n), values, motion=("B", "rotation"), progress=False,
                                properties={"which": ("modes",), "n_modes": 2, "held": [("B", "rz")]})
        pushed = flexmb.sweep(hinge(n, force=1.0), values, motion=("B", "rotation"), progress=False)
        if not (unloaded.converged.all() and pushed.converged.all()):
            raise flexmb.ConvergenceError(f"{n} el./leaf: a turn did not converge", None)
        t = dict(unloaded.table())
        t["intended"] = flexmb.properties(unloaded, ("modes",), n_modes=1, held="fixed")["f1"]
        t["ratio"] = t["f1"] / t["intended"]
        t["F_cr"] = np.array([flexmb.buckling(p, held=[("B", "rz")], base=u)[0] for p, u in zip(pushed, unloaded)])
        out[n] = flexmb.Table(t)
    return out


def table(results: dict) -> str:
    """The results as a Markdown table, one row per turn and mesh."""
    rows = ["| B turned | el./leaf | f1, f2 parasitic [Hz] | intended [Hz] | f1 / intended | F_cr along the axis [N] |",
            "|---|---|---|---|---|---|"]
    for n, t in sorted(results.items()):
        for k, turn in enumerate(t["B.rotation_z"]):
            rows.append(f"| {round(float(np.degrees(turn))) + 0:+d} deg | {n} | {t['f1'][k]:.1f}, {t['f2'][k]:.1f} | "
                        f"{t['intended'][k]:.2f} | {t['ratio'][k]:.2f} | {t['F_cr'][k]:.1f} |")
    return "\n".join(rows)


def main(out=None, quick: bool = False) -> dict:
    """Print the table (`run`'s results; ``quick``: 3 el./leaf at -45, 0, 45 deg). Writes no files."""
    results = run(angles=(-45.0, 0.0, 45.0), elements=(3,)) if quick else run()
    print(table(results))
    return results


if __name__ == "__main__":
    main(*example_arguments(__doc__))
