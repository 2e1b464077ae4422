"""MEMS gripper with curved-beam flexures, Cammarata et al. (2022), Sec. 5: the whole study.

Prints the closing forces (linear, partial non-linear and flexmb's fully non-linear FE model;
silicon and nylon), K_T at rest and at F_2y = 50 uN with its terms (Tables 2-7), the five
Newton strategies over the force sweep (Figs. 11-13) with the force where the constant tangent
stops converging, the speed of the closed forms against the FE model (Table 8) and the
cross-section study (Fig. 10); saves Figs. 7, 9, 10 and 11-13 as PNG in --out.

Run: python examples/gripper.py [--out figures] [--quick]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexmb.studies import example_arguments
from flexmb.studies import gripper as g

LABELS = ("x2", "y2", "th2", "x3", "y3", "th3", "x4", "y4", "th4")


def matrix(K: np.ndarray, fmt: str = "{:10.3g}") -> str:
    head = "      " + "".join(f"{lab:>10s}" for lab in LABELS)
    return "\n".join([head] + [f"{LABELS[i]:>5s} " + "".join(fmt.format(x) for x in row) for i, row in enumerate(K)])


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print the study's tables and write its figures into ``out`` (None: no figures); ``quick``:
    coarser sweeps and grid."""
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
    res: dict = {}
    print("Closing force F_2y [uN] (end-effector x = 0), Cammarata et al. (2022) Sec. 5.1")
    print(f"{'material':9s} {'linear':>10s} {'partial NL':>11s} {'FE (fully NL)':>14s}")
    closing = {}
    for material in ("silicon", "nylon"):
        closing[material] = {m: g.closing_force(material, m) for m in g.MODELS}
        closing[material]["fe"] = g.closing_force(material, method="conventional")
        c = closing[material]
        print(f"{material:9s} {c['linear']:10.3f} {c['partial-nonlinear']:11.3f} {c['fe']:14.3f}")
    res["closing"] = closing
    print(f"(FE: {g.FE_OPTIONS['elements']} co-rotational elements per arc, tol {g.FE_OPTIONS['tol']} uN)\n")

    # Figs. 7 and 9: the opening-closing sweep, both models and the FE reference
    points = 41 if quick else 131
    comparison = {}
    for material in ("silicon", "nylon"):
        upper = max(closing[material].values())
        curves = {f"{m} (closed form)": g.opening_closing(material, m, upper=upper, points=points) for m in g.MODELS}
        curves["fully non-linear (FE)"] = g.opening_closing(material, method="conventional", upper=upper,
                                                             points=max(points // 3, 11))
        comparison[material] = curves
    res["comparison"] = comparison
    if out is not None:
        g.plot_workspace({m: g.opening_closing("silicon", m, points=points) for m in g.MODELS},
                         out / "gripper_workspace.png")
        g.plot_comparison(comparison, out / "gripper_models.png")
    print("End-effector departure of the closed forms from the FE model over the sweep (silicon)")
    fe = comparison["silicon"]["fully non-linear (FE)"]
    for m in g.MODELS:
        r = comparison["silicon"][f"{m} (closed form)"]
        ee = np.column_stack([np.interp(fe["forces"], r["forces"], r["ee"][:, k]) for k in (0, 1)])
        d = np.linalg.norm(ee - fe["ee"], axis=1)
        print(f"  {m:18s}: max {1e3 * np.nanmax(d):6.1f} um at F = {fe['forces'][np.nanargmax(d)]:6.1f} uN; "
              f"within |F| <= 20 uN: {1e3 * np.nanmax(d[np.abs(fe['forces']) <= 20]):5.2f} um")
    print()

    # Tables 2-7
    tables = g.stiffness_tables(50.0)
    res["tables"] = tables
    print("Table 2: K_T at rest, partial non-linear model (uN/mm, uN, uN mm)")
    print(matrix(tables["rest"]))
    print("\nTable 3: K_T at F_2y = 50 uN")
    print(matrix(tables["loaded"]))
    print("\nTable 4: percentage difference (Table 3 - Table 2) / Table 2")
    print(matrix(tables["percent"], "{:10.1f}"))
    for name, number in (("I", 5), ("II", 6), ("III", 7)):
        print(f"\nTable {number}: K_T^{name} at F_2y = 50 uN")
        print(matrix(tables["terms"][name]))
    print()

    # Figs. 11-13
    study = g.strategy_study(repeat=1 if quick else 3)
    res["strategies"] = study
    if out is not None:
        g.plot_strategies(study, out / "gripper_strategies.png")
    print(f"Newton strategies over F_2y = {study['forces'][0]:g} ... {study['forces'][-1]:g} uN "
          f"({len(study['forces'])} forces, partial non-linear, silicon, max_iter {study['max_iter']})")
    print(f"{'strategy':30s} {'converged':>9s} {'iterations':>10s} {'time [ms]':>10s}")
    for label, s in study["strategies"].items():
        print(f"{label:30s} {s['converged'].sum():9d} {s['iterations'][s['converged']].sum():10d} "
              f"{1e3 * s['time'].sum():10.1f}")
    print(f"The constant tangent converges up to F_2y = {study['constant_last_converged']} uN and not at "
          f"{study['constant_first_failure']} uN (Fig. 11).\n")

    # Table 8: closed forms vs the fully non-linear model, same sweep
    print("Wall time of the opening-closing sweep (Table 8; the paper: Adams 41-50 s, MATLAB 0.10-0.15 s)")
    for material, curves in comparison.items():
        t = {k: v["total_time"] for k, v in curves.items()}
        n = {k: len(v["forces"]) for k, v in curves.items()}
        for k in curves:
            print(f"  {material:8s} {k:28s}: {t[k]:7.3f} s for {n[k]:3d} forces ({1e3 * t[k] / n[k]:7.2f} ms per force)")

    # Fig. 10
    widths = np.linspace(0.015, 0.035, 3 if quick else 5)
    heights = np.linspace(0.003, 0.007, 3 if quick else 5)
    grid = g.cross_section_study(widths, heights)
    res["cross_section"] = (widths, heights, grid)
    if out is not None:
        g.plot_cross_section(widths, heights, grid, out / "gripper_cross_section.png")
    print("\nClosing force [uN] vs cross-section (partial non-linear, silicon); rows h [um], columns b [um]")
    print("  h \\ b " + "".join(f"{1e3 * b:9.1f}" for b in widths))
    for h, row in zip(heights, grid):
        print(f"{1e3 * h:7.1f} " + "".join(f"{x:9.2f}" for x in row))
    if out is not None:
        print(f"\nFigures written to {out}/gripper_*.png")
    return res


if __name__ == "__main__":
    main(*example_arguments(__doc__))
