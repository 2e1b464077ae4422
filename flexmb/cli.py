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
    # medians of interleaved solves: a solve takes milliseconds since the continuation, and single
    # timings on a busy machine swung the printed KSD ratios by two orders of magnitude between positions
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
            from .joints._base import UNSET

            for a in attrs.fields(cls):  # by keyword; a material keyword has no default of its own
                default = "" if a.default is attrs.NOTHING or a.default is UNSET else f" = {a.default!r}"
                print(f"    {a.alias}{default}")
    return 0


def _train(args) -> int:
    from . import database

    out = _out_folder(args.out if args.out is not None else database.user_path())
    shipped = database.data_path()
    if out.resolve() == shipped.resolve():
        raise _UsageError(f"--out {str(out)!r} is the shipped data, which flexmb never writes; train into a folder of "
                          f"your own (default: {database.user_path()}, or set {database.store.ENVIRONMENT})")
    params = dict(_parse_params(args.param))
    range_deg = None if args.range is None else (-args.range, args.range)
    first = _trainable(args.kind, params)
    _check_sampling(first, args.range, args.step)
    dims = args.dim or [d for d in (2, 3) if d in first.dims]  # a spatial joint: 3D
    for dim in dims:
        for j in _training_joints(args.kind, params, args.elements, dim):
            try:  # the joint's own settings, checked before any solve (a plugin's mistake: exit 2)
                database.training_settings(j, range_deg=range_deg, step_deg=args.step)
            except ParameterError as exc:
                raise _UsageError(str(exc)) from None
            data = database.train(j, dim, range_deg=range_deg, step_deg=args.step, eob_table=args.eob_table)
            path = database.write(data, out)  # named by the design (store.design_file_name), never another's
            res = ", ".join(f"{k} {f.max_residual:.1e}" for k, f in data.functions.items())
            print(f"{path}: {len(data.samples)} runs; max fit residuals: {res}, elements "
                  f"{data.elements.max_residual:.1e} rad, nodes {data.nodes.max_residual:.1e} rad")
            if any((shipped / n).exists() for n in database.store.candidate_names(j, dim)):  # as `locate` looks
                print(f"  (for KSD this file takes precedence over the shipped data of the same joint when found "
                      f"first; search order: {', '.join(map(str, database.search_path(out)))}; delete it to go back)")
    return 0


#: Most training runs one ``flexmb train`` does per mesh (``--range`` over ``--step``): 100 000
#: FE solves are hours; ``--step 1e-9`` (1.5e11 runs) asked for 1.09 TiB before this check.
MAX_TRAINING_RUNS = 100_000


def _check_sampling(joint, range_deg: float | None, step: float | None) -> None:
    """Refuse (`_UsageError`, exit 2) a ``--step`` so small that the sampling of ``--range`` (the
    joint's own range and step where not given, `flexmb.database.training_settings`) exceeds
    `MAX_TRAINING_RUNS`."""
    from . import database

    try:
        opt = database.training_settings(joint, range_deg=None if range_deg is None else (-range_deg, range_deg),
                                         step_deg=step)
    except ParameterError as exc:
        raise _UsageError(str(exc)) from None
    (lo, hi), step = opt["range_deg"], opt["step_deg"]
    runs = (hi - lo) / step + 1
    if runs > MAX_TRAINING_RUNS:
        raise _UsageError(f"--step {step:g}: {runs:.3g} training runs over [{lo:g}, {hi:g}] deg, more than "
                          f"{MAX_TRAINING_RUNS}; use --step {(hi - lo) / (MAX_TRAINING_RUNS - 1):.3g} or more")


def _trainable(kind: str, params: dict, **mesh):
    """The registered joint ``kind`` built from ``--param`` (and ``mesh``: its mesh parameter),
    refused as a usage error (exit 2, one line) when the kind is unknown, a parameter is unknown or
    out of range, or the joint has no database to train (no finite-element model or no
    `flexmb.Joint.database_key`)."""
    from .registry import joint as make_joint

    try:
        j = make_joint(kind, **params, **mesh)
    except FlexmbError as exc:
        raise _UsageError(f"train: {exc}") from None
    missing = {"fe_model", "database"} - j.capabilities
    if missing:
        raise _UsageError(f"train {kind}: the joint has no {' and no '.join(sorted(missing))} (it offers "
                          f"{sorted(j.capabilities)}): nothing to train")
    return j


def _training_joints(kind: str, params: dict, elements, dim: int) -> list:
    """The joints `flexmb train` trains in ``dim``: one per ``--elements`` value, set through the
    joint class's `flexmb.Joint.mesh_parameter`; without ``--elements`` the meshes shipped for
    these parameters and the joint's own default (`_shipped_meshes`)."""
    from .registry import available_joints

    cls = available_joints()[kind]
    mesh = getattr(cls, "mesh_parameter", None)
    if elements and mesh is None:
        raise _UsageError(f"train {kind}: --elements sets a joint's mesh through its mesh_parameter, and {kind} "
                          "names none; give its mesh with --param NAME=VALUE")
    if mesh is not None and mesh in params:
        if elements:
            raise _UsageError(f"train {kind}: give the mesh once, --elements or --param {mesh}=, not both")
        elements = [params.pop(mesh)]
    if mesh is None:
        return [_trainable(kind, params)]
    return [_trainable(kind, params, **{mesh: n}) for n in (elements or _shipped_meshes(kind, params, dim))]


def _shipped_meshes(kind: str, params: dict, dim: int) -> list[int]:
    """`flexmb train`'s default ``--elements``: the meshes shipped for this joint (these
    parameters, ``dim``) and the joint's own default mesh, so that training reproduces what
    ships (cross flexure: 1-5 and 10 el./leaf, 10 its default since the finer mesh). Meshes are
    read through the joint class's `flexmb.Joint.mesh_parameter`."""
    from . import database

    j = _trainable(kind, params)
    mesh = type(j).mesh_parameter
    meshes = {int(getattr(j, mesh))}
    key = database.training.checked_key(j)
    if mesh in key:
        for path in database.data_path().glob(f"{kind}-{dim}d-*.json"):
            found = re.search(rf"-{re.escape(mesh)}(\d+)", path.name)
            if found and path.name == database.file_name(kind, dim, {**key, mesh: int(found[1])}):
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
    _check_model_params(case, names, params)
    try:
        return build(**params), default
    except TypeError as exc:
        raise ParameterError(f"solve {case}: {exc}; its parameters: {', '.join(names)} (and the joint's shape "
                             f"parameters where the model takes them)") from None


#: The joint whose shape parameters a ready-made model passes on (``**joint_params``).
_MODEL_JOINTS = {"cross_flexure": "cross_flexure", "fourbar": "cross_flexure", "cantilever": "leaf_spring",
                 "manipulator": "three_x_infinity"}


def _check_model_params(case: str, names: list, params: dict) -> None:
    """A ``--param`` that is neither the model's nor its joint's: refused naming the model, with the
    closest name (``displacment`` -> ``displacement``), before the joint blames itself."""
    import difflib

    from .registry import available_joints

    cls = available_joints().get(_MODEL_JOINTS.get(case, ""))
    joint = [a.alias for a in attrs.fields(cls) if a.init] if cls is not None and attrs.has(cls) else []
    for key in params:
        if key not in names and key not in joint:
            close = difflib.get_close_matches(key, names + joint, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ParameterError(f"solve {case}: unknown parameter {key!r}{hint} The model's parameters: "
                                 f"{', '.join(names)}" + (f"; its joint's ({_MODEL_JOINTS[case]}): {', '.join(joint)}"
                                                          if joint else ""))


def _solve(args) -> int:
    from .solvers import solve

    if args.case not in _cases():  # a mechanism file (checked to exist by `_case_or_file`)
        return _solve_file(args)
    if args.sweep or args.properties or args.trace or args.csv:
        raise _UsageError(f"solve {args.case}: --sweep, --properties, --trace and --csv take a mechanism file "
                          "(flexmb.save(mechanism, 'm.json')); the ready-made models take --param and --json")
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
        from .units import label

        lab = {q: label(mechanism.units, q) for q in ("length", "force", "moment")}  # the model's declared units
        for link, d in report["links"].items():
            print(f"  {link}: position {np.array(d['position'])} {lab['length']}, rotation "
                  f"{np.array(d['rotation'])} rad, reaction {np.array(d['reaction'])} [{lab['force']}, {lab['moment']}]")
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


# -- flexmb solve FILE: a mechanism file, a sweep, properties, a traced path ----------

def _case_or_file(text: str) -> str:
    """argparse type of ``solve``'s first argument: a ready-made model's name or an existing file."""
    if text in _cases() or Path(text).is_file():
        return text
    raise argparse.ArgumentTypeError(f"{text!r} is neither a ready-made model ({', '.join(sorted(_cases()))}) nor a "
                                     "mechanism file")


def _file_options(p) -> None:
    """The options of ``flexmb solve FILE``."""
    p.add_argument("--sweep", default=None, metavar="LINK.COMPONENT=START:STOP:N",
                   help="FILE only: solve over a prescribed motion (e.g. block.x=0:0.002:11, or a list "
                        "block.x=0,1e-3,2e-3; 3D rotations rx, ry, rz) or the actuation force (force=0:5:11)")
    p.add_argument("--properties", default=None, metavar="NAMES",
                   help="FILE only: design properties of every solution, comma-separated: modes, buckling, "
                        "compliance, stress")
    p.add_argument("--n-modes", type=_positive_int, default=6, help="FILE only: frequencies with --properties modes")
    p.add_argument("--trace", action="store_true",
                   help="FILE only: follow the equilibrium path (flexmb.trace) of the loads and motions")
    p.add_argument("--steps", type=_positive_int, default=40, help="FILE only: arc-length steps of --trace (40)")
    p.add_argument("--csv", action="store_true", help="FILE only: print the result table as CSV")


def _solve_file(args) -> int:
    """`flexmb solve FILE [--sweep ...] [--properties ...] [--trace]`: exit 2 for a file flexmb
    refuses (one line naming the place in it), 1 for a solve that does not converge."""
    from . import files
    from .errors import ConvergenceWarning
    from .solvers import solve

    try:
        mechanism = files.load(args.case)
    except files.MechanismFileError as exc:
        raise _UsageError(str(exc)) from None
    if args.param:
        raise _UsageError("solve FILE: --param sets a ready-made model's parameters; edit the file instead")
    if args.sweep and args.trace:
        raise _UsageError("solve FILE: --sweep and --trace are two different paths; give one")
    method = args.method or "conventional"
    options = dict(_parse_params(args.option, "--option"))
    if {"mechanism", "method"} & set(options):
        raise _UsageError("--option method=...: not a solver option (choose the method with --method)")
    with warnings.catch_warnings():  # a solve that does not converge is the exit code and its column
        warnings.simplefilter("ignore", ConvergenceWarning)
        if args.sweep:
            solutions = _file_sweep(mechanism, args.sweep, method, options)
        elif args.trace:
            from .path import trace

            solutions = trace(mechanism, steps=args.steps, max_load_factor=1.0, method=method, progress=False,
                              **options)
        else:
            solutions = [solve(mechanism, method=method, **options)]
    units = mechanism.units
    if len(solutions) == 1 and not args.sweep and not args.properties and not args.csv:
        _print_solution(args, solutions[0], units)
    else:
        table = _file_table(solutions, args)
        _print_table(args, table, units)
    failed = sum(not s.converged for s in solutions)
    if failed:
        print(f"flexmb: error: {args.case}: {failed} of {len(solutions)} solve(s) did not converge", file=sys.stderr)
        return 1
    return 0


def _file_sweep(mechanism, spec: str, method: str, options: dict):
    """`flexmb.sweep` over ``spec`` = ``LINK.COMPONENT=VALUES`` or ``force=VALUES``."""
    from .sweeps import sweep

    target, sep, text = spec.partition("=")
    values = _sweep_values(text) if sep else None
    if values is None:
        raise _UsageError(f"--sweep {spec!r}: expected LINK.COMPONENT=START:STOP:N (e.g. block.x=0:0.002:11), a "
                          "comma-separated list, or force=START:STOP:N for the actuation")
    if target == "force":
        return sweep(mechanism, values, method=method, progress=False, **options)
    link, _, comp = target.rpartition(".")
    if mechanism.dim == 3 and comp in ("rx", "ry", "rz"):
        base = np.asarray(mechanism.prescribed(link).get("rotation", np.zeros(3)), dtype=float)
        if base.shape != (3,):
            raise _UsageError(f"--sweep {spec!r}: link {link!r} has no rotation vector prescribed")
        rows = np.tile(base, (len(values), 1))
        rows[:, "xyz".index(comp[1])] = values
        return sweep(mechanism, rows, motion=(link, "rotation"), method=method, progress=False, **options)
    return sweep(mechanism, values, motion=(link, comp), method=method, progress=False, **options)


def _sweep_values(text: str):
    """``START:STOP:N`` (N values, ends included) or ``a,b,c`` as a float array; None if malformed."""
    try:
        if ":" in text:
            start, stop, n = text.split(":")
            n = int(n)
            return np.linspace(float(start), float(stop), n) if n >= 1 else None
        values = np.array([float(x) for x in text.split(",")])
    except ValueError:
        return None
    return values if len(values) and np.all(np.isfinite(values)) else None


def _file_table(solutions, args):
    """The results as a `flexmb.Table`: the sequence's own columns, and the properties asked for."""
    from .design_properties import properties
    from .table import Table

    which = tuple(w.strip() for w in args.properties.split(",") if w.strip()) if args.properties else ()
    unknown = sorted(set(which) - {"modes", "buckling", "compliance", "stress"})
    if unknown:
        raise _UsageError(f"--properties {args.properties!r}: unknown {', '.join(unknown)}; valid: modes, buckling, "
                          "compliance, stress")
    if which:
        return properties(solutions, which, n_modes=args.n_modes)
    if callable(getattr(solutions, "table", None)):
        return solutions.table()
    sol = solutions[0]
    cols = {"converged": [sol.converged], "iterations": [sol.iterations]}
    for link in sol.compiled.link_node:
        for k, x in enumerate(sol.pose(link)[0]):
            cols[f"{link}.{'xyz'[k]}"] = [x]
    return Table(cols)


def _print_table(args, table, units) -> None:
    from .units import column_unit

    names = list(table)
    labels = {n: column_unit(n, units) for n in names}
    if args.json:
        out = {"file": str(args.case), "units": None if units is None else units.name, "column_units": labels,
               "columns": {n: table[n].tolist() for n in names}}
        print(json.dumps(strict_json(out), indent=2, allow_nan=False))
        return
    header = [f"{n} [{labels[n]}]" if labels[n] not in ("", "-") else n for n in names]
    cols = [table[n].tolist() for n in names]
    if args.csv:
        import csv

        w = csv.writer(sys.stdout, lineterminator="\n")
        w.writerow(header)
        for row in zip(*cols):
            w.writerow([repr(x) if isinstance(x, float) else x for x in row])
        return
    width = [max(12, len(h)) for h in header]
    print("  ".join(h.rjust(k) for h, k in zip(header, width)))
    for row in zip(*cols):
        print("  ".join((f"{x:.6g}" if isinstance(x, float) else str(x)).rjust(k) for x, k in zip(row, width)))


def _print_solution(args, sol, units) -> None:
    """One solve of a file: as the ready-made models' (`solution_report`), with its unit labels."""
    from .units import label

    lab = {q: label(units, q) for q in ("length", "angle", "force", "moment")}
    if args.json:
        report = solution_report(sol, file=str(args.case), units=None if units is None else units.name,
                                 unit_labels=lab)
        print(json.dumps(strict_json(report), indent=2, allow_nan=False))
        return
    print(f"{args.case} ({sol.method}, units {units.name if units else 'undeclared (SI)'}): {sol.message}; "
          f"{sol.iterations} iterations, {sol.wall_time.get('total', float('nan')) * 1e3:.1f} ms")
    for link in sol.compiled.link_node:
        print(f"  {link}: position {sol.pose(link)[0]} {lab['length']}, rotation {sol.rotation_vector(link)} "
              f"{lab['angle']}, reaction {sol.reaction(link)} [{lab['force']}, {lab['moment']}]")


def _run(args) -> int:
    """`flexmb run SCRIPT`: the script as ``python SCRIPT`` runs it, its folder first on the import
    path (a sibling module imports), ``sys.argv`` its arguments; both restored afterwards."""
    path = Path(args.script)
    if not path.suffix and not path.exists():  # a case name: examples/<name>.py in this folder
        path = Path("examples") / f"{args.script}.py"
    if not path.is_file():
        raise ParameterError(f"run: no script {str(path)!r} (give a path, or an example name with an examples/ "
                             f"folder in the current directory)")
    argv, sys_path = sys.argv, list(sys.path)
    sys.argv = [str(path), *args.args]
    sys.path.insert(0, str(path.resolve().parent))
    try:
        runpy.run_path(str(path), run_name="__main__")
    except SystemExit as exc:  # as the interpreter does: an int is the code, anything else is printed
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        print(exc.code, file=sys.stderr)
        return 1
    finally:
        sys.argv = argv
        sys.path[:] = sys_path
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
                   help="the joint's mesh (its mesh_parameter: elements per leaf of cross_flexure, elements of a "
                        "plugin's notch ...), at least 1 (default: the meshes shipped for this joint and parameters, "
                        "and the joint's own default mesh: 1 2 3 4 5 10 for cross_flexure)")
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
    p.add_argument("case", type=_case_or_file, metavar="MODEL|FILE",
                   help=f"a ready-made model ({', '.join(sorted(_cases()))}) or a mechanism file (flexmb.save)")
    p.add_argument("--method", default=None, help="solver strategy (default: conventional; newton for the gripper)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="model parameter, repeatable (e.g. --param rotation=0.5 --param elements_per_leaf=4)")
    p.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="solver option, repeatable (e.g. --option tol=1e-9)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    _file_options(p)
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
