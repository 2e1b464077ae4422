"""Four-bar of four cross flexures, Dwarshuis et al. (2020), Sec. 4.3: the KSD method against the
full model.

Prints the actuation force over F_lin = 4 E I d / (L H^2) (Eq. 4.7) against d/H for the full
model and KSD-reduced with 1 and 3 elements per leaf (Fig. 10), the rotation of the upper link
under an extra moment about z at d = 0.3 m with iterations and times (Fig. 12), and saves both
figures as docs/fourbar.png (or --out).

Run: python examples/fourbar.py [--out docs] [--quick]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexmb.studies import example_arguments
from flexmb.studies import fourbar as fc


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print Figs. 10 and 12 as tables and write ``out/fourbar.png`` (``out`` None: no figure);
    ``quick``: fewer points."""
    res = {}
    d_over_h = np.linspace(0.1, 1.0, 4 if quick else 10)
    print("Actuation force F / F_lin (Eq. 4.7) against d/H (Fig. 10); H = 0.3 m is the rigid link length,")
    print("the pivots are H + D0 = 0.371 m apart, so F/F_lin -> (H/(H+D0))^2 = 0.655 for small d.")
    for n in (1, 3):
        curve = fc.force_curve(n, d_over_h)
        res[f"curve{n}"] = curve
        print(f"\n{n} element(s) per leaf\n{'d/H':>6s} {'full model':>11s} {'KSD-reduced':>12s} {'difference':>11s}")
        for r, f, k in zip(curve["d/H"], curve["conventional"], curve["ksd-reduced"]):
            print(f"{r:6.2f} {f:11.5f} {k:12.5f} {100 * (k / f - 1):10.3f}%")

    moments = np.linspace(-200.0, 200.0, 5 if quick else 21)
    study = fc.moment_study(3, moments)
    res["moments"] = study
    print("\nExtra moment on the upper link at d = 0.3 m, 3 el./leaf (Fig. 12)")
    print(f"{'M [N m]':>8s} {'rot. full [mrad]':>17s} {'rot. KSD-red.':>14s} {'conv. it.':>10s} {'conv. [ms]':>11s} "
          f"{'KSD-full step 5 it.':>20s} {'KSD-full [ms]':>14s}")
    c, r, f = study["conventional"], study["ksd-reduced"], study["ksd-full"]
    for k, M in enumerate(study["moment"]):
        print(f"{M:8.1f} {1e3 * c['rotation'][k]:17.4f} {1e3 * r['rotation'][k]:14.4f} {c['iterations'][k]:10d} "
              f"{1e3 * c['time'][k]:11.1f} {f['full_iterations'][k]:20d} {1e3 * f['time'][k]:14.1f}")
    print(f"KSD-full over the range: {c['time'].sum() / f['time'].sum():.1f}x faster than the conventional method "
          "(the paper: about 5x)")
    if out is not None:
        try:
            Path(out).mkdir(parents=True, exist_ok=True)
            fc.plot(res["curve3"], study, Path(out) / "fourbar.png")
            print(f"\nsaved {Path(out) / 'fourbar.png'}")
        except ImportError:
            print("\n(matplotlib not installed: no figure)")
    return res


if __name__ == "__main__":
    main(*example_arguments(__doc__, out="docs"))
