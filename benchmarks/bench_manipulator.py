"""Manipulator benchmark (issues 5 and 21, Fig. 15 of Dwarshuis et al. 2020): conventional vs KSD.

The three-link manipulator of Sec. 4.4 with three three_x_infinity joints (flexmb's design,
27 flexible elements each), 19 positions with all joint rotations from -45 to 45 deg: the joint
case, then the location case through the end points of the joint case. Per position the
conventional method with the default continuation and with the paper's step control
(``step_control="paper"``, Fig. 18), KSD-reduced and KSD-full, interleaved in one run (each a
whole `flexmb.solve` of the same mechanism object after a warm-up, garbage collection paused
during each solve), their speed-ups against both conventional variants, and KSD-reduced's errors
against the converged full model. Then the joint case at 45 deg timed longer (the issue-21 target:
KSD-reduced under 1 ms, at least 600x the conventional method with the paper's step control) with
KSD-reduced's time per stage.
Writes the "manipulator" section of BENCHMARKS.md. Run: python benchmarks/bench_manipulator.py [--quick]
"""

from __future__ import annotations

import gc
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run  # noqa: E402
import numpy as np  # noqa: E402
import flexmb  # noqa: E402
from flexmb.models import manipulator  # noqa: E402
from flexmb.plausibility import check  # noqa: E402
from flexmb.studies.manipulator import errors  # noqa: E402

#: (label, method, options); per round each is solved ``share`` times (KSD is cheap: more samples)
METHODS = (("default", "conventional", {}), ("paper", "conventional", {"step_control": "paper"}),
           ("ksd-reduced", "ksd-reduced", {}), ("ksd-full", "ksd-full", {}))


def timed(m, rounds: int, share: dict) -> tuple[dict, dict]:
    """Interleaved medians [s] and the last solution per label."""
    sols, times = {}, {label: [] for label, *_ in METHODS}
    for label, method, opts in METHODS:  # warm-up: compiled model, joint templates, kernels
        flexmb.solve(m, method=method, **opts)
    for _ in range(rounds):
        for label, method, opts in METHODS:
            gc.collect()
            for _ in range(share.get(label, 1)):
                gc.disable()
                try:
                    t = time.perf_counter()
                    sols[label] = flexmb.solve(m, method=method, raise_on_failure=True, **opts)
                    times[label].append(time.perf_counter() - t)
                finally:
                    gc.enable()
    return sols, {k: float(np.median(v)) for k, v in times.items()}


def focus(rounds: int) -> list[str]:
    """The joint case at 45 deg: longer interleaved medians, KSD-reduced's stages."""
    m = manipulator("joint", np.radians(45))
    sols, t = timed(m, rounds, {"ksd-reduced": 40, "ksd-full": 5})
    stages = {}
    checks = []
    for _ in range(200):
        gc.disable()
        try:
            sol = flexmb.solve(m, method="ksd-reduced")
            c0 = time.perf_counter()
            check(sol)
            checks.append(time.perf_counter() - c0)
        finally:
            gc.enable()
        for k, v in sol.wall_time.items():
            stages.setdefault(k, []).append(v)
    med = {k: 1e3 * float(np.median(v)) for k, v in stages.items()}
    red = t["ksd-reduced"]
    return [
        "",
        f"**Joint case at 45 deg** ({rounds} rounds, KSD-reduced 40 and KSD-full 5 solves per round, interleaved; "
        f"load average {os.getloadavg()[0]:.1f} at its end):",
        "",
        "| method | iterations | median [ms] | KSD-reduced faster by |",
        "|---|---:|---:|---:|",
        f"| conventional, paper's step control | {sols['paper'].iterations} | {1e3 * t['paper']:.1f} | "
        f"{t['paper'] / red:.0f}x |",
        f"| conventional, default continuation | {sols['default'].iterations} | {1e3 * t['default']:.1f} | "
        f"{t['default'] / red:.0f}x |",
        f"| KSD-full | {sols['ksd-full'].iterations} | {1e3 * t['ksd-full']:.2f} | {t['ksd-full'] / red:.1f}x |",
        f"| KSD-reduced | {sols['ksd-reduced'].iterations} | {1e3 * red:.2f} | 1x |",
        "",
        f"KSD-reduced's `flexmb.solve` {1e3 * red:.2f} ms = strategy {med['total']:.2f} ms (set-up "
        f"{med['setup']:.3f}, step 1 kinematics {med['kinematics']:.3f}, step 2 EOBs {med['eob']:.3f}, step 3 reduced "
        f"{med['reduced']:.3f}, step 4 internal nodes {med['internal']:.3f}; medians of 200) + the plausibility check "
        f"{1e3 * float(np.median(checks)):.3f} ms + the cached compile's fingerprint and the strategy's construction.",
        "",
        f"Issue 21's target, KSD-reduced at least 600x faster than the conventional method with the paper's step "
        f"control: {t['paper'] / red:.0f}x here ({'met' if t['paper'] / red >= 600 else 'not met'}). Against the new "
        f"default continuation it is {t['default'] / red:.0f}x: the conventional method itself became "
        f"{t['paper'] / t['default']:.1f}x faster ({sols['paper'].iterations} -> {sols['default'].iterations} Newton "
        "iterations), so 600x against the default would need KSD-reduced below "
        f"{1e3 * t['default'] / 600:.2f} ms. (The issue's 600x was set against a 1048 ms conventional solve.) On a "
        "loaded host this ratio is inflated: a solve of a second is time-shared with the other work, a solve of a "
        "millisecond mostly runs within one time slice (measured before the compiled assembly: 681x at load 4.7, "
        "1049x at load 9.9; the CPU clock, as `flexmb demo` uses, does not count those waits).",
    ]


def main(quick: bool = False) -> str:
    rounds = 1 if quick else 3
    rotations = tuple(range(-45, 46, 15)) if quick else tuple(range(-45, 46, 5))
    rows = []
    for case in ("joint", "location"):
        for deg in rotations:
            m = manipulator(case, np.radians(deg))
            sols, t = timed(m, rounds, {"ksd-reduced": 5, "ksd-full": 2})
            # errors against the paper-control solution: its absolute tol (5e-7) says when a reaction
            # is below the solve's accuracy (at rest: NaN, as the study reports)
            err = errors(case, sols["ksd-reduced"], sols["paper"])
            if deg == 0:  # at rest the reactions are roundoff (the study's NaN): nothing to compare
                err = {k: np.nan for k in err}
            rows.append((case, deg, sols, t, err))
    lines = [
        "## Manipulator: conventional method vs KSD (issues 5 and 21, Fig. 15)",
        "",
        f"Dwarshuis et al. (2020) Sec. 4.4 manipulator with flexmb's three_x_infinity joints; {machine()}.",
        f"Medians of {rounds} rounds per position, the methods interleaved (KSD-reduced 5 and KSD-full 2 solves per",
        "round), each a whole `flexmb.solve` of one mechanism object after a warm-up (its compiled model and KSD's",
        "set-up kept, as in a loop; steps 1-5 run every solve). Conventional: the default continuation and the paper's",
        "Fig. 18 step control (`step_control=\"paper\"`); residual norm below 5e-7 (N, N m) for every solve. Errors:",
        "KSD-reduced against the converged full model, reactions (joint case: the three joint moments; location case:",
        "the end-point force) and link displacements, relative. Paper: KSD-full up to 65x, KSD-reduced up to 600x",
        "(against its conventional method, the Fig. 18 control); errors below 2 % (force) and 0.3 % (displacement).",
        "",
        "| case | rotation [deg] | conventional default it. / ms | conventional paper it. / ms | KSD-reduced it. / ms | "
        "KSD-full it. / ms | KSD-reduced faster vs paper / default | KSD-full vs paper / default | "
        "error reaction / displacement [%] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for case, deg, s, t, err in rows:
        lines.append(
            f"| {case} | {deg} | {s['default'].iterations} / {1e3 * t['default']:.0f} | {s['paper'].iterations} / "
            f"{1e3 * t['paper']:.0f} | {s['ksd-reduced'].iterations} / {1e3 * t['ksd-reduced']:.2f} | "
            f"{s['ksd-full'].iterations} / {1e3 * t['ksd-full']:.1f} | {t['paper'] / t['ksd-reduced']:.0f}x / "
            f"{t['default'] / t['ksd-reduced']:.0f}x | {t['paper'] / t['ksd-full']:.0f}x / "
            f"{t['default'] / t['ksd-full']:.0f}x | {100 * err['reaction']:.3f} / {100 * err['displacement']:.4f} |")
    lines.append("")
    for case in ("joint", "location"):
        sel = [(t, err) for c, _, _, t, err in rows if c == case]

        def ratio(base, method):
            r = [t[base] / t[method] for t, _ in sel]
            return f"{min(r):.0f}-{max(r):.0f}x (total {sum(t[base] for t, _ in sel) / sum(t[method] for t, _ in sel):.0f}x)"

        lines.append(f"- {case} case: KSD-reduced {ratio('paper', 'ksd-reduced')} faster than the paper's step control, "
                     f"{ratio('default', 'ksd-reduced')} than the default; KSD-full {ratio('paper', 'ksd-full')} / "
                     f"{ratio('default', 'ksd-full')}; largest KSD-reduced errors "
                     f"{100 * np.nanmax([e['reaction'] for _, e in sel]):.3f} % (reaction), "
                     f"{100 * np.nanmax([e['displacement'] for _, e in sel]):.4f} % (displacement).")
    lines += focus(3 if quick else 7)
    lines.append(f"\nLoad average {os.getloadavg()[0]:.1f} at the end of the run.")
    return "\n".join(lines)


if __name__ == "__main__":
    run("manipulator", main, __doc__, "7 positions, one round")
