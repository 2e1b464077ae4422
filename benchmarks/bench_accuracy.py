"""Accuracy by default (issue 30 item 3): the designer's quantities of `flexmb.studies.accuracy`
(a parallel guide, a double-parallelogram stage at full stroke, a 3D cross flexure's frequencies
and buckling, a chevron bistable's snap force) on the former and the new default meshes against
converged-mesh references (Richardson of three fine meshes with the observed order), the
estimate each result carries (`flexmb.accuracy`) against the true error, and what the new
defaults and the estimates cost in time. Writes the "accuracy" section of BENCHMARKS.md.
Run: python benchmarks/bench_accuracy.py [--quick]
"""

from __future__ import annotations

import os
import sys
import time
import warnings

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _report import machine, run  # noqa: E402

import flexmb  # noqa: E402
from flexmb import accuracy  # noqa: E402
from flexmb.discretisation import richardson  # noqa: E402
from flexmb.studies import accuracy as cases  # noqa: E402

#: case -> (former default, new default, the three meshes of the reference)
MESHES = {"parallel_guide": (12, 24, (64, 128, 256)), "stage": (12, 24, (64, 128, 256)),
          "pivot": (10, 24, (32, 64, 128)), "bistable": (12, 24, (32, 64, 128))}


def _quantities(case: str, n: int | None) -> tuple[dict, object]:
    """The case's quantities on mesh ``n`` (None: the default) and the result carrying the estimate
    (the bistable's: its snap, whose estimate is made on request, read here when they are on)."""
    if case == "bistable":
        point = cases.snap(cases.bistable(n))
        assert point.kind == "limit", (n, point.kind)
        if accuracy.target() is not None:
            point.discretisation
        return {"snap_force": 40.0 * point.load_factor}, point
    build, quantities = cases.CASES[case]
    sol = flexmb.solve(build(n), raise_on_failure=True)
    return quantities(sol), sol


def reference(case: str) -> tuple[dict, dict]:
    """``({name: Richardson reference}, {name: observed order})`` from the case's three meshes."""
    rows = [_quantities(case, n)[0] for n in MESHES[case][2]]
    names = list(rows[0])
    ref, order = richardson(np.array([[r[k] for k in names] for r in rows]))
    return dict(zip(names, ref)), dict(zip(names, order))


def _estimates(case: str) -> dict:
    """{quantity: estimated relative error} that the new default's results carry."""
    if case == "bistable":
        return {"snap_force": cases.snap(cases.bistable()).discretisation["load factor"]["relative"]}
    build, _ = cases.CASES[case]
    sol = flexmb.solve(build(), raise_on_failure=True)
    out = {}
    if case == "parallel_guide":
        out["shortening"] = sol.discretisation["displacement stage x"]["relative"]
        out["support_stiffness"] = flexmb.compliance(sol, "stage").discretisation["C[0,0]"]["relative"]
    elif case == "stage":
        out["support_stiffness"] = flexmb.compliance(sol, "stage").discretisation["C[1,1]"]["relative"]
        out["force"] = sol.discretisation["reaction stage x"]["relative"]
    else:
        est = flexmb.modes(sol, n_modes=3).discretisation
        out.update({f"f{k}": est[f"f{k}"]["relative"] for k in (1, 2, 3)})
        out["buckling"] = flexmb.buckling(sol).discretisation["buckling1"]["relative"]
    return out


def errors(case: str, ref: dict) -> list[str]:
    old, new, _ = MESHES[case]
    got = {n: _quantities(case, n)[0] for n in (old, new)}
    est = _estimates(case)
    lines = []
    for name, r in ref.items():
        e = {n: 100 * (got[n][name] - r) / abs(r) for n in (old, new)}
        guess = f"{100 * est[name]:.3f} %"
        lines.append(f"| {case} | {name} | {r:.6g} | {e[old]:+.3f} % | {e[new]:+.3f} % | {guess} |")
    return lines


def _time_case(case: str, n: int | None, estimates: bool) -> float:
    accuracy.set_target(accuracy.DEFAULT_TARGET if estimates else None)
    try:
        t0 = time.perf_counter()
        _quantities(case, n)
        return time.perf_counter() - t0
    finally:
        accuracy.set_target(accuracy.DEFAULT_TARGET)


def cost(case: str, repeats: int) -> str:
    """Median wall time [ms] of building, solving and reading the quantities: the former default
    without estimates (the library before), the new default without and with them; interleaved."""
    old = MESHES[case][0]
    runs = (("before", old, False), ("new mesh", None, False), ("new mesh + estimates", None, True))
    t = {k: [] for k, _, _ in runs}
    for _ in range(repeats):
        for label, n, est in runs:
            t[label].append(_time_case(case, n, est))
    med = {k: 1e3 * float(np.median(v)) for k, v in t.items()}
    return (f"| {case} | {med['before']:.1f} | {med['new mesh']:.1f} ({med['new mesh'] / med['before']:.2f}x) | "
            f"{med['new mesh + estimates']:.1f} ({med['new mesh + estimates'] / med['before']:.2f}x) |")


def main(quick: bool = False) -> str:
    warnings.simplefilter("ignore", flexmb.DiscretisationWarning)
    lines = ["## Accuracy by default (issue 30 item 3)", "",
             f"{machine()}. The quantities of `flexmb.studies.accuracy` against converged-mesh references "
             "(Richardson of the three meshes named, observed order), on the former default meshes (leaf_spring "
             "12 el., cross_flexure 10 el./leaf) and the new ones (24), and the relative error the new default's "
             "result carries as its estimate (`.discretisation`, a Richardson pair with the companion mesh of "
             "half the elements).", "",
             "| case | quantity | reference | former default | new default | estimate carried |",
             "|---|---|---:|---:|---:|---:|"]
    refs = {}
    for case in MESHES:
        ref, order = reference(case)
        refs[case] = (ref, order)
        lines += errors(case, ref)
    lines += ["", "References: " + "; ".join(
        f"{case} from {'/'.join(map(str, MESHES[case][2]))} el. (order "
        + ", ".join(f"{k} {p:.2f}" for k, p in order.items()) + ")" for case, (_, order) in refs.items()), ""]
    repeats = 3 if quick else 11
    lines += ["### Cost", "", f"Medians of {repeats} interleaved runs [ms] of building the mechanism, solving it and "
              "reading the quantities (the bistable: tracing its path to the snap, and with the estimates its "
              "snap's estimate, made on request); ratios to before.", "",
              "| case | before (former mesh, no estimates) | new default mesh | new default + estimates |",
              "|---|---:|---:|---:|"]
    for case in MESHES:
        lines.append(cost(case, 1 if case == "bistable" and quick else (3 if case == "bistable" else repeats)))
    return "\n".join(lines)


if __name__ == "__main__":
    run("accuracy", main, __doc__, "3 repetitions (1 for the bistable's path)")
