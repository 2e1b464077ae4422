"""Step control benchmark (issue 19): the continuation (default) vs the paper's Fig. 18 control.

Newton iterations and median wall time of the conventional method with ``step_control="adaptive"``
(the default) and ``"paper"`` on the benchmark cases: the Table 1 cross flexure (3 el./leaf,
5-75 deg, 2D and 3D), the four-bar (d = 0.3 m, 1-5 el./leaf) and the 38 manipulator positions
(joint and location case, -45...45 deg), the largest node-position difference between the two
(relative to the largest coordinate), and the KSD speed-ups against both controls (four-bar and
manipulator). All measured interleaved in one run (garbage collection paused during each solve).
Writes the "steps" section of BENCHMARKS.md. Run: python benchmarks/bench_steps.py [--quick]
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
from flexmb.solvers import Conventional  # noqa: E402

#: before (Fig. 18 with the paper's absolute tol, as released) and after (the defaults)
CONTROLS = {"paper": Conventional(step_control="paper", tol=5e-7), "default": Conventional()}


def _timed(mechanism, methods: dict, repeats: int) -> tuple[dict, dict]:
    """Last solution and median time [s] per method (name -> strategy or method name), interleaved."""
    times = {k: [] for k in methods}
    sols = {}
    for k, method in methods.items():  # warm-up (joint templates, compiled kernels)
        flexmb.solve(mechanism, method=method)
    for _ in range(repeats):
        for k, method in methods.items():
            gc.collect()
            gc.disable()
            try:
                t = time.perf_counter()
                sols[k] = flexmb.solve(mechanism, method=method)
                times[k].append(time.perf_counter() - t)
            finally:
                gc.enable()
            if not sols[k].converged:
                raise RuntimeError(f"{k} did not converge: {sols[k].message}")
    return sols, {k: float(np.median(v)) for k, v in times.items()}


def _difference(a, b) -> float:
    x = b.node_positions()
    return float(np.abs(a.node_positions() - x).max() / np.abs(x).max())


def cases(quick: bool):
    angles = range(5, 76, 35 if quick else 5)
    for dim in (2, 3):
        yield (f"cross flexure {dim}D", [flexmb.models.cross_flexure_pivot(3, dim=dim, rotation=np.radians(a))
                                         for a in angles], False)
    for n in range(1, 6):
        yield f"four-bar {n} el./leaf", [flexmb.models.fourbar(n, displacement=0.3)], True
    for case in ("joint", "location"):
        for deg in range(-45, 46, 45 if quick else 5):
            yield f"manipulator {case} {deg} deg", [flexmb.models.manipulator(case, np.radians(deg))], True


def main(quick: bool = False) -> str:
    repeats = 1 if quick else 3
    rows = []
    for name, mechanisms, ksd in cases(quick):
        methods = dict(CONTROLS, **({"ksd-reduced": "ksd-reduced", "ksd-full": "ksd-full"} if ksd else {}))
        agg = {"it": {k: 0 for k in CONTROLS}, "t": {k: 0.0 for k in methods}, "diff": 0.0}
        for m in mechanisms:
            sols, times = _timed(m, methods, repeats)
            for k in CONTROLS:
                agg["it"][k] += sols[k].iterations
            for k in methods:
                agg["t"][k] += times[k]
            agg["diff"] = max(agg["diff"], _difference(sols["default"], sols["paper"]))
        rows.append((name, len(mechanisms), ksd, agg))
    it = {k: sum(r[3]["it"][k] for r in rows) for k in CONTROLS}
    tt = {k: sum(r[3]["t"][k] for r in rows) for k in CONTROLS}
    lines = [
        "## Step control: continuation (default) vs Fig. 18 (issue 19)",
        "",
        f"{machine()}; median of {repeats} interleaved solves per method (garbage collection paused), each a whole",
        "`flexmb.solve` from the undeformed state. *paper* (before): `tol=5e-7` (absolute, the paper's) and",
        "`step_control=\"paper\"` (Fig. 18: linear predictor, halving, doubling after <= 4 iterations); *default* (after): the",
        "continuation (degree-9 extrapolation of the last ten converged states, the corrector's geometric stiffness from the",
        "last converged stresses for its first <= 4 iterations, path-deviation bound, step adaptation), `rtol=1e-9` (the steps",
        "before the last to 1e-5).",
        "Difference: largest node-position difference default vs paper over the largest coordinate. KSD speed-ups",
        "against both controls. Cross-flexure rows sum the angles 5-75 deg.",
        "",
        "| case | solves | iterations paper / default | time paper / default [ms] | node difference | "
        "KSD-reduced speed-up vs paper / default | KSD-full speed-up vs paper / default |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, n, ksd, a in rows:
        t = a["t"]
        sp = (lambda k: f"{t['paper'] / t[k]:.1f}x / {t['default'] / t[k]:.1f}x") if ksd else (lambda k: "")
        lines.append(f"| {name} | {n} | {a['it']['paper']} / {a['it']['default']} | {1e3 * t['paper']:.1f} / "
                     f"{1e3 * t['default']:.1f} | {a['diff']:.1e} | {sp('ksd-reduced')} | {sp('ksd-full')} |")
    worst = max(r[3]["diff"] for r in rows)
    lines += ["", f"- All cases: {it['paper']} / {it['default']} iterations, {tt['paper']:.2f} / {tt['default']:.2f} s "
                  f"(paper / default); equilibria within {worst:.1e} (relative)."]
    for case in ("joint", "location"):
        sel = [r for r in rows if r[0].startswith(f"manipulator {case}")]
        lines.append(f"- Manipulator {case} case: {sum(r[3]['it']['paper'] for r in sel)} / "
                     f"{sum(r[3]['it']['default'] for r in sel)} iterations, largest at one position "
                     f"{max(r[3]['it']['paper'] for r in sel)} / {max(r[3]['it']['default'] for r in sel)}.")
    return "\n".join(lines)


if __name__ == "__main__":
    run("steps", main, __doc__, "one repeat, fewer angles and positions")
