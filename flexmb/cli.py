"""The ``flexmb`` command: ``flexmb demo``, ``flexmb train``, ``flexmb joints``. Errors are one line (``--debug`` for a traceback).

Exit codes: 0 success, 1 a flexmb error (bad input, no convergence), 2 usage error.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path

import attrs
import numpy as np

from .errors import FlexmbError, ParameterError


def _demo(args) -> int:
    from . import demo

    print("flexmb demo 1: cross-flexure pivot of Dwarshuis et al. (2020), Table 1, full model, conventional method")
    print("M / M_lin with M_lin = 2 E I theta / L (Eq. 4.3); reference: inextensible elastica (Wittrick 1948)\n")
    elements = (1, 2, 3) if args.quick else (1, 2, 3, 4, 5)
    curves = {n: demo.cross_flexure_curve(n, dim=3) for n in elements}
    reference = demo.cross_flexure_reference()
    print(demo.cross_flexure_table(curves, reference))
    last = curves[elements[-1]][0]
    print(f"\nat 75 deg, {elements[-1]} el./leaf vs reference: {100 * (last[-1] / reference[-1] - 1):+.2f} % "
          f"(discretisation ~1/n^2, plus axial/shear compliance the reference lacks)")
    print(f"small-angle limit: M/M_lin -> {curves[elements[-1]][0][0]:.4f} at 5 deg "
          "(linear theory for leaves crossing at midpoints gives 0.5: Eq. 4.3's M_lin is twice E I theta / L)")
    err, pred, its = demo.cantilever_circle_check()
    print(f"\nend-moment cantilever, 8 elements, 180 deg: tip error {err:.6e} L, closed form {pred:.6e} L, "
          f"{its} iterations")
    gripper = _demo_gripper(args.quick)
    _demo_fourbar(args.quick)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        demo.plot_cross_flexure(curves, reference, out / "cross_flexure.png")
        from . import gripper_case as g

        g.plot_comparison({"silicon": gripper}, out / "gripper_models.png")
        print(f"\nfigures: {out / 'cross_flexure.png'}, {out / 'gripper_models.png'}")
    except ImportError:
        print("\n(no figures: install the plot extra, pip install 'flexmb[plot]')")
    return 0


def _demo_fourbar(quick: bool) -> None:
    """The four-bar of Dwarshuis et al. (2020), Sec. 4.3: conventional method against KSD (Fig. 11)."""
    from . import fourbar_case as fc

    print("\nFour-bar of four cross flexures, Dwarshuis et al. (2020) Sec. 4.3, d = 0.3 m: conventional vs KSD")
    print(f"{'el./leaf':>8s} {'method':>13s} {'F [N]':>10s} {'iterations':>11s} {'time [ms]':>10s} {'speed-up':>9s}")
    for r in fc.speed_study((1, 3) if quick else (1, 3, 5), repeats=1 if quick else 3):
        print(f"{r['elements_per_leaf']:8d} {r['method']:>13s} {r['force']:10.4f} {r['iterations']:11d} "
              f"{r['time'] * 1e3:10.1f} {r['speedup']:8.1f}x")


def _demo_gripper(quick: bool) -> dict:
    """The gripper of Cammarata et al. (2022): closing forces and strategy timings; returns the sweeps."""
    from . import gripper_case as g

    print("\nMEMS gripper with curved beams, Cammarata et al. (2022) Table 1, silicon, mm and uN")
    print(f"{'model':26s} {'closing F_2y [uN]':>18s} {'sweep -60..close':>17s} {'iterations':>11s}")
    sweeps = {}
    for label, model, method in (("linear (closed form)", "linear", "newton"),
                                 ("partial NL (closed form)", "partial-nonlinear", "newton"),
                                 ("fully NL (FE, 32 el./arc)", "partial-nonlinear", "conventional")):
        F = g.closing_force("silicon", model, method)
        r = g.opening_closing("silicon", model, method, points=21 if method == "conventional" else 131, upper=F)
        sweeps[label] = r
        print(f"{label:26s} {F:18.3f} {r['total_time'] * 1e3:12.1f} ms {r['iterations'].sum():11d}"
              f"  ({len(r['forces'])} forces)")
    return sweeps


def _joints(args) -> int:
    from .registry import available_joints

    for name, cls in sorted(available_joints().items()):
        doc = (inspect.getdoc(cls) or "").splitlines()[0] if inspect.getdoc(cls) else ""
        print(f"{name}: {doc}")
        if attrs.has(cls):
            for a in attrs.fields(cls):
                default = "" if a.default is attrs.NOTHING else f" = {a.default!r}"
                print(f"    {a.name}{default}")
    return 0


def _train(args) -> int:
    from . import database
    from .registry import joint as make_joint

    out = Path(args.out) if args.out else database.data_path()
    out.mkdir(parents=True, exist_ok=True)
    for dim in args.dim:
        for n in args.elements:
            params = dict(_parse_params(args.param))
            j = make_joint(args.kind, elements_per_leaf=n, **params) if n else make_joint(args.kind, **params)
            data = database.train(j, dim, range_deg=None if args.range is None else (-args.range, args.range),
                                  step_deg=args.step)
            path = database.save(data, out / database.file_name(j.kind, dim, data.key))
            res = ", ".join(f"{k} {f.max_residual:.1e}" for k, f in data.functions.items())
            print(f"{path}: {len(data.samples)} runs; max fit residuals: {res}, elements "
                  f"{data.elements.max_residual:.1e} rad, nodes {data.nodes.max_residual:.1e} rad")
    return 0


def _parse_params(items) -> list[tuple[str, object]]:
    """``["angle=0.6", "gap=1e-3"]`` -> ``[("angle", 0.6), ("gap", 0.001)]`` (numbers where they parse)."""
    out = []
    for item in items or ():
        key, sep, val = item.partition("=")
        if not sep or not key:
            raise ParameterError(f"--param {item!r}: expected NAME=VALUE, e.g. --param angle=0.6")
        try:
            out.append((key, int(val) if val.lstrip("-").isdigit() else float(val)))
        except ValueError:
            out.append((key, val))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="flexmb", description="Kinetostatics of flexure mechanisms.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="solve the paper cases, print a result table, write figures")
    p.add_argument("--out", default="figures", help="folder for the figures (default: ./figures)")
    p.add_argument("--quick", action="store_true", help="fewer element counts")
    p.set_defaults(func=_demo)
    p = sub.add_parser("train", help="(re)train a joint database from the joint's finite-element model")
    p.add_argument("kind", nargs="?", default="cross_flexure", help="joint kind (default: cross_flexure)")
    p.add_argument("--dim", type=int, nargs="+", default=[2, 3], choices=(2, 3))
    p.add_argument("--elements", type=int, nargs="+", default=[1, 2, 3, 4, 5], help="elements per leaf")
    p.add_argument("--range", type=float, default=None,
                   help="intended rotation range +- [deg] (default: the joint's own, 75 for cross_flexure)")
    p.add_argument("--step", type=float, default=None, help="sampling step [deg] (default: the joint's own, 5)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="joint shape parameter, repeatable (e.g. --param angle=0.6)")
    p.add_argument("--out", default=None, help="folder (default: the package's shipped data); pass it to "
                                               "solve(..., method='ksd-full', database=FOLDER)")
    p.set_defaults(func=_train)
    p = sub.add_parser("joints", help="list the registered joint plugins and their parameters")
    p.set_defaults(func=_joints)
    args = parser.parse_args(argv)
    np.set_printoptions(precision=4, suppress=True)
    try:
        return args.func(args)
    except FlexmbError as exc:
        if args.debug:
            raise
        print(f"flexmb: error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
