"""Design optimisation benchmark (issue 28): the three optimisations of flexmb.studies.optimization,
each run from the same start under the same constraints by

- SLSQP on flexmb's design gradients (adjoint / direct, `flexmb.optimize`),
- the same SLSQP on central differences of plain solves (2 solves of the stroke per parameter),
- COBYLA on plain solves (the derivative-free baseline, 400 evaluations at most),
- MMA (nlopt) and IPOPT (cyipopt) on flexmb's gradients, where installed,

reporting the objective (and the exact extreme its KS aggregate stands in for), feasibility,
evaluations, equilibrium solves and wall time; the ratios within one run. Writes the "optimize"
section of BENCHMARKS.md.
Run: python benchmarks/bench_optimize.py [--quick]
"""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run

from flexmb.studies.optimization import PROBLEMS, warm_up

RUNS = [("SLSQP adjoint", "slsqp", "adjoint", {}),
        ("SLSQP central", "slsqp", "central", {}),
        ("COBYLA", "cobyla", None, {"max_iter": 400}),
        ("MMA adjoint", "mma", "adjoint", {"max_iter": 400}),
        ("IPOPT adjoint", "ipopt", "adjoint", {})]
EXTRA = {"mma": "nlopt", "ipopt": "cyipopt"}


def _rows(name: str, quick: bool) -> list[str]:
    problem = PROBLEMS[name](quick)
    warm_up(problem)
    results = {}
    for label, optimizer, gradient, options in RUNS:
        if optimizer in EXTRA and importlib.util.find_spec(EXTRA[optimizer]) is None:
            continue
        t0 = time.perf_counter()
        results[label] = (problem.run(optimizer, gradient, **options), time.perf_counter() - t0)
    base, t_base = results["SLSQP adjoint"]
    t_central = results["SLSQP central"][1]
    ref = results["COBYLA"][0].objective
    rows = []
    for label, (r, t) in results.items():
        gain = (r.objective / ref - 1) * (1 if problem.maximize else -1)
        rows.append(f"| {name} ({len(problem.p0)} p.) | {label} | {r.objective:.6g} | {r.objective_exact:.6g} | "
                    f"{'yes' if r.feasible else 'no'} | {gain * 100:+.3f} % | {r.evaluations} | {r.solves} | "
                    f"{t:.2f} | {t_central / t:.1f}x |")
    print("\n".join(rows), flush=True)
    return rows


def main(quick: bool = False) -> str:
    """Run every problem (``quick``: their small versions) and return the section's markdown."""
    rows = []
    for name in PROBLEMS:
        rows += _rows(name, quick)
    head = ["## optimize: three design optimisations against derivative-free and central-difference baselines",
            "",
            f"`python benchmarks/bench_optimize.py{' --quick' if quick else ''}` ({machine()}). Each problem "
            "(flexmb/studies/optimization.py, examples/optimize_*.py) from the same start under the same "
            "constraints; one run each after a warm-up evaluation (kernels compiled, database loaded). "
            "*vs COBYLA*: the objective's gain over the derivative-free optimum (positive = better); "
            "*central / time*: the wall time of SLSQP on central differences of plain solves over this run's.",
            "",
            "| problem | run | objective | exact extreme | feasible | vs COBYLA | evaluations | solves | time [s] | "
            "central / time |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    foot = ["",
            "Every run reaches COBYLA's optimum or better (within 0.5 %). The wall-time gain over central "
            "differences stays below the issue's 3x at 4 parameters and 10x at 10: per design the exact "
            "gradient costs about one to two plain evaluations (the design's builds, one complex-step build per parameter, the "
            "complex-step tangent blocks of every parameter direction; on the hinge also the stress sample "
            "points of each new section size, ~40 ms, which the differences pay too), against the 2K plain "
            "evaluations of central differences (docs/design.md)."]
    return "\n".join(head + rows + foot)


if __name__ == "__main__":
    run("optimize", main, __doc__, "the problems' small versions")
