"""KSD-reduced with the tabulated EOB condensation (issue 21 item 4): the manipulator at 45 deg.

In one run, interleaved: KSD-reduced on the compiled manipulator (joint and location case) with
the database's table (`flexmb.ksd.eob_table`) and with the condensation computed per solve (the
table detached), minimum and median of N solves with the phase times of the fastest; the same
through `flexmb.solve` (which compiles the mechanism every call); one lookup against one direct
condensation of the three joints; and the largest difference of the answers. Writes the
"eob_table" section of BENCHMARKS.md. Run: python benchmarks/bench_eob_table.py [--quick]
"""

from __future__ import annotations

import gc
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import flexmb  # noqa: E402
from _report import machine, median_time, run  # noqa: E402
from flexmb.joints import ThreeXInfinity  # noqa: E402
from flexmb.ksd.reduced import template  # noqa: E402
from flexmb.solvers import KSDReduced  # noqa: E402

PHASES = ("setup", "kinematics", "eob", "reduced", "internal")


def timed(fn, n):
    """(times [s], the results) of ``n`` calls, garbage collection paused during each."""
    out, times = [], []
    for _ in range(n):
        gc.collect()
        gc.disable()
        try:
            t = time.perf_counter()
            out.append(fn())
            times.append(time.perf_counter() - t)
        finally:
            gc.enable()
    return times, out


def main(quick: bool = False) -> str:
    n = 30 if quick else 200
    tpl = template(ThreeXInfinity(elements_per_leaf=3), 3)  # the paper's mesh, as models.manipulator (shipped table)
    table = tpl.lookup
    strategy = KSDReduced()
    lines = ["## KSD-reduced with the tabulated EOB condensation (issue 21 item 4)", "",
             f"{machine()}. Manipulator at 45 deg, KSD-reduced; table = the database's EOB table (degree-7 splines, "
             f"{len(table.table.theta)} samples), computed = the Craig-Bampton condensation per solve (as before). "
             f"{n} solves per cell, interleaved in rounds of 10; min and median [ms]; phases of the fastest solve.", "",
             "| case | call | condensation | min [ms] | median [ms] | " + " | ".join(PHASES) + " |",
             "|---|---|---|---:|---:|" + "---:|" * len(PHASES)]
    diffs = []
    for case in ("joint", "location"):
        m = flexmb.models.manipulator(case, rotation=np.radians(45.0))
        compiled = m.compile()
        calls = {"strategy.solve(compiled)": lambda: strategy.solve(compiled),
                 "flexmb.solve(m)": lambda: flexmb.solve(m, method="ksd-reduced")}
        res = {}
        for _ in range(n // 10):
            for mode in ("table", "computed"):
                tpl.lookup = table if mode == "table" else None
                for call, fn in calls.items():
                    t, sols = timed(fn, 10)
                    r = res.setdefault((call, mode), {"t": [], "sols": []})
                    r["t"].extend(t)
                    r["sols"].extend(sols)
        tpl.lookup = table
        for (call, mode), r in res.items():
            t = np.array(r["t"])
            w = r["sols"][int(np.argmin(t))].wall_time
            lines.append(f"| {case} | {call} | {mode} | {t.min()*1e3:.2f} | {np.median(t)*1e3:.2f} | "
                         + " | ".join(f"{w.get(p, np.nan)*1e3:.2f}" for p in PHASES) + " |")
        a, b = (res[("strategy.solve(compiled)", mode)]["sols"][-1] for mode in ("table", "computed"))
        links = list(compiled.link_node)
        scale = max(np.abs(b.reaction(k)).max() for k in links)
        diffs.append((case, np.abs(a.node_positions() - b.node_positions()).max() / np.abs(b.node_positions()).max(),
                      max(np.abs(a.reaction(k) - b.reaction(k)).max() for k in links) / scale))
    theta = np.full(3, np.radians(45.0))
    bpos = np.tile(tpl.node_x0[1], (3, 1))
    t_lookup = median_time(lambda: table(theta, bpos), repeat=7, number=50)
    t_eval = median_time(lambda: tpl.evaluate(theta, bpos, held_a=True), repeat=7, number=50)
    lines += ["", f"Three joints' condensation: lookup {t_lookup*1e6:.0f} us, computed {t_eval*1e6:.0f} us "
              f"({t_eval/t_lookup:.0f}x; medians of 7 x 50).",
              "Answers with the table against the computed condensation (largest difference, relative to the largest "
              "entry): " + "; ".join(f"{c} case positions {p:.1e}, reactions {r:.1e}" for c, p, r in diffs) + ".",
              "`flexmb.solve(m)` keeps the compiled model and KSD's set-up while the mechanism is unchanged "
              "(`flexmb.compiled.compiled_for`): a loop solving one mechanism pays the compile once."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("eob_table", main, __doc__, "30 solves per cell instead of 200")
