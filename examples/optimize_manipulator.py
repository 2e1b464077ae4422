"""Design optimisation 3: joint placements of the spatial manipulator (Dwarshuis et al. 2020, Sec. 4.4).

Maximise the end link's minimum rotational support stiffness over the end point's path of the
joints turned -30 .. 30 deg, the reach and height at rest bounded, over 10 placement parameters
(KSD-reduced in the loop: its placements' gradients through KSD steps 1-3).
Run: python examples/optimize_manipulator.py [--out figures] [--quick]   (--quick: 0 and +-30 deg only, COBYLA limited)
"""

from __future__ import annotations

from pathlib import Path

from flexmb.studies import example_arguments
from flexmb.studies.optimization import manipulator, run_example


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Optimise with SLSQP on flexmb's design gradients and with the derivative-free COBYLA on plain
    solves from the same start (``quick``: 0 and +-30 deg, COBYLA to 60 evaluations), print both side by side and write each
    run's history as CSV into ``out`` (None: nothing written)."""
    return run_example(manipulator(quick), "optimize_manipulator", out, 60 if quick else 400)


if __name__ == "__main__":
    main(*example_arguments(__doc__))
