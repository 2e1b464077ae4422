"""Design-loop benchmark (issue 31): freshly built mechanisms, as a design loop builds them.

1. Fresh: every solve builds its mechanism anew (``flexmb.models``), compiles it and solves it:
   the manipulator of Dwarshuis et al. (2020) Sec. 4.4, location case at 30 deg, and the four-bar
   of Sec. 4.3 at d = 0.3 m with 5 elements per leaf; the conventional method with the paper's
   step control (``step_control="paper"``, Fig. 18) and with the default continuation, KSD-full
   and KSD-reduced, interleaved in rounds (garbage collection paused during each), medians of the
   wall clock and of the process's CPU time; beside them the same solves of one kept mechanism.
2. Loops: 100 designs built by ``build(p)``, each solved once, against re-solving one fixed
   design as often, interleaved design by design: the manipulator's joint placements (its link
   geometry, `flexmb.models.manipulator` ``geometry=``: post, arms and arm angles drawn within
   +-10 % and +-5 deg, seeded) with KSD-reduced at 30 deg (location case: each design's end point
   from its own joint-case kinematics, part of its build), and the four-bar's leaf thickness
   (0.8...1.2 mm) with the conventional method. Per design: build + compile + solve + check; the
   same loop with the structure reuse switched off (`flexmb.compiled.STRUCTURES_KEPT` = 0) shows
   what the reuse saves. The location case's end point (the joint case's KSD kinematics) is solved once per
   rotation and joint and chained through each design's geometry (`flexmb.models.manipulator`).

Writes the "design" section of BENCHMARKS.md. Run: python benchmarks/bench_design.py [--quick]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import gc  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run  # noqa: E402
import numpy as np  # noqa: E402

import flexmb  # noqa: E402
from flexmb import compiled as compiled_module  # noqa: E402
from flexmb import models  # noqa: E402

METHODS = (("paper", "conventional", {"step_control": "paper"}), ("default", "conventional", {}),
           ("ksd-full", "ksd-full", {}), ("ksd-reduced", "ksd-reduced", {}))
CASES = {"manipulator, location case, 30 deg": lambda: models.manipulator("location", math.radians(30.0)),
         "four-bar, d = 0.3 m, 5 el./leaf": lambda: models.fourbar(5, displacement=0.3)}


def _timed(fn) -> tuple:
    """(result, wall [s], CPU [s]) of ``fn()``, garbage collection paused."""
    gc.disable()
    try:
        c, t = time.process_time(), time.perf_counter()
        out = fn()
        return out, time.perf_counter() - t, time.process_time() - c
    finally:
        gc.enable()


def fresh(build, rounds: int) -> tuple[dict, dict, dict]:
    """Per method label: medians (wall, CPU) [s] of freshly built solves and of a kept mechanism's,
    and the iterations."""
    kept = build()
    for _, method, opts in METHODS:  # warm-up: kernels, joint meshes, the structure's first analysis
        flexmb.solve(build(), method=method, **opts)
        flexmb.solve(kept, method=method, **opts)
    new = {label: ([], []) for label, *_ in METHODS}
    old = {label: ([], []) for label, *_ in METHODS}
    its = {}
    for _ in range(rounds):
        for label, method, opts in METHODS:
            gc.collect()
            share = 5 if label == "ksd-reduced" else 2 if label == "ksd-full" else 1
            for _ in range(share):
                sol, w, c = _timed(lambda: flexmb.solve(build(), method=method, raise_on_failure=True, **opts))
                new[label][0].append(w)
                new[label][1].append(c)
                its[label] = sol.iterations
                _, w, c = _timed(lambda: flexmb.solve(kept, method=method, raise_on_failure=True, **opts))
                old[label][0].append(w)
                old[label][1].append(c)
    med = lambda d: {k: (float(np.median(w)), float(np.median(c))) for k, (w, c) in d.items()}  # noqa: E731
    return med(new), med(old), its


def placements(n: int) -> list[dict]:
    """``n`` manipulator geometries within +-10 % (lengths) and +-5 deg (angles) of `MANIPULATOR`."""
    rng = np.random.default_rng(31)
    g0 = models.MANIPULATOR
    out = []
    for _ in range(n):
        g = {k: g0[k] * (1.0 + rng.uniform(-0.1, 0.1)) for k in ("post", "arm2", "arm3")}
        g.update({k: g0[k] + math.radians(rng.uniform(-5.0, 5.0)) for k in ("angle2", "angle3")})
        out.append(g)
    return out


def loop(builds: list, fixed, method: str) -> dict:
    """Per design (build + solve) against re-solving ``fixed`` (a kept mechanism), interleaved:
    medians (wall, CPU) [s], the iteration range, and the same loop without structure reuse."""
    flexmb.solve(fixed, method=method)
    flexmb.solve(builds[0](), method=method)  # the structure's first analysis
    out = {}
    for reuse in (True, False):
        kept = compiled_module.STRUCTURES_KEPT
        compiled_module.STRUCTURES_KEPT = kept if reuse else 0
        try:
            design, again, its = ([], []), ([], []), []
            for build in builds:
                sol, w, c = _timed(lambda: flexmb.solve(build(), method=method, raise_on_failure=True))
                design[0].append(w)
                design[1].append(c)
                its.append(sol.iterations)
                _, w, c = _timed(lambda: flexmb.solve(fixed, method=method, raise_on_failure=True))
                again[0].append(w)
                again[1].append(c)
        finally:
            compiled_module.STRUCTURES_KEPT = kept
        out[reuse] = {"design": tuple(map(np.median, design)), "again": tuple(map(np.median, again)),
                      "iterations": (min(its), max(its))}
    return out


def main(quick: bool = False) -> str:
    rounds = 3 if quick else 7
    n = 20 if quick else 100
    lines = ["## Design loops: freshly built mechanisms and structure reuse (issue 31)", "",
             f"{machine()}. Every solve a whole `flexmb.solve` (compile, plausibility check and the default accuracy "
             "estimates included: conventional and KSD-full solve a companion mesh, KSD-reduced makes one Newton "
             "correction on the full model and compiles the companion mesh of a new model); "
             "*fresh*: of a mechanism built for it by `flexmb.models` (its build timed too), as a design loop "
             "builds them; *kept*: of one mechanism object solved again. Medians of "
             f"{rounds} interleaved rounds (KSD-reduced 5, KSD-full 2 solves per round), wall clock and process CPU "
             "time; speed-ups on CPU time (the host is shared; CPU time does not count the time slices other work takes).",
             "", "| case | method | iterations | fresh wall [ms] | fresh CPU [ms] | kept CPU [ms] | "
             "paper / this (fresh, CPU) | default / this (fresh, CPU) |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    notes = []
    for case, build in CASES.items():
        new, old, its = fresh(build, rounds)
        for label, *_ in METHODS:
            lines.append(f"| {case} | {label} | {its[label]} | {1e3 * new[label][0]:.2f} | {1e3 * new[label][1]:.2f} | "
                         f"{1e3 * old[label][1]:.2f} | {new['paper'][1] / new[label][1]:.0f}x | "
                         f"{new['default'][1] / new[label][1]:.1f}x |")
        notes.append(f"- {case}, freshly built, CPU time: KSD-full {new['paper'][1] / new['ksd-full'][1]:.0f}x and "
                     f"KSD-reduced {new['paper'][1] / new['ksd-reduced'][1]:.0f}x faster than the paper's step control; "
                     f"{new['default'][1] / new['ksd-full'][1]:.1f}x and {new['default'][1] / new['ksd-reduced'][1]:.1f}x "
                     "than the default conventional method.")
    lines += [""] + notes
    loops = {"manipulator placements, KSD-reduced (location, 30 deg)":
             ([lambda g=g: models.manipulator("location", math.radians(30.0), geometry=g) for g in placements(n)],
              models.manipulator("location", math.radians(30.0)), "ksd-reduced"),
             "four-bar leaf thickness 0.8-1.2 mm, conventional (d = 0.3 m, 5 el./leaf)":
             ([lambda t=t: models.fourbar(5, displacement=0.3, thickness=t) for t in np.linspace(0.8e-3, 1.2e-3, n)],
              models.fourbar(5, displacement=0.3), "conventional")}
    lines += ["", f"Design loops: {n} designs, each built and solved once, interleaved with re-solving one fixed "
              "design; medians per design. *Without reuse*: the same loop with the structure reuse off "
              "(`flexmb.compiled.STRUCTURES_KEPT = 0`).", "",
              "| loop | iterations | per design wall / CPU [ms] | fixed design again wall / CPU [ms] | "
              "design / again (CPU) | without reuse: per design CPU [ms] | without / with reuse |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    for name, (builds, fixed, method) in loops.items():
        r = loop(builds, fixed, method)
        on, off = r[True], r[False]
        lo, hi = on["iterations"]
        lines.append(f"| {name} | {lo}-{hi} | {1e3 * on['design'][0]:.2f} / {1e3 * on['design'][1]:.2f} | "
                     f"{1e3 * on['again'][0]:.2f} / {1e3 * on['again'][1]:.2f} | "
                     f"{on['design'][1] / on['again'][1]:.2f} | {1e3 * off['design'][1]:.2f} | "
                     f"{off['design'][1] / on['design'][1]:.2f} |")
    lines += ["", f"Load average {os.getloadavg()[0]:.1f} at the end of the run."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("design", main, __doc__, "3 rounds, 20 designs per loop")
