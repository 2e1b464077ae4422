"""Mesh-independent iterations (issue 31 item 3): the continuation's Newton iterations on refined meshes.

The four-bar (d = 0.3 m) at 5, 10, 20 and 40 elements per leaf and the manipulator's joint and
location cases at -45 and 45 deg (the location case along its kinematic path, `models.manipulator`,
and on the straight end-point line it followed before), solved by the default conventional method
(the continuation) as it is (*after*: the tangent predictor, `StaticProblem.path_rate`, and the first step sized by its
linear predictor's stretch, `AdaptiveControl.predictor_cut`) and with those two switched off
(*before*: the extrapolation of the converged states alone and the whole first step, as released
until issue 31), interleaved in one run; iterations, steps (rejected), median wall and CPU time of a
whole `flexmb.solve` of one kept mechanism (compile cached), and the largest node-position
difference after / before over the largest coordinate. Writes the "meshes" section of
BENCHMARKS.md. Run: python benchmarks/bench_meshes.py [--quick]
"""

from __future__ import annotations

import gc
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import flexmb  # noqa: E402
from _report import machine, run  # noqa: E402
from flexmb.solvers import conventional  # noqa: E402


class Before(conventional.AdaptiveControl):
    """The continuation without the tangent predictor and without the first step's stretch cut."""

    def _rate(self, step):
        return None

    def predictor_cut(self, predicted):
        return None


def _solve(mechanism, before: bool):
    """One timed `flexmb.solve` (wall, CPU [s]) with the control of ``before``."""
    keep = conventional.AdaptiveControl
    conventional.AdaptiveControl = Before if before else keep
    gc.disable()
    try:
        w, c = time.perf_counter(), time.process_time()
        sol = flexmb.solve(mechanism)
        return sol, time.perf_counter() - w, time.process_time() - c
    finally:
        gc.enable()
        conventional.AdaptiveControl = keep


def cases(quick: bool):
    for n in ((5, 10, 20) if quick else (5, 10, 20, 40)):
        yield f"four-bar, d = 0.3 m, {n} el./leaf", flexmb.models.fourbar(n, displacement=0.3)
    for case in ("joint", "location"):
        for deg in (-45, 45):
            yield f"manipulator, {case} case, {deg} deg", flexmb.models.manipulator(case, np.radians(deg))
    for deg in (-45, 45):  # the location case as before its kinematic path: the end point on a straight line
        m = flexmb.models.manipulator("location", np.radians(deg))
        m.prescribe("link3", path=None)
        yield f"manipulator, location on a straight end-point line, {deg} deg", m


def main(quick: bool = False) -> str:
    repeats = 1 if quick else 5
    rows = []
    for name, mech in cases(quick):
        runs = {True: [], False: []}
        for _ in range(repeats):
            for before in (True, False):
                runs[before].append(_solve(mech, before))
        sols = {k: v[0][0] for k, v in runs.items()}
        scale = float(np.max(np.abs(sols[True].node_positions())))
        diff = float(np.max(np.abs(sols[False].node_positions() - sols[True].node_positions()))) / scale
        med = {k: (float(np.median([r[1] for r in v])), float(np.median([r[2] for r in v]))) for k, v in runs.items()}
        rows.append((name, sols, med, diff))
    lines = [
        "## Iterations on refined meshes: the continuation's tangent predictor and first step (issue 31 item 3)",
        "",
        f"{machine()}. Each row: the default conventional method (`flexmb.solve(mechanism)`) *before* (extrapolation of",
        "the converged states only, the whole first step) and *after* (the Hermite extrapolation with the path's",
        "tangent at the last converged state, `StaticProblem.path_rate`; the first step scaled until its linear",
        "predictor changes no element's chord by more than 10 %, `AdaptiveControl.predictor_cut`), interleaved,",
        f"median of {repeats} solves of one kept mechanism (garbage collection paused). Node difference: after vs",
        "before over the largest coordinate.",
        "",
        "| case | iterations before / after | steps (rejected) before / after | wall before / after [ms] "
        "| CPU before / after [ms] | node difference |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, sols, med, diff in rows:
        b, a = sols[True], sols[False]
        lines.append(f"| {name} | {b.iterations} / {a.iterations} | {b.steps} ({b.rejected_steps}) / {a.steps} "
                     f"({a.rejected_steps}) | {1e3 * med[True][0]:.1f} / {1e3 * med[False][0]:.1f} | "
                     f"{1e3 * med[True][1]:.1f} / {1e3 * med[False][1]:.1f} | {diff:.1e} |")
    fb = [r for r in rows if r[0].startswith("four-bar")]
    coarse = fb[0][1][False].iterations
    worst = max(r[1][False].iterations for r in fb)
    lines += ["", f"- Four-bar after: the finest meshes take at most {worst} iterations, {worst / coarse:.2f}x the "
                  f"coarsest's {coarse} (before: {max(r[1][True].iterations for r in fb)} against "
                  f"{fb[0][1][True].iterations}).",
              f"- Load average {__import__('os').getloadavg()[0]:.1f} at the end."]
    for case in ("joint", "location"):
        sel = [r for r in rows if f"{case} case" in r[0]]
        lines.append(f"- Manipulator {case} case at -45 / 45 deg after: "
                     + " / ".join(str(r[1][False].iterations) for r in sel) + " iterations (before: "
                     + " / ".join(str(r[1][True].iterations) for r in sel) + ").")
    sel = [r for r in rows if "straight" in r[0]]
    if sel:
        lines.append("- The location case with its end point on a straight line (as until its kinematic path, "
                     "`Mechanism.prescribe`'s `path`): " + " / ".join(str(r[1][False].iterations) for r in sel)
                     + " iterations after, " + " / ".join(str(r[1][True].iterations) for r in sel) + " before.")
    return "\n".join(lines)


if __name__ == "__main__":
    run("meshes", main, __doc__, "one repeat, the four-bar up to 20 el./leaf")
