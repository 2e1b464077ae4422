"""Design optimisation 2: a double-parallelogram stage in mm, N, MPa over a +-5 mm stroke.

Maximise the minimum support stiffness at the tool point over the stroke subject to a stroke-force
ceiling (5 N at 5 mm) and a stress limit (300 MPa) over leaf thickness, length and spacing.
Run: python examples/optimize_stage.py [--out figures] [--quick]   (--quick: the stroke's two ends)
"""

from __future__ import annotations

from pathlib import Path

from flexmb.studies import example_arguments
from flexmb.studies.optimization import stage, run_example


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Optimise with SLSQP on flexmb's design gradients and with the derivative-free COBYLA on plain
    solves from the same start (``quick``: the stroke's two ends only), print both side by side and write each
    run's history as CSV into ``out`` (None: nothing written)."""
    return run_example(stage(quick), "optimize_stage", out, 150 if quick else 400)


if __name__ == "__main__":
    main(*example_arguments(__doc__))
