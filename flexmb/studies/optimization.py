"""Three design optimisations beyond the papers, each against a derivative-free
baseline: the problems, a runner and the comparison table (examples/optimize_*.py,
benchmarks/bench_optimize.py, docs/design.md).

1. `hinge`: a 3D cross-flexure hinge carrying a 1 kg block, turned 0.5 rad: maximise the first
   parasitic eigenfrequency subject to the peak von Mises stress <= 300 MPa and the actuation
   moment <= 2.5 N m, over leaf thickness, width, length and crossing angle (SI units).
2. `stage`: a folded double-parallelogram stage in mm, N, MPa: maximise the minimum support
   stiffness at its tool point over a +-5 mm stroke subject to a stroke-stiffness ceiling (the
   force at 5 mm <= 5 N, 1 N/mm) and a stress limit (300 MPa), over leaf thickness, length and
   spacing.
3. `manipulator`: the spatial three-link manipulator of Dwarshuis et al. (2020) Sec. 4.4
   (`flexmb.models.manipulator`'s links and joints) with its end point driven along the path of
   all three joints turned -30 .. 30 deg (the location case): the placements of the joints
   (the post, the links' lengths and elevations, each joint's roll about its own axis and the
   shifts of joints 2 and 3 along theirs; 10 parameters) that maximise the minimum rotational
   support stiffness of the end link (the rotations a 3-DOF positioner must resist) over the
   stroke, with the end point's reach and height at rest bounded; solved by KSD-reduced (its
   placements' gradients through KSD steps 1-3, `flexmb.design.reduced`).
"""

from __future__ import annotations

import functools
import time
from pathlib import Path

import attrs
import numpy as np

from ..design import responses as R
from ..design.derived import support_stiffness
from ..design.optimize import Constraint, optimize
from ..design.stroke import Stroke, at, ks_max, ks_min
from ..joints.three_x_infinity import ThreeXInfinity
from ..mechanism import Mechanism
from ..models import MANIPULATOR, manipulator_rotations
from ..rotations import expm_so3, logm_so3

__all__ = ["Problem", "hinge", "stage", "manipulator", "PROBLEMS", "RUNS", "warm_up", "compare", "comparison_table"]


@attrs.frozen
class Problem:
    """An optimisation problem: ``run(optimizer, gradient, **options)`` calls `flexmb.optimize`."""

    name: str
    build: object
    p0: dict
    bounds: dict
    objective: object
    constraints: tuple
    stroke: object = None
    maximize: bool = True
    method: str = "conventional"
    units: str = ""

    def run(self, optimizer: str = "slsqp", gradient: str | None = None, **options):
        """`flexmb.optimize` of this problem (``options`` as there, e.g. ``max_iter``)."""
        return optimize(self.build, dict(self.p0), dict(self.bounds), objective=self.objective,
                        maximize=self.maximize, constraints=list(self.constraints), stroke=self.stroke,
                        optimizer=optimizer, gradient=gradient, method=self.method, **options)


# -- 1. the cross-flexure hinge ---------------------------------------------------------------------
BLOCK = 1.0  # [kg]
BLOCK_INERTIA = BLOCK * 0.05**2 / 6.0  # [kg m^2] a 50 mm steel cube about its centre


def hinge_build(p: dict, elements: int = 6) -> Mechanism:
    """A 3D cross-flexure hinge (inner leaf width ``w``, outer leaves ``w/2``; thickness ``t``,
    length ``L`` [m], crossing angle ``a`` [rad]) whose upper block of 1 kg is turned 0.5 rad."""
    m = Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, p["L"] * np.sin(p["a"]), 0.0), mass=BLOCK, inertia=BLOCK_INERTIA * np.eye(3))
    m.add_joint("A", "B", "cross_flexure", length=p["L"], angle=p["a"], thickness=p["t"], width_inner=p["w"],
                width_outer=0.5 * p["w"], elements_per_leaf=elements, name="hinge")
    m.prescribe("B", rotation=(0.0, 0.0, 0.5))
    return m


def hinge(quick: bool = False) -> Problem:
    """Problem 1 (module notes); ``quick``: 4 elements per leaf instead of 6."""
    build = functools.partial(hinge_build, elements=4) if quick else hinge_build
    return Problem("hinge", build, {"t": 0.5e-3, "w": 0.03, "L": 0.1, "a": np.pi / 4},
                   {"t": (0.2e-3, 1.5e-3), "w": (0.01, 0.06), "L": (0.05, 0.15), "a": (0.5, 1.1)},
                   R.frequency(1, held=[("B", "rz")]),
                   (Constraint(R.stress(scale=300e6, rho=100.0), upper=300e6, name="stress <= 300 MPa"),
                    Constraint(R.reaction("B", "rz"), upper=2.5, name="moment <= 2.5 N m")),
                   units="m, kg, s; frequency [Hz]")


# -- 2. the double-parallelogram stage --------------------------------------------------------------
CLEARANCE = 5.0  # [mm] between the outer and the inner leaves


def stage_build(p: dict) -> Mechanism:
    """A folded double-parallelogram stage in mm, N, MPa (tonne): outer leaves (thickness ``t``,
    length ``L``, 10 mm wide, steel) from the ground at x = +-d/2 up to the intermediate body, inner
    leaves from it down to the stage at +-(d/2 - 5 mm); the stage's x prescribed (the stroke) and a
    tool point 30 mm beside its centre."""
    t, L, d = p["t"], p["L"], p["d"]
    m = Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("intermediate", position=(0.0, L))
    m.add_link("stage", position=(0.0, 0.0))
    leaf = dict(length=L, thickness=t, width=10.0, E=210000.0, G=80769.0, elements=6, density=7.85e-9)
    for s in (-1, 1):
        m.add_joint("ground", "intermediate", "leaf_spring", origin=(s * d / 2, 0.0), rotation=np.pi / 2,
                    name=f"outer{s:+d}", **leaf)
        m.add_joint("stage", "intermediate", "leaf_spring", origin=(s * (d / 2 - CLEARANCE), 0.0),
                    rotation=np.pi / 2, name=f"inner{s:+d}", **leaf)
    m.add_point("stage", "tool", (30.0, 0.0))
    m.prescribe("stage", x=0.0)
    return m


def stage(quick: bool = False) -> Problem:
    """Problem 2 (module notes); ``quick``: the stroke's two ends only (6 configurations otherwise,
    not through the unstressed x = 0, where von Mises has a kink)."""
    values = [-5.0, 5.0] if quick else [-5.0, -3.0, -1.0, 1.0, 3.0, 5.0]
    return Problem("stage", stage_build, {"t": 0.5, "L": 60.0, "d": 40.0},
                   {"t": (0.2, 1.0), "L": (30.0, 100.0), "d": (20.0, 60.0)},
                   ks_min(support_stiffness("stage", "y", point="tool")),
                   (Constraint(ks_max(R.reaction("stage", "x")), upper=5.0, name="stroke force <= 5 N"),
                    Constraint(ks_max(R.stress(scale=500.0, rho=100.0)), upper=300.0, name="stress <= 300 MPa")),
                   Stroke(values, motion=("stage", "x")), units="mm, N, MPa; stiffness [N/mm]")


# -- 3. the manipulator's joint placements ----------------------------------------------------------
MANIPULATOR_JOINT = ThreeXInfinity(elements_per_leaf=3)  # the mesh of the shipped database
Y_AXIS = (-0.5 * np.pi, 0.0, 0.0)  # turns a joint's z axis onto global y


def _rolled(base, roll: float) -> np.ndarray:
    """The rotation vector of ``exp(base) exp(roll e_z)``: a joint turned about its own axis."""
    return logm_so3(expm_so3(np.asarray(base, dtype=float)) @ expm_so3(np.array([0.0, 0.0, roll])))


def manipulator_build(p: dict) -> Mechanism:
    """`flexmb.models.manipulator`'s mechanism with its joints placed by ``p`` [m, rad]: ``post``,
    ``arm2``, ``angle2``, ``arm3``, ``angle3`` (`flexmb.models.MANIPULATOR`), ``roll1..3`` (each
    joint turned about its own axis), ``shift2``, ``shift3`` (joints 2 and 3 moved along their
    axes); the end point (link3's reference) prescribed at rest, the joints' axis points named."""
    joint = MANIPULATOR_JOINT
    D0 = float(joint.interface_b(3)[2])
    ex, ey, ez = np.eye(3)
    a2 = (D0 + p["post"]) * ez + p["shift2"] * ey
    b2 = a2 + D0 * ey
    a3 = b2 + p["arm2"] * (np.cos(p["angle2"]) * ex + np.sin(p["angle2"]) * ez) + p["shift3"] * ey
    end = a3 + D0 * ey + p["arm3"] * (np.cos(p["angle3"]) * ex + np.sin(p["angle3"]) * ez)
    m = Mechanism(dim=3)
    m.add_link("ground", fixed=True)
    m.add_link("link1", position=D0 * ez)
    m.add_link("link2", position=b2)
    m.add_link("link3", position=end)
    m.add_joint("ground", "link1", joint, name="joint1", rotation=_rolled((0.0, 0.0, 0.0), p["roll1"]))
    m.add_joint("link1", "link2", joint, name="joint2", origin=a2, rotation=_rolled(Y_AXIS, p["roll2"]))
    m.add_joint("link2", "link3", joint, name="joint3", origin=a3, rotation=_rolled(Y_AXIS, p["roll3"]))
    m.add_point("link1", "axis2", a2)
    m.add_point("link2", "axis3", a3)
    m.prescribe("link3", x=0.0, y=0.0, z=0.0)
    return m


@functools.lru_cache(maxsize=64)
def _rotations(value: float) -> tuple:
    """`flexmb.models.manipulator_rotations` kept per stroke value (every design's configure step
    asks for the same few), read-only."""
    out = manipulator_rotations(value)
    for R in out:
        R.flags.writeable = False
    return out


def manipulator_configure(mechanism: Mechanism, value: float) -> None:
    """Prescribe the end point where rigid links put it with all three joints turned by ``value``
    [rad] about their axes (joint 1 about global z through the origin, joints 2, 3 about global y
    through their named axis points): the location case of Sec. 4.4 for any placement."""
    pts, links = mechanism.points, mechanism.links
    a2, a3 = (links[pts[k][0]].position + pts[k][1] for k in ("axis2", "axis3"))
    end = links["link3"].position
    R1, R2, R3 = _rotations(float(np.real(value)))
    A2 = R1 @ a2
    A3 = A2 + R2 @ (a3 - a2)
    d = A3 + R3 @ (end - a3) - end
    mechanism.prescribe("link3", x=d[0], y=d[1], z=d[2])  # no float(): the placements' complex step passes


def manipulator(quick: bool = False) -> Problem:
    """Problem 3 (module notes); ``quick``: the configurations at 0 and +-30 deg only (five
    otherwise: 0, +-15, +-30 deg, in that order of continuation)."""
    degrees = [0.0, 30.0, -30.0] if quick else [0.0, 15.0, 30.0, -15.0, -30.0]
    g = MANIPULATOR
    p0 = {"post": g["post"], "arm2": g["arm2"], "angle2": g["angle2"], "arm3": g["arm3"], "angle3": g["angle3"],
          "roll1": 0.0, "roll2": 0.0, "roll3": 0.0, "shift2": 0.0, "shift3": 0.0}
    bounds = {"post": (0.05, 0.3), "arm2": (0.15, 0.4), "angle2": (0.0, np.radians(60.0)), "arm3": (0.15, 0.4),
              "angle3": (np.radians(-60.0), 0.0), "roll1": (-0.5, 0.5), "roll2": (-0.5, 0.5), "roll3": (-0.5, 0.5),
              "shift2": (-0.05, 0.05), "shift3": (-0.05, 0.05)}
    objective = ks_min([support_stiffness("link3", c) for c in ("rx", "ry", "rz")])
    constraints = (Constraint(at(R.position("link3", "x"), 0), lower=0.45, name="reach >= 0.45 m"),
                   Constraint(at(R.position("link3", "z"), 0), lower=0.15, upper=0.35, name="height 0.15-0.35 m"))
    return Problem("manipulator", manipulator_build, p0, bounds, objective, constraints,
                   Stroke(np.radians(degrees), configure=manipulator_configure), method="ksd-reduced",
                   units="m, rad; stiffness [N m/rad]")


PROBLEMS = {"hinge": hinge, "stage": stage, "manipulator": manipulator}

#: The runs of a comparison: (label, optimizer, gradient, options).
RUNS = (("SLSQP, adjoint gradients", "slsqp", "adjoint", {}),
        ("SLSQP, central differences", "slsqp", "central", {}),
        ("COBYLA (derivative-free)", "cobyla", None, {"max_iter": 400}))


def warm_up(problem: Problem) -> None:
    """Evaluate the start once with gradients (compiles the kernels, loads the joint database), so
    that no run's time includes the one-time costs."""
    from ..design.stroke import StrokePoint

    StrokePoint(problem.build, problem.p0, [problem.objective] + [c.response for c in problem.constraints],
                problem.stroke, method=problem.method).evaluation()


def compare(problem: Problem, runs=RUNS, **options) -> dict:
    """Run ``problem`` with each of ``runs`` from the same start (after `warm_up`):
    ``{label: (result, wall time [s])}``."""
    warm_up(problem)
    out = {}
    for label, optimizer, gradient, kw in runs:
        t0 = time.perf_counter()
        result = problem.run(optimizer, gradient, **{**kw, **options})
        out[label] = (result, time.perf_counter() - t0)
    return out


def comparison_table(problem: Problem, results: dict) -> str:
    """The runs side by side: objective (and its exact extreme), feasibility, evaluations, solves,
    wall time, and each run's objective and time relative to the first run's."""
    (first, t_first), *_ = results.values()
    rows = [f"{problem.name}: {'maximise' if problem.maximize else 'minimise'} {problem.objective.name} ({problem.units})",
            f"{'run':30s} {'objective':>12s} {'exact':>12s} {'feasible':>8s} {'evals':>6s} {'solves':>7s} "
            f"{'time [s]':>9s} {'obj/first':>9s} {'time/first':>10s}"]
    for label, (r, t) in results.items():
        rows.append(f"{label:30s} {r.objective:12.6g} {r.objective_exact:12.6g} {str(r.feasible):>8s} "
                    f"{r.evaluations:6d} {r.solves:7d} {t:9.2f} {r.objective / first.objective:9.4f} "
                    f"{t / t_first:10.2f}")
    rows.append("best: " + ", ".join(f"{k}={v:.6g}" for k, v in first.p.items()))
    return "\n".join(rows)


def run_example(problem: Problem, name: str, out=None, cobyla_evaluations: int = 400) -> dict:
    """The optimisation examples' run: SLSQP on flexmb's design gradients (`RUNS`' first) and the
    derivative-free COBYLA (at most ``cobyla_evaluations``) from the same start, printed side by
    side; each run's history written as ``<name>_gradients.csv`` / ``<name>_cobyla.csv`` into
    ``out`` (None: nothing written). Returns ``{"problem", "result", "baseline"}``."""
    runs = (RUNS[0], ("COBYLA (derivative-free)", "cobyla", None, {"max_iter": cobyla_evaluations}))
    results = compare(problem, runs)
    print(comparison_table(problem, results))
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        for tag, (label, *_) in zip(("gradients", "cobyla"), runs):
            path = results[label][0].history.to_csv(Path(out) / f"{name}_{tag}.csv")
            print(f"history written to {path}")
    return {"problem": problem, "result": results[runs[0][0]][0], "baseline": results[runs[1][0]][0]}
