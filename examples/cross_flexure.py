"""Cross-flexure pivot, Dwarshuis et al. (2020) Sec. 4.2 / Fig. 7(a): moment vs rotation, 1...5 elements per leaf.

Run: python examples/cross_flexure.py [--out figures] [--quick]   (--quick: the planar model)
"""

from __future__ import annotations

from pathlib import Path

from flexmb.studies import example_arguments
from flexmb.studies.demo import cross_flexure_curve, cross_flexure_reference, cross_flexure_table, plot_cross_flexure

ELEMENTS = (1, 2, 3, 4, 5)


def run(dim: int = 3):
    return {n: cross_flexure_curve(n, dim=dim) for n in ELEMENTS}, cross_flexure_reference()


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print M / M_lin against the reference and write ``out/cross_flexure.png`` (``out`` None: no
    figure); ``quick``: the planar model (dim 2) instead of the spatial one."""
    dim = 2 if quick else 3
    curves, reference = run(dim)
    print(f"Cross flexure (Table 1): M / M_lin, M_lin = 2 E I theta / L (Eq. 4.3); full model, dim={dim}")
    print(cross_flexure_table(curves, reference))
    if out is not None:
        try:
            Path(out).mkdir(parents=True, exist_ok=True)
            plot_cross_flexure(curves, reference, Path(out) / "cross_flexure.png")
            print(f"figure written to {Path(out) / 'cross_flexure.png'}")
        except ImportError:
            print("(no figure: install the plot extra)")
    return {"curves": curves, "reference": reference}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
