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
- ``plate-*`` (3D): one `Poly3DCollection` per configuration holding, for every beam element of
  rectangular section, the four long faces of the box between its end sections (width and
  thickness to scale, turned with the element's nodes: `flexmb.fe.section_geometry`), and for
  every element of circular section the 16 faces of the tube of its diameter;

`plot_mode` names its two configurations ``-equilibrium`` and ``-mode`` instead.

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

__all__ = ["plot_mechanism", "plot_mode", "plot_frequencies", "plot_force_curve", "plot_trajectory", "plot_strategies", "plot_map", "save"]

# Styles of the two configurations: the undeformed one recedes (light grey, dashed).
_STYLE = {
    "undeformed": {"beam": dict(color="0.6", linestyle="--", linewidth=1.0),
                   "face": "0.75", "edge": "0.55", "alpha": 0.3, "edgestyle": "--"},
    "deformed": {"beam": dict(color="C0", linestyle="-", linewidth=1.6),
                 "face": "C1", "edge": "C1", "alpha": 0.4, "edgestyle": "-"},
}
_STYLE["equilibrium"], _STYLE["mode"] = _STYLE["undeformed"], _STYLE["deformed"]
# Leaves as plates (3D): face colour, edge colour, opacity per configuration.
_PLATE = {"undeformed": ("0.8", "0.6", 0.15), "deformed": ("C0", "C0", 0.45)}
_PLATE["equilibrium"], _PLATE["mode"] = _PLATE["undeformed"], _PLATE["deformed"]
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


def _draw_plates(ax, which: str, model, state, P, poly3d) -> None:
    """The rectangle- and circle-section elements of ``model`` in ``state`` as boxes and tubes of
    their real cross-section (``gid="plate-<which>"``; `flexmb.fe.section_geometry`)."""
    from .fe.section_geometry import section_outlines, shaped_elements

    faces = []
    for shape, idx in shaped_elements(model).items():
        C = section_outlines(model, state, idx, shape, P)  # (E, 2, K, 3)
        k = np.arange(C.shape[2])
        kn = (k + 1) % len(k)
        faces.append(np.stack([C[:, 0, k], C[:, 0, kn], C[:, 1, kn], C[:, 1, k]], axis=2).reshape(-1, 4, 3))
    if not faces:
        return
    face, edge, alpha = _PLATE[which]
    coll = poly3d(list(np.concatenate(faces)), facecolor=face, edgecolor=edge, alpha=alpha, linewidth=0.3)
    coll.set_gid(f"plate-{which}")
    ax.add_collection3d(coll)


def _draw_states(ax, compiled, configs, labels: bool, plates: bool, unit: str, legend: dict | None = None):
    """Draw ``configs`` [(which, State)] of ``compiled``'s model on ``ax``; ``legend`` maps a
    configuration to the label of its first beam line."""
    model = compiled.problem.model
    dim = model.dim
    had_data = ax.has_data()
    poly3d = require("mpl_toolkits.mplot3d.art3d", "plot", "plot_mechanism").Poly3DCollection if dim == 3 else None
    master, segments, seg_kind = _topology("plot_mechanism", model)
    link_of_node = {n: name for name, n in compiled.link_node.items()}
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
        first = len(ax.lines)
        _draw_configuration(ax, which, P, master, segments, seg_kind, bodies, poly3d, tol)
        if legend and which in legend and len(ax.lines) > first:
            ax.lines[first].set_label(legend[which])
        if plates and dim == 3 and seg_kind == "beam":
            _draw_plates(ax, which, model, st, P, poly3d)
        drawn.append(P)
        drawn.extend(named.values())

    if labels:
        st = configs[-1][1]
        for name, n in compiled.link_node.items():
            ax.text(*st.positions[n], name, fontsize=8, ha="left", va="bottom", gid="label")
    suffix = f" [{unit}]" if unit else ""
    ax.set_xlabel("x" + suffix)
    ax.set_ylabel("y" + suffix)
    if dim == 3:
        ax.set_zlabel("z" + suffix)
        _equal_3d(ax, np.concatenate(drawn), had_data)
    else:
        ax.set_aspect("equal", adjustable="datalim")
    return ax


def _unit(owner: str, unit, source=None) -> str:
    """The length unit written on the axes: ``unit``, or with None the declared units' of
    ``source`` (a `Solution`, a `Mechanism`: `flexmb.units`; undeclared: m)."""
    if unit is None:
        from .units import label

        units = getattr(source, "units", None) or getattr(getattr(source, "compiled", None), "units", None)
        return label(units, "length")
    if not isinstance(unit, str):
        raise ParameterError(f"{owner}: unit={unit!r} must be a string (the model's length unit, e.g. 'm', 'mm')")
    return unit


def _magnified(model, state0, state, scale: float):
    """``state`` with its displacements and rotations from ``state0`` times ``scale``."""
    from .fe.model import State
    from .rotations import expm_so3, logm_so3

    pos = state0.positions + scale * (state.positions - state0.positions)
    if model.dim == 2:
        return State(pos, scale * np.asarray(state.rotations), state.multipliers)
    return State(pos, expm_so3(scale * logm_so3(state.rotations)), state.multipliers)


def plot_mechanism(solution, ax=None, *, undeformed: bool = True, deformed: bool = True, labels: bool = True,
                   plates: bool = True, unit: str | None = None, scale: float = 1.0):
    """Draw the undeformed and deformed shape of a mechanism.

    Beam elements are lines between their end points; every rigid link is shaded as the convex
    hull of all points rigidly attached to it (its reference point, the connector blocks of its
    joints, its named points): a filled polygon, a thick line when they are collinear, a square
    when they coincide; rigid bodies inside joints likewise, without a name. In 3D, elements of
    rectangular section (leaf springs) are also drawn as plates of their real width and
    thickness about their line, and of circular section (wires) as tubes of their diameter,
    turned with their nodes. The undeformed shape is light grey and
    dashed, the deformed one in colour. Coordinates are the model's lengths (SI: m), drawn with
    equal aspect ratio.

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
    plates
        Draw rectangle- and circle-section elements as plates and tubes (3D only; planar figures
        show lines).
    unit
        The model's length unit, written on the axes (``"x [m]"``); ``""`` writes none; None
        (default): the mechanism's declared units' (``docs/units.md``; undeclared: ``"m"``).
    scale
        Deformation scale: the deformed shape is drawn with every node's displacement and
        rotation (rotation vector) from the undeformed state times ``scale`` (> 0), to magnify
        small parasitic motions; the title then says so. Default 1: the true shape.

    Returns
    -------
    The axes. See the module docstring for the ``gid`` of each artist.
    """
    owner = "plot_mechanism"
    mfig = _figure_module(owner)
    undeformed = v.flag(owner, "undeformed", undeformed)
    deformed = v.flag(owner, "deformed", deformed)
    labels = v.flag(owner, "labels", labels)
    plates = v.flag(owner, "plates", plates)
    unit = _unit(owner, unit, solution)
    compiled, state0, state = _geometry(owner, solution)
    if state is None:
        deformed = False
    if not (undeformed or deformed):
        raise ParameterError(f"{owner}: undeformed=False and deformed=False draws nothing; set one to True")
    dim = compiled.problem.model.dim
    ax = _axes(owner, mfig, ax, dim, (6.0, 6.0) if dim == 3 else (5.0, 5.0))
    scale = v.positive(owner, "scale", scale)
    if deformed and scale != 1.0:
        state = _magnified(compiled.problem.model, state0, state, scale)
        ax.set_title(f"deformation x {scale:g}")
    configs = ([("undeformed", state0)] if undeformed else []) + ([("deformed", state)] if deformed else [])
    return _draw_states(ax, compiled, configs, labels, plates, unit)


def plot_mode(modes, k: int, ax=None, scale: float | None = None, *, solution=None, labels: bool = False,
              plates: bool = True, unit: str | None = None):
    """Draw mode ``k`` of ``modes`` (`flexmb.modes`): the equilibrium (grey, dashed) and the
    configuration displaced by ``scale`` times the mode shape (colour), 2D or 3D.

    The displaced configuration is the equilibrium's nodes moved by ``scale * shape``
    (positions added, rotations composed with the scaled spins, as a Newton update), so the
    links stay rigid and the leaves' plates (3D) turn with their nodes.

    Parameters
    ----------
    modes
        A `flexmb.Modes`; its ``solution`` is the equilibrium (give ``solution=`` for a `Modes`
        built without one).
    k
        The mode's index in ``modes.frequencies`` (0: the lowest, the table column ``f1``).
    ax
        2D or 3D axes matching the mechanism, or None (a new figure).
    scale
        Deformation scale (the shapes are mass-normalised, so any scale is a choice); default:
        the largest point displacement is 10 % of the mechanism's size
        (`flexmb.fe.section_geometry.mode_scale`).
    solution, labels, plates, unit
        The equilibrium (see ``modes``), link names, plates, length unit as in `plot_mechanism`.

    Returns
    -------
    The axes; title ``"mode <k+1>: <f> Hz (scale <s>)"``, a legend of the two configurations;
    artists' ``gid`` end in ``-equilibrium`` and ``-mode``.
    """
    from .fe.section_geometry import mode_scale
    from .modal import Modes

    owner = "plot_mode"
    mfig = _figure_module(owner)
    if not isinstance(modes, Modes):
        raise ParameterError(f"{owner}: modes must be a flexmb.Modes (from flexmb.modes), got {type(modes).__name__}")
    n = len(modes.frequencies)
    k = v.integer(owner, "k", k, 0)
    if k >= n:
        raise ParameterError(f"{owner}: k={k} must be in [0, {n - 1}] (the modes computed)")
    sol = solution if solution is not None else getattr(modes, "solution", None)
    if sol is None:
        raise ParameterError(f"{owner}: these modes carry no solution; pass solution= (the equilibrium they were "
                             "computed at)")
    compiled, _, state = _geometry(owner, sol)
    model = compiled.problem.model
    shape = np.asarray(modes.shapes[k], dtype=float)
    if shape.shape != (model.n_nodes, model.ndof):
        raise ParameterError(f"{owner}: mode shape of shape {shape.shape} does not fit the solution's model "
                             f"({model.n_nodes} nodes x {model.ndof} DOFs)")
    labels = v.flag(owner, "labels", labels)
    plates = v.flag(owner, "plates", plates)
    unit = _unit(owner, unit, sol)
    scale = mode_scale(model, state, shape) if scale is None else v.finite(owner, "scale", scale)
    du = np.zeros(model.n_dofs)
    du[:model.n_node_dofs] = scale * shape.ravel()
    moved = model.apply_increment(state, du)
    dim = model.dim
    ax = _axes(owner, mfig, ax, dim, (6.0, 6.0) if dim == 3 else (5.0, 5.0))
    f = float(modes.frequencies[k])
    legend = {"equilibrium": "equilibrium", "mode": f"mode {k + 1} x {scale:.3g}"}
    _draw_states(ax, compiled, [("equilibrium", state), ("mode", moved)], labels, plates, unit, legend)
    note = " (unstable: negative eigenvalue)" if f < 0 else ""
    ax.set_title(f"mode {k + 1}: {f:.4g} Hz{note} (scale {scale:.3g})")
    ax.legend(loc="best", fontsize=8)
    return ax


def plot_frequencies(table, x: str, columns=None, ax=None, *, xlabel: str | None = None, degrees: bool = False):
    """Natural frequencies over the stroke (Naves et al. 2017's figure): ``f1`` ... ``fn`` [Hz]
    of a `flexmb.Table` (`flexmb.properties`, ``sweep(..., properties=)``) against column ``x``.

    Parameters
    ----------
    table
        A `flexmb.Table` or mapping of 1-D columns.
    x
        The column on the horizontal axis (e.g. ``"B.rotation_z"`` [rad]).
    columns
        The frequency columns to draw; default every ``f<k>`` column, in order of ``k``.
    ax
        2D axes or None.
    xlabel
        The horizontal axis' label with its unit; default ``x``, with ``[deg]`` when ``degrees``.
    degrees
        ``x`` holds radians: draw it in degrees.

    Returns
    -------
    The axes; one line per column with ``gid`` and label the column's name (NaN rows, an
    unconverged configuration or a failed property, leave gaps); a column with no finite value is
    not drawn and not in the legend.
    """
    owner = "plot_frequencies"
    mfig = _figure_module(owner)
    if not isinstance(table, Mapping):
        raise ParameterError(f"{owner}: table must be a flexmb.Table or a mapping of columns, got "
                             f"{type(table).__name__}")
    if x not in table:
        raise ParameterError(f"{owner}: no column {x!r}; columns: {', '.join(table)}")
    if columns is None:
        columns = sorted((c for c in table if c[:1] == "f" and c[1:].isdigit()), key=lambda c: int(c[1:]))
        if not columns:
            raise ParameterError(f"{owner}: the table has no frequency columns f1, f2, ...; compute them with "
                                 "flexmb.properties(..., which=('modes',)); columns: " + ", ".join(table))
    else:
        columns = _as_list(owner, "columns", columns, "a sequence of column names")
        missing = [c for c in columns if c not in table]
        if missing:
            raise ParameterError(f"{owner}: no column(s) {missing}; columns: {', '.join(table)}")
    degrees = v.flag(owner, "degrees", degrees)
    if xlabel is not None and not isinstance(xlabel, str):
        raise ParameterError(f"{owner}: xlabel={xlabel!r} must be a string or None")
    xs = _series(owner, x, table[x])
    if degrees:
        xs = np.degrees(xs)
    ax = _axes(owner, mfig, ax, 2, (5.0, 3.5))
    drawn = 0
    for c in columns:
        try:
            y = np.asarray(table[c], dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"{owner}: column {c!r} is not numeric") from None
        if y.shape != xs.shape:
            raise ParameterError(f"{owner}: column {c!r} has shape {y.shape}, {x!r} {xs.shape}")
        if not np.isfinite(y).any():
            continue  # nothing to draw: no legend entry either
        ax.plot(xs, y, marker="o", markersize=3, label=c, gid=c)
        drawn += 1
    ax.set_xlabel(xlabel if xlabel is not None else (f"{x} [deg]" if degrees else x))
    ax.set_ylabel("frequency [Hz]")
    if drawn:
        ax.legend(fontsize=8)
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


def plot_trajectory(solutions, link: str, point: str | None = None, ax=None, *, unit: str | None = None,
                    **line_kw):
    """Path of a link's reference point, or of its named ``point``, over a sequence of solutions.

    Parameters
    ----------
    solutions
        `flexmb.Solution` objects of one mechanism (a sweep, a workspace), in path order.
    link, point
        The link, and optionally one of its named points (`Mechanism.add_point`).
    ax
        2D axes for planar mechanisms (an x-y line), 3D axes for spatial ones; None: new figure.
    unit
        The model's length unit, written on the axes (``"x [m]"``); ``""`` writes none; None
        (default): the mechanism's declared units' (``docs/units.md``; undeclared: ``"m"``).
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
    unit = _unit(owner, unit, sols[0])
    suffix = f" [{unit}]" if unit else ""
    X = np.array([s.pose(link)[0] if point is None else s.point(link, point) for s in sols])
    ax = _axes(owner, mfig, ax, dim, (6.0, 6.0) if dim == 3 else (5.0, 5.0))
    had_data = ax.has_data()
    kw = {"marker": "o", "markersize": 3, "label": link if point is None else point, **line_kw}
    kw.setdefault("gid", "trajectory")
    ax.plot(*X.T, **kw)
    ax.set_xlabel("x" + suffix)
    ax.set_ylabel("y" + suffix)
    if dim == 3:
        ax.set_zlabel("z" + suffix)
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

