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


def _rows(name: str, quick: bool) -> tuple[list[str], str]:
    """One problem's rows (each run's objective, counts, wall and CPU time) and its summary line."""
    problem = PROBLEMS[name](quick)
    warm_up(problem)
    results = {}
    for label, optimizer, gradient, options in RUNS:
        if optimizer in EXTRA and importlib.util.find_spec(EXTRA[optimizer]) is None:
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        r = problem.run(optimizer, gradient, **options)
        results[label] = (r, time.perf_counter() - t0, time.process_time() - c0)
    _, t_central, c_central = results["SLSQP central"]
    ref = results["COBYLA"][0].objective
    rows = []
    for label, (r, t, c) in results.items():
        gain = (r.objective / ref - 1) * (1 if problem.maximize else -1)
        rows.append(f"| {name} ({len(problem.p0)} p., {problem.method}) | {label} | {r.objective:.6g} | "
                    f"{r.objective_exact:.6g} | {'yes' if r.feasible else 'no'} | {gain * 100:+.3f} % | {r.evaluations} | "
                    f"{r.solves} | {t:.2f} | {c:.2f} | {t_central / t:.1f}x | {c_central / c:.1f}x |")
    print("\n".join(rows), flush=True)
    _, t_adj, c_adj = results["SLSQP adjoint"]
    summary = (f"{name} ({len(problem.p0)} p.): SLSQP central / adjoint {t_central / t_adj:.1f}x wall, "
               f"{c_central / c_adj:.1f}x CPU")
    return rows, summary


def main(quick: bool = False) -> str:
    """Run every problem (``quick``: their small versions) and return the section's markdown."""
    rows, summaries = [], []
    for name in PROBLEMS:
        r, s = _rows(name, quick)
        rows += r
        summaries.append(s)
    head = ["## optimize: three design optimisations against derivative-free and central-difference baselines",
            "",
            f"`python benchmarks/bench_optimize.py{' --quick' if quick else ''}` ({machine()}). Each problem "
            "(flexmb/studies/optimization.py, examples/optimize_*.py) from the same start under the same "
            "constraints; one run each after a warm-up evaluation (kernels compiled, database loaded). "
            "*vs COBYLA*: the objective's gain over the derivative-free optimum (positive = better); "
            "*central / time*: SLSQP on central differences of plain solves over this run, in wall time and in "
            "the process's CPU time (the host is shared: CPU time is the fairer ratio).",
            "",
            "| problem | run | objective | exact extreme | feasible | vs COBYLA | evaluations | solves | time [s] | "
            "CPU [s] | central / time | central / CPU |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    foot = ["",
            "Ratios of this run: " + "; ".join(summaries) + ". The issue's targets are 3x at 4 parameters and "
            "10x at 10 or more. Per design the exact gradient costs about one to two plain evaluations of the "
            "stroke (one complex-step build per parameter and the configure step on each, the complex-step "
            "tangent blocks of every parameter direction; on the hinge also the stress sample points of each new "
            "section size), against the 2K plain evaluations of central differences (docs/design.md). The "
            "manipulator runs KSD-reduced (its placements' gradients through KSD steps 1-3, "
            "flexmb/design/reduced.py)."]
    return "\n".join(head + rows + foot)


if __name__ == "__main__":
    run("optimize", main, __doc__, "the problems' small versions")
