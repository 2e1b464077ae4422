"""Path-following benchmark (issue 19): steps, corrector iterations and time per traced path.

Writes the "path" section of BENCHMARKS.md. Run: python benchmarks/bench_path.py [--quick]
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import flexmb  # noqa: E402
from _report import machine, run  # noqa: E402
from flexmb.studies import paths as cases  # noqa: E402

F_TOP, _ = cases.qiu_switching_forces()

#: (name, mechanism builder, trace options, what the path covers)
CASES = [
    ("Lee's frame, 10 el./member", lambda: cases.lee_frame(elements=10),
     dict(steps=200, arc_length=1.0, stop=lambda s: -s.displacement("P")[1] > 95.0), "both limit points, snap-back"),
    ("Lee's frame, 40 el./member", lambda: cases.lee_frame(elements=40),
     dict(steps=200, arc_length=1.0, stop=lambda s: -s.displacement("P")[1] > 95.0), "both limit points, snap-back"),
    ("Lee's frame, 150 el./member (899 DOFs, sparse)", lambda: cases.lee_frame(elements=150),
     dict(steps=200, arc_length=1.0, stop=lambda s: -s.displacement("P")[1] > 95.0), "both limit points, snap-back"),
    ("215 deg arch, 40 chords", cases.deep_arch,
     dict(steps=400, arc_length=0.25, stop=lambda s: -s.displacement("apex")[1] > 150.0), "limit, snap-back, 2nd limit"),
    ("Qiu bistable, 20 el. (half)", lambda: cases.qiu_bistable(load=F_TOP),
     dict(steps=200, arc_length=0.05, stop=lambda s: -s.displacement("C")[1] > 2.45e-4), "snap-through, 2 limits"),
    ("Euler strut, 20 el., 1e-4 imp.", lambda: cases.euler_strut(load=math.pi**2 / 4, imperfection=1e-4),
     dict(steps=300, arc_length=0.05, stop=lambda s: s.rotation_vector("B")[0] > 2.5), "post-buckling to 2.5 rad"),
    ("Euler strut, perfect", lambda: cases.euler_strut(load=math.pi**2 / 4, imperfection=0.0),
     dict(arc_length=0.05, max_load_factor=1.5), "bifurcation, to 1.5 P_E"),
    ("von Mises truss (mm), 4 el.", cases.von_mises_truss,
     dict(steps=100, arc_length=0.05, stop=lambda s: -s.displacement("T")[1] > 120.0), "both limit points"),
]


def measure(build, options, repeat: int):
    """(points, steps, iterations, critical points, median seconds) of one traced path."""
    times, path = [], None
    for _ in range(repeat):
        m = build()
        t = time.perf_counter()
        path = flexmb.trace(m, progress=False, **options)
        times.append(time.perf_counter() - t)
    iterations = sum(s.iterations for s in path)
    return len(path), len(path) - 1, iterations, path, float(np.median(times))


def main(quick: bool = False) -> str:
    repeat = 1 if quick else 3
    lines = [
        "## Path following: flexmb.trace (issue 19)",
        "",
        f"Arc-length paths from the undeformed state (`flexmb.studies.paths`), default options; {machine()}; "
        f"median of {repeat} run(s), one BLAS thread. Iterations: corrector iterations of the path's points "
        "(the located critical points and rejected steps come on top and are in the time).",
        "",
        "| path | covers | steps | iterations | iterations/step | critical points (load factor) | time [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, build, options, covers in CASES:
        _, steps, its, path, sec = measure(build, options, repeat)
        crit = ", ".join(f"{c.kind[0]} {c.load_factor:.4g}" for c in path.critical) or "none"
        lines.append(f"| {name} | {covers} | {steps} | {its} | {its / max(steps, 1):.1f} | {crit} | {sec:.2f} |")
    lines += ["", "l: limit point, b: bifurcation point. The host runs other jobs: times are indicative."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("path", main, __doc__, "one repetition")
