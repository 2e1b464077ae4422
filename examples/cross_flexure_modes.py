"""Vibration modes of the Table 1 three-leaf cross flexure (Dwarshuis et al. 2020) over its stroke.

Leaves of steel (7800 kg/m^3), block A fixed, block B a rigid body of 1 kg with inertia
diag(1e-3) kg m^2 about its centre, which is interface node B; B turned about z to 0, 30, 60 and
75 deg (prescribed), then linearised there (`flexmb.modes`):

* the first six frequencies with B's rotation about z held and B otherwise free (the parasitic
  modes; the moment that holds the turn stays as a dead load, so its -1/2 skew(M) part makes the
  problem non-symmetric), and the first one of the same problem symmetrised (that part dropped);
* the intended mode's frequency with B's rotation released too (``held="fixed"``);

at 3, 5 and 10 elements per leaf (mesh convergence).
Run: python examples/cross_flexure_modes.py [--quick]   (--quick: 75 deg, 3 el./leaf)
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

import flexmb
from flexmb.studies import example_arguments
from flexmb.modal import stiffness_and_mass

ANGLES_DEG = (0.0, 30.0, 60.0, 75.0)
ELEMENTS = (3, 5, 10)
BLOCK_MASS, BLOCK_INERTIA = 1.0, 1e-3  # [kg], [kg m^2] about B's centre


def pivot(rotation_deg: float, elements_per_leaf: int = 5) -> flexmb.Mechanism:
    """The cross flexure with block B's mass, B turned to ``rotation_deg`` about z."""
    joint = flexmb.CrossFlexure(elements_per_leaf=elements_per_leaf, density=7800.0)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3), mass=BLOCK_MASS, inertia=BLOCK_INERTIA * np.eye(3))
    m.add_joint("A", "B", joint, name="pivot")
    m.prescribe("B", rotation=(0.0, 0.0, np.radians(rotation_deg)))
    return m


def symmetrised_first(sol, held) -> float:
    """The first frequency [Hz] of the symmetrised problem (the dead moment's skew part dropped)."""
    md = flexmb.modes(sol, n_modes=1, held=held)
    K, M = stiffness_and_mass(sol)
    free = np.setdiff1d(np.arange(K.shape[0]), md.held)
    Kf, Mf = K.toarray()[np.ix_(free, free)], M.toarray()[np.ix_(free, free)]
    lam = sla.eigh(0.5 * (Kf + Kf.T), Mf, eigvals_only=True, subset_by_index=[0, 0])[0]
    return float(np.sqrt(lam) / (2 * np.pi))


def run(angles=ANGLES_DEG, elements=ELEMENTS) -> dict:
    """``{(deg, n): {"parasitic": (6,) Hz, "parasitic_symmetrised": Hz, "intended": Hz}}``."""
    out = {}
    for n in elements:
        for deg in angles:
            sol = flexmb.solve(pivot(deg, n))
            if not sol.converged:
                raise flexmb.ConvergenceError(f"{deg} deg, {n} el./leaf: {sol.message}", sol)
            held = [("B", "rz")]
            out[deg, n] = {
                "parasitic": flexmb.modes(sol, n_modes=6, held=held).frequencies,
                "parasitic_symmetrised": symmetrised_first(sol, held),
                "intended": float(flexmb.modes(sol, n_modes=1, held="fixed").frequencies[0]),
            }
    return out


def table(results: dict) -> str:
    """The results as a Markdown table."""
    rows = ["| B turned | el./leaf | f1 ... f6 [Hz], B's z rotation held | f1 symmetrised | intended mode [Hz] |",
            "|---|---|---|---|---|"]
    for (deg, n), r in sorted(results.items()):
        f = " ".join(f"{x:.1f}" for x in r["parasitic"])
        shift = r["parasitic_symmetrised"] / r["parasitic"][0] - 1
        rows.append(f"| {deg:g} deg | {n} | {f} | {r['parasitic_symmetrised']:.2f} ({shift:+.2%}) | {r['intended']:.3f} |")
    return "\n".join(rows)


def main(out=None, quick: bool = False) -> dict:
    """Print the table (`run`'s results; ``quick``: 75 deg at 3 el./leaf). Writes no files."""
    results = run(angles=(75.0,), elements=(3,)) if quick else run()
    print(table(results))
    return results


if __name__ == "__main__":
    main(*example_arguments(__doc__))
