"""First-call cost of the compiled kernels (issue 21): cold (empty numba cache) and cached.

Each measurement is a fresh Python process (``NUMBA_CACHE_DIR`` a new temporary folder for the
cold run, the same folder again for the cached one) that imports flexmb, then times the first
call of each kernel: the 2D and 3D beam elements (one small solve each), the closed-form
linkage (a gripper solve), KSD-reduced's steps 1-4 and its modes and stresses (the manipulator;
the first modes also build the joints' condensed-mass table once); the numpy path's first call
for comparison. Writes the "compile"
section of BENCHMARKS.md. Run: python benchmarks/bench_compile.py [--quick]
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import ROOT, machine, run  # noqa: E402

PROBE = r"""
import json, time
t = time.perf_counter()
import numpy as np, flexmb
out = {"import flexmb": time.perf_counter() - t}
cases = {
    "2D beam (cantilever, 8 el.)": lambda: flexmb.models.cantilever(8, dim=2),
    "3D beam (cantilever, 8 el.)": lambda: flexmb.models.cantilever(8, dim=3),
}
for name, make in cases.items():
    m = make()
    m.apply_force("tip", (0.0, 1.0) if "2D" in name else (0.0, 1.0, 0.0))
    t = time.perf_counter(); flexmb.solve(m); first = time.perf_counter() - t
    t = time.perf_counter(); flexmb.solve(m); out[name] = (first, time.perf_counter() - t)
m = flexmb.models.gripper(force=50.0)
t = time.perf_counter(); flexmb.solve(m, method="newton"); first = time.perf_counter() - t
t = time.perf_counter(); flexmb.solve(m, method="newton"); out["closed-form linkage (gripper)"] = (first, time.perf_counter() - t)
m = flexmb.models.manipulator("joint", np.radians(45))
t = time.perf_counter(); sol = flexmb.solve(m, method="ksd-reduced"); first = time.perf_counter() - t
t = time.perf_counter(); sol = flexmb.solve(m, method="ksd-reduced"); out["KSD-reduced (manipulator, 45 deg)"] = (first, time.perf_counter() - t)
t = time.perf_counter(); flexmb.modes(sol, n=6); sol.stresses(); first = time.perf_counter() - t
sol = flexmb.solve(m, method="ksd-reduced")
t = time.perf_counter(); flexmb.modes(sol, n=6); sol.stresses(); out["KSD-reduced modes + stresses (same)"] = (first, time.perf_counter() - t)
print(json.dumps(out))
"""


def probe(kernels: str, cache: str) -> dict:
    env = {**os.environ, "FLEXMB_KERNELS": kernels, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(ROOT),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    res = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(quick: bool = False) -> str:
    repeat = 1 if quick else 3
    rows = {"cold": [], "cached": [], "numpy": []}
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as cache:
            rows["cold"].append(probe("numba", cache))
            rows["cached"].append(probe("numba", cache))
            rows["numpy"].append(probe("numpy", cache))
    names = [k for k in rows["cold"][0] if k != "import flexmb"]

    def med(kind, name, i):
        return float(np.median([r[name][i] for r in rows[kind]]))

    lines = ["## Kernel compile time: first call cold and cached (issue 21)", "",
             f"{machine()}. Fresh process per cell, median of {repeat}; cold = empty numba cache "
             "(`NUMBA_CACHE_DIR` a new folder), cached = the same folder again; second call = the same solve "
             "once more in that process.", "",
             "| kernel (first solve) | cold first [s] | cached first [s] | numpy first [s] | second call, compiled [ms] "
             "| second call, numpy [ms] |", "|---|---:|---:|---:|---:|---:|"]
    for name in names:
        lines.append(f"| {name} | {med('cold', name, 0):.2f} | {med('cached', name, 0):.3f} | "
                     f"{med('numpy', name, 0):.3f} | {med('cached', name, 1)*1e3:.2f} | {med('numpy', name, 1)*1e3:.2f} |")
    imp = {k: float(np.median([r["import flexmb"] for r in rows[k]])) for k in rows}
    lines += ["", f"`import flexmb`: {imp['cold']:.2f} s (numba), {imp['numpy']:.2f} s (numpy); numba itself is "
              "imported with the first kernel module. The cold compile is paid once per machine and flexmb "
              "version (numba's on-disk cache, `cache=True`)."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("compile", main, __doc__, "one repetition instead of three")
