"""Design properties over a range of motion: `properties` of any sequence of Solutions (a
`flexmb.SweepResult`, a list, a path traced through the configurations) as table columns, their
extremes over the range (`summary`; `flexmb.study.joint_range` makes one design of a parameter
study from them).

The properties are SPACAR's per-configuration outputs (Dwarshuis et al. 2020, Sec. 1): the
natural frequencies (`flexmb.modes`), buckling load multipliers (`flexmb.buckling`), chosen
compliance entries (`flexmb.compliance`) and peak stresses (`flexmb.Solution.stresses`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

import warnings

from .errors import FlexmbError, ModelError, ParameterError, UnsupportedStrategyError
from .linearised import buckling, compliance
from .modal import modes
from .table import Table

__all__ = ["properties", "property_columns", "summary", "PROPERTIES"]

PROPERTIES = ("modes", "buckling", "compliance", "stress")
_LABELS = {2: ("x", "y", "rotation"), 3: ("x", "y", "z", "rx", "ry", "rz")}


def _entries(spec, compiled, dim):
    """Compliance entries ``[(column, link, i, j, point)]`` from ``spec`` (module docs of `properties`)."""
    labels = _LABELS[dim]
    if spec is None:  # the diagonal of every link that is not fixed
        return [(f"C.{link}.{a}.{a}", link, k, k, None) for link in compiled.link_node if link not in compiled.fixed
                for k, a in enumerate(labels)]
    items = spec.items() if isinstance(spec, Mapping) else ((None, e) for e in spec)
    out = []
    for name, entry in items:
        if not isinstance(entry, (tuple, list)) or len(entry) not in (3, 4):
            raise ParameterError(f"properties: compliance entry {entry!r} must be (link, row, column[, point]) with "
                                 f"row and column among {', '.join(labels)} or their indices")
        link, rc, point = entry[0], [], entry[3] if len(entry) == 4 else None
        if link not in compiled.link_node:
            raise ModelError(f"properties: compliance entry names no link {link!r}; links: "
                             f"{', '.join(compiled.link_node)}")
        for c in entry[1:3]:
            if isinstance(c, str) and c in labels:
                rc.append(labels.index(c))
            elif isinstance(c, (int, np.integer)) and not isinstance(c, bool) and 0 <= c < len(labels):
                rc.append(int(c))
            else:
                raise ParameterError(f"properties: compliance component {c!r} of link {link!r}; valid: "
                                     f"{', '.join(labels)} or 0..{len(labels) - 1}")
        label = name if name is not None else \
            f"C.{link}{'' if point is None else '@' + str(point)}.{labels[rc[0]]}.{labels[rc[1]]}"
        out.append((label, link, rc[0], rc[1], point))
    return out


def _row(sol, which, n_modes, held, n_buckling, entries, axes, concentration, limit):
    """The property columns of one converged solution, as a dict of floats."""
    out = {}
    if "modes" in which:
        f = modes(sol, n_modes=n_modes, held=held).frequencies
        out.update({f"f{k + 1}": float(x) for k, x in enumerate(f)})
    if "buckling" in which:
        lam = buckling(sol, n_buckling=n_buckling, held=held)
        out.update({"buckling": float(lam[0])} if n_buckling == 1 else
                   {f"buckling{k + 1}": float(x) for k, x in enumerate(lam)})
    if "compliance" in which:
        cache = {}
        for label, link, i, j, point in entries:
            key = (link, None if point is None else str(point) if isinstance(point, str) else tuple(np.ravel(point)))
            if key not in cache:
                cache[key] = compliance(sol, link, point, axes=axes, held=held)
            out[label] = float(cache[key][i, j])
    if "stress" in which:
        s = sol.stresses(concentration=concentration, limit=limit)
        out.update(s.summary())
        for joint in s.joints:
            out.update({f"{joint}.{k}": v for k, v in s.joint(joint).items()})
    return out


def properties(solutions, which=("modes", "buckling", "stress"), *, n_modes: int = 6, held="prescribed",
               n_buckling: int = 1, compliance_entries=None, axes: str = "global", concentration=None,
               limit=None) -> Table:
    """Design properties of every solution in ``solutions`` (any sequence of `flexmb.Solution`:
    a `flexmb.SweepResult`, a list, a traced path) as a `flexmb.Table`, one row per solution.

    The columns start with the sequence's own (``solutions.table()`` if it has one, e.g. a
    sweep's values and link positions; else ``converged``), then, for each name in ``which``:

    * ``"modes"``: ``f1`` ... ``f<n_modes>`` [Hz] (`flexmb.modes` with ``held``);
    * ``"buckling"``: ``buckling`` (``buckling1`` ... with ``n_buckling`` > 1), the lowest
      positive multipliers of the loads and prescribed motions (`flexmb.buckling`, ``held``);
    * ``"compliance"``: the entries ``compliance_entries`` of `flexmb.compliance` (``axes``,
      ``held``): a sequence of ``(link, row, column[, point])`` with components ``"x"``, ``"y"``,
      ``"z"``, ``"rx"``, ``"ry"``, ``"rz"`` (2D: ``"x"``, ``"y"``, ``"rotation"``) or indices,
      columns named ``C.<link>.<row>.<column>`` [m/N, 1/N, rad/(N m)], or a mapping column name ->
      entry; default the diagonal of every link that is not fixed;
    * ``"stress"``: the peaks ``normal``, ``shear``, ``von_mises`` [Pa] and with a ``limit``
      [Pa] the minimum ``safety``, for the mechanism and per joint (``<joint>.von_mises``, ...)
      (`flexmb.Solution.stresses` with ``concentration``).

    A solution that did not converge gets NaN properties (its ``converged`` column says so). The
    first converged solution is evaluated strictly: bad arguments raise there. A later one whose
    property fails numerically (e.g. a singular tangent at a bifurcation) gets NaN for that
    property and the reason in the text column ``property_errors`` (only present then), so one
    failure never discards the other rows. A property the solutions' strategy does not offer
    (buckling of a KSD-reduced solution: `flexmb.buckling`) gets NaN and its reason in
    ``property_errors`` on every converged row, with a warning, so the default ``which`` (or a
    sweep's ``properties=``) still returns every property the strategy has.

    The properties are those of the solutions' mesh: `flexmb.discretisation_error(mechanism,
    which)` estimates their discretisation error (Richardson from meshes refined by 2 and 4).
    """
    if not isinstance(solutions, Sequence) or isinstance(solutions, (str, bytes)) or len(solutions) == 0:
        raise ParameterError("properties: solutions must be a non-empty sequence of flexmb.Solution (a sweep's "
                             "result, a list)")
    sols = list(solutions)
    if not all(hasattr(s, "compiled") and hasattr(s, "converged") for s in sols):
        raise ParameterError("properties: every item of solutions must be a flexmb.Solution")
    base = dict(solutions.table()) if callable(getattr(solutions, "table", None)) else \
        {"converged": np.array([bool(s.converged) for s in sols])}
    for name in getattr(solutions, "property_table", None) or ():  # a sweep's own property columns
        base.pop(name, None)
    cols = property_columns(sols, which, n_modes=n_modes, held=held, n_buckling=n_buckling,
                            compliance_entries=compliance_entries, axes=axes, concentration=concentration, limit=limit)
    clash = set(cols) & set(base)
    if clash:
        raise ParameterError(f"properties: property columns {sorted(clash)} clash with columns of the sequence's table")
    return Table({**base, **cols})


def property_columns(solutions, which=("modes", "buckling", "stress"), *, n_modes: int = 6, held="prescribed",
                     n_buckling: int = 1, compliance_entries=None, axes: str = "global", concentration=None,
                     limit=None) -> dict:
    """The property columns of `properties` alone, ``{name: (n,) array}``."""
    if isinstance(which, str):
        which = (which,)
    which = tuple(which)
    for name in which:
        if name not in PROPERTIES:
            raise ParameterError(f"properties: {name!r} is not a property; valid: {', '.join(PROPERTIES)}")
    sols = list(solutions)
    if not sols or not all(hasattr(s, "compiled") and hasattr(s, "converged") for s in sols):
        raise ParameterError("properties: solutions must be a non-empty sequence of flexmb.Solution")
    first = next((s for s in sols if s.converged), None)
    entries = _entries(compliance_entries, sols[0].compiled, sols[0].dim) if "compliance" in which else []
    args = (which, n_modes, held, n_buckling, entries, axes, concentration, limit)
    rows, errors = [], [""] * len(sols)
    first_row, unsupported = {}, {}
    for name in [n for n in PROPERTIES if n in which] if first is not None else ():  # strict: bad arguments raise
        try:
            first_row.update(_row(first, (name,), *args[1:]))
        except UnsupportedStrategyError as exc:  # what the strategy lacks is left out, not the rest
            unsupported[name] = f"{name}: {exc}"
    if unsupported:
        warnings.warn(f"properties: NaN for {', '.join(unsupported)} of {first.method} solutions (reason in the "
                      "column property_errors): " + "; ".join(unsupported.values()), UserWarning, stacklevel=3)
    args = (tuple(n for n in which if n not in unsupported),) + args[1:]
    for k, sol in enumerate(sols):
        if not sol.converged:
            rows.append({})
            continue
        errors[k] = "; ".join(unsupported.values())
        if sol is first:
            rows.append(first_row)
            continue
        try:
            rows.append(_row(sol, *args))
        except (FlexmbError, np.linalg.LinAlgError, ArithmeticError, RuntimeError):
            rows.append(_partial(sol, args, errors, k))
    names = list(dict.fromkeys([n for r in rows for n in r] + [n for u in unsupported for n in _names(u, args)]))
    cols = {n: np.array([r.get(n, np.nan) for r in rows], dtype=float) for n in names}
    if any(errors):
        cols["property_errors"] = np.array(errors, dtype=object)
    return cols


def _names(name, args) -> list:
    """The columns property ``name`` would have (`properties`), for a property left out."""
    n_modes, n_buckling, entries, limit = args[1], args[3], args[4], args[7]
    if name == "modes":
        return [f"f{k + 1}" for k in range(n_modes)]
    if name == "buckling":
        return ["buckling"] if n_buckling == 1 else [f"buckling{k + 1}" for k in range(n_buckling)]
    if name == "compliance":
        return [e[0] for e in entries]
    return ["normal", "shear", "von_mises"] + (["safety"] if limit is not None else [])


def _partial(sol, args, errors, k) -> dict:
    """The properties of one solution one by one, recording each failure."""
    out, msgs = {}, [errors[k]] if errors[k] else []
    which, rest = args[0], args[1:]
    for name in which:
        try:
            out.update(_row(sol, (name,), *rest))
        except (FlexmbError, np.linalg.LinAlgError, ArithmeticError, RuntimeError) as exc:
            msgs.append(f"{name}: {exc}")
    errors[k] = "; ".join(msgs)
    return out


def summary(table) -> dict:
    """The extremes of `properties` columns over the range (a `Table`'s rows): the minimum of the
    frequencies ``f<k>.min``, buckling multipliers and safety factors, the maximum of the
    stresses ``<...>.max`` and of the compliance entries' magnitudes ``|C...|.max``; NaN rows
    ignored (NaN when all are)."""
    out = {}
    for name, col in table.items():
        if col.dtype.kind != "f":
            continue
        leaf = name.rsplit(".", 1)[-1]
        ok = col[np.isfinite(col) | np.isinf(col)]
        if name[0] == "f" and name[1:].isdigit() or leaf.startswith("buckling") or leaf == "safety":
            out[f"{name}.min"] = float(ok.min()) if len(ok) else np.nan
        elif leaf in ("normal", "shear", "von_mises"):
            out[f"{name}.max"] = float(ok.max()) if len(ok) else np.nan
        elif name.startswith("C."):
            out[f"|{name}|.max"] = float(np.abs(ok).max()) if len(ok) else np.nan
    return out
