"""The spatial manipulator of Dwarshuis et al. (2020), Sec. 4.4 (Figs. 13 and 15): the joint and
the location case solved by the conventional method, KSD-reduced and KSD-full at positions with
all three joint rotations varied together, with iterations, times and KSD-reduced's errors."""

from __future__ import annotations


import numpy as np

from ..models import manipulator
from ._timing import interleaved
from ..solvers import solve

__all__ = ["METHODS", "joint_moments", "study", "errors"]

METHODS = ("conventional", "ksd-reduced", "ksd-full")
LINKS = ("link1", "link2", "link3")


def joint_moments(sol) -> np.ndarray:
    """Moments [N m] the joint case's reactions exert about the three joint axes: the reactions
    on the links beyond joint k, summed (pure moments: the link positions are free), projected
    on joint k's current axis (joint 1: global z; joints 2, 3: the y axis of links 1, 2)."""
    M = np.array([sol.reaction(k)[3:] for k in LINKS])
    axes = [np.array([0.0, 0.0, 1.0]), sol.pose("link1")[1][:, 1], sol.pose("link2")[1][:, 1]]
    return np.array([M[k:].sum(axis=0) @ axes[k] for k in range(3)])


def errors(case: str, reduced, reference) -> dict:
    """KSD-reduced against the converged full model: the largest relative error of the reactions
    (joint case: the joint moments; location case: the force on the end point, over its norm) and
    of the link displacements (largest position difference over the largest displacement);
    NaN where the reference has no reaction (below its solve tolerance) or displacement (below
    1 um) to compare with: at rest."""
    if case == "joint":
        a, b = joint_moments(reduced), joint_moments(reference)
    else:
        a, b = reduced.reaction("link3")[:3], reference.reaction("link3")[:3]
    scale = np.abs(b).max() if case == "joint" else np.linalg.norm(b)
    d = max(np.linalg.norm(reference.displacement(k)) for k in LINKS)
    dx = max(np.linalg.norm(reduced.pose(k)[0] - reference.pose(k)[0]) for k in LINKS)
    # at rest nothing to compare: reactions below the solve tolerance, displacements below 1 um
    # (the database fits' size at rest) give NaN
    return {"reaction": float(np.abs(a - b).max() / scale) if scale > reference.tolerance else np.nan,
            "displacement": float(dx / d) if d > 1e-6 else np.nan}


def study(rotations_deg=tuple(range(-45, 46, 5)), cases=("joint", "location"), repeats: int = 3,
          elements: int | None = None, clock: str = "wall") -> list[dict]:
    """Fig. 15: per case, position and method the Newton iterations, the median ``clock`` time
    (`flexmb.studies._timing.interleaved`: ``"wall"`` or ``"cpu"``) of
    ``repeats`` solves (interleaved; garbage collection paused as timeit), the speed-up over the
    conventional method, and KSD-reduced's errors against the conventional solution."""
    rows = []
    for case in cases:
        for deg in rotations_deg:
            m = manipulator(case, np.radians(deg), elements=elements)
            for method in METHODS[1:]:
                solve(m, method=method)  # warm-up: joint templates cached as in an optimisation loop
            sols, times = interleaved(m, METHODS, repeats, clock=clock)
            base = times["conventional"]
            err = errors(case, sols["ksd-reduced"], sols["conventional"])
            for method in METHODS:
                s, t = sols[method], times[method]
                rows.append({"case": case, "rotation": deg, "method": method, "iterations": s.iterations,
                             "time": t, "speedup": base / t, "residual": float(s.residual_history[-1]),
                             "converged": s.converged, **({f"error_{k}": v for k, v in err.items()}
                                                          if method == "ksd-reduced" else {})})
    return rows


def plot_joint(joint, path, rotation: float = 0.0) -> None:
    """The joint's mesh in 3D (needs matplotlib): leaves as lines, rigid blocks (sides A and B
    dark, intermediate bodies grey) as thick spokes to their points; deformed at ``rotation`` [rad]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..testing import joint_mechanism

    sol = solve(joint_mechanism(joint, 3, motion=rotation))
    pts = sol.node_positions()[len(sol.compiled.link_node):]
    mesh = joint.mesh(3)
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    for i, j in mesh.elements:
        ax.plot(*pts[[i, j]].T * 1e3, color="tab:blue", lw=1.5)
    groups = [np.flatnonzero(mesh.side == 1), np.flatnonzero(mesh.side == 2)]
    groups += [np.flatnonzero(mesh.body == b) for b in range(mesh.body.max() + 1)]
    for g, color in zip(groups, ["0.2", "0.2"] + ["tab:gray"] * len(groups)):
        c = pts[g].mean(axis=0)  # a rigid block drawn as spokes from its centre to its points
        for p in pts[g]:
            ax.plot(*np.stack([c, p]).T * 1e3, color=color, lw=3, alpha=0.6)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.set_title(f"three_x_infinity at {np.degrees(rotation):.0f} deg: {len(mesh.elements)} flexible elements, "
                 f"{mesh.body.max() + 1} rigid bodies", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_study(rows, path) -> None:
    """Fig. 15: iterations and time per position for every method and case (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for case, ls in (("joint", "-"), ("location", "--")):
        for method, color in zip(METHODS, ("k", "tab:orange", "tab:blue")):
            sel = [r for r in rows if r["case"] == case and r["method"] == method]
            x = [r["rotation"] for r in sel]
            axes[0].semilogy(x, [max(r["iterations"], 1) for r in sel], ls, color=color, label=f"{method}, {case}")
            axes[1].semilogy(x, [r["time"] * 1e3 for r in sel], ls, color=color)
    axes[0].set_ylabel("iterations")
    axes[1].set_ylabel("time [ms]")
    for a in axes:
        a.set_xlabel("joint rotation [deg]")
        a.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
