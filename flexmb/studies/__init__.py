"""The papers' case studies, the demo and their timing helpers.

Dwarshuis et al. (2020): the cross flexure (`demo`), the EOB limits (`eob`), the four-bar
(`fourbar`) and the spatial manipulator (`manipulator`); Cammarata et al. (2022): the MEMS gripper
(`gripper`). They sit on top of the library: the command line, the examples and the benchmarks
import them; ``import flexmb`` does not (tests/test_layout.py checks it).
"""


def example_arguments(doc: str, out: str = "figures", flags: dict | None = None) -> tuple:
    """``(out, quick, *flags)`` from the command line every example in ``examples/`` takes:
    ``--out FOLDER`` for its figures and files (default ``out``), ``--quick`` for the smaller case
    the test suite runs (tests/test_examples.py calls each example's ``main(out, quick=True)``),
    and the example's own on/off ``flags`` (``{"--dask": "help text"}``), in that order."""
    import argparse
    from pathlib import Path

    ap = argparse.ArgumentParser(description=doc.strip().splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(out), help=f"folder for figures and files (default: {out})")
    ap.add_argument("--quick", action="store_true", help="the smaller case the test suite runs")
    for flag, text in (flags or {}).items():
        ap.add_argument(flag, action="store_true", help=text)
    args = vars(ap.parse_args())
    return (args.pop("out"), args.pop("quick"), *args.values())
