"""Design-property benchmark (issue 22): the cost of the properties per configuration.

(1) The spatial manipulator of Dwarshuis et al. (2020) Sec. 4.4 (joint case, three_x_infinity
joints, steel leaves 7800 kg/m^3, links massless), 19 positions from -45 to 45 deg: per strategy
the median solve time and the median time of the properties at that configuration -- the six
lowest frequencies (`flexmb.modes`, prescribed DOFs held), the end point's 6x6 compliance
(`flexmb.compliance` of link3) and the stresses (`Solution.stresses`) -- interleaved; KSD-full's
frequencies against the conventional ones, KSD-reduced's peak von Mises stress against the
conventional one (KSD-reduced has no modes or compliance: its internal nodes are first-order).
(2) A 10 000-DOF model: the manipulator with 62 elements per leaf, turned to 30 deg: modes,
buckling and compliance times (sparse shift-invert and LDL^T paths).
Writes the "properties" section of BENCHMARKS.md. Run: python benchmarks/bench_properties.py [--quick]
"""

from __future__ import annotations

import gc
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run  # noqa: E402
import numpy as np  # noqa: E402

import flexmb  # noqa: E402
from flexmb.models import manipulator  # noqa: E402

METHODS = ("conventional", "ksd-full", "ksd-reduced")


def _timed(fn):
    gc.disable()
    try:
        t = time.perf_counter()
        out = fn()
        return out, time.perf_counter() - t
    finally:
        gc.enable()


def _properties(sol):
    if sol.method == "ksd-reduced":
        return None, None, sol.stresses()
    return flexmb.modes(sol, n=6), flexmb.compliance(sol, "link3"), sol.stresses()


def positions(rotations_deg, repeats: int) -> list[dict]:
    """Per position and method: median solve and property times [s], f1..f3 [Hz], peak von Mises [Pa]."""
    rows = []
    for deg in rotations_deg:
        m = manipulator("joint", np.radians(deg))
        for method in METHODS:  # warm-up: joint templates, stress tables
            _properties(flexmb.solve(m, method=method))
        times = {k: ([], []) for k in METHODS}
        out = {}
        for _ in range(repeats):
            for method in METHODS:
                sol, ts = _timed(lambda: flexmb.solve(m, method=method))
                props, tp = _timed(lambda: _properties(sol))
                times[method][0].append(ts)
                times[method][1].append(tp)
                out[method] = (sol, props)
        for method in METHODS:
            sol, (md, _, st) = out[method]
            rows.append({"rotation": deg, "method": method, "converged": sol.converged,
                         "solve": float(np.median(times[method][0])), "properties": float(np.median(times[method][1])),
                         "f": None if md is None else md.frequencies[:3], "stress": float(st.von_mises.max())})
    return rows


def large(elements: int = 62, rotation_deg: float = 30.0, repeats: int = 3) -> dict:
    """Times [s] of the properties of the manipulator with ``elements`` per leaf (~10 000 DOFs)."""
    m = manipulator("joint", np.radians(rotation_deg), elements=elements)
    sol, t_solve = _timed(lambda: flexmb.solve(m, tol=1e-5))  # 5e-7 is below this model's roundoff floor
    out = {"dofs": len(sol.compiled.problem.free), "converged": sol.converged, "solve": t_solve}
    for name, fn in (("modes", lambda: flexmb.modes(sol, n=6)), ("buckling", lambda: flexmb.buckling(sol)),
                     ("compliance", lambda: flexmb.compliance(sol, "link3")), ("stresses", lambda: sol.stresses())):
        ts = []
        for _ in range(repeats):
            value, t = _timed(fn)
            ts.append(t)
        out[name] = float(np.median(ts))
        if name == "modes":
            out["f"], out["solver"] = value.frequencies[:3], value.solver
    return out


def main(quick: bool = False) -> str:
    repeats = 1 if quick else 3
    rotations = tuple(range(-45, 46, 15)) if quick else tuple(range(-45, 46, 5))
    rows = positions(rotations, repeats)
    at = {(r["rotation"], r["method"]): r for r in rows}
    lines = [
        "## Design properties: modes, compliance, stresses per configuration (issue 22)",
        "",
        f"Dwarshuis et al. (2020) Sec. 4.4 manipulator, joint case, flexmb's three_x_infinity joints (3 el./leaf, steel "
        f"leaves, links massless); {machine()}; host shared with other sessions (timings noisy).",
        f"Median of {repeats} interleaved runs per method and position. Properties: `modes(n=6)` (prescribed DOFs held), "
        "`compliance(sol, \"link3\")` and `stresses()`; KSD-reduced: stresses only (no modes or compliance: its "
        "internal nodes are first-order). Errors against the conventional solution.",
        "",
        "| rotation [deg] | conventional solve / properties [ms] | KSD-full solve / properties [ms] | "
        "KSD-reduced solve / stresses [ms] | f1 f2 f3 [Hz] | KSD-full f1-3 error | KSD-reduced von Mises error |",
        "|---:|---:|---:|---:|---|---:|---:|",
    ]
    for deg in rotations:
        c, f, r = (at[deg, k] for k in METHODS)
        ef = np.abs(f["f"] / c["f"] - 1).max()
        er = abs(r["stress"] / c["stress"] - 1) if c["stress"] > 1e3 else np.nan
        lines.append(f"| {deg} | {c['solve']*1e3:.0f} / {c['properties']*1e3:.1f} | {f['solve']*1e3:.1f} / "
                     f"{f['properties']*1e3:.1f} | {r['solve']*1e3:.1f} / {r['properties']*1e3:.1f} | "
                     f"{' '.join(f'{x:.1f}' for x in c['f'])} | {ef:.1e} | {er:.1e} |")
    tot = {k: sum(at[d, k]["solve"] + at[d, k]["properties"] for d in rotations) for k in METHODS}
    props = {k: sum(at[d, k]["properties"] for d in rotations) for k in METHODS}
    lines += ["", f"- all {len(rotations)} positions, solve + properties: conventional {tot['conventional']:.2f} s, "
              f"KSD-full {tot['ksd-full']:.2f} s ({tot['conventional'] / tot['ksd-full']:.0f}x), KSD-reduced (stresses "
              f"only) {tot['ksd-reduced']:.2f} s; the properties alone {props['conventional']*1e3:.0f} / "
              f"{props['ksd-full']*1e3:.0f} / {props['ksd-reduced']*1e3:.0f} ms."]
    big = large(repeats=1 if quick else 3)
    lines += ["", f"10 000-DOF model: the manipulator with 62 el./leaf ({big['dofs']} free DOFs), 30 deg (solved to "
              f"tol = 1e-5 N, 5e-7 being below its roundoff floor; converged {big['converged']}, "
              f"{big['solve']:.1f} s): `modes(n=6)` {big['modes']:.2f} s ({big['solver']}; f1-3 "
              f"{', '.join(f'{x:.1f}' for x in big['f'])} Hz), `buckling` {big['buckling']:.2f} s, `compliance` "
              f"{big['compliance']:.2f} s, `stresses` {big['stresses']:.2f} s (medians of {1 if quick else 3})."]
    return "\n".join(lines)


if __name__ == "__main__":
    run("properties", main, __doc__, "7 positions, one repetition")
