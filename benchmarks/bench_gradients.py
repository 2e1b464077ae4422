"""Design-gradient benchmark (issue 28): what a gradient costs against the solve it belongs to.

A 3D cross-flexure hinge (10 el./leaf, 30 elements) carrying a 1 kg block, turned 0.5 rad, with
20 parameters of every kind (leaf length, angle, thickness, widths, gap, E, G, density; the block's
mass, inertia, centre; the joint's placement and turn; a dead load's components):

(1) one response (the actuation moment) w.r.t. the 20 parameters: the plain solve (build + solve),
    the design's model-number rates (one complex-step build per parameter and two real builds
    checking them along one direction, once per design: `flexmb.design.builds`), the configuration's
    linearisation and adjoint solve, and the central differences of plain solves (40 solves) for
    perspective;
(2) five responses (actuation moment, first frequency, support compliance, KS stress, a
    displacement) at 10 configurations along the stroke (0.05 ... 0.5 rad) w.r.t. the 20 parameters
    against the 10 solves.
Medians of process CPU times (the host is shared), each repetition a fresh design (`fresh`), ratios within
one run; the stroke's rows interleaved per repetition. Writes the "gradients" section of BENCHMARKS.md.
Run: python benchmarks/bench_gradients.py [--quick]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np
from _report import machine, run

import flexmb
from flexmb.design import DesignPoint
from flexmb.design import responses as R
from flexmb.design.adjoint import Sensitivity
from flexmb.linear import single_threaded


def hinge(p: dict, turn: float = 0.5) -> flexmb.Mechanism:
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    L, a = p["L"], p["a"]
    m.add_link("B", position=(0.0, L * np.sin(a), 0.0), mass=p["m"], inertia=np.diag([p["Jx"], p["Jx"], p["Jz"]]),
               center=(p["cx"], p["cy"], 0.0))
    m.add_joint("A", "B", "cross_flexure", length=L, angle=a, thickness=p["t"], width_inner=p["wi"],
                width_outer=p["wo"], gap=p["gap"], E=p["E"], G=p["G"], density=p["rho"], elements_per_leaf=10,
                origin=(p["x"], p["y"], 0.0), rotation=(0.0, 0.0, p["phi"]), yield_stress=1e9)
    m.prescribe("B", rotation=(0.0, 0.0, turn))
    m.apply_force("B", (p["Fx"], p["Fy"], p["Fz"]), point=(0.0, L * np.sin(a) + 0.02, 0.0))
    return m


P = dict(L=0.1, a=np.pi / 4, t=1e-3, wi=0.04, wo=0.02, gap=1e-3, E=200e9, G=76.9e9, rho=7800.0, m=1.0, Jx=1e-3,
         Jz=1e-3, cx=0.0, cy=0.01, x=0.0, y=0.0, phi=0.0, Fx=1.0, Fy=-9.81, Fz=0.5)
BOUNDS = {"x": (-0.01, 0.01), "y": (-0.01, 0.01), "phi": (-0.1, 0.1), "cx": (-0.02, 0.02), "gap": (0.0, 0.005)}
FIVE = (R.reaction("B", "rz"), R.frequency(1), R.compliance("B", "x", "x"), R.stress(scale=300e6),
        R.displacement("B", "x"))


def _median(fn, repeat):
    """``fn(i)``'s last result and the median of its process CPU times [s] over ``repeat`` calls
    (CPU time: the host is shared, wall time counts the other processes' time slices)."""
    out, times = None, []
    for i in range(repeat):
        t = time.process_time()
        out = fn(i)
        times.append(time.process_time() - t)
    return out, float(np.median(times))


def fresh(i: int) -> dict:
    """The design moved by a relative 1e-7 i (an optimiser's next design): nothing of an earlier
    design's builds (flexmb's mesh cache keyed on the joint's values) serves it."""
    return {k: (x * (1 + 1e-7 * i) if x else 1e-9 * i) for k, x in P.items()}


def _central_rates(p: dict, compiled):
    """The model numbers' rates by central differences of the build (two real builds per
    parameter: the former method, `flexmb.design.builds` rule 2 for every parameter)."""
    from flexmb.design.builds import _central, _context

    design = DesignPoint(hinge, p, BOUNDS).design
    check, base = _context(design, compiled)
    return [_central(design, q, compiled.link_node, check, base, 3, "") for q in design.parameters]


def _gradient(point, solution, responses):
    with single_threaded():
        sens = Sensitivity(solution, point.rates(solution.compiled))
        return [r.gradient(sens) for r in responses]


def one_response(repeat: int) -> dict:
    sol, t_solve = _median(lambda i: flexmb.solve(hinge(fresh(i))), repeat)
    _, t_rates = _median(lambda i: DesignPoint(hinge, fresh(i), BOUNDS).rates(sol.compiled), repeat)
    _, t_central = _median(lambda i: _central_rates(fresh(repeat + i), sol.compiled), repeat)
    point = DesignPoint(hinge, fresh(repeat - 1), BOUNDS)
    point.rates(sol.compiled)
    _, t_adj = _median(lambda i: _gradient(point, sol, [FIVE[0]]), repeat)
    t_cd = None
    if repeat > 1:
        _, t_cd = _median(lambda i: [flexmb.solve(hinge({**P, k: P[k] * (1 + s * 1e-4) if P[k] else s * 1e-6}))
                                     for k in P for s in (1, -1)], 1)
    complex_step = sum(m == "complex step" for m, _ in point.rates(sol.compiled).methods)
    return {"solve": t_solve, "rates": t_rates, "central": t_central, "adjoint": t_adj, "cd": t_cd,
            "iterations": sol.iterations, "complex": complex_step,
            "elements": len(sol.compiled.problem.model.elements.L0), "dofs": sol.compiled.problem.model.n_dofs}


def _evaluate_all(point, turns, sols, gradient=True):
    for th, sol in zip(turns, sols):
        point.evaluate(FIVE, configure=lambda m, th=th: m.prescribe("B", rotation=(0.0, 0.0, th)), solution=sol,
                       gradient=gradient)


def _former(q, sols, turns):
    """The former rows: a new DesignPoint of design ``q`` on its kept solutions ``sols`` (their modes
    kept from an earlier repetition); CPU times of its rates and of all (rates + 10 evaluations)."""
    point = DesignPoint(hinge, q, BOUNDS)
    t = time.process_time()
    point.rates(sols[-1].compiled)
    t_rates = time.process_time() - t
    _evaluate_all(point, turns, sols)
    return t_rates, time.process_time() - t


def _unkept(q, turns, gradient: bool) -> float:
    """CPU time of the 10 evaluations on solutions and a design point of their own (nothing an
    earlier evaluation kept serves them: the modes, the linearisations, the design's rates)."""
    sols = [flexmb.solve(hinge(q, th)) for th in turns]
    point = DesignPoint(hinge, q, BOUNDS)
    t = time.process_time()
    _evaluate_all(point, turns, sols, gradient)
    return time.process_time() - t


def stroke(repeat: int, n_config: int = 10) -> dict:
    """The stroke's rows, interleaved: each repetition times the 10 solves of a fresh design, the
    former rows, the values alone and values with gradients (each on designs of their own), so
    that every ratio's two sides run under the same load; medians over the repetitions."""
    turns = np.linspace(0.05, 0.5, n_config)
    _unkept(fresh(10 * repeat + 1), turns[:2], True)  # warm-up: the kernels loaded from numba's cache
    q0 = fresh(0)
    sols = [flexmb.solve(hinge(q0, th)) for th in turns]
    rows = {k: [] for k in ("solves", "rates", "all", "values", "unkept")}
    for i in range(repeat):
        t = time.process_time()
        for th in turns:
            flexmb.solve(hinge(fresh(i + 1), th))
        rows["solves"].append(time.process_time() - t)
        t_rates, t_all = _former(q0, sols, turns)
        rows["rates"].append(t_rates)
        rows["all"].append(t_all)
        rows["values"].append(_unkept(fresh(repeat + i + 1), turns, False))
        rows["unkept"].append(_unkept(fresh(2 * repeat + i + 1), turns, True))
    return {"configs": n_config, **{k: float(np.median(v)) for k, v in rows.items()}}


def main(quick: bool = False) -> str:
    repeat = 3 if quick else 7
    a = one_response(repeat)
    b = stroke(1 if quick else 5)
    g = a["rates"] + a["adjoint"]
    lines = [
        "## Design gradients (issue 28)", "",
        f"3D cross-flexure hinge, {a['elements']} beam elements ({a['dofs']} DOFs), a 1 kg block, turned 0.5 rad "
        f"({a['iterations']} Newton iterations); 20 parameters of every kind; every repetition a fresh design (the "
        f"parameters moved by 1e-7, as an optimiser's next design); medians of process CPU times. {machine()}.", "",
        "| what | CPU time [ms] | / plain solve |", "| --- | ---: | ---: |",
        f"| plain solve (build + solve) | {a['solve'] * 1e3:.1f} | 1 |",
        f"| model-number rates: {a['complex']} complex-step builds + 2 check builds (once per design) | "
        f"{a['rates'] * 1e3:.1f} | {a['rates'] / a['solve']:.1f} |",
        f"| (the former method: central differences of the build, 40 builds) | {a['central'] * 1e3:.1f} | "
        f"{a['central'] / a['solve']:.1f} |",
        f"| linearisation + adjoint of one response (per configuration) | {a['adjoint'] * 1e3:.1f} | "
        f"{a['adjoint'] / a['solve']:.2f} |",
        f"| gradient of one response w.r.t. 20 parameters (both) | {g * 1e3:.1f} | {g / a['solve']:.1f} |",
    ]
    if a["cd"] is not None:
        lines.append(f"| central differences of plain solves (40 solves, for scale) | {a['cd'] * 1e3:.1f} | "
                     f"{a['cd'] / a['solve']:.1f} |")
    lines += ["",
              f"Five responses (actuation moment, first frequency, support compliance, KS stress, displacement) at "
              f"{b['configs']} configurations (0.05 ... 0.5 rad) w.r.t. 20 parameters:", "",
              "| what | CPU time [ms] | / the 10 solves |", "| --- | ---: | ---: |",
              f"| the {b['configs']} solves | {b['solves'] * 1e3:.1f} | 1 |",
              f"| rates (once) | {b['rates'] * 1e3:.1f} | {b['rates'] / b['solves']:.2f} |",
              f"| all gradients (rates + 10 linearisations, 5 responses each) | {b['all'] * 1e3:.1f} | "
              f"{b['all'] / b['solves']:.2f} |",
              f"| of which per configuration | {(b['all'] - b['rates']) / b['configs'] * 1e3:.1f} | "
              f"{(b['all'] - b['rates']) / b['solves']:.2f} (all 10) |", "",
              "The rows above evaluate the same 10 solutions in every repetition: the modes behind the "
              "frequency's value (`flexmb.modes`, kept per solution) are computed in the first repetition only. "
              "On solutions and a design of their own (each repetition a fresh design; nothing kept), the "
              "values alone and with their gradients:", "",
              "| what (fresh solutions) | CPU time [ms] | / the 10 solves |", "| --- | ---: | ---: |",
              f"| the five values at the {b['configs']} configurations (`gradient=False`) | {b['values'] * 1e3:.1f} | "
              f"{b['values'] / b['solves']:.2f} |",
              f"| the values and their gradients (rates included) | {b['unkept'] * 1e3:.1f} | "
              f"{b['unkept'] / b['solves']:.2f} |",
              f"| the gradients beyond the values | {(b['unkept'] - b['values']) * 1e3:.1f} | "
              f"{(b['unkept'] - b['values']) / b['solves']:.2f} |", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    run("gradients", main, __doc__, "fewer repeats")
