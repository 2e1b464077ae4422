"""Peer benchmark (issues 19 and 21): flexmb's conventional method against Exudyn on the same mesh.

Each case is solved by `flexmb.solve` (conventional method, defaults: its relative convergence
test) and by Exudyn 1.13 (geometrically exact beams, exact rigid constraints, its static solver) on
the Exudyn model `flexmb.peers.ExudynModel` builds from flexmb's own compiled mesh. Exudyn's
settings are searched first (node type, load steps, Newton iterations per step, full or modified
Newton) and the fastest configuration that converges to the paper's criterion (2-norm of the
residual below 5e-7 N, N m on every step) is timed; flexmb's final residuals are below it. Both
codes run on one thread (BLAS limited by threadpoolctl, Exudyn's own threads 1); solves alternate
(flexmb, Exudyn, flexmb, ...), garbage collection paused during each, medians reported with the
host's load average.

Cases: the four-bar of Dwarshuis et al. (2020) Sec. 4.3 at d = 0.3 m with 5, 10 and 20 elements per
leaf (issue 31: flexmb's iterations independent of the mesh);
the spatial manipulator of Sec. 4.4, joint case at 45 deg (3 elements per leaf); beyond the
papers, a serial chain of N = 16 and 64 cross flexures (Table 1, 5 elements per leaf), the end
link turned 30 deg about z (free in x and y), the links between free.
Writes the "peers" section of BENCHMARKS.md. Run: python benchmarks/bench_peers.py [--quick]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import gc  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import machine, run  # noqa: E402
import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import flexmb  # noqa: E402
from flexmb.models import fourbar, manipulator  # noqa: E402
from flexmb.peers import ExudynModel, NODE_TYPES  # noqa: E402
from flexmb.studies.manipulator import joint_moments  # noqa: E402

TOL = 5e-7  # the paper's absolute tolerance [N, N m]: Exudyn's criterion
# the 64-pivot chain's round-off floor is above it (flexmb's default test stops at its floor,
# 1.8e-6; Exudyn does not reach 5e-7): there Exudyn gets 1e-5
# the four-bar at 20 el./leaf: Exudyn's residual stops at 1.2-1.4e-6 (Rxyz nodes; 2.9e-6 EP), so
# 5e-7 failed in all 84 settings tried (EP and Rxyz nodes, 1-128 load steps, 12-50 iterations per
# step, full and modified Newton); to 2e-6 it converges (flexmb's residual: below 5e-7)
TOL_FOURBAR_20 = 2e-6


def chain(n: int, turn: float = np.radians(30.0), elements_per_leaf: int = 5) -> flexmb.Mechanism:
    """N cross flexures (Table 1) in series along y, built as a user would: link 0 fixed, the
    end link N turned by ``turn`` [rad] about z (its z and tilts held, x and y free), the links
    between free."""
    joint = flexmb.joint("cross_flexure", elements_per_leaf=elements_per_leaf)
    h = float(joint.interface_b(3)[1])
    m = flexmb.Mechanism(dim=3)
    m.add_link("L0", fixed=True)
    for k in range(1, n + 1):
        m.add_link(f"L{k}", position=(0.0, k * h, 0.0))
        m.add_joint(f"L{k - 1}", f"L{k}", joint, name=f"pivot{k}", origin=(0.0, (k - 1) * h, 0.0))
    m.prescribe(f"L{n}", z=0.0, rotation=(0.0, 0.0, turn))
    return m


def _manipulator_moments(sol, model) -> np.ndarray:
    """The joint case's three joint moments [N m] from an Exudyn solution (as `joint_moments`)."""
    node = model.compiled.link_node
    M = np.array([sol.reactions[k][3:] for k in ("link1", "link2", "link3")])
    R = sol.state.rotations
    axes = [np.array([0.0, 0.0, 1.0]), R[node["link1"]][:, 1], R[node["link2"]][:, 1]]
    return np.array([M[k:].sum(axis=0) @ axes[k] for k in range(3)])


CASES = {
    "four-bar, d = 0.3 m, 5 el./leaf": (lambda: fourbar(5, displacement=0.3),
                                        lambda s: np.array([s.reaction("top")[0]]),
                                        lambda e, x: np.array([e.reactions["top"][0]]), "actuation force F [N]", TOL),
    "four-bar, d = 0.3 m, 10 el./leaf": (lambda: fourbar(10, displacement=0.3),
                                         lambda s: np.array([s.reaction("top")[0]]),
                                         lambda e, x: np.array([e.reactions["top"][0]]), "actuation force F [N]", TOL),
    "four-bar, d = 0.3 m, 20 el./leaf": (lambda: fourbar(20, displacement=0.3),
                                         lambda s: np.array([s.reaction("top")[0]]),
                                         lambda e, x: np.array([e.reactions["top"][0]]), "actuation force F [N]",
                                         TOL_FOURBAR_20),
    "manipulator, joint case, 45 deg": (lambda: manipulator("joint", np.radians(45.0)), joint_moments,
                                        _manipulator_moments, "joint moments [N m]", TOL),
    "chain of 16 cross flexures, end turned 30 deg": (lambda: chain(16), lambda s: s.reaction("L16")[[0, 1, 5]],
                                                      lambda e, x: e.reactions["L16"][[0, 1, 5]],
                                                      "end link's F_x, F_y, M_z [N, N m]", TOL),
    "chain of 64 cross flexures, end turned 30 deg": (lambda: chain(64), lambda s: s.reaction("L64")[[0, 1, 5]],
                                                      lambda e, x: e.reactions["L64"][[0, 1, 5]],
                                                      "end link's F_x, F_y, M_z [N, N m]", 1e-5),
}


def _timed(fn):
    """``fn()``, its wall and CPU time [s] (garbage collection paused, as timeit)."""
    gc.collect()
    gc.disable()
    try:
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        return out, time.perf_counter() - t, time.process_time() - c
    finally:
        gc.enable()


def _ok(sol, tol) -> bool:
    return sol.converged and sol.residual <= tol and sol.constraint_error < 1e-9


def search(model: ExudynModel, tol: float, quick: bool) -> tuple[dict, list, dict]:
    """The fastest Exudyn options that converge (greedy: node type, then load steps and Newton
    iterations per step, then modified Newton and the linear solver). Returns the options and
    the tried configurations ``(options, converged, iterations, time)`` and the models built."""
    tried = []

    def attempt(opts):
        ex = models.setdefault(opts["node_type"], model if opts["node_type"] == model.node_type
                               else ExudynModel(model.compiled, node_type=opts["node_type"]))
        kw = {k: v for k, v in opts.items() if k != "node_type"}
        sol = ex.solve(absolute_tolerance=tol, **kw)
        tried.append((dict(opts), _ok(sol, tol), sol.iterations, sol.cpu_time))
        return sol.cpu_time if _ok(sol, tol) else np.inf

    models = {}
    best = {"node_type": model.node_type, "load_steps": 4, "max_iterations": 25, "modified_newton": False,
            "linear_solver": "EigenSparse"}
    grid = [("node_type", NODE_TYPES[:2]), ("load_steps", (1, 4, 16) if quick else (1, 2, 4, 8, 16)),
            ("max_iterations", (12, 25)), ("modified_newton", (False, True))]
    best_time = attempt(best)
    for key, values in grid:
        for v in values:
            if v == best[key]:
                continue
            opts = {**best, key: v}
            t = attempt(opts)
            if t < best_time:
                best, best_time = opts, t
    return best, tried, models


def case(name: str, repeats: int, quick: bool) -> dict:
    build, ours, theirs, what, tol = CASES[name]
    mech = build()
    sol = flexmb.solve(mech)  # warm-up: joint meshes cached, kernels compiled
    model = ExudynModel(mech.compile(), node_type="EP")
    best, tried, models = search(model, tol, quick)
    ex = models[best["node_type"]]
    opts = {k: v for k, v in best.items() if k != "node_type"}
    opts["absolute_tolerance"] = tol
    tf, te, cf, ce = [], [], [], []
    for _ in range(repeats):
        sol, t, c = _timed(lambda: flexmb.solve(mech))
        tf.append(t)
        cf.append(c)
        es = ex.solve(**opts)
        te.append(es.wall_time)
        ce.append(es.cpu_time)
    dx = np.abs(es.positions - sol.node_positions()).max()
    moved = np.abs(sol.node_positions() - mech.compile().problem.model.point_x0).max()
    a, b = ours(sol), theirs(es, ex)
    return {"name": name, "flexmb_it": sol.iterations, "flexmb_t": float(np.median(tf)),
            "flexmb_res": float(np.linalg.norm(sol.residual[sol.compiled.problem.free])),
            "exudyn_it": es.iterations, "exudyn_t": float(np.median(te)),
            "flexmb_cpu": float(np.median(cf)), "exudyn_cpu": float(np.median(ce)), "exudyn_res": es.residual,
            "exudyn_steps": es.steps,
            "best": best, "tried": tried, "dx": dx, "moved": moved, "react": np.abs(a - b).max() / np.abs(a).max(),
            "react_scale": np.abs(a).max(), "what": what, "free": sol.compiled.problem.n_free,
            "exudyn_n": ex.mbs.systemData.GetODE2Coordinates().size + ex.mbs.systemData.GetAECoordinates().size,
            "beams": ex.n_beams, "ties": ex.n_ties, "tol": tol, "converged": sol.converged and es.converged}


def refinement() -> list[str]:
    """The four-bar's actuation force as both meshes are refined: the two beams converge to one
    answer (the same-mesh difference is the beams' discretisation error)."""
    out = []
    c = fourbar(5, displacement=0.3).compile()
    for k in (1, 2, 4):
        e = ExudynModel(c, node_type="Rxyz", refine=k).solve(load_steps=2, absolute_tolerance=1e-5)
        s = flexmb.solve(fourbar(5 * k, displacement=0.3))
        peer = f"{e.reactions['top'][0]:.3f}" if e.converged else "not converged"
        out.append(f"| {5 * k} | {s.reaction('top')[0]:.3f} | {peer} |")
    return out


def main(quick: bool = False) -> str:
    repeats = 5 if quick else 7
    names = list(CASES)[:5] if quick else list(CASES)
    host = machine()  # the load average at the start
    with threadpool_limits(1):
        rows = [case(n, repeats, quick) for n in names]
        conv = refinement()
    load1 = os.getloadavg()
    import exudyn

    lines = [
        "## Peers: flexmb's conventional method vs Exudyn on the same mesh (issues 19, 21)",
        "",
        f"{host}; {load1[0]:.1f} at the end. flexmb {flexmb.__version__}, Exudyn {exudyn.__version__}.",
        "The Exudyn model is `flexmb.peers.ExudynModel` of flexmb's compiled mesh: one geometrically exact beam",
        "(`ObjectBeamGeometricallyExact`) per flexmb element, rigid links and blocks tied exactly (`GenericJoint`,",
        "Lagrange multipliers), prescribed motion by constraints following Exudyn's load factor. Both solve from the",
        f"undeformed state; flexmb with its defaults (relative test), Exudyn to a residual 2-norm below {TOL:g}",
        "(N, N m) on every step (final residuals of both in the table); one thread each. Times: median",
        f"of {repeats} solves alternating flexmb / Exudyn; flexmb's is a whole `flexmb.solve` (compiling included),",
        "Exudyn's its `MainSolverStatic.SolveSystem` (model built once). Exudyn's configuration: the fastest",
        "converging one of a greedy search (node type, load steps, Newton iterations per step before a step is",
        "cut, modified Newton), named in the last column.",
        "",
        "| case | free DOFs (flexmb) / unknowns (Exudyn) | flexmb it. / ms wall / ms CPU "
        "| Exudyn it. / ms wall / ms CPU "
        "| flexmb / Exudyn wall, CPU | final residual flexmb / Exudyn | positions max diff [m] (largest "
        "displacement) | reaction diff (rel.) | Exudyn configuration |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        b = r["best"]
        if r["tol"] != TOL:
            r["name"] += f" (Exudyn to {r['tol']:g})"
        cfg = (f"{b['node_type']} nodes, {b['load_steps']} load steps, {b['max_iterations']} it./step, "
               f"{'modified' if b['modified_newton'] else 'full'} Newton, {b['linear_solver']}")
        lines.append(f"| {r['name']} | {r['free']} / {r['exudyn_n']} | {r['flexmb_it']} / {r['flexmb_t'] * 1e3:.0f} / "
                     f"{r['flexmb_cpu'] * 1e3:.0f} | {r['exudyn_it']} / {r['exudyn_t'] * 1e3:.0f} / "
                     f"{r['exudyn_cpu'] * 1e3:.0f} | "
                     f"{r['flexmb_t'] / r['exudyn_t']:.2f}, {r['flexmb_cpu'] / r['exudyn_cpu']:.2f} | "
                     f"{r['flexmb_res']:.1e} / {r['exudyn_res']:.1e} | "
                     f"{r['dx']:.2e} ({r['moved']:.3g}) | {r['react']:.2e} of {r['react_scale']:.4g} ({r['what']}) "
                     f"| {cfg} |")
        if not r["converged"]:
            lines[-1] += " NOT CONVERGED"
    lines += ["", "Exudyn configurations tried (Newton iterations / ms CPU, or no: not converged to the tolerance). "
              "Not searched: RotVecLG nodes (Exudyn's static solver diverged with them on every case but the four-bar) "
              "and the dense solver EXUdense (four-bar: 5.3 s against 0.16 s sparse).", ""]
    for r in rows:
        tried = "; ".join(f"{o['node_type']} {o['load_steps']} st. {o['max_iterations']} it. "
                          f"{'mod.' if o['modified_newton'] else 'full'} {o['linear_solver']}: "
                          + (f"{it} / {t * 1e3:.0f}" if ok else "no") for o, ok, it, t in r["tried"])
        lines.append(f"- {r['name']}: {tried}")
    lines += ["", "Timing: wall time is what a user waits; on this shared host (load above) it includes waiting for a",
              "core, so the CPU time of the process (both codes single-threaded) is the steadier measure of the work",
              "done."]
    lines += ["", "The same-mesh differences are the two beams' discretisation errors: flexmb's element has the exact",
              "two-node Timoshenko stiffness, Exudyn's interpolates linearly with one-point integration. Refined, both",
              "approach one answer (four-bar actuation force [N]; Exudyn refined by splitting each element of the",
              "5 el./leaf mesh, residual below 1e-5 N):", "",
              "| elements per leaf | flexmb | Exudyn |", "|---:|---:|---:|", *conv]
    return "\n".join(lines)


if __name__ == "__main__":
    import importlib.util

    if importlib.util.find_spec("exudyn") is None:  # `flexmb bench` without the extra: keep the section
        print("bench_peers: skipped, Exudyn is not installed (python -m pip install 'flexmb[peers]')", file=sys.stderr)
    else:
        run("peers", main, __doc__, "three cases, smaller search, 5 repetitions")
