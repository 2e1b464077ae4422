"""KSD-reduced's error estimate against its true error (issue 32, `flexmb.ksd.estimate`).

Every case of `flexmb.studies.ksd_accuracy` solved with KSD-reduced (which estimates its own error
from the full model at its answer) and with the conventional method (the true answer); the table
gives both relative errors, their ratio, whether KSD-reduced warned (tolerance 1 %) and whether
the true error exceeds the tolerance; the figure (docs/ksd_error_estimate.png) plots one against
the other. Writes the "estimate" section of BENCHMARKS.md. Run: python benchmarks/bench_estimate.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import ROOT, machine, run  # noqa: E402
from flexmb.ksd.estimate import DEFAULT_TOLERANCE  # noqa: E402
from flexmb.studies import ksd_accuracy as accuracy  # noqa: E402

FIGURE = ROOT / "docs" / "ksd_error_estimate.png"


def figure(rows: list, path: Path = FIGURE) -> None:
    """Estimated against true relative error, log-log, with the factor-3 band and the tolerance."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 5.2))
    lo, hi = 1e-8, 1e2
    line = np.array([lo, hi])
    ax.fill_between(line, line / accuracy.FACTOR, line * accuracy.FACTOR, color="0.9", label="within a factor 3")
    ax.plot(line, line, color="0.5", lw=0.8)
    ax.axvline(DEFAULT_TOLERANCE, color="C3", lw=0.8, ls="--")
    ax.axhline(DEFAULT_TOLERANCE, color="C3", lw=0.8, ls="--", label="tolerance 1 %")
    ax.axvspan(lo, accuracy.RESOLUTION, color="0.97")
    for k, group in enumerate(dict.fromkeys(r["group"] for r in rows)):
        sel = [r for r in rows if r["group"] == group and r["converged"]]
        ax.scatter([max(r["true"], lo) for r in sel], [max(r["estimate"], lo) for r in sel], s=22, color=f"C{k}",
                   marker="os^vDP<>"[k % 8], label=group, zorder=3)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_xlabel("true relative error (KSD-reduced vs conventional)")
    ax.set_ylabel("estimated relative error (flexmb.ksd.estimate)")
    ax.set_title("KSD-reduced: estimated vs true error")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(quick: bool = False) -> str:
    rows = accuracy.study(select=(lambda label: "pivot 3D, 0.5 rad" in label) if quick else None)
    figure(rows)
    ok = sum(accuracy.agrees(r) for r in rows)
    lines = [
        "## KSD-reduced error estimate: estimated vs true error (issue 32)",
        "",
        f"{machine()}. `flexmb.studies.ksd_accuracy`: each case solved with KSD-reduced (its estimate from Newton corrections",
        "of the full model at its answer, `flexmb.ksd.estimate`: one where it is clearly within the tolerance, else until",
        "it settles, at most four) and with the conventional method (the true answer). Relative error = the larger of the",
        "links' motion error and the reactions' error, each the",
        "largest over the links of a link's own (translations over the model's length, rotations [rad]; forces, moments over",
        f"the length). Tolerance {DEFAULT_TOLERANCE:g} (the default `error_tol`). Below {accuracy.RESOLUTION:g} both numbers",
        "are the reference's round-off (the ratio is not meaningful). Figure: `docs/ksd_error_estimate.png`.",
        "",
        "| case | estimated | true | ratio | corrections | warned | true > tol |",
        "|---|---:|---:|---:|---:|---|---|",
    ]
    for r in rows:
        if not r["converged"]:
            lines.append(f"| {r['case']} | not converged: {r['message'][:80]} | | | | | |")
            continue
        lines.append(f"| {r['case']} | {r['estimate']:.3g} | {r['true']:.3g} | {r['ratio']:.2f} | {r['corrections']} | "
                     f"{'yes' if r['warned'] else 'no'} | {'yes' if r['exceeds'] else 'no'} |")
    ratios = [r["ratio"] for r in rows if r["converged"] and r["true"] >= accuracy.RESOLUTION]
    lines += ["", f"- {ok} of {len(rows)} cases: estimate within a factor {accuracy.FACTOR:g} of the true error (or both "
              f"below {accuracy.RESOLUTION:g}) and the warning exactly where the true error exceeds the tolerance; "
              f"ratios {min(ratios):.2f} to {max(ratios):.2f} where the true error is resolved."]
    lines += cost(3 if quick else 25)
    return "\n".join(lines)


def cost(repeats: int) -> list[str]:
    """What the estimate costs: median whole-solve times, interleaved, after a warm-up solve."""
    import gc
    import time
    import warnings

    from flexmb import models, solve

    cases = {"cross flexure 0.5 rad (3D, 3 el./leaf)": models.cross_flexure_pivot(rotation=0.5),
             "four-bar d = 0.2 m (3 el./leaf)": models.fourbar(displacement=0.2),
             "manipulator joints 0.6 rad": models.manipulator(rotation=0.6)}
    methods = {"KSD-reduced, error_tol=None": ("ksd-reduced", {"error_tol": None}),
               "KSD-reduced (estimate)": ("ksd-reduced", {}), "KSD-full": ("ksd-full", {}),
               "conventional": ("conventional", {})}
    out = ["", f"Cost of the estimate (median of {repeats} whole `flexmb.solve` calls per method, interleaved, after a "
           "warm-up solve; garbage collection paused) [ms]:", "",
           "| case | " + " | ".join(methods) + " |", "|---|" + "---:|" * len(methods)]
    for label, m in cases.items():
        times = {k: [] for k in methods}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for name, (method, opt) in methods.items():
                solve(m, method=method, **opt)
            gc.disable()
            try:
                for _ in range(repeats):
                    for name, (method, opt) in methods.items():
                        t = time.perf_counter()
                        solve(m, method=method, **opt)
                        times[name].append(time.perf_counter() - t)
            finally:
                gc.enable()
        out.append(f"| {label} | " + " | ".join(f"{np.median(v) * 1e3:.2f}" for v in times.values()) + " |")
    return out


if __name__ == "__main__":
    run("estimate", main, __doc__, "the 3D pivot cases only")
