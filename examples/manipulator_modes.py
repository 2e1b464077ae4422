"""The spatial manipulator's parasitic frequencies over its range (issue 22, item 10 case 4):
f1 ... f6 at the 19 joint-case positions of Dwarshuis et al. (2020) Sec. 4.4 with the conventional
method (lines), KSD-full (circles) and KSD-reduced (crosses); the links' prescribed DOFs held
(`flexmb.modes`, SPACAR's convention). Writes ``manipulator_frequencies.png`` into --out.
The numbers are docs/properties.md's table (``benchmarks/bench_properties.py``). Run:
python examples/manipulator_modes.py [--out docs] [--quick]   (--quick: -45, 0, 45 deg)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb import plot
from flexmb.studies import example_arguments

DEGREES = np.arange(-45, 46, 5)
METHODS = ("conventional", "ksd-full", "ksd-reduced")


def frequencies(n: int = 6, degrees=DEGREES) -> dict:
    """``{method: array (positions, n)}`` of the first ``n`` frequencies [Hz] at ``degrees``."""
    out = {method: [] for method in METHODS}
    for deg in degrees:
        m = flexmb.models.manipulator("joint", np.radians(deg))
        for method in METHODS:
            sol = flexmb.solve(m, method=method, raise_on_failure=True)
            out[method].append(flexmb.modes(sol, n_modes=n).frequencies)
    return {method: np.array(f) for method, f in out.items()}


def figure(freqs: dict, degrees=DEGREES):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    styles = {"conventional": dict(ls="-", marker=""), "ksd-full": dict(ls="", marker="o", mfc="none"),
              "ksd-reduced": dict(ls="", marker="x")}
    for method in METHODS:
        for k in range(freqs[method].shape[1]):
            ax.plot(degrees, freqs[method][:, k], color=f"C{k}", label=method if k == 0 else None,
                    **styles[method])
    ax.set_xlabel("joint rotation [deg]")
    ax.set_ylabel("parasitic frequency f1 ... f6 [Hz]")
    ax.set_title("Spatial manipulator (Dwarshuis et al. 2020), inputs held", fontsize=10)
    ax.legend(title="colour: mode number", fontsize=8)
    fig.tight_layout()
    return fig


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print KSD's frequency errors and write ``out/manipulator_frequencies.png`` (``out`` None: no
    figure); ``quick``: three positions."""
    degrees = np.array([-45, 0, 45]) if quick else DEGREES
    freqs = frequencies(degrees=degrees)
    err = 100 * (freqs["ksd-reduced"][:, :3] / freqs["conventional"][:, :3] - 1)
    print(f"KSD-reduced f1-f3 error: {err.min():+.2f} ... {err.max():+.2f} %; KSD-full largest relative "
          f"difference {np.abs(freqs['ksd-full'] / freqs['conventional'] - 1).max():.1e}")
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        print(f"wrote {plot.save(figure(freqs, degrees), Path(out) / 'manipulator_frequencies.png')}")
    return {"degrees": degrees, "frequencies": freqs}


if __name__ == "__main__":
    main(*example_arguments(__doc__, out="docs"))
