"""The four-bar of Dwarshuis et al. (2020), Sec. 4.3: force curve (Fig. 10), extra moment
(Fig. 12) and the speed of the conventional method against KSD (Fig. 11)."""

from __future__ import annotations

import time

import numpy as np

from ..models import fourbar, fourbar_linear_force
from ._timing import interleaved
from ..solvers import solve

__all__ = ["METHODS", "force_curve", "moment_study", "speed_study", "plot"]

METHODS = ("conventional", "ksd-reduced", "ksd-full")
HEIGHT = 0.3


def force_curve(elements_per_leaf: int = 3, d_over_h=np.linspace(0.05, 1.0, 20),
                methods=("conventional", "ksd-reduced")) -> dict:
    """Actuation force over F_lin (Eq. 4.7) against d/H for each method: ``{method: (n,) array}``
    plus ``"d/H"``."""
    out = {"d/H": np.asarray(d_over_h, dtype=float)}
    for method in methods:
        vals = []
        for r in out["d/H"]:
            d = r * HEIGHT
            sol = solve(fourbar(elements_per_leaf, displacement=d), method=method, raise_on_failure=True)
            vals.append(sol.reaction("top")[0] / fourbar_linear_force(d, elements_per_leaf))
        out[method] = np.array(vals)
    return out


def moment_study(elements_per_leaf: int = 3, moments=np.linspace(-200.0, 200.0, 21), displacement: float = 0.3,
                 methods=METHODS) -> dict:
    """Rotation of the upper link about z [rad] under an extra moment [N m] on it at d = 0.3 m
    (Fig. 12a), with iterations and wall time per solve (Fig. 12b; KSD-full: step 5 separately)."""
    out = {"moment": np.asarray(moments, dtype=float)}
    for method in methods:
        rot, its, secs, its5 = [], [], [], []
        for M in out["moment"]:
            m = fourbar(elements_per_leaf, displacement=displacement, moment=M)
            t = time.perf_counter()
            sol = solve(m, method=method, raise_on_failure=True)
            secs.append(time.perf_counter() - t)
            rot.append(sol.rotation_vector("top")[-1])
            its.append(sol.iterations)
            its5.append(sol.stages.get("full", {}).get("iterations", 0))
        out[method] = {"rotation": np.array(rot), "iterations": np.array(its), "time": np.array(secs),
                       "full_iterations": np.array(its5)}
    return out


def speed_study(elements=(1, 2, 3, 4, 5), displacement: float = 0.3, repeats: int = 5,
                clock: str = "wall") -> list[dict]:
    """Fig. 11: per method and elements per leaf, iterations (KSD split by step), median ``clock``
    time (``"wall"`` or ``"cpu"``, `flexmb.studies._timing.interleaved`)
    of ``repeats`` solves (joint templates cached after the first call, as in an optimisation
    loop) and the speed-up over the conventional method measured in the same run: ``time`` for
    single solves interleaved between the methods, ``time_steady`` for the steady state of
    consecutive solves of one method (`flexmb.studies._timing.interleaved`)."""
    rows = []
    for n in elements:
        m = fourbar(n, displacement=displacement)
        for method in METHODS:
            solve(m, method=method)  # warm-up: builds and caches the joint mesh/EOB template
        sols, times = interleaved(m, METHODS, repeats, clock=clock)
        _, warm = interleaved(m, METHODS, repeats, consecutive=3, clock=clock)
        for method in METHODS:
            s, t = sols[method], times[method]
            st = s.stages
            rows.append({"elements_per_leaf": n, "method": method, "iterations": s.iterations,
                         "kinematics": st.get("kinematics", {}).get("iterations", 0),
                         "reduced": st.get("reduced", {}).get("iterations", 0),
                         "full": st.get("full", {}).get("iterations", s.iterations if method == "conventional" else 0),
                         "time": t, "speedup": times["conventional"] / t, "time_steady": warm[method],
                         "speedup_steady": warm["conventional"] / warm[method], "force": s.reaction("top")[0],
                         "dofs": s.compiled.problem.n_free})
    return rows


def plot(curve: dict, moments: dict, path) -> None:
    """Figs. 10 and 12a as one PNG (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for method, style in (("conventional", "-"), ("ksd-reduced", "--")):
        if method in curve:
            a.plot(curve["d/H"], curve[method], style, label=method)
    a.set_xlabel("d / H")
    a.set_ylabel("F / F_lin (Eq. 4.7)")
    a.set_title("Four-bar actuation force (Fig. 10)")
    a.legend()
    for method, style in (("conventional", "-"), ("ksd-reduced", "--")):
        if method in moments:
            b.plot(moments["moment"], 1e3 * moments[method]["rotation"], style, label=method)
    b.set_xlabel("extra moment on the upper link [N m]")
    b.set_ylabel("rotation of the upper link [mrad]")
    b.set_title("Unintended rotation at d = 0.3 m (Fig. 12a)")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
