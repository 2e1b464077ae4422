"""Discretisation error of the shipped joints' properties against elements per leaf (issue 22,
item 8): each case's quantities on meshes n = 1, 2, 4, ... times a base count, the converged-mesh
reference by Richardson from the three finest (`flexmb.discretisation.richardson`), the error of
every mesh and the time per solve, and the cost of the second default meshes (the defaults before `Accuracy by default` chose 24 elements per leaf). Writes the
"discretisation" section of BENCHMARKS.md. Run: python benchmarks/bench_discretisation.py [--quick]
"""

from __future__ import annotations

import math
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _report import machine, run  # noqa: E402

import flexmb  # noqa: E402
from flexmb.discretisation import richardson  # noqa: E402


def parallel_guide(n: int, *, length=0.1, thickness=1e-3, width=0.02, spacing=0.04, stroke=0.01, force=None):
    """Two leaf springs (``leaf_spring``, ``n`` elements each) along x, ``spacing`` apart, from
    ground to a stage of 0.1 kg pushed ``stroke`` along y; optional dead force on the stage."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("base", fixed=True)
    m.add_link("stage", position=(length, 0.5 * spacing), mass=0.1, inertia=1e-5)
    for name, y in (("lower", 0.0), ("upper", spacing)):
        m.add_joint("base", "stage", flexmb.LeafSpring(length=length, thickness=thickness, width=width,
                                                         **({} if n is None else {"elements": n})),
                    name=name, origin=(0.0, y))
    m.prescribe("stage", y=stroke)
    if force is not None:
        m.apply_force("stage", force)
    return m


def guide_quantities(sol):
    C = flexmb.compliance(sol, "stage")
    return {"force": sol.reaction("stage")[1], "drop": sol.displacement("stage")[0],
            "k_axial": 1.0 / C[0, 0], "k_rotation": 1.0 / C[2, 2],
            "f1": flexmb.modes(sol, n_modes=1).frequencies[0],
            "buckling": flexmb.buckling(sol)[0], "stress": sol.stresses().summary()["von_mises"]}


def pivot(n: int, *, rotation=math.radians(20.0), dim=3, force=None, **params):
    """The Table 1 cross flexure (``n`` elements per leaf), block B of 1 kg turned about z."""
    joint = flexmb.CrossFlexure(**({} if n is None else {"elements_per_leaf": n}), **params)
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim), mass=1.0, inertia=np.eye(3) * 1e-3 if dim == 3 else 1e-3)
    m.add_joint("A", "B", joint, name="pivot")
    m.prescribe("B", **({"z": 0.0, "rotation": (0.0, 0.0, rotation)} if dim == 3 else {"rotation": rotation}))
    if force is not None:
        m.apply_force("B", force)
    return m


def centre_shift(sol, centre) -> float:
    """|shift| [m] of the pivot's centre: B's displacement less that of a rigid turn about the
    undeformed leaf crossing ``centre``."""
    x0 = sol.compiled.problem.model.x0[sol.compiled.link_node["B"]]
    pos, R = sol.pose("B")
    R = np.asarray(R) if np.ndim(R) else np.array([[math.cos(R), -math.sin(R)], [math.sin(R), math.cos(R)]])
    return float(np.linalg.norm(pos - (centre + R[:len(centre), :len(centre)] @ (x0 - centre))))


def pivot_quantities(sol, centre):
    C = flexmb.compliance(sol, "B")
    return {"moment": sol.reaction("B")[-1], "shift": centre_shift(sol, centre),
            "k_x": 1.0 / C[0, 0], "k_y": 1.0 / C[1, 1],
            "f1": flexmb.modes(sol, n_modes=1).frequencies[0],
            "buckling": flexmb.buckling(sol)[0], "stress": sol.stresses().summary()["von_mises"]}


def three_x(n: int, *, rotation=math.radians(45.0)):
    joint = flexmb.ThreeXInfinity(**({} if n is None else {"elements_per_leaf": n}))
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3), mass=0.1, inertia=np.eye(3) * 1e-5)
    m.add_joint("A", "B", joint, name="hinge")
    m.prescribe("B", rotation=(0.0, 0.0, rotation))
    m.apply_force("B", (0.0, 0.0, -10.0))  # axial load, for the buckling multiplier
    return m


def curved(n: int, *, rotation=math.radians(10.0)):
    """A 90 deg steel arc of radius 30 mm from ground to link B of 10 g, B turned 10 deg."""
    joint = flexmb.CurvedBeam(radius=0.03, angle=math.pi / 2, E=200e9, width=0.01, height=0.5e-3,
                              **({} if n is None else {"elements": n}))
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(2), mass=0.01, inertia=1e-6)
    m.add_joint("A", "B", joint, name="arc")
    m.prescribe("B", rotation=rotation)
    m.apply_force("B", (-1.0, 0.0))
    return m


def hinge_quantities(axial: int):
    """Moment, drift of B, support stiffness in x and along ``axial`` (index of `flexmb.compliance`)."""
    def quantities(sol):
        C = flexmb.compliance(sol, "B")
        return {"moment": sol.reaction("B")[-1], "shift": float(np.linalg.norm(sol.displacement("B"))),
                "k_x": 1.0 / C[0, 0], f"k_{'xyz'[axial]}": 1.0 / C[axial, axial],
                "f1": flexmb.modes(sol, n_modes=1).frequencies[0],
                "buckling": flexmb.buckling(sol)[0], "stress": sol.stresses().summary()["von_mises"]}
    return quantities


CROSSING = np.array([0.0, 0.05 * math.sin(math.pi / 4), 0.0])
CASES = {
    "parallel_guide": (lambda n: parallel_guide(n, force=(-50.0, 0.0)), guide_quantities, 4,
                       (1, 2, 3, 4, 6, 8, 12, 16, 32, 64)),
    "cross_flexure": (lambda n: pivot(n, force=(0.0, -50.0, 0.0)), lambda s: pivot_quantities(s, CROSSING), 3,
                      (1, 2, 3, 4, 6, 8, 10, 16, 32, 64)),
    "three_x_infinity": (three_x, hinge_quantities(2), 3, (1, 2, 3, 4, 6, 8, 12, 16, 32, 64)),
    "curved_beam": (curved, hinge_quantities(1), 16, (4, 8, 16, 24, 32, 64, 128, 256)),
}


#: The cost of the defaults: (case, first default, second default) timed interleaved; the defaults are
#: now 24 elements per leaf (16 on the curved beam), BENCHMARKS.md `Accuracy by default`.
DEFAULTS = (("parallel_guide", 4, 12), ("cross_flexure", 3, 10), ("three_x_infinity", 3, 12), ("curved_beam", 16, 16))


def cost(repeats: int) -> list[str]:
    """Median wall time of one solve (and of solve + modes + compliance + buckling + stress) on the
    first and the second default mesh of every case, the two interleaved."""
    lines = ["| case | mesh (first -> second default) | solve [ms] | solve + properties [ms] | Newton iterations (steps) |",
             "|---|---|---:|---:|---:|"]
    for case, old, new in DEFAULTS:
        build, quantities, _, _ = CASES[case]
        t, its = {n: ([], []) for n in (old, new)}, {}
        models = {n: build(n) for n in (old, new)}
        for _ in range(repeats):
            for n in (old, new):
                t0 = time.perf_counter()
                sol = flexmb.solve(models[n])
                t1 = time.perf_counter()
                quantities(sol)
                t[n][0].append(t1 - t0)
                t[n][1].append(time.perf_counter() - t0)
                its[n] = f"{sol.iterations} ({sol.steps})"
        med = {n: [1e3 * float(np.median(x)) for x in t[n]] for n in t}
        lines.append(f"| {case} | {old} -> {new} | {med[old][0]:.1f} -> {med[new][0]:.1f} | {med[old][1]:.1f} -> "
                     f"{med[new][1]:.1f} | {its[old]} -> {its[new]} |")
    return lines


def convergence(case: str, repeats: int, quick: bool) -> list[str]:
    """Error of every quantity against elements per leaf, and the median time per solve."""
    build, quantities, default, meshes = CASES[case]
    meshes = meshes[-5:] if quick else meshes
    new = dict((c, n) for c, _, n in DEFAULTS)[case]
    rows, times = [], []
    for n in meshes:
        m = build(n)
        t = []
        for _ in range(repeats if n <= 16 else 1):
            t0 = time.perf_counter()
            sol = flexmb.solve(m)
            t.append(time.perf_counter() - t0)
        assert sol.converged, (case, n, sol.message)
        rows.append(quantities(sol))
        times.append(float(np.median(t)))
    names = list(rows[0])
    q = np.array([[r[k] for k in names] for r in rows])
    assert meshes[-1] == 2 * meshes[-2] == 4 * meshes[-3], "the reference needs meshes refined by 2"
    ref, order = richardson(q[-3:])
    lines = [f"### {case}: {DESCRIPTION[case]}", "",
             f"First default {default}, second default {new} (now 24 per leaf, 16 on the curved beam: `Accuracy by default`); reference: Richardson of n = {meshes[-3]}, {meshes[-2]}, "
             f"{meshes[-1]} with the observed order.", "",
             "| n | solve [ms] | " + " | ".join(names) + " |", "|---:|---:|" + "---:|" * len(names),
             "| reference | | " + " | ".join(f"{r:.6g}" for r in ref) + " |",
             "| observed order | | " + " | ".join(f"{p:.2f}" for p in order) + " |"]
    for n, t, row in zip(meshes, times, q):
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = (row - ref) / np.abs(ref)
        mark = " (first default)" if n == default else " (second default)" if n == new else ""
        lines.append(f"| {n}{mark} | {1e3 * t:.1f} | " + " | ".join(f"{100 * e:+.3f} %" for e in rel) + " |")
    return lines + [""]


DESCRIPTION = {
    "parallel_guide": "two `leaf_spring`s 0.1 m x 20 mm x 1 mm, 40 mm apart, stage (0.1 kg) pushed 10 mm, 50 N "
                      "compressive dead load along the leaves; drop = stage's displacement along the leaves, "
                      "k = 1/C of the stage (`flexmb.compliance`, stroke held), f1 = `flexmb.modes`, buckling = "
                      "`flexmb.buckling` multiplier, stress = peak von Mises",
    "cross_flexure": "Table 1 (3D), B (1 kg, 1e-3 kg m^2) turned 20 deg, 50 N compressive dead load along the axis; "
                     "shift = B's displacement less a rigid turn about the undeformed leaf crossing",
    "three_x_infinity": "defaults, B (0.1 kg) turned 45 deg under a 10 N axial load; shift = B's drift off the axis",
    "curved_beam": "90 deg steel arc r = 30 mm, 10 x 0.5 mm, B (10 g) turned 10 deg under a 1 N side load; "
                   "shift = B's displacement",
}


def main(quick: bool = False) -> str:
    lines = ["## Discretisation error of the shipped joints' properties (issue 22 item 8)", "",
             f"{machine()}. Relative error of each quantity against its converged-mesh reference "
             "(`flexmb.discretisation.richardson`); times are medians of " + ("1" if quick else "3") +
             " solves (one above 16 el.).", ""]
    for case in CASES:
        lines += convergence(case, 1 if quick else 3, quick)
    lines += ["### Cost of the second defaults", "", "Medians of " + ("3" if quick else "15") +
              " interleaved runs; properties: the quantities of the tables above.", ""]
    lines += cost(3 if quick else 15)
    return "\n".join(lines)


if __name__ == "__main__":
    run("discretisation", main, __doc__, "the five finest meshes, one repetition")
