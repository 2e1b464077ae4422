"""Path-following benchmark (issues 19, 29): points, corrector iterations and time per traced path,
each path traced as the device goes (``branch="stable"``: switching at bifurcations) and on its
primary branch only (``branch="primary"``, the trace before issue 29).

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


def _imperfect_pair():
    """The bistable pair pushed by 100 N with 0.1 N across the middle of one leaf (a point inside
    the joint)."""
    m = cases.bistable_pair(12, "load")
    m.add_joint_point("leaf_spring_0", "mid", 0.5)
    m.apply_force("mid", (0.0, 0.1))
    return m


#: (name, mechanism builder, trace options, what the path covers)
CASES = [
    ("Lee's frame, 10 el./member", lambda: cases.lee_frame(elements=10),
     dict(steps=200, arc_length=1.0, stop=lambda s: -s.displacement("P")[1] > 95.0), "both limit points, snap-back"),
    ("Lee's frame, 150 el./member (899 DOFs, sparse)", lambda: cases.lee_frame(elements=150),
     dict(steps=200, arc_length=1.0, stop=lambda s: -s.displacement("P")[1] > 95.0), "both limit points, snap-back"),
    ("215 deg arch, 40 chords", cases.deep_arch,
     dict(steps=400, arc_length=0.25, stop=lambda s: -s.displacement("apex")[1] > 150.0), "limit, snap-back, 2nd limit"),
    ("Qiu bistable, 20 el. (half), 1e-3 imp.", lambda: cases.qiu_bistable(load=F_TOP),
     dict(steps=200, arc_length=0.05, stop=lambda s: -s.displacement("C")[1] > 2.45e-4), "snap-through, 2 limits"),
    ("Euler strut, 20 el., 1e-4 imp.", lambda: cases.euler_strut(load=math.pi**2 / 4, imperfection=1e-4),
     dict(steps=300, arc_length=0.05, stop=lambda s: s.rotation_vector("B")[0] > 2.5), "post-buckling to 2.5 rad"),
    ("Euler strut, perfect", lambda: cases.euler_strut(load=math.pi**2 / 4, imperfection=0.0),
     dict(arc_length=0.05, max_load_factor=1.5), "bifurcation, to 1.5 P_E"),
    ("von Mises truss (mm), 4 el.", cases.von_mises_truss,
     dict(steps=100, arc_length=0.05, stop=lambda s: -s.displacement("T")[1] > 120.0), "both limit points"),
    ("bistable pair, 12 el./leaf, stroke", lambda: cases.bistable_pair(12),
     dict(steps=200, max_load_factor=1.0), "to twice the rise"),
    ("bistable pair, 48 el./leaf, stroke", lambda: cases.bistable_pair(48),
     dict(steps=200, max_load_factor=1.0), "to twice the rise"),
    ("bistable pair, 12 el./leaf, 100 N", lambda: cases.bistable_pair(12, "load"),
     dict(steps=40, stop=lambda s: -s.displacement("S")[1] > 1.0), "1 mm of push"),
    ("bistable pair, 0.1 % load inside a leaf", _imperfect_pair,
     dict(steps=40, stop=lambda s: -s.displacement("S")[1] > 1.0), "1 mm of push"),
    ("sine arch e = 6, 40 el.", lambda: cases.sine_arch(40), dict(steps=40, max_load_factor=30.0), "to Q = 30"),
    ("sine arch, 0.01 r imperfection", lambda: cases.sine_arch(40, imperfection=0.01),
     dict(steps=40, stop=lambda s: s.load_factor < 0), "through the limit to Q < 0"),
    ("Qiu double beam + shuttle, 20 el./half", lambda: cases.qiu_beam(20, True),
     dict(steps=300, max_load_factor=1.0), "to twice the rise"),
    ("Qiu single beam, 20 el./half", lambda: cases.qiu_beam(20, False),
     dict(steps=300, max_load_factor=1.0), "to twice the rise"),
    ("motor four-bar, cross-flexure rocker, 2D", lambda: cases.motor_fourbar(2),
     dict(steps=200, max_load_factor=1.0), "a full crank turn"),
    ("motor four-bar, cross-flexure rocker, 3D", lambda: cases.motor_fourbar(3),
     dict(steps=200, max_load_factor=1.0), "a full crank turn"),
    ("Roorda frame, 12 el./member, perfect", lambda: cases.roorda_frame(12),
     dict(steps=30, max_load_factor=16.0), "asymmetric bifurcation, to 16 EI/L^2"),
    ("Roorda frame, 48 el./member, perfect", lambda: cases.roorda_frame(48),
     dict(steps=30, max_load_factor=16.0), "asymmetric bifurcation, to 16 EI/L^2"),
    ("Roorda frame, 12 el., eccentricity 1e-5 L", lambda: cases.roorda_frame(12, 1e-5),
     dict(steps=60, stop=lambda s: not s.stable), "to the limit point"),
    ("Roorda frame, 48 el., eccentricity 1e-5 L", lambda: cases.roorda_frame(48, 1e-5),
     dict(steps=60, stop=lambda s: not s.stable), "to the limit point"),
    ("clamped arch, uniform load, 40 el.", lambda: cases.clamped_arch(40),
     dict(steps=20, max_load_factor=8.0), "bifurcation below the limit"),
    ("clamped arch, uniform load, 80 el.", lambda: cases.clamped_arch(80),
     dict(steps=20, max_load_factor=8.0), "bifurcation below the limit"),
    ("clamped arch, central point load, 40 el.", lambda: cases.clamped_arch(40, e=30.0, load="point"),
     dict(steps=30, stop=lambda s: s.load_factor < 1.5 and not s.stable), "limit, bifurcation past it"),
    ("clamped arch, central point load, 80 el.", lambda: cases.clamped_arch(80, e=30.0, load="point"),
     dict(steps=30, stop=lambda s: s.load_factor < 1.5 and not s.stable), "limit, bifurcation past it"),
]


def measure(build, options, repeat: int, branch: str):
    """(points, iterations, path, median seconds) of one traced path."""
    times, path = [], None
    for _ in range(repeat):
        m = build()
        t = time.perf_counter()
        path = flexmb.trace(m, progress=False, branch=branch, **options)
        times.append(time.perf_counter() - t)
    return len(path), sum(s.iterations for s in path), path, float(np.median(times))


def _critical(path) -> str:
    return ", ".join(f"{c.kind[0]}{'' if c.multiplicity == 1 else f'x{c.multiplicity}'}"
                     f"{'*' if c.switched else ''} {c.load_factor:.4g}" for c in path.critical) or "none"


def main(quick: bool = False) -> str:
    import warnings

    repeat = 1 if quick else 3
    with warnings.catch_warnings():  # compile the kernels first: not in the first case's time
        warnings.simplefilter("ignore")
        flexmb.trace(cases.von_mises_truss(), steps=3, progress=False)
    lines = [
        "## Path following: flexmb.trace (issues 19, 29)",
        "",
        f"Arc-length paths from the undeformed state (`flexmb.studies.paths`); {machine()}; median of {repeat} "
        "run(s), one BLAS thread. Each path traced as the device goes (`branch=\"stable\"`, the default since issue "
        "29: at a bifurcation the branch with the fewest negative eigenvalues, then, where the path's own continuation "
        "is unstable, a branch that leaves it, then a growing load factor) and on its "
        "primary branch only (`branch=\"primary\"`, the trace before). Iterations: corrector iterations of the path's "
        "points (the located critical points, the branch-switching trials and rejected steps come on top and are in "
        "the time).",
        "",
        "| path | covers | branch | points | iterations | iterations/point | time [s] | ms/point | critical points "
        "(load factor) | Path.snap |",
        "|---|---|---|---:|---:|---:|---:|---:|---|---|",
    ]
    for name, build, options, covers in CASES:
        rows = {}
        for branch in ("stable", "primary"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rows[branch] = measure(build, options, repeat, branch)
        for branch, (n, its, path, sec) in rows.items():
            snap = path.snap
            snap = "none" if snap is None else f"{snap.kind[0]} {snap.load_factor:.4g}"
            lines.append(f"| {name if branch == 'stable' else ''} | {covers if branch == 'stable' else ''} | {branch} | "
                         f"{n} | {its} | {its / max(n - 1, 1):.1f} | {sec:.2f} | {1e3 * sec / max(n - 1, 1):.0f} | "
                         f"{_critical(path)} | {snap} |")
    lines += ["", "l: limit point, b: bifurcation point, x2: its multiplicity, *: the path switched branch there. "
              "The host runs other jobs: times are indicative, the ratio of a case's two rows is what to read."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("path", main, __doc__, "one repetition")
