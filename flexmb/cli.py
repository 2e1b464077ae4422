"""The ``flexmb`` command: ``demo``, ``solve``, ``run``, ``bench``, ``train``, ``joints``.

Errors are one line on stderr (``--debug`` for a traceback), and so is each warning
(``flexmb: warning: RuntimeWarning: ...``). Exit codes:

- 0 success;
- 1 a flexmb error: flexmb refused a model or solver parameter, a solve did not converge (its
  result is still printed), a database is missing, a benchmark failed; ``run``: the script's own
  exit code (``sys.exit("message")`` prints the message and gives 1, as Python does);
- 2 a usage error: an unknown command or option, a value of the wrong type or outside its range
  (``--step 0``, ``--range -5``, ``--elements 0``), ``--param``/``--option`` without ``=VALUE``,
  an ``--out`` folder that cannot be created or is the shipped data;
- 1 also when the output cannot be written (``flexmb solve fourbar --json > /dev/full``): one
  line on stderr, no traceback;
- 141 the reader of the output went away (``flexmb solve fourbar --json | head -c1``): nothing
  more is printed, as for a process ended by SIGPIPE (128 + 13).

``--json`` output is strict JSON (RFC 8259): non-finite numbers (a diverged state, an infinite
residual) are written as ``null``.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import re
import runpy
import subprocess
import sys
import warnings
from pathlib import Path

import attrs
import numpy as np

from .errors import FlexmbError, ParameterError


def _demo(args) -> int:
    from .studies import demo

    out = _out_folder(args.out, create=False)  # checked before minutes of solving, created after
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
    fourbar_rows = _demo_fourbar(args.quick)
    manipulator_rows = _demo_manipulator(args.quick)
    try:
        written = _demo_figures(_out_folder(out), curves, reference, gripper, fourbar_rows, manipulator_rows)
        print("\nfigures: " + ", ".join(str(p) for p in written))
    except ImportError:
        print("\n(no figures: install the plot extra, pip install 'flexmb[plot]')")
    return 0


def _demo_figures(out: Path, curves, reference, gripper, fourbar_rows, manipulator_rows) -> list:
    """The demo's PNG figures (needs matplotlib); returns their paths."""
    from . import models, plot
    from .studies import demo
    from .studies import gripper as g
    from .studies import manipulator as mc
    from .solvers import solve

    paths = [out / "cross_flexure.png", out / "gripper_models.png"]
    demo.plot_cross_flexure(curves, reference, paths[0])
    g.plot_comparison({"silicon": gripper}, paths[1])
    sol = solve(models.fourbar(elements_per_leaf=3, displacement=0.3), method="ksd-full")
    ax = plot.plot_mechanism(sol)
    ax.view_init(elev=65, azim=-90)  # nearly from above: the four-bar moves in its x-y plane
    ax.set_title("Four-bar, d = 0.3 m (KSD-full)")
    paths.append(plot.save(ax, out / "fourbar_shape.png"))
    last = max(r["elements_per_leaf"] for r in fourbar_rows)
    axes = plot.plot_strategies([r for r in fourbar_rows if r["elements_per_leaf"] == last])
    axes[0].set_title(f"Four-bar, {last} el./leaf")
    paths.append(plot.save(axes, out / "fourbar_strategies.png"))
    sol = solve(models.manipulator("joint", np.radians(30.0)), method="ksd-full")
    ax = plot.plot_mechanism(sol, labels=False)
    ax.set_title("Manipulator of three three_x_infinity joints, 30 deg (KSD-full)")
    paths.append(plot.save(ax, out / "manipulator_shape.png"))
    mc.plot_study(manipulator_rows, out / "manipulator_fig15.png")
    paths.append(out / "manipulator_fig15.png")
    return paths


def _demo_manipulator(quick: bool) -> list:
    """The spatial manipulator of Dwarshuis et al. (2020), Sec. 4.4: conventional vs KSD (Fig. 15)."""
    from .studies import manipulator as mc

    degrees = (-45, 0, 45) if quick else (-45, -30, -15, 0, 15, 30, 45)
    # medians of 5 interleaved solves: since the continuation (issue 19) a solve takes 2-50 ms, and
    # single timings on a busy machine swung the printed KSD ratios 0.3-25x between positions
    rows = mc.study(degrees, cases=("joint",), repeats=3 if quick else 5, clock="cpu")
    _speed_table("Manipulator of three three_x_infinity joints, Dwarshuis et al. (2020) Sec. 4.4, joint case",
                 rows, "rotation", "deg")
    return rows


def _demo_fourbar(quick: bool) -> list:
    """The four-bar of Dwarshuis et al. (2020), Sec. 4.3: conventional method against KSD (Fig. 11)."""
    from .studies import fourbar as fc

    rows = fc.speed_study((1, 3) if quick else (1, 3, 5), repeats=3 if quick else 5, clock="cpu")
    _speed_table("Four-bar of four cross flexures, Dwarshuis et al. (2020) Sec. 4.3, d = 0.3 m: conventional vs KSD",
                 rows, "elements_per_leaf", "el./leaf", force=True)
    return rows


def _speed_table(title: str, rows: list, key: str, label: str, force: bool = False) -> None:
    """Print conventional-vs-KSD rows: the ``key`` column headed ``label``, the method, the
    actuation force [N] if ``force``, iterations, CPU time (medians of interleaved solves: the
    same on a busy machine as on an idle one, where it equals the wall time) and speed-up."""
    print(f"\n{title}")
    print(f"{label:>8s} {'method':>13s}" + (f" {'F [N]':>10s}" if force else "")
          + f" {'iterations':>11s} {'CPU [ms]':>10s} {'speed-up':>9s}")
    for r in rows:
        print(f"{r[key]:8d} {r['method']:>13s}" + (f" {r['force']:10.4f}" if force else "")
              + f" {r['iterations']:11d} {r['time'] * 1e3:10.1f} {r['speedup']:8.1f}x")


def _demo_gripper(quick: bool) -> dict:
    """The gripper of Cammarata et al. (2022): closing forces and strategy timings; returns the sweeps."""
    from .studies import gripper as g

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

    out = _out_folder(args.out if args.out is not None else database.user_path())
    shipped = database.data_path()
    if out.resolve() == shipped.resolve():
        raise _UsageError(f"--out {str(out)!r} is the shipped data, which flexmb never writes; train into a folder of "
                          f"your own (default: {database.user_path()}, or set {database.store.ENVIRONMENT})")
    params = dict(_parse_params(args.param))
    _check_sampling(args.kind, params, args.range, args.step)
    range_deg = None if args.range is None else (-args.range, args.range)
    dims = args.dim or [d for d in (2, 3) if d in make_joint(args.kind, **params).dims]  # a spatial joint: 3D
    for dim in dims:
        for n in args.elements or _shipped_meshes(args.kind, params, dim):
            j = make_joint(args.kind, elements_per_leaf=n, **params)
            data = database.train(j, dim, range_deg=range_deg, step_deg=args.step, eob_table=args.eob_table)
            path = database.write(data, out)  # named by the design (store.design_file_name), never another's
            name = database.file_name(j.kind, dim, data.key)  # the shipped data's (key-only) name
            res = ", ".join(f"{k} {f.max_residual:.1e}" for k, f in data.functions.items())
            print(f"{path}: {len(data.samples)} runs; max fit residuals: {res}, elements "
                  f"{data.elements.max_residual:.1e} rad, nodes {data.nodes.max_residual:.1e} rad")
            if (shipped / name).exists():
                print(f"  (for KSD this file takes precedence over the shipped data of the same joint when found "
                      f"first; search order: {', '.join(map(str, database.search_path(out)))}; delete it to go back)")
    return 0


#: Most training runs one ``flexmb train`` does per mesh (``--range`` over ``--step``): 100 000
#: FE solves are hours; ``--step 1e-9`` (1.5e11 runs) asked for 1.09 TiB before this check (issue 32).
MAX_TRAINING_RUNS = 100_000


def _check_sampling(kind: str, params: dict, range_deg: float | None, step: float | None) -> None:
    """Refuse (`_UsageError`, exit 2) a ``--step`` so small that the sampling of ``--range`` (the
    joint's own range and step where not given) exceeds `MAX_TRAINING_RUNS`."""
    from .database.training import TRAINING
    from .registry import joint as make_joint

    opt = {**TRAINING, **getattr(type(make_joint(kind, **params)), "training", {})}
    lo, hi = (-range_deg, range_deg) if range_deg is not None else opt["range_deg"]
    step = float(opt["step_deg"] if step is None else step)
    runs = (hi - lo) / step + 1
    if runs > MAX_TRAINING_RUNS:
        raise _UsageError(f"--step {step:g}: {runs:.3g} training runs over [{lo:g}, {hi:g}] deg, more than "
                          f"{MAX_TRAINING_RUNS}; use --step {(hi - lo) / (MAX_TRAINING_RUNS - 1):.3g} or more")


def _shipped_meshes(kind: str, params: dict, dim: int) -> list[int]:
    """`flexmb train`'s default ``--elements``: the meshes shipped for this joint (these
    parameters, ``dim``) and the joint's own default mesh, so that training reproduces what
    ships (cross flexure: 1-5 and 10 el./leaf, 10 its default since the finer mesh)."""
    from . import database
    from .registry import joint as make_joint

    j = make_joint(kind, **params)
    key = j.database_key()
    meshes = {int(key["elements_per_leaf"])}
    for path in database.data_path().glob(f"{kind}-{dim}d-*.json"):
        found = re.search(r"-elements_per_leaf(\d+)", path.name)
        if found and path.name == database.file_name(kind, dim, {**key, "elements_per_leaf": int(found[1])}):
            meshes.add(int(found[1]))
    return sorted(meshes)


class _UsageError(FlexmbError):
    """A command-line argument that is malformed or cannot be used (exit code 2)."""


def _out_folder(path, *, create: bool = True) -> Path:
    """The ``--out`` folder, created if needed (with ``create=False`` only checked: it exists as a
    writable folder, or its nearest existing parent does); `_UsageError` when it cannot be used."""
    out = Path(path)
    if create:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise _UsageError(f"--out {str(out)!r}: cannot create the folder: {exc.strerror or exc}") from None
    where = out.absolute()
    while not where.exists() and where != where.parent:
        where = where.parent
    if not where.is_dir():
        raise _UsageError(f"--out {str(out)!r}: {str(where)!r} is a file, not a folder")
    if not os.access(where, os.W_OK | os.X_OK):
        raise _UsageError(f"--out {str(out)!r}: {str(where)!r} is not writable")
    return out


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{n} must be at least 1")
    return n


def _angle(upper: float):
    """argparse type: a finite angle [deg] in (0, ``upper``]."""
    def parse(text: str) -> float:
        try:
            x = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number [deg]") from None
        if not 0.0 < x <= upper:  # NaN fails too
            raise argparse.ArgumentTypeError(f"{text} must lie in (0, {upper:g}] deg")
        return x
    parse.__name__ = "angle"
    return parse


def _parse_params(items, flag: str = "--param") -> list[tuple[str, object]]:
    """``["angle=0.6", "gap=1e-3", "w=0,0,1"]`` -> ``[("angle", 0.6), ("gap", 0.001), ("w", [0, 0, 1])]``
    (numbers where they parse, comma-separated lists of numbers, else the text)."""
    out = []
    for item in items or ():
        key, sep, val = item.partition("=")
        if not sep or not key:
            raise _UsageError(f"{flag} {item!r}: expected NAME=VALUE, e.g. {flag} angle=0.6")
        out.append((key, [_number(x) for x in val.split(",")] if "," in val else _number(val)))
    _once_each(out, flag)
    return out


def _once_each(pairs: list, flag: str) -> None:
    """Refuse a name given twice (``--param rotation=0.3 --param rotation=0.6``): which one was meant?"""
    seen = {}
    for key, value in pairs:
        if key in seen:
            raise _UsageError(f"{flag} {key} is given twice ({key}={seen[key]!r} and {key}={value!r}); give it once")
        seen[key] = value


def _number(text: str):
    try:
        return int(text) if text.strip().lstrip("-").isdigit() else float(text)
    except ValueError:
        return {"true": True, "false": False}.get(text.lower(), text)


def _cases() -> dict:
    """``flexmb solve`` cases: name -> (model builder, default method)."""
    from . import models

    return {"cross_flexure": (models.cross_flexure_pivot, "conventional"),
            "cantilever": (models.cantilever, "conventional"),
            "fourbar": (models.fourbar, "conventional"),
            "gripper": (models.gripper, "newton"),
            "manipulator": (models.manipulator, "conventional")}


def _build(case: str, params: dict):
    build, default = _cases()[case]
    names = [n for n, p in inspect.signature(build).parameters.items() if p.kind is not p.VAR_KEYWORD]
    try:
        return build(**params), default
    except TypeError as exc:
        raise ParameterError(f"solve {case}: {exc}; its parameters: {', '.join(names)} (and the joint's shape "
                             f"parameters where the model takes them)") from None


def _solve(args) -> int:
    from .solvers import solve

    params = dict(_parse_params(args.param))
    mechanism, default = _build(args.case, params)
    method = args.method or default
    options = dict(_parse_params(args.option, "--option"))
    clash = sorted({"mechanism", "method"} & set(options))
    if clash:
        raise _UsageError(f"--option {clash[0]}=...: not a solver option (choose the method with --method)")
    from .errors import ConvergenceWarning

    with warnings.catch_warnings():  # a solve that does not converge is the error line below
        warnings.simplefilter("ignore", ConvergenceWarning)
        sol = solve(mechanism, method=method, **options)
    report = solution_report(sol, case=args.case, parameters=params)
    if args.json:
        print(json.dumps(strict_json(report), indent=2, allow_nan=False))
    else:
        print(f"{args.case} ({method}): {sol.message}; {sol.iterations} iterations, "
              f"{sol.wall_time.get('total', float('nan')) * 1e3:.1f} ms")
        for link, d in report["links"].items():
            print(f"  {link}: position {np.array(d['position'])} m, rotation {np.array(d['rotation'])} rad, "
                  f"reaction {np.array(d['reaction'])}")
    if not sol.converged:
        print(f"flexmb: error: {args.case} did not converge: {sol.message}", file=sys.stderr)
        return 1
    return 0


def solution_report(sol, **extra) -> dict:
    """A JSON-ready summary of a `Solution`: status, iterations, wall times [s], and per link
    the position [m], rotation (angle or rotation vector) [rad] and reaction wrench [N, N m]."""
    links = {name: {"position": sol.pose(name)[0].tolist(), "rotation": sol.rotation_vector(name).tolist(),
                    "reaction": sol.reaction(name).tolist()} for name in sol.compiled.link_node}
    out = dict(extra)
    out.update(method=sol.method, converged=bool(sol.converged), message=sol.message, iterations=int(sol.iterations),
               load_factor=float(sol.load_factor), wall_time={k: float(v) for k, v in sol.wall_time.items()},
               residual_history=[float(r) for r in sol.residual_history], links=links)
    out.update(_ksd_report(sol))
    return out


def _ksd_report(sol) -> dict:
    """What a KSD solution adds to `solution_report`: ``"database"``, per joint the database file
    its data came from and whether it lay in the ``database=`` folder, the user's or the shipped
    data (`flexmb.ksd.provenance`); ``"error_estimate"`` (`flexmb.ksd.estimate`) when made."""
    out = {}
    files = sol.stages.get("setup", {}).get("files")
    if files is not None:
        out["database"] = {name: dict(entry) for name, entry in files.items()}
    estimate = sol.stages.get("estimate")
    if estimate is not None:
        out["error_estimate"] = estimate.to_json()
    return out


def strict_json(value):
    """``value`` (dicts, lists, numbers, text) with every non-finite float replaced by ``None``,
    so that `json.dumps` writes strict JSON (``null``, not ``NaN``/``Infinity``)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    return value


def _run(args) -> int:
    path = Path(args.script)
    if not path.suffix and not path.exists():  # a case name: examples/<name>.py in this folder
        path = Path("examples") / f"{args.script}.py"
    if not path.is_file():
        raise ParameterError(f"run: no script {str(path)!r} (give a path, or an example name with an examples/ "
                             f"folder in the current directory)")
    argv = sys.argv
    sys.argv = [str(path), *args.args]
    try:
        runpy.run_path(str(path), run_name="__main__")
    except SystemExit as exc:  # as the interpreter does: an int is the code, anything else is printed
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        print(exc.code, file=sys.stderr)
        return 1
    finally:
        sys.argv = argv
    return 0


def _bench(args) -> int:
    folder = Path(args.root) / "benchmarks"
    scripts = {p.stem.removeprefix("bench_"): p for p in sorted(folder.glob("bench_*.py"))}
    if not scripts:
        raise ParameterError(f"bench: no benchmarks/bench_*.py under {str(Path(args.root).resolve())!r}; run it in "
                             f"a checkout of the flexmb repository (or pass --root)")
    unknown = sorted(set(args.only or ()) - set(scripts))
    if unknown:
        raise ParameterError(f"bench: unknown benchmark(s) {', '.join(unknown)}; available: {', '.join(scripts)}")
    if args.list:
        print("\n".join(scripts))
        return 0
    failed = []
    for name in args.only or scripts:
        print(f"== {name} ==", flush=True)
        code = subprocess.call([sys.executable, str(scripts[name]), *(["--quick"] if args.quick else [])])
        if code:
            failed.append(f"{name} (exit {code})")
    if failed:
        raise _BenchFailed(f"bench: failed: {', '.join(failed)}")
    print(f"BENCHMARKS.md updated: {(Path(args.root) / 'BENCHMARKS.md').resolve()}")
    return 0


class _BenchFailed(FlexmbError):
    """A benchmark script exited with an error."""


class _Parser(argparse.ArgumentParser):
    """argparse with its usage errors as one line on stderr (exit code 2)."""

    def error(self, message):
        self.exit(2, f"flexmb: error: {self.prog}: {message} (see {self.prog} --help)\n")


def main(argv: list[str] | None = None) -> int:
    parser = _Parser(prog="flexmb", description="Kinetostatics of flexure mechanisms.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="solve the paper cases, print a result table, write figures")
    p.add_argument("--out", default="figures", help="folder for the figures (default: ./figures)")
    p.add_argument("--quick", action="store_true", help="fewer element counts")
    p.set_defaults(func=_demo)
    p = sub.add_parser("train", help="(re)train a joint database from the joint's finite-element model")
    p.add_argument("kind", nargs="?", default="cross_flexure", help="joint kind (default: cross_flexure)")
    p.add_argument("--dim", type=int, nargs="+", default=None, choices=(2, 3),
                   help="2, 3 or both (default: those the joint supports; three_x_infinity: 3)")
    p.add_argument("--elements", type=_positive_int, nargs="+", default=None,
                   help="elements per leaf, at least 1 (default: the meshes shipped for this joint and "
                        "parameters, and the joint's own default mesh: 1 2 3 4 5 10 for cross_flexure)")
    p.add_argument("--range", type=_angle(180.0), default=None,
                   help="intended rotation range +- [deg], in (0, 180] (default: the joint's own, 75 for "
                        "cross_flexure)")
    p.add_argument("--step", type=_angle(360.0), default=None,
                   help="sampling step [deg], positive (default: the joint's own, 5)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="joint shape parameter, repeatable (e.g. --param angle=0.6)")
    p.add_argument("--eob-table", action="store_true",
                   help="also tabulate this joint's EOB condensation against the rotation (a side file "
                        "<name>.eob.bin; KSD-reduced then looks it up for joints with exactly these parameters)")
    p.add_argument("--out", default=None,
                   help="folder (default: the user data folder, flexmb.database.user_path(), where KSD looks before "
                        "the shipped data; $FLEXMB_DATABASE overrides it); another folder: pass it to "
                        "solve(..., method='ksd-full', database=FOLDER). The shipped data are never written")
    p.set_defaults(func=_train)
    p = sub.add_parser("joints", help="list the registered joint plugins and their parameters")
    p.set_defaults(func=_joints)
    p = sub.add_parser("solve", help="solve a ready-made model and print (or --json) the result",
                       description="Solve one of the ready-made models of flexmb.models. Exit code 1 when it does not "
                                   "converge (the result is still printed).")
    p.add_argument("case", choices=sorted(_cases()), help="the model (flexmb.models)")
    p.add_argument("--method", default=None, help="solver strategy (default: conventional; newton for the gripper)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="model parameter, repeatable (e.g. --param rotation=0.5 --param elements_per_leaf=4)")
    p.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="solver option, repeatable (e.g. --option tol=1e-9)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=_solve)
    p = sub.add_parser("run", help="run an example script (a path, or a name from ./examples)")
    p.add_argument("script", help="e.g. examples/fourbar.py or fourbar")
    p.add_argument("args", nargs=argparse.REMAINDER, help="arguments passed to the script")
    p.set_defaults(func=_run)
    p = sub.add_parser("bench", help="run the benchmarks/ scripts of a checkout and regenerate BENCHMARKS.md")
    p.add_argument("--quick", action="store_true", help="the scripts' quick variants (fewer sizes and repeats)")
    p.add_argument("--only", nargs="+", default=None, metavar="NAME", help="run only these (e.g. core fourbar)")
    p.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    p.add_argument("--root", default=".", help="the checkout holding benchmarks/ (default: the current folder)")
    p.set_defaults(func=_bench)
    args = parser.parse_args(argv)
    np.set_printoptions(precision=4, suppress=True)
    stdout, sys.stdout = sys.stdout, _CheckedOutput(sys.stdout)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning
            code = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return code
    except BrokenPipeError:
        _silence_stdout()
        return 141

    except FlexmbError as exc:
        if isinstance(exc, _OutputError):
            _silence_stdout()
        elif args.debug:
            raise
        print(f"flexmb: error: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, _UsageError) else 1
    finally:
        sys.stdout = stdout


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on stderr, ``flexmb: warning: <kind>: <message>`` (not Python's two
    lines with the source line)."""
    text = " ".join(str(message).split())
    print(f"flexmb: warning: {category.__name__}: {text}", file=sys.stderr if file is None else file)


class _OutputError(FlexmbError):
    """The standard output cannot be written (a full disk, ``> /dev/full``): exit code 1."""


class _CheckedOutput:
    """The standard output while a command runs: a failed write or flush raises `_OutputError`
    (one line, no traceback) instead of an `OSError`; a closed pipe stays `BrokenPipeError`
    (exit code 141). Everything else is the stream's own."""

    def __init__(self, stream):
        self._stream = stream

    def _checked(self, method, *args):
        try:
            return method(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _OutputError(f"cannot write the output: {exc.strerror or exc}") from None

    def write(self, text):
        return self._checked(self._stream.write, text)

    def flush(self):
        return self._checked(self._stream.flush)

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _silence_stdout() -> None:
    """Point the standard output at the null device, so the interpreter's final flush into the
    closed pipe neither fails nor prints (Python docs, "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # not a real file (pytest's capture): nothing to flush
        pass


if __name__ == "__main__":
    sys.exit(main())
