"""Buckling of the Table 1 three-leaf cross flexure (Dwarshuis et al. 2020) under a compressive
dead force on block B along the joint axis (A -> B), B turned about z to 0 and 30 deg.

The critical force from `flexmb.buckling` about a preloaded state (``base``: B turned, the force
off or at a level F0; the multiplier scales only the force's increment of 1 N, the turn's
stresses stay), with B's rotation about z held (B otherwise free) and with it free too (the
moment that holds the turn stays a dead load), at 3, 5 and 10 elements per leaf. Each is found
twice: from F0 = 0, and from F0 = half the critical force found so, which shows how far the
pre-buckling path is from linear (where it is linear the two agree). The non-linear answer is the
critical point of a traced path (`flexmb.trace`): at 0 deg with the turn free (B not prescribed,
the force scaled from 0 to 1.2 times the linearised estimate), its bifurcation point. (`trace`
scales prescribed motions with the load, so a turned B is no preload for it.)
Run: python examples/cross_flexure_buckling.py [--quick]   (--quick: 3 el./leaf only)
"""

from __future__ import annotations

import numpy as np

import flexmb
from flexmb.studies import example_arguments

ANGLES_DEG = (0.0, 30.0)
ELEMENTS = (3, 5, 10)
HELD = {"turn held": [("B", "rz")], "turn free": "fixed"}


def loaded_pivot(rotation_deg: float, force: float, elements_per_leaf: int = 5) -> flexmb.Mechanism:
    """The cross flexure, B turned to ``rotation_deg`` about z and pushed towards A by ``force`` [N]."""
    joint = flexmb.CrossFlexure(elements_per_leaf=elements_per_leaf)
    axis = joint.interface_b(3) / np.linalg.norm(joint.interface_b(3))
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3))
    m.add_joint("A", "B", joint, name="pivot")
    m.prescribe("B", rotation=(0.0, 0.0, np.radians(rotation_deg)))
    m.apply_force("B", -force * axis)
    return m


def _solve(rotation_deg, force, elements):
    sol = flexmb.solve(loaded_pivot(rotation_deg, force, elements))
    if not sol.converged:
        raise flexmb.ConvergenceError(f"{rotation_deg} deg, {force:.4g} N, {elements} el./leaf: {sol.message}", sol)
    return sol


def critical_force(rotation_deg: float, elements: int, held, preload: float = 0.0, step: float = 1.0) -> float:
    """The linearised critical force [N] about the state under ``preload`` [N]: ``preload + lam
    step`` with ``lam`` the multiplier of the increment ``step`` [N] (`flexmb.buckling` with
    ``base``)."""
    base = _solve(rotation_deg, preload, elements)
    sol = _solve(rotation_deg, preload + step, elements)
    return float(preload + flexmb.buckling(sol, held=held, base=base)[0] * step)


def traced_critical_force(elements: int, estimate: float) -> float:
    """The bifurcation force [N] of the unturned pivot with B free, from `flexmb.trace` of the force
    scaled up to 1.2 ``estimate`` [N]."""
    joint = flexmb.CrossFlexure(elements_per_leaf=elements)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3))
    m.add_joint("A", "B", joint, name="pivot")
    m.apply_force("B", -1.2 * estimate * joint.interface_b(3) / np.linalg.norm(joint.interface_b(3)))
    path = flexmb.trace(m, max_load_factor=1.0, steps=60, progress=False)
    found = [c.load_factor for c in path.critical if c.kind == "bifurcation"]
    return 1.2 * estimate * found[0] if found else float("nan")


def run(angles=ANGLES_DEG, elements=ELEMENTS) -> dict:
    """``{(deg, n, case): (F_cr from 0 N, F_cr from half of it)}`` [N], case "turn held" / "turn
    free"; at 0 deg also ``(0, n, "trace")``: the traced bifurcation force, turn free."""
    out = {}
    for n in elements:
        for deg in angles:
            for case, held in HELD.items():
                first = critical_force(deg, n, held)
                out[deg, n, case] = (first, critical_force(deg, n, held, preload=0.5 * first))
            if deg == 0.0:
                out[deg, n, "trace"] = traced_critical_force(n, out[deg, n, "turn free"][0])
    return out


def table(results: dict) -> str:
    """The results as a Markdown table."""
    rows = ["| B turned | el./leaf | F_cr, turn held [N]: from 0 / from ½ F_cr | "
            "F_cr, turn free [N]: from 0 / from ½ F_cr | traced bifurcation, turn free [N] |", "|---|---|---|---|---|"]
    for deg, n in sorted({k[:2] for k in results}):
        cells = [" / ".join(f"{x:.1f}" for x in results[deg, n, case]) for case in HELD]
        traced = results.get((deg, n, "trace"))
        rows.append(f"| {deg:g} deg | {n} | {cells[0]} | {cells[1]} | {'—' if traced is None else f'{traced:.1f}'} |")
    return "\n".join(rows)


def main(out=None, quick: bool = False) -> dict:
    """Print the table (`run`'s results; ``quick``: 3 el./leaf only). Writes no files."""
    results = run(elements=(3,) if quick else ELEMENTS)
    print(table(results))
    return results


if __name__ == "__main__":
    main(*example_arguments(__doc__))
