"""The paper cases flexmb can run today, as small functions shared by the CLI demo and `examples/`.

Cross flexure (Dwarshuis et al. 2020, Sec. 4.2, Fig. 7a): node B of the Table 1 cross flexure is
rotated about z from 0 to 75 degrees (B free in x and y) on the full model with the conventional
solver; the moment is normalised by M_lin = 2 E I theta / L (Eq. 4.3, I of Eq. 4.4) and compared
with the inextensible, shear-free elastica model of the symmetric cross-spring pivot (Wittrick
1948; Haringx 1949), solved to ~1e-10 by `flexmb.reference.cross_spring_pivot`.
"""

from __future__ import annotations

import time

import numpy as np

from .. import models
from ..reference import cross_spring_pivot
from ..solvers import solve

__all__ = ["ANGLES_DEG", "cross_flexure_curve", "cross_flexure_reference", "cross_flexure_table",
           "plot_cross_flexure", "cantilever_circle_check"]

ANGLES_DEG = np.arange(5, 76, 5)


def cross_flexure_curve(elements_per_leaf: int, angles_deg=ANGLES_DEG, dim: int = 3, **joint_params):
    """M / M_lin (Eq. 4.3) at each angle [deg], total Newton iterations, wall time [s] of the
    solves. One untimed solve first: the first solve of a session loads the numba kernels, and
    `flexmb demo` had printed ten times the warm time for 1 el./leaf."""
    def pivot(deg):
        return models.cross_flexure_pivot(elements_per_leaf=elements_per_leaf, dim=dim, rotation=np.radians(deg),
                                          **joint_params)

    solve(pivot(angles_deg[0]), method="conventional", raise_on_failure=True)  # warm-up, untimed
    ratios, iterations, t0 = [], 0, time.perf_counter()
    for deg in angles_deg:
        theta = np.radians(deg)
        m = pivot(deg)
        sol = solve(m, method="conventional", raise_on_failure=True)
        j = m.joints["cross_flexure"]
        ratios.append(sol.reaction("B")[-1] / (2 * j.E * j.second_moment * theta / j.length))
        iterations += sol.iterations
    return np.array(ratios), iterations, time.perf_counter() - t0


def cross_flexure_reference(angles_deg=ANGLES_DEG, angle: float = np.pi / 4) -> np.ndarray:
    """Analytic reference M / M_lin: the elastica moment (equal leaf stiffness) over 2 E I theta / L."""
    ref = cross_spring_pivot(np.radians(angles_deg), length=1.0, angle=angle, bending_stiffness=(1.0, 1.0))
    return ref.moment_ratio / 2.0


def cross_flexure_table(curves: dict, reference: np.ndarray, angles_deg=ANGLES_DEG) -> str:
    """Plain-text table: one column per element count, the reference last."""
    head = "theta [deg] | " + " | ".join(f"n={n:<4d}" for n in curves) + " | reference"
    lines = [head, "-" * len(head)]
    for i, deg in enumerate(angles_deg):
        lines.append(f"{deg:11.0f} | " + " | ".join(f"{curves[n][0][i]:.4f}" for n in curves) + f" | {reference[i]:.4f}")
    lines.append("iterations  | " + " | ".join(f"{curves[n][1]:6d}" for n in curves))
    lines.append("time [s]    | " + " | ".join(f"{curves[n][2]:6.3f}" for n in curves))
    return "\n".join(lines)


def plot_cross_flexure(curves: dict, reference: np.ndarray, path, angles_deg=ANGLES_DEG) -> None:
    """Save Fig. 7(a)-style moment-rotation curves to ``path`` (PNG; needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for n, (r, *_) in curves.items():
        ax.plot(angles_deg, r, "o-", ms=3, label=f"full model, {n} el./leaf")
    ax.plot(angles_deg, reference, "k--", label="elastica reference (rigid axially, no shear)")
    ax.set_xlabel("rotation of node B, theta [deg]")
    ax.set_ylabel("M / M_lin   (Eq. 4.3)")
    ax.set_title("Cross flexure, Table 1 (Dwarshuis et al. 2020, Fig. 7a)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def cantilever_circle_check(n: int = 8, phi: float = np.pi, dim: int = 3):
    """End-moment cantilever: (flexmb tip error, closed-form co-rotational tip error) / L, iterations."""
    m = models.cantilever(elements=n, dim=dim)
    leaf = m.joints["leaf"]
    EI, L = leaf.E * leaf.cross_section().Iz, leaf.length
    m.apply_moment("tip", EI * phi / L if dim == 2 else (0.0, 0.0, EI * phi / L))
    sol = solve(m, raise_on_failure=True)
    exact = L / phi * np.array([np.sin(phi), 1.0 - np.cos(phi)])
    b = phi / (2 * n)
    return (float(np.linalg.norm(sol.pose("tip")[0][:2] - exact) / L),
            float(2 * np.sin(phi / 2) / phi * (b / np.sin(b) - 1.0)), sol.iterations)
