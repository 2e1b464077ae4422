"""Figures of mechanisms and results (matplotlib, the optional ``plot`` extra).

Every function draws on ``ax`` (a new `matplotlib.figure.Figure` and axes when None) and returns
the axes, so ``ax.figure.savefig(path)`` or `save` writes the figure. Figures are built from
`matplotlib.figure.Figure` directly, never through ``pyplot``: no display and no backend switch
are needed, and nothing is left open in a global figure manager.

Every artist drawn by `plot_mechanism` carries a ``gid`` naming what it shows, so that a figure
can be inspected, e.g. ``[a for a in ax.lines if a.get_gid() == "beam-deformed"]``; each name
ends in ``-undeformed`` or ``-deformed``:

- ``beam-*``: one line per beam element, between its two end points;
- ``flexure-*``: closed-form models (``method="newton"``, no beam elements): one dotted chord
  per flexure, between its two attachment points;
- ``link-*``: one shape per rigid link, the convex hull of its points;
- ``body-*``: rigid bodies inside joints (e.g. the intermediate blocks of ``three_x_infinity``);

and the link names are texts with ``gid="label"``.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from . import _validate as v
from .errors import ModelError, ParameterError, require

__all__ = ["plot_mechanism", "plot_force_curve", "plot_trajectory", "plot_strategies", "plot_map", "save"]

# Styles of the two configurations: the undeformed one recedes (light grey, dashed).
_STYLE = {
    "undeformed": {"beam": dict(color="0.6", linestyle="--", linewidth=1.0),
                   "face": "0.75", "edge": "0.55", "alpha": 0.3, "edgestyle": "--"},
    "deformed": {"beam": dict(color="C0", linestyle="-", linewidth=1.6),
                 "face": "C1", "edge": "C1", "alpha": 0.4, "edgestyle": "-"},
}
# Points closer than this fraction of the mechanism's size count as one (rank of a link's hull).
_RANK_TOL = 1e-9


# -- matplotlib access ---------------------------------------------------------------------------
def _figure_module(feature: str):
    """``matplotlib.figure``, or `MissingExtraError` naming the ``plot`` extra."""
    return require("matplotlib.figure", "plot", f"flexmb.plot.{feature}")


def _is_axes(ax) -> bool:
    return isinstance(ax, importlib.import_module("matplotlib.axes").Axes)


def _is_3d(ax) -> bool:
    return getattr(ax, "name", None) == "3d"


def _new_axes(mfig, dim: int = 2, figsize=(5.0, 4.0)):
    fig = mfig.Figure(figsize=figsize, layout="constrained")
    return fig.add_subplot(projection="3d") if dim == 3 else fig.add_subplot()


def _axes(owner: str, mfig, ax, dim: int, figsize):
    """``ax`` checked against ``dim`` (2D axes for planar data, 3D axes for spatial), or new axes."""
    if ax is None:
        return _new_axes(mfig, dim, figsize)
    if not _is_axes(ax):
        raise ParameterError(f"{owner}: ax={ax!r} must be a matplotlib Axes or None")
    if _is_3d(ax) != (dim == 3):
        want = "fig.add_subplot(projection='3d')" if dim == 3 else "2D axes (fig.add_subplot())"
        raise ParameterError(f"{owner}: ax is {'3D' if _is_3d(ax) else '2D'} but the data are {dim}D; pass {want}")
    return ax


def _equal_3d(ax, pts: np.ndarray, had_data: bool) -> None:
    """Equal data ranges on the three axes and a cubic box: lengths read the same in x, y, z.

    The cube holds ``pts`` and, if the axes held data before, their previous limits."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if had_data:
        old = np.array([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()])
        lo, hi = np.minimum(lo, old[:, 0]), np.maximum(hi, old[:, 1])
    centre, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    half = 1.05 * half if half > 0 else 1.0  # a single point: any cube around it
    ax.set_xlim3d(centre[0] - half, centre[0] + half)
    ax.set_ylim3d(centre[1] - half, centre[1] + half)
    ax.set_zlim3d(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))


# -- the mechanism's geometry ----------------------------------------------------------------------
def _geometry(owner: str, obj):
    """``(compiled, undeformed state, deformed state or None)`` of a Solution or Mechanism."""
    from .errors import UnsupportedStrategyError
    from .mechanism import Mechanism
    from .results import Solution

    if isinstance(obj, Solution):
        model = obj.compiled.problem.model
        if len(obj.state.positions) != model.n_nodes:
            raise ModelError(f"{owner}: the solution's state holds {len(obj.state.positions)} nodes, its model "
                             f"{model.n_nodes}; it cannot be drawn")
        return obj.compiled, model.initial_state(), obj.state
    if isinstance(obj, Mechanism):
        try:
            compiled = obj.compile()
        except UnsupportedStrategyError:  # joints without a beam model: links and chords only
            compiled = obj.compile("closed_form")
        return compiled, compiled.problem.model.initial_state(), None
    raise ParameterError(f"{owner}: solution={obj!r} must be a flexmb.Solution or flexmb.Mechanism, "
                         f"got {type(obj).__name__}")


def _topology(owner: str, model):
    """``(point_master (P,), segments (S, 2) point indices, segment kind)`` of a model.

    The finite-element model's segments are its beam elements; the closed-form model of
    ``method="newton"`` has no beam elements, only each flexure's two attachment points (its
    `point_positions` are the link reference points, then each flexure's first and end point),
    so its segments are the flexures' chords."""
    if hasattr(model, "elements") and hasattr(model, "point_master"):
        return np.asarray(model.point_master), np.asarray(model.elements.ends).reshape(-1, 2), "beam"
    flex = getattr(model, "flexures", None)
    if flex is not None:
        n, F = model.n_nodes, len(flex.i)
        master = np.concatenate([np.arange(n), np.stack([flex.i, flex.j], axis=1).ravel()])
        return master, n + np.arange(2 * F).reshape(F, 2), "flexure"
    raise ModelError(f"{owner}: cannot draw a model of type {type(model).__name__} "
                     "(neither beam elements nor closed-form flexures)")


def _named_points(compiled, model, state) -> dict:
    """Current positions [m] of the named points, grouped by link: ``{link: (K, dim)}``."""
    out: dict = {}
    for link, offset in compiled.points.values():
        n = compiled.link_node[link]
        x = state.positions[n] + model.offsets(state, np.array([n]), np.asarray(offset, float)[None])[0]
        out.setdefault(link, []).append(x)
    return {k: np.array(x) for k, x in out.items()}


def _shape(pts: np.ndarray, tol: float):
    """The convex hull of ``pts`` (K, dim) as ``("point", p)``, ``("segment", (2, dim))``,
    ``("polygon", (V, dim) vertices in order)`` or ``("solid", triangles (T, 3, 3))``.

    The affine rank decides (singular values above ``tol``), so collinear blocks become a
    segment and flat 3D blocks one polygon in their own plane, where Qhull would fail."""
    from scipy.spatial import ConvexHull, QhullError

    c = pts.mean(axis=0)
    _, s, vt = np.linalg.svd(pts - c, full_matrices=False)
    rank = int(np.sum(s > tol))
    if rank >= 2:
        try:
            if rank == 3:
                hull = ConvexHull(pts)
                return "solid", pts[hull.simplices]
            hull = ConvexHull((pts - c) @ vt[:2].T)  # in the points' own plane
            return "polygon", pts[hull.vertices]
        except QhullError:  # nearly degenerate despite the tolerance: draw the longest extent
            pass
    if rank == 0:
        return "point", c
    t = (pts - c) @ vt[0]
    return "segment", pts[[int(np.argmin(t)), int(np.argmax(t))]]


def _draw_shape(ax, kind: str, geom, style: dict, gid: str, poly3d) -> None:
    face, edge, alpha, ls = style["face"], style["edge"], style["alpha"], style["edgestyle"]
    if kind == "point":
        ax.plot(*np.asarray(geom)[:, None], marker="s", markersize=6, color=face, alpha=alpha + 0.3,
                linestyle="none", gid=gid)
    elif kind == "segment":
        ax.plot(*geom.T, color=face, alpha=alpha + 0.2, linewidth=6.0, solid_capstyle="round", gid=gid)
    elif _is_3d(ax):
        alpha *= 0.6  # faces in 3D overlap the beams behind them: lighter
        polys = [geom] if kind == "polygon" else list(geom)
        coll = poly3d(polys, facecolor=face, edgecolor=edge, alpha=alpha, linestyle=ls, linewidth=0.8)
        coll.set_gid(gid)
        ax.add_collection3d(coll)
    else:
        ax.fill(*geom.T, facecolor=face, edgecolor=edge, alpha=alpha, linestyle=ls, linewidth=0.8, gid=gid)


def _draw_configuration(ax, which: str, P: np.ndarray, master, segments, seg_kind, bodies, poly3d, tol):
    style = _STYLE[which]
    line = dict(style["beam"])
    if seg_kind == "flexure":  # a chord stands for a curved flexure: thin and dotted
        line.update(linestyle=":", linewidth=1.0)
    for a, b in segments:
        ax.plot(*np.stack([P[a], P[b]]).T, gid=f"{seg_kind}-{which}", **line)
    for kind, pts in bodies:
        shape, geom = _shape(pts, tol)
        if kind == "body" and shape == "point":
            continue  # coincident points on a joint's internal node: a beam node, not a body
        _draw_shape(ax, shape, geom, style, f"{kind}-{which}", poly3d)


def plot_mechanism(solution, ax=None, *, undeformed: bool = True, deformed: bool = True, labels: bool = True):
    """Draw the undeformed and deformed shape of a mechanism.

    Beam elements are lines between their end points; every rigid link is shaded as the convex
    hull of all points rigidly attached to it (its reference point, the connector blocks of its
    joints, its named points): a filled polygon, a thick line when they are collinear, a square
    when they coincide; rigid bodies inside joints likewise, without a name. The undeformed shape
    is light grey and dashed, the deformed one in colour. Coordinates are the model's lengths
    (SI: m), drawn with equal aspect ratio.

    Parameters
    ----------
    solution
        A solved `flexmb.Solution` or an unsolved `flexmb.Mechanism` (undeformed shape only;
        ``deformed`` is then ignored). Closed-form solutions (``method="newton"``) have no beam
        elements: their flexures are drawn as dotted chords between their attachment points.
    ax
        Axes to draw on: 2D axes for planar mechanisms, 3D axes
        (``fig.add_subplot(projection="3d")``) for spatial ones; None makes a new figure.
    undeformed, deformed
        Which configurations to draw.
    labels
        Write the link names at their reference points (deformed, if drawn).

    Returns
    -------
    The axes. See the module docstring for the ``gid`` of each artist.
    """
    owner = "plot_mechanism"
    mfig = _figure_module(owner)
    undeformed = v.flag(owner, "undeformed", undeformed)
    deformed = v.flag(owner, "deformed", deformed)
    labels = v.flag(owner, "labels", labels)
    compiled, state0, state = _geometry(owner, solution)
    if state is None:
        deformed = False
    if not (undeformed or deformed):
        raise ParameterError(f"{owner}: undeformed=False and deformed=False draws nothing; set one to True")
    model = compiled.problem.model
    dim = model.dim
    ax = _axes(owner, mfig, ax, dim, (6.0, 6.0) if dim == 3 else (5.0, 5.0))
    had_data = ax.has_data()
    poly3d = require("mpl_toolkits.mplot3d.art3d", "plot", owner).Poly3DCollection if dim == 3 else None
    master, segments, seg_kind = _topology(owner, model)
    link_of_node = {n: name for name, n in compiled.link_node.items()}

    configs = ([("undeformed", state0)] if undeformed else []) + ([("deformed", state)] if deformed else [])
    drawn = []
    for which, st in configs:
        P = model.point_positions(st)
        named = _named_points(compiled, model, st)
        bodies = []
        for node in np.unique(master):
            pts = P[master == node]
            name = link_of_node.get(int(node))
            if name is not None and name in named:
                pts = np.concatenate([pts, named[name]])
            if name is None and len(pts) < 2:
                continue  # a joint's internal node on one point: a beam node
            bodies.append(("link" if name is not None else "body", pts))
        tol = _RANK_TOL * max(float(np.ptp(P, axis=0).max()), np.finfo(float).tiny)
        _draw_configuration(ax, which, P, master, segments, seg_kind, bodies, poly3d, tol)
        drawn.append(P)
        drawn.extend(named.values())

    if labels:
        st = configs[-1][1]
        for name, n in compiled.link_node.items():
            ax.text(*st.positions[n], name, fontsize=8, ha="left", va="bottom", gid="label")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if dim == 3:
        ax.set_zlabel("z")
        _equal_3d(ax, np.concatenate(drawn), had_data)
    else:
        ax.set_aspect("equal", adjustable="datalim")
    return ax


def _as_list(owner: str, name: str, value, what: str, single: tuple = ()) -> list:
    """``value`` as a list; a string, a lone ``single`` instance or a non-iterable is refused."""
    if isinstance(value, (str, bytes, *single)):
        raise ParameterError(f"{owner}: {name} must be {what}, got one {type(value).__name__}")
    try:
        return list(value)
    except TypeError:
        raise ParameterError(f"{owner}: {name} must be {what}, got {type(value).__name__}") from None


# -- result curves -------------------------------------------------------------------------------
def _series(owner: str, name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{owner}: {name} must be a 1D array of real numbers, "
                             f"got {type(value).__name__}") from None
    if a.ndim != 1 or a.size == 0:
        raise ParameterError(f"{owner}: {name} must be a non-empty 1D array, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{owner}: {name} must be finite (no NaN/inf)")
    return a


def _reference_values(owner: str, reference, x: np.ndarray) -> np.ndarray:
    if callable(reference):
        try:  # vectorised first; a scalar-only function (float(d), math.*) element by element
            y = np.asarray(reference(x), dtype=float)
        except (TypeError, ValueError):
            y = np.array([float(reference(float(d))) for d in x])
        if y.ndim == 0:
            y = np.full(x.shape, float(y))
    else:
        y = _series(owner, "reference", reference)
    if y.shape != x.shape:
        raise ParameterError(f"{owner}: reference gives shape {y.shape}, displacement has {x.shape}")
    if not np.all(np.isfinite(y)):
        raise ParameterError(f"{owner}: reference must be finite (no NaN/inf)")
    return y


def plot_force_curve(displacement, force, *, reference: np.ndarray | Callable | None = None,
                     reference_label: str = "linear", xlabel: str = "displacement [m]",
                     ylabel: str = "force [N]", label: str | None = None, ax=None):
    """Actuation force against displacement, optionally beside a reference curve.

    Parameters
    ----------
    displacement
        Actuation displacements [m] (or the model's length unit), shape (n,).
    force
        Actuation forces [N] (or the model's force unit), shape (n,); drawn with markers.
    reference
        A reference force, shape (n,), or a callable of the displacement array giving it (called
        element by element if it only takes scalars); drawn dashed black, named ``reference_label``.
    xlabel, ylabel, label
        Axis labels (give the units) and the legend entry of ``force``.
    ax
        2D axes to draw on; None makes a new figure.

    Returns
    -------
    The axes; the force line has ``gid="force"``, the reference ``gid="reference"``.
    """
    owner = "plot_force_curve"
    mfig = _figure_module(owner)
    x = _series(owner, "displacement", displacement)
    f = _series(owner, "force", force)
    if f.shape != x.shape:
        raise ParameterError(f"{owner}: force has shape {f.shape}, displacement {x.shape}; they must match")
    for name, text in (("xlabel", xlabel), ("ylabel", ylabel), ("reference_label", reference_label)):
        if not isinstance(text, str):
            raise ParameterError(f"{owner}: {name}={text!r} must be a string")
    if label is not None and not isinstance(label, str):
        raise ParameterError(f"{owner}: label={label!r} must be a string or None")
    ref = None if reference is None else _reference_values(owner, reference, x)
    ax = _axes(owner, mfig, ax, 2, (5.0, 3.5))
    ax.plot(x, f, marker="o", markersize=3, label=label, gid="force")
    if ref is not None:
        ax.plot(x, ref, linestyle="--", color="k", linewidth=1.0, label=reference_label, gid="reference")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if label is not None or ref is not None:
        ax.legend()
    return ax


def plot_trajectory(solutions, link: str, point: str | None = None, ax=None, **line_kw):
    """Path of a link's reference point, or of its named ``point``, over a sequence of solutions.

    Parameters
    ----------
    solutions
        `flexmb.Solution` objects of one mechanism (a sweep, a workspace), in path order.
    link, point
        The link, and optionally one of its named points (`Mechanism.add_point`).
    ax
        2D axes for planar mechanisms (an x-y line), 3D axes for spatial ones; None: new figure.
    line_kw
        Passed to ``ax.plot`` (default: markers ``"o"``, the label ``point`` or ``link``).

    Returns
    -------
    The axes; the path is the line with ``gid="trajectory"``, coordinates in [m] (model units).
    """
    from .results import Solution

    owner = "plot_trajectory"
    mfig = _figure_module(owner)
    sols = _as_list(owner, "solutions", solutions, "a sequence of flexmb.Solution", (Solution,))
    if not sols:
        raise ParameterError(f"{owner}: solutions is empty")
    for i, s in enumerate(sols):
        if not isinstance(s, Solution):
            raise ParameterError(f"{owner}: solutions[{i}] is a {type(s).__name__}, not a flexmb.Solution")
    dims = {s.dim for s in sols}
    if len(dims) != 1:
        raise ParameterError(f"{owner}: solutions mix planar and spatial mechanisms (dim {sorted(dims)})")
    dim = dims.pop()
    X = np.array([s.pose(link)[0] if point is None else s.point(link, point) for s in sols])
    ax = _axes(owner, mfig, ax, dim, (6.0, 6.0) if dim == 3 else (5.0, 5.0))
    had_data = ax.has_data()
    kw = {"marker": "o", "markersize": 3, "label": link if point is None else point, **line_kw}
    kw.setdefault("gid", "trajectory")
    ax.plot(*X.T, **kw)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if dim == 3:
        ax.set_zlabel("z")
        _equal_3d(ax, X, had_data)
    else:
        ax.set_aspect("equal", adjustable="datalim")
    return ax


def plot_strategies(records, ax=None):
    """Compare solver strategies: Newton iterations and wall time, side by side.

    Parameters
    ----------
    records
        One mapping per run with ``"method"`` (str), ``"iterations"`` (int >= 0), ``"time"``
        [s] (> 0, drawn on a log scale) and optionally ``"label"`` (the bar's name, default
        the method).
    ax
        None (a new figure with two panels) or a pair of 2D axes (iterations, time).

    Returns
    -------
    ``(ax_iterations, ax_time)``; the bars have ``gid="iterations"`` and ``gid="time"``.
    """
    owner = "plot_strategies"
    mfig = _figure_module(owner)
    records = _as_list(owner, "records", records, "a list of dicts", (Mapping,))
    if not records:
        raise ParameterError(f"{owner}: records is empty")
    names, iters, times = [], [], []
    for i, r in enumerate(records):
        where = f"{owner}: records[{i}]"
        if not isinstance(r, Mapping):
            raise ParameterError(f"{where} is a {type(r).__name__}, not a dict")
        missing = [k for k in ("method", "iterations", "time") if k not in r]
        if missing:
            raise ParameterError(f"{where} lacks {', '.join(map(repr, missing))}")
        if not isinstance(r["method"], str):
            raise ParameterError(f"{where}: method={r['method']!r} must be a string")
        lab = r.get("label", r["method"])
        if not isinstance(lab, str):
            raise ParameterError(f"{where}: label={lab!r} must be a string")
        names.append(lab)
        iters.append(v.integer(where, "iterations", r["iterations"], 0))
        times.append(v.positive(where, "time", r["time"]))
    if ax is None:
        fig = mfig.Figure(figsize=(8.0, 3.5), layout="constrained")
        axes = tuple(fig.subplots(1, 2))
    else:
        axes = tuple(_as_list(owner, "ax", ax, "None or a pair of matplotlib Axes"))
        if len(axes) != 2 or not all(_is_axes(a) and not _is_3d(a) for a in axes):
            raise ParameterError(f"{owner}: ax must be None or a pair of 2D matplotlib Axes")
    x = np.arange(len(records))
    colours = [f"C{k % 10}" for k in range(len(records))]
    rotate = 30 if max(map(len, names)) > 10 else 0
    for a, values, gid, ylabel, fmt in ((axes[0], iters, "iterations", "Newton iterations", "%d"),
                                        (axes[1], times, "time", "time [s]", "%.3g")):
        bars = a.bar(x, values, color=colours, gid=gid)
        a.bar_label(bars, fmt=fmt, fontsize=8)
        a.set_xticks(x, names, rotation=rotate, ha="right" if rotate else "center")
        a.set_ylabel(ylabel)
    axes[1].set_yscale("log")
    return axes


def plot_map(table, x: str, y: str, value: str, *, ax=None, label: str | None = None, log: bool = False):
    """A map of ``table[value]`` over a full grid of two inputs (a `flexmb.study.grid` study).

    ``table`` is a `flexmb.Table` (or mapping of 1-D arrays) with one row per grid point;
    ``x``, ``y``, ``value`` name its columns. Drawn as coloured cells (``pcolormesh``,
    ``gid="map"``) with a colour bar labelled ``label`` (default ``value``); ``log`` colours
    by log10 of the value. Returns the axes.
    """
    owner = "plot_map"
    mfig = _figure_module(owner)
    if not isinstance(table, Mapping):
        raise ParameterError(f"{owner}: table must be a flexmb.Table or a mapping of columns, got "
                             f"{type(table).__name__}")
    cols = {}
    for name in (x, y, value):
        if name not in table:
            raise ParameterError(f"{owner}: no column {name!r}; columns: {', '.join(table)}")
        cols[name] = _series(owner, name, table[name])
    xs, ys = np.unique(cols[x]), np.unique(cols[y])
    if len(cols[x]) != len(xs) * len(ys):
        raise ParameterError(f"{owner}: {x!r} and {y!r} do not form a full grid ({len(cols[x])} rows for "
                             f"{len(xs)} x {len(ys)} values)")
    Z = np.full((len(ys), len(xs)), np.nan)
    Z[np.searchsorted(ys, cols[y]), np.searchsorted(xs, cols[x])] = cols[value]
    if np.isnan(Z).any():
        raise ParameterError(f"{owner}: {x!r} and {y!r} do not form a full grid (repeated pairs)")
    log = v.flag(owner, "log", log)
    ax = _axes(owner, mfig, ax, 2, (5.0, 4.0))
    mesh = ax.pcolormesh(xs, ys, np.log10(Z) if log else Z, shading="nearest", gid="map")
    ax.figure.colorbar(mesh, ax=ax, label=(f"log10 {label or value}" if log else label or value))
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    return ax


def save(ax_or_fig, path, dpi: float = 120) -> Path:
    """Write a figure to ``path`` and return it as a `Path`.

    Parameters
    ----------
    ax_or_fig
        A matplotlib Figure, Axes, or a pair of axes (as `plot_strategies` returns).
    path
        File name; without a suffix ``.png`` is added (another suffix picks that format, e.g.
        ``.pdf``). Missing parent directories are made.
    dpi
        Resolution [dots per inch], > 0.
    """
    owner = "save"
    mfig = _figure_module(owner)
    obj = ax_or_fig
    if isinstance(obj, (tuple, list)) and obj:
        obj = obj[0]
    if _is_axes(obj):
        fig = obj.figure
    elif isinstance(obj, mfig.Figure):
        fig = obj
    else:
        raise ParameterError(f"{owner}: ax_or_fig={ax_or_fig!r} must be a matplotlib Figure or Axes")
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"{owner}: path={path!r} must be a str or os.PathLike")
    dpi = v.positive(owner, "dpi", dpi)
    out = Path(path)
    if not out.suffix:
        out = out.with_suffix(".png")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    return out

