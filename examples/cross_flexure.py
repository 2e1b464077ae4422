"""Cross-flexure pivot, Dwarshuis et al. (2020) Sec. 4.2 / Fig. 7(a): moment vs rotation.

Node B of the Table 1 cross flexure is rotated about z from 0 to 75 degrees (B free in x and y)
with the conventional full-model solver, for 1...5 elements per leaf. The moment is normalised by
M_lin = 2 E I theta / L (Eq. 4.3, I of Eq. 4.4) and printed beside the analytic reference:
the inextensible, shear-free elastica model of the symmetric cross-spring pivot (Wittrick 1948;
Haringx 1949), solved to ~1e-10 by `flexmb.reference.cross_spring_pivot`.

Run: python examples/cross_flexure.py [--dim 2|3] [--plot FILE.png]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import flexmb
from flexmb.reference import cross_spring_pivot

ANGLES_DEG = np.arange(0, 76, 5)
ELEMENTS = (1, 2, 3, 4, 5)


def moment_curve(elements_per_leaf: int, angles_deg=ANGLES_DEG, dim: int = 3):
    """M / M_lin (Eq. 4.3) at each angle, total Newton iterations and wall time [s]."""
    ratios, iterations, t0 = [], 0, time.perf_counter()
    for deg in angles_deg:
        theta = np.radians(deg)
        if theta == 0.0:
            ratios.append(np.nan)  # M/M_lin is 0/0 at rest
            continue
        m = flexmb.models.cross_flexure_pivot(elements_per_leaf=elements_per_leaf, dim=dim, rotation=theta)
        sol = flexmb.solve(m, method="conventional", raise_on_failure=True)
        j = m.joints["cross_flexure"]
        m_lin = 2 * j.E * j.second_moment * theta / j.length
        ratios.append(sol.reaction("B")[-1] / m_lin)
        iterations += sol.iterations
    return np.array(ratios), iterations, time.perf_counter() - t0


def reference_curve(angles_deg=ANGLES_DEG):
    """Analytic reference M / M_lin: the elastica moment over 2 E I theta / L (equal leaf stiffness)."""
    ref = cross_spring_pivot(np.radians(angles_deg), length=0.1, angle=np.pi / 4, bending_stiffness=(1.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ANGLES_DEG == 0, np.nan, ref.moment_ratio / 2.0)


def run(dim: int = 3):
    curves = {n: moment_curve(n, dim=dim) for n in ELEMENTS}
    return curves, reference_curve()


def table(curves, reference) -> str:
    head = "theta [deg] | " + " | ".join(f"n={n}" for n in curves) + " | reference"
    lines = [head, "-" * len(head)]
    for i, deg in enumerate(ANGLES_DEG):
        if deg == 0:
            continue
        lines.append(f"{deg:11.0f} | " + " | ".join(f"{curves[n][0][i]:.4f}" for n in curves)
                     + f" | {reference[i]:.4f}")
    lines.append("iterations  | " + " | ".join(f"{curves[n][1]:4d}" for n in curves))
    lines.append("time [s]    | " + " | ".join(f"{curves[n][2]:.3f}" for n in curves))
    return "\n".join(lines)


def plot(curves, reference, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for n, (r, *_) in curves.items():
        ax.plot(ANGLES_DEG, r, "o-", ms=3, label=f"full model, {n} el./leaf")
    ax.plot(ANGLES_DEG, reference, "k--", label="elastica reference (no axial/shear compliance)")
    ax.set_xlabel("rotation theta [deg]")
    ax.set_ylabel("M / M_lin  (Eq. 4.3)")
    ax.set_title("Cross flexure, Table 1 (Dwarshuis et al. 2020, Fig. 7a)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=3, choices=(2, 3))
    ap.add_argument("--plot", default=None, help="save the figure to this PNG file (needs matplotlib)")
    args = ap.parse_args()
    curves, reference = run(args.dim)
    print(f"Cross flexure (Table 1), M / M_lin with M_lin = 2EI theta/L, dim={args.dim}")
    print(table(curves, reference))
    if args.plot:
        plot(curves, reference, args.plot)
        print(f"figure written to {args.plot}")
