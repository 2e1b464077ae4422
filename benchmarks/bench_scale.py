"""Scale (issue 21 item 5): conventional Newton iterations from 1e2 to 1e5 elements, and the dense /
LDL^T crossover of `flexmb.linear.TangentSolver`.

1. A fine 3D cantilever, 0.1 x 0.02 x 0.001 m steel, built as a chain of ten 10 mm leaf springs
   (`flexmb.LeafSpring`, at most 10 000 elements per joint) joined by nine links, ``n``
   elements in all, tip force (0, 5, 2) N (tip deflection ~5 % of the length): one fresh
   process per size, so the peak resident memory (``resource.getrusage`` ``ru_maxrss``) is that
   size's; its increase over the process after a warm-up solve is the model's share. Per size:
   the first solve's time (sparsity patterns and LDL^T analysis included) and, solving the same
   compiled model again, the iterations, time per Newton iteration, its assembly (element kernels
   + sparse assembly) and linear-solve shares, the per-element cost, the tip displacement (the
   same beam: it must converge with the mesh). The tolerance follows the round-off floor of the
   residual, which grows like ``eps EA n sqrt(n_dofs)`` (absolute coordinates: a node's force
   error is ~eps x position x EA / element length): ``tol = max(5e-7, 10 eps EA n sqrt(6 n))``.
2. The dense / LDL^T crossover: converged tangents of 3D cantilevers from 24 to 480 unknowns,
   dense LAPACK (``np.linalg.solve`` of the dense matrix) against qdldl with its analysis reused
   (numeric refactorisation + solve + refinement), medians in one run.

Writes the "scale" section of BENCHMARKS.md. Run: python benchmarks/bench_scale.py [--quick]
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import ROOT, machine, median_time, run  # noqa: E402

FORCE = (0.0, 5.0, 2.0)
EA = 200e9 * 0.02 * 0.001  # the default leaf's axial stiffness [N]

PROBE = r"""
import json, resource, sys, time
import numpy as np, flexmb
n, force, tol = int(sys.argv[1]), tuple(map(float, sys.argv[2:5])), float(sys.argv[5])
def model(n, k=10, L=0.1):
    # a chain of k leaf springs (links between them) along x: the 0.1 m cantilever cut in k joints
    m = flexmb.Mechanism(dim=3)
    m.add_link("ground", fixed=True)
    prev = "ground"
    for i in range(k):
        name = "tip" if i == k - 1 else f"link{i + 1}"
        m.add_link(name, position=((i + 1) * L / k, 0.0, 0.0))
        m.add_joint(prev, name, flexmb.LeafSpring(length=L / k, elements=n // k), name=f"leaf{i + 1}",
                    origin=(i * L / k, 0.0, 0.0))
        prev = name
    m.apply_force("tip", force)
    return m
flexmb.solve(model(20), tol=1e-6)  # warm-up: kernels loaded (compiled and cached), imports done
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter(); m = model(n); compiled = m.compile(); t_build = time.perf_counter() - t
from flexmb.solvers import Conventional
strategy = Conventional(tol=tol)
t = time.perf_counter(); first = strategy.solve(compiled); t_first = time.perf_counter() - t
sol = strategy.solve(compiled)  # again: sparsity patterns and the LDL^T analysis reused
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
w = sol.wall_time
print(json.dumps({"n": n, "build": t_build, "first": t_first, "iterations": sol.iterations, "steps": sol.steps,
                  "converged": bool(sol.converged), "total": w["total"], "assemble": w.get("assemble", 0.0),
                  "solve": w.get("solve", 0.0), "tip": sol.displacement("tip")[:3].tolist(),
                  "peak_kb": peak, "base_kb": base, "message": sol.message[:120]}))
"""


def tolerance(n: int) -> float:
    return max(5e-7, 10 * np.finfo(float).eps * EA * n * np.sqrt(6 * n))


def probe(n: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    res = subprocess.run([sys.executable, "-c", PROBE, str(n), *map(str, FORCE), repr(float(tolerance(n)))], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def crossover(elements, repeat: int):
    """(unknowns, dense [s], LDL^T reused [s]) per cantilever size, at its converged tangent."""
    import flexmb
    from flexmb.linear import TangentSolver

    rows = []
    for k in elements:
        m = flexmb.models.cantilever(k, dim=3)
        m.apply_force("tip", FORCE)
        sol = flexmb.solve(m)
        _, K, _, _ = sol.compiled.problem.evaluate(sol.state, 1.0, tangent=True)
        b = np.random.default_rng(0).normal(size=K.shape[0])
        ldl = TangentSolver(use_ldl=True)
        ldl._analyse(K)  # the analysis, once per pattern
        t_dense = median_time(lambda: np.linalg.solve(K.toarray(), b), repeat=repeat, number=20)
        t_ldl = median_time(lambda: ldl._solve_ldl(K, b, np.inf), repeat=repeat, number=20)
        rows.append((K.shape[0], t_dense, t_ldl))
    return rows


def main(quick: bool = False) -> str:
    sizes = [100, 300, 1000, 3000, 10000] + ([] if quick else [30000, 100000])
    results = [probe(n) for n in sizes]
    ref_tip = np.array(results[-1]["tip"])
    lines = ["## Scale: conventional Newton iterations from 1e2 to 1e5 elements (issue 21 item 5)", "",
             f"{machine()}. 3D cantilever (0.1 x 0.02 x 0.001 m steel) as a chain of ten leaf springs, tip force "
             f"{FORCE} N, one fresh process per size; tolerance at the residual's round-off floor (see benchmarks/bench_scale.py).", "",
             "| elements | unknowns | tol [N] | first solve [s] | steps / iterations | per iteration [ms] | assembly share | "
             "solve share | assembly per element [us] | peak RSS [MB] | model's share [MB] | kB per element | "
             f"tip y vs {sizes[-1]} el. |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        n, it = r["n"], max(r["iterations"], 1)
        per = r["total"] / it
        extra = (r["peak_kb"] - r["base_kb"]) / 1024
        ok = "" if r["converged"] else " (not converged)"
        lines.append(f"| {n} | {6 * n} | {tolerance(n):.1e} | {r['first']:.2f} | {r['steps']} / {r['iterations']}{ok} | {per*1e3:.1f} | "
                     f"{r['assemble']/r['total']:.0%} | {r['solve']/r['total']:.0%} | "
                     f"{r['assemble']/it/n*1e6:.2f} | {r['peak_kb']/1024:.0f} | {extra:.0f} | "
                     f"{extra*1024/n:.1f} | {r['tip'][1]/ref_tip[1] - 1:+.1e} |")
    big = results[-1]
    lines += ["", f"The {big['n']}-element solve: {big['first']:.1f} s the first time, {big['total']:.1f} s again, "
              f"{big['iterations']} iterations; model build "
              f"{big['build']:.2f} s, peak RSS {big['peak_kb']/1024:.0f} MB; memory grows linearly with the element "
              "count (the element batches, the sparse tangent and its LDL^T factor of a banded matrix). The last "
              "column compares each mesh's tip with the largest mesh's, which stops at its loose round-off "
              f"tolerance ({tolerance(sizes[-1]):.2g} N): the smaller meshes agree among themselves far better.", ""]
    rows = crossover([4, 6, 8, 10, 12, 15, 20, 25, 30, 35, 40, 50, 60, 80], 3 if quick else 7)
    lines += ["Dense LAPACK against qdldl's LDL^T with its analysis reused (one solve incl. the numeric "
              "refactorisation and refinement; medians of 7 x 20, converged 3D cantilever tangents):", "",
              "| unknowns | dense [ms] | LDL^T reused [ms] | dense / LDL^T |", "|---:|---:|---:|---:|"]
    for n, td, tl in rows:
        lines.append(f"| {n} | {td*1e3:.3f} | {tl*1e3:.3f} | {td/tl:.2f} |")
    first = next((n for n, td, tl in rows if td > tl), None)
    lines += ["", f"LDL^T is faster from {first} unknowns on (flexmb.linear.DENSE_BELOW_LDL is the switch; DENSE_BELOW "
              "= 220 stays for SuperLU)."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("scale", main, __doc__, "sizes up to 1e4 elements and fewer repetitions")
