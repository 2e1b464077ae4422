"""The gripper of Cammarata et al. (2022), Sec. 5: the studies behind `examples/gripper.py` and the demo.

Closing forces (end-effector x = 0) of the linear and partial non-linear closed-form models
and of flexmb's fully non-linear finite-element model, the opening-closing sweep (Figs. 7, 9),
the tangent stiffness and its terms (Tables 2-7), the Newton strategies over the sweep
(Figs. 11-13) and the cross-section study (Fig. 10). Units: mm, uN (the paper's).
"""

from __future__ import annotations

import time

import numpy as np

from .. import models
from ..solvers import solve
from ..sweeps import find_actuation, sweep, tangent_stiffness

__all__ = ["MODELS", "STRATEGIES", "FE_OPTIONS", "closing_force", "opening_closing", "stiffness_tables",
           "strategy_study", "cross_section_study", "plot_workspace", "plot_comparison", "plot_strategies",
           "plot_cross_section"]

MODELS = ("linear", "partial-nonlinear")
#: The five Newton strategies of Sec. 5.3: (label, tangent, start).
STRATEGIES = (("constant K_T(q_hat)", "constant", "undeformed"),
              ("full K_T, undeformed start", "full", "undeformed"),
              ("K_T^I only, undeformed start", "first-term", "undeformed"),
              ("full K_T, previous start", "full", "previous"),
              ("K_T^I only, previous start", "first-term", "previous"))
#: The finite-element reference: 32 elements per arc (closing force within 0.2 % of the
#: extrapolated value); its residual floor in mm/uN is ~1e-6 uN, so tol is 1e-5 uN.
FE_OPTIONS = {"elements": 32, "tol": 1e-5}
EE = ("body3", "end_effector")
#: Opening force of the sweep for silicon (Sec. 5.1: from -60 uN); other materials scale with E.
OPENING_FORCE = -60.0


def _scale(material: str) -> float:
    return models.GRIPPER_MATERIALS[material] / models.GRIPPER_MATERIALS["silicon"]


def _mechanism(material: str, model: str, elements: int = FE_OPTIONS["elements"], **section):
    return models.gripper(material, model=model, elements=elements, **section)


def closing_force(material: str = "silicon", model: str = "partial-nonlinear", method: str = "newton",
                  **section) -> float:
    """Actuation force F_2y [uN] that closes the clamp (end-effector x = 0)."""
    m = _mechanism(material, model, **section)
    opts = {"tol": FE_OPTIONS["tol"]} if method == "conventional" else {}
    b, h = models.GRIPPER_TABLE_1["b"], models.GRIPPER_TABLE_1["h"]
    scale = _scale(material) * (section.get("height", h) / h) ** 3 * section.get("width", b) / b  # F ~ E b h^3
    return find_actuation(m, EE, np.arange(0.0, 400.0, 10.0) * scale, method=method, **opts)


def opening_closing(material: str = "silicon", model: str = "partial-nonlinear", method: str = "newton",
                    points: int = 131, upper: float | None = None, **options) -> dict:
    """The sweep from the opening force to the closing force (or ``upper``): forces, end-effector
    positions, convergence, iterations and wall time [s] per force, and the total time, timed
    after an untimed sweep of two forces: a session's first compiled sweep loads its kernels, and
    `flexmb demo` had printed ten times the warm time."""
    scale = _scale(material)
    upper = closing_force(material, model, method) if upper is None else upper
    forces = np.linspace(OPENING_FORCE * scale, upper, points)
    m = _mechanism(material, model)
    if method == "conventional":
        options = {"tol": FE_OPTIONS["tol"], **options}
    sweep(m, forces[:2], method=method, **options)  # warm-up, untimed
    t = time.perf_counter()
    sols = sweep(m, forces, method=method, **options)
    total = time.perf_counter() - t
    return {"forces": forces, "ee": np.array([s.point(*EE) if s.converged else (np.nan, np.nan) for s in sols]),
            "converged": np.array([s.converged for s in sols]), "iterations": np.array([s.iterations for s in sols]),
            "time": np.array([s.wall_time["total"] for s in sols]), "total_time": total, "solutions": sols}


def stiffness_tables(force: float = 50.0, model: str = "partial-nonlinear", material: str = "silicon") -> dict:
    """K_T at rest (Table 2), at ``force`` (Table 3), their percentage difference (Table 4) and the
    terms at ``force`` (Tables 5-7), 9 x 9 in body 2-4 x (x, y, theta)."""
    m = models.gripper(material, model=model)
    rest = tangent_stiffness(m)
    loaded = models.gripper(material, model=model, force=force)
    sol = solve(loaded, method="newton", raise_on_failure=True)
    terms = tangent_stiffness(loaded, sol, terms=True)
    K = sum(terms.values())
    with np.errstate(divide="ignore", invalid="ignore"):
        diff = np.where(rest != 0, 100.0 * (K - rest) / rest, np.nan)
    return {"rest": rest, "loaded": K, "percent": diff, "terms": terms, "force": force}


def strategy_study(forces=None, model: str = "partial-nonlinear", material: str = "silicon",
                   max_iter: int = 1000, repeat: int = 3) -> dict:
    """Iterations and wall time per force for the five strategies (Figs. 11-13), medians of
    ``repeat`` sweeps, and the largest force at which the constant tangent still converges."""
    forces = np.arange(0.0, 76.0, 1.0) * _scale(material) if forces is None else np.asarray(forces, float)
    m = _mechanism(material, model)
    out = {}
    for label, tangent, start in STRATEGIES:
        times = []
        for _ in range(repeat):
            sols = sweep(m, forces, method="newton", tangent=tangent, start=start, max_iter=max_iter)
            times.append([s.wall_time["total"] for s in sols])
        ok = np.array([s.converged for s in sols])
        out[label] = {"iterations": np.array([s.iterations for s in sols]), "converged": ok,
                      "time": np.median(np.array(times), axis=0), "tangent": tangent, "start": start}
    ok = out[STRATEGIES[0][0]]["converged"]
    first_fail = int(np.argmin(ok)) if not ok.all() else None
    return {"forces": forces, "strategies": out, "max_iter": max_iter,
            "constant_last_converged": None if first_fail is None or first_fail == 0 else forces[first_fail - 1],
            "constant_first_failure": None if first_fail is None else forces[first_fail]}


def cross_section_study(widths, heights, model: str = "partial-nonlinear", material: str = "silicon") -> np.ndarray:
    """Closing force [uN] over a grid of cross-sections (b = widths [mm], h = heights [mm]), Fig. 10.

    Rows follow ``heights``, columns ``widths``. With Eq. (2) the force scales exactly with
    E b h^3, which the grid shows (and the tests check)."""
    return np.array([[closing_force(material, model, width=b, height=h) for b in widths] for h in heights])


# -- figures ----------------------------------------------------------------------------------
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _draw(ax, sol, color, lw=1.0, label=None):
    """Links as sticks from their reference points to their joints' attachment points; FE arcs
    as their node polylines, closed-form flexures as chords between their attachment points."""
    problem = sol.compiled.problem
    pts = problem.model.point_positions(sol.state)
    nl = len(sol.compiled.link_node)
    if hasattr(problem.model, "flexures"):
        ends = pts[nl:].reshape(-1, 2, 2)
        fl = problem.model.flexures
        for k, (a, b) in enumerate(ends):
            ax.plot(*np.stack([pts[fl.i[k]], a]).T, color=color, lw=2 * lw)
            ax.plot(*np.stack([pts[fl.j[k]], b]).T, color=color, lw=2 * lw)
            ax.plot(*np.stack([a, b]).T, color=color, lw=0.6 * lw, ls=":")
    else:
        master = problem.model.point_master
        el = problem.model.elements.ends
        for k, (p, q) in enumerate(el):
            ax.plot(*pts[[p, q]].T, color=color, lw=lw, label=label if k == 0 else None)
        for p in np.flatnonzero(master < nl):
            if p >= nl:
                ax.plot(*np.stack([pts[master[p]], pts[p]]).T, color=color, lw=2 * lw)
    ee = sol.point(*EE)
    owner = sol.compiled.link_node[EE[0]]
    ax.plot(*np.stack([pts[owner], ee]).T, color=color, lw=2 * lw)


def plot_workspace(results: dict, path) -> None:
    """Fig. 7: undeformed and limit configurations and the end-effector trajectory, per model."""
    plt = _plt()
    fig, axes = plt.subplots(1, len(results), figsize=(5 * len(results), 5), squeeze=False)
    for ax, (name, r) in zip(axes[0], results.items()):
        sols = [s for s in r["solutions"] if s.converged]
        rest = min(sols, key=lambda s: abs(s.compiled.problem.loads.force).sum())
        _draw(ax, rest, "tab:blue")
        _draw(ax, sols[0], "tab:red")
        _draw(ax, sols[-1], "tab:red")
        ax.plot(*r["ee"][r["converged"]].T, "k-", lw=1.5)
        ax.set_title(f"{name}: F = {r['forces'][0]:.3g} ... {r['forces'][-1]:.3g} uN", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_comparison(results: dict, path) -> None:
    """Fig. 9: end-effector trajectory and actuation force vs end-effector x, per material (rows)
    and model (curves); ``results[material][label]`` are `opening_closing` outputs."""
    plt = _plt()
    fig, axes = plt.subplots(len(results), 2, figsize=(11, 4.2 * len(results)), squeeze=False)
    for row, (material, curves) in zip(axes, results.items()):
        for label, r in curves.items():
            ok = r["converged"]
            row[0].plot(*r["ee"][ok].T, label=label)
            row[1].plot(r["ee"][ok, 0], r["forces"][ok], label=label)
        row[0].set_title(f"{material}: end-effector trajectory", fontsize=9)
        row[0].set_xlabel("x_EE [mm]")
        row[0].set_ylabel("y_EE [mm]")
        row[1].set_title(f"{material}: actuation force", fontsize=9)
        row[1].set_xlabel("x_EE [mm]")
        row[1].set_ylabel("F_2y [uN]")
        for ax in row:
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_strategies(study: dict, path) -> None:
    """Figs. 11-13: iterations and time per force for the five strategies."""
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    F = study["forces"]
    for label, s in study["strategies"].items():
        ok = s["converged"]
        a.semilogy(F[ok], np.maximum(s["iterations"][ok], 1), ".-", ms=3, label=label)
        b.semilogy(F[ok], 1e3 * s["time"][ok], ".-", ms=3, label=label)
    if study["constant_first_failure"] is not None:
        a.axvline(study["constant_first_failure"], color="k", ls=":", lw=1)
    a.set_xlabel("F_2y [uN]")
    a.set_ylabel("Newton iterations")
    b.set_xlabel("F_2y [uN]")
    b.set_ylabel("wall time per solve [ms]")
    for ax in (a, b):
        ax.grid(alpha=0.3, which="both")
    a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_cross_section(widths, heights, forces: np.ndarray, path) -> None:
    """Fig. 10: closing force over the cross-section (b, h)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    cs = ax.contourf(1e3 * np.asarray(widths), 1e3 * np.asarray(heights), forces, levels=20, cmap="viridis")
    fig.colorbar(cs, ax=ax, label="closing force F_2y [uN]")
    ax.set_xlabel("cross-section base b [um]")
    ax.set_ylabel("cross-section height h [um]")
    ax.set_title("Gripper closing force vs flexure cross-section (silicon)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
