"""Equilibrium paths through limit points, snap-through and snap-back with `flexmb.trace`.

Five cases (builders and closed forms in `flexmb.studies.paths`), each traced from the undeformed
state by arc length, with stability at every point and the located critical points:

* Lee's frame (E = 720, A = 6, I = 2, L = 120; 10 and 40 elements per member): limit loads in
  P L^2 / EI, the upper one against the literature's 18.5;
* DaDeppo & Schmidt's (1975) 215 deg clamped-hinged arch under an apex load: P R^2 / EI = 9.0;
* Qiu, Lang & Slocum's (2004) double curved-beam bistable (silicon, Q = 12) under force control,
  against their modal model's force curve and switching forces;
* an Euler strut with a 1e-4 lateral imperfection against the elastica;
* half a shallow von Mises truss in mm, N, MPa against its closed form.

Run: python examples/path_following.py [--out docs] [--quick]   (prints the table, writes
path_following.png into --out; --quick: the Qiu bistable and the truss only)
"""

from __future__ import annotations

import math
import time

import numpy as np

import flexmb
from flexmb.studies import example_arguments
from flexmb.studies import paths as cases


def _trace(mechanism, **kw):
    t = time.perf_counter()
    path = flexmb.trace(mechanism, progress=False, **kw)
    return path, time.perf_counter() - t


CASES = ("lee10", "lee40", "arch", "qiu", "strut", "truss")


def run(names=CASES) -> dict:
    """``{case: {"path": Path, "seconds": ..., "u": displacements, ...}}`` for the cases ``names``."""
    out = {}
    EI_L2 = 720.0 * 2.0 / 120.0**2
    for n in [k for k in (10, 40) if f"lee{k}" in names]:
        path, sec = _trace(cases.lee_frame(elements=n), steps=200, arc_length=1.0,
                           stop=lambda s: -s.displacement("P")[1] > 95.0)
        out[f"lee{n}"] = dict(path=path, seconds=sec, scale=1.0 / EI_L2,
                              u=np.array([s.displacement("P") for s in path]))
    if "arch" in names:
        path, sec = _trace(cases.deep_arch(), steps=400, arc_length=0.25,
                           stop=lambda s: -s.displacement("apex")[1] > 150.0)
        out["arch"] = dict(path=path, seconds=sec, scale=1.0, u=np.array([s.displacement("apex") for s in path]))
    if "qiu" in names:
        f_top, f_bot = cases.qiu_switching_forces()
        path, sec = _trace(cases.qiu_bistable(load=f_top), steps=200, arc_length=0.05,
                           stop=lambda s: -s.displacement("C")[1] > 2.45e-4)
        out["qiu"] = dict(path=path, seconds=sec, scale=f_top, u=np.array([s.displacement("C") for s in path]),
                          analytic=(f_top, f_bot))
    if "strut" in names:
        path, sec = _trace(cases.euler_strut(load=math.pi**2 / 4, imperfection=1e-4), steps=300, arc_length=0.05,
                           stop=lambda s: s.rotation_vector("B")[0] > 2.5)
        out["strut"] = dict(path=path, seconds=sec, scale=1.0,
                            alpha=np.array([s.rotation_vector("B")[0] for s in path]))
    if "truss" in names:
        path, sec = _trace(cases.von_mises_truss(), steps=100, arc_length=0.05,
                           stop=lambda s: -s.displacement("T")[1] > 120.0)
        out["truss"] = dict(path=path, seconds=sec, scale=1e4, u=np.array([s.displacement("T") for s in path]))
    return out


def table(results: dict) -> str:
    """The critical points, steps, iterations and time per case (Markdown)."""
    rows = ["| case | points | iterations | time [s] | critical points (kind: value) | reference |",
            "|---|---|---|---|---|---|"]
    refs = {"lee10": "upper 18.5 (P L²/EI; as quoted from Schweizerhof & Wriggers 1986, 10 el.)",
            "lee40": "upper 18.5 (P L²/EI)",
            "arch": "9.0 (P R²/EI; DaDeppo & Schmidt 1975)",
            "qiu": "F_top {:.4g} N, F_bot {:.4g} N (Qiu et al. 2004 modal model)",
            "strut": "elastica (no critical point with the imperfection)",
            "truss": "limit 4001.415 N (closed form)"}
    for name, r in results.items():
        p = r["path"]
        crit = ", ".join(f"{c.kind}: {c.load_factor * r['scale']:.5g}" for c in p.critical) or "none"
        ref = refs[name].format(*r["analytic"]) if name == "qiu" else refs[name]
        its = sum(s.iterations for s in p)
        rows.append(f"| {name} | {len(p)} | {its} | {r['seconds']:.2f} | {crit} | {ref} |")
    return "\n".join(rows)


def plot(results: dict, path="docs/path_following.png"):
    """Six panels: the load-displacement paths (unstable points in red, critical points marked)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))

    def draw(ax, x, y, p, crit_x, scale, title, xlabel, ylabel):
        ax.plot(x, y, color="0.6", linewidth=0.8)
        ax.plot(x[p.stable], y[p.stable], "o", markersize=2.5, color="C0", label="stable")
        ax.plot(x[~p.stable], y[~p.stable], "o", markersize=2.5, color="C3", label="unstable")
        for c in p.critical:
            ax.plot(crit_x(c.solution), c.load_factor * scale, "k*", markersize=9)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)

    for ax in axes.ravel():
        ax.set_axis_off()
    for ax, key in zip(axes.ravel(), ("lee10", "lee10", "arch", "qiu", "strut", "truss")):
        if key in results:
            ax.set_axis_on()
    if "lee10" in results:
        _plot_lee(results, axes, draw)
    if "arch" in results:
        _plot_arch(results, axes, draw)
    if "qiu" in results:
        _plot_qiu(results, axes, draw)
    if "strut" in results:
        _plot_strut(results, axes, draw)
    if "truss" in results:
        _plot_truss(results, axes, draw)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_lee(results, axes, draw):
    r = results["lee10"]
    p = r["path"]
    draw(axes[0, 0], -r["u"][:, 1], p.load_factor * r["scale"], p, lambda s: -s.displacement("P")[1], r["scale"],
         "Lee's frame, 10 el./member: vertical", "-v at the load", "P L²/EI")
    draw(axes[0, 1], r["u"][:, 0], p.load_factor * r["scale"], p, lambda s: s.displacement("P")[0], r["scale"],
         "Lee's frame: horizontal (snap-back)", "u at the load", "P L²/EI")


def _plot_arch(results, axes, draw):
    r = results["arch"]
    p = r["path"]
    draw(axes[0, 2], -r["u"][:, 1], p.load_factor, p, lambda s: -s.displacement("apex")[1], 1.0,
         "215° arch (DaDeppo & Schmidt)", "apex deflection (R = 100)", "P R²/EI")


def _plot_qiu(results, axes, draw):
    r = results["qiu"]
    p = r["path"]
    d = -r["u"][:, 1]
    draw(axes[1, 0], d * 1e6, p.load_factor * r["scale"] * 1e3, p, lambda s: -s.displacement("C")[1] * 1e6,
         r["scale"] * 1e3, "Qiu's bistable (double curved beam)", "centre travel [µm]", "force [mN]")
    dd = np.linspace(0, d.max(), 300)
    axes[1, 0].plot(dd * 1e6, cases.qiu_force(dd) * 1e3, "k--", linewidth=1, label="Qiu's modal model")
    axes[1, 0].legend(fontsize=8)


def _plot_strut(results, axes, draw):
    r = results["strut"]
    p = r["path"]
    draw(axes[1, 1], r["alpha"], p.load_factor, p, lambda s: s.rotation_vector("B")[0], 1.0,
         "Euler strut, 1e-4 imperfection", "tip rotation [rad]", "P / P_E")
    a = np.linspace(1e-3, r["alpha"].max(), 200)
    axes[1, 1].plot(a, cases.strut_elastica(a)[0], "k--", linewidth=1, label="elastica")
    axes[1, 1].legend(fontsize=8)


def _plot_truss(results, axes, draw):
    r = results["truss"]
    p = r["path"]
    w = -r["u"][:, 1]
    draw(axes[1, 2], w, p.load_factor * r["scale"], p, lambda s: -s.displacement("T")[1], r["scale"],
         "von Mises truss (mm, N, MPa)", "apex deflection [mm]", "half apex load [N]")
    ww = np.linspace(0, w.max(), 300)
    axes[1, 2].plot(ww, cases.von_mises_force(ww), "k--", linewidth=1, label="closed form")
    axes[1, 2].legend(fontsize=8)


def main(out=None, quick: bool = False) -> dict:
    """Trace the cases (``quick``: the Qiu bistable and the truss), print the table and write
    ``out/path_following.png`` (``out`` None: no figure)."""
    results = run(names=("qiu", "truss") if quick else CASES)
    print(table(results))
    if out is not None:
        from pathlib import Path

        Path(out).mkdir(parents=True, exist_ok=True)
        print("wrote", plot(results, Path(out) / "path_following.png"))
    return results


if __name__ == "__main__":
    main(*example_arguments(__doc__, out="docs"))
