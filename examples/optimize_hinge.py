"""Design optimisation 1: a 3D cross-flexure hinge carrying a 1 kg block, turned 0.5 rad.

Maximise the first parasitic eigenfrequency subject to the peak stress <= 300 MPa and the actuation
moment <= 2.5 N m over leaf thickness, width, length and crossing angle (flexmb.studies.optimization).
Run: python examples/optimize_hinge.py [--out figures] [--quick]   (--quick: 4 elements per leaf)
"""

from __future__ import annotations

from pathlib import Path

from flexmb.studies import example_arguments
from flexmb.studies.optimization import hinge, run_example


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Optimise with SLSQP on flexmb's design gradients and with the derivative-free COBYLA on plain
    solves from the same start (``quick``: 4 elements per leaf instead of 6), print both side by side and write each
    run's history as CSV into ``out`` (None: nothing written)."""
    return run_example(hinge(quick), "optimize_hinge", out, 150 if quick else 400)


if __name__ == "__main__":
    main(*example_arguments(__doc__))
