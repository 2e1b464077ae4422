"""Cross-flexure pivot, Dwarshuis et al. (2020) Sec. 4.2 / Fig. 7(a): moment vs rotation, 1...5 elements per leaf.

Results stay in module-level variables (``curves``, ``reference``) so tests can import this file.
Run: python examples/cross_flexure.py [--dim 2|3] [--plot figures/cross_flexure.png]
"""

from __future__ import annotations

import argparse

from flexmb.studies.demo import cross_flexure_curve, cross_flexure_reference, cross_flexure_table, plot_cross_flexure

ELEMENTS = (1, 2, 3, 4, 5)


def run(dim: int = 3):
    return {n: cross_flexure_curve(n, dim=dim) for n in ELEMENTS}, cross_flexure_reference()


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=3, choices=(2, 3))
    ap.add_argument("--plot", default="figures/cross_flexure.png",
                    help="save the figure to this PNG file (needs matplotlib; default figures/cross_flexure.png)")
    args = ap.parse_args()
    curves, reference = run(args.dim)
    print(f"Cross flexure (Table 1): M / M_lin, M_lin = 2 E I theta / L (Eq. 4.3); full model, dim={args.dim}")
    print(cross_flexure_table(curves, reference))
    try:
        from pathlib import Path

        Path(args.plot).parent.mkdir(parents=True, exist_ok=True)
        plot_cross_flexure(curves, reference, args.plot)
        print(f"figure written to {args.plot}")
    except ImportError:
        print("(no figure: install the plot extra)")
