"""Four-bar benchmark (issue 4, Fig. 11 of Dwarshuis et al. 2020): conventional vs KSD.

The four-bar of Sec. 4.3 (four 3D cross flexures of Table 1, W = 0.4 m, H = 0.3 m) with the
upper link displaced by d = 0.3 m, for 1-5 elements per leaf: iterations (KSD split into step 1,
step 3 on the reduced mechanism and step 5 on the full model), median wall times measured
interleaved in one run (single solves, and the steady state of consecutive solves with one
method), and the speed-ups over the conventional method. Every solve stops at a residual norm
below 5e-7 (N and N m), as the paper.
Writes the "fourbar" section of BENCHMARKS.md. Run: python benchmarks/bench_fourbar.py [--quick]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run  # noqa: E402
from flexmb.studies import fourbar as fc  # noqa: E402


def main(quick: bool = False) -> str:
    repeats = 3 if quick else 15
    rows = fc.speed_study(repeats=repeats)
    lines = [
        "## Four-bar: conventional method vs KSD (issue 4, Fig. 11)",
        "",
        f"Dwarshuis et al. (2020) Sec. 4.3 four-bar, d = 0.3 m; {machine()}. Median of {repeats} solves per method;",
        "each time is a whole `flexmb.solve` (compiling the model included; garbage collection paused as in timeit; joint meshes and EOB",
        "templates cached after a warm-up solve, as in an optimisation loop). Two timings, each measured interleaved over the",
        "methods in this run: *single* = one solve per method in turn after a full garbage collection, so each starts with the",
        "CPU caches another method left; *steady* = three solves in a row per method and turn, the last two timed (a sweep or",
        "optimisation loop solving with one method). Iterations: Newton corrections; KSD = step 1 (kinematics) + step 3 (reduced",
        "mechanism) + step 5 (full model). The paper (MATLAB): KSD-full about 5x and KSD-reduced about 20x faster at 4-5 elements",
        "per leaf.",
        "",
        "| el./leaf | free DOFs | method | iterations (step 1 + 3 + 5) | single [ms] | speed-up | steady [ms] | speed-up | F [N] |",
        "|---:|---:|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        split = (f"{r['iterations']}" if r["method"] == "conventional"
                 else f"{r['iterations']} ({r['kinematics']} + {r['reduced']} + {r['full']})")
        lines.append(f"| {r['elements_per_leaf']} | {r['dofs']} | {r['method']} | {split} | {r['time']*1e3:.1f} | "
                     f"{r['speedup']:.1f}x | {r['time_steady']*1e3:.1f} | {r['speedup_steady']:.1f}x | "
                     f"{r['force']:.4f} |")
    at = {(r["elements_per_leaf"], r["method"]): r for r in rows}
    lines += [""]
    for n in (4, 5):
        f, red = at[n, "ksd-full"], at[n, "ksd-reduced"]
        lines.append(f"- {n} el./leaf: KSD-full {f['speedup']:.1f}x single / {f['speedup_steady']:.1f}x steady, "
                     f"KSD-reduced {red['speedup']:.1f}x single / {red['speedup_steady']:.1f}x steady faster than "
                     "the conventional method (paper: ~5x, ~20x).")
    return "\n".join(lines)


if __name__ == "__main__":
    run("fourbar", main, __doc__, "3 repetitions instead of 15")
