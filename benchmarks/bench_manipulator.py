"""Manipulator benchmark (issue 5, Fig. 15 of Dwarshuis et al. 2020): conventional vs KSD.

The three-link manipulator of Sec. 4.4 with three three_x_infinity joints (flexmb's design,
27 flexible elements each), 19 positions with all joint rotations from -45 to 45 deg: the joint
case, then the location case through the end points of the joint case. Iterations and median
wall time per position for each method, measured interleaved in one run, the speed-ups, and
KSD-reduced's errors against the converged full model.
Writes the "manipulator" section of BENCHMARKS.md. Run: python benchmarks/bench_manipulator.py [--quick]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run  # noqa: E402
import numpy as np  # noqa: E402
from flexmb.studies import manipulator as mc  # noqa: E402


def main(quick: bool = False) -> str:
    repeats = 1 if quick else 3
    rotations = tuple(range(-45, 46, 15)) if quick else tuple(range(-45, 46, 5))
    rows = mc.study(rotations, repeats=repeats)
    at = {(r["case"], r["rotation"], r["method"]): r for r in rows}
    lines = [
        "## Manipulator: conventional method vs KSD (issue 5, Fig. 15)",
        "",
        f"Dwarshuis et al. (2020) Sec. 4.4 manipulator with flexmb's three_x_infinity joints; {machine()}.",
        f"Median of {repeats} solves per method and position, interleaved, each a whole `flexmb.solve` from the",
        "undeformed state (joint templates cached after a warm-up). Residual norm below 5e-7 (N, N m) for every solve.",
        "Errors: KSD-reduced against the converged full model, reactions (joint case: the three joint moments;",
        "location case: the end-point force) and link displacements, relative. Paper: KSD-full up to 65x,",
        "KSD-reduced up to 600x; errors below 2 % (force) and 0.3 % (displacement) in the location case.",
        "",
        "| case | rotation [deg] | conventional it. / ms | KSD-reduced it. / ms | KSD-full it. / ms | "
        "speed-up reduced / full | error reaction / displacement [%] |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for case in ("joint", "location"):
        for deg in rotations:
            c, r, f = (at[case, deg, k] for k in mc.METHODS)
            lines.append(f"| {case} | {deg} | {c['iterations']} / {c['time']*1e3:.0f} | {r['iterations']} / "
                         f"{r['time']*1e3:.1f} | {f['iterations']} / {f['time']*1e3:.1f} | {r['speedup']:.0f}x / "
                         f"{f['speedup']:.0f}x | {100*r['error_reaction']:.3f} / {100*r['error_displacement']:.4f} |")
    lines.append("")
    for case in ("joint", "location"):
        sel = [r for r in rows if r["case"] == case]
        red = [r for r in sel if r["method"] == "ksd-reduced"]
        full = [r for r in sel if r["method"] == "ksd-full"]
        conv = sum(r["time"] for r in sel if r["method"] == "conventional")
        lines.append(f"- {case} case: KSD-reduced {min(r['speedup'] for r in red):.0f}-{max(r['speedup'] for r in red):.0f}x "
                     f"(total {conv / sum(r['time'] for r in red):.0f}x), KSD-full {min(r['speedup'] for r in full):.0f}-"
                     f"{max(r['speedup'] for r in full):.0f}x (total {conv / sum(r['time'] for r in full):.0f}x); "
                     f"largest KSD-reduced errors {100*np.nanmax([r['error_reaction'] for r in red]):.3f} % (reaction), "
                     f"{100*np.nanmax([r['error_displacement'] for r in red]):.4f} % (displacement).")
    return "\n".join(lines)


if __name__ == "__main__":
    run("manipulator", main, __doc__, "7 positions, one repetition")
