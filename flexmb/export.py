"""Deformed configurations as VTK files for ParaView (optional extra ``export``: meshio).

`to_meshio` turns a finite-element `Solution` into a `meshio.Mesh`; `write_vtk` writes one
configuration (``.vtu``, XML unstructured grid, or legacy ``.vtk``); `write_series` writes a
sweep as numbered ``.vtu`` files and a ParaView collection (``.pvd``) that plays them as
time steps; `mode_mesh` and `write_mode` write a vibration mode (`flexmb.modes`) about its
equilibrium, the leaves as solids (layout: `mode_mesh`).

Mesh layout
-----------
Points
    Every point of the finite-element model, in the order of `Solution.node_positions`
    (link reference points first, then each joint's points), in 3D coordinates [m]; planar
    models get z = 0.
Cells
    Two blocks of ``"line"`` cells: first the beam elements, in the model's element order, then
    the rigid connections, one line from the reference point of each rigid body (a link, or a
    rigid intermediate body inside a joint such as `ThreeXInfinity`'s) to every other point
    attached to it, so that connector blocks and link arms show as thin lines. Points that
    coincide with their body's reference point get no line. The VTK formats do not keep
    blocks, so a file read back holds one ``"line"`` block: the beams first, then the rigid
    lines (tell them apart by ``kind``).
Point data
    ``"displacement"`` [m] (P, 3): current minus undeformed position, z = 0 in 2D;
    ``"rotation"`` [rad] (P, 3): rotation vector of the body (FE node) the point is attached
    to, relative to the undeformed configuration; ``(0, 0, angle)`` in 2D.
Cell data
    ``"kind"``: 0 beam element, 1 rigid connection; ``"joint"``: index of the joint owning the
    cell (order of ``mesh.info["joints"]``, the order joints were added), -1 for the rigid
    connections of links; ``"link"``: index of the link a rigid connection belongs to (order
    of ``mesh.info["links"]``), -1 for beams and for rigid bodies inside joints;
    ``"peak_stress"`` [Pa]: `Solution.peak_stress` for beams (NaN when a section lacks its
    extreme-fibre distances), 0 for rigid connections.
Field data
    The solution's ``"converged"`` (1 or 0), ``"load_factor"`` and ``"iterations"``, and
    ``"undeformed"`` (1 when the undeformed configuration was written); written into ``.vtu`` files
    (ParaView's Information panel; meshio's VTK writers drop field data, so flexmb adds it), not
    into legacy ``.vtk`` files. ``mesh.info`` (in memory only) also holds the method, the
    solver message and the link and joint names.
"""

from __future__ import annotations

import math
import os
import pathlib
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence

import numpy as np

from ._validate import finite
from .errors import ModelError, ParameterError, UnsupportedStrategyError, require
from .fe.model import FEModel
from .fe.section_geometry import mode_scale, point_motion, section_outlines, shaped_elements
from .fe.stress import peak_normal_stress
from .results import Solution
from .rotations import logm_so3

__all__ = ["to_meshio", "write_vtk", "write_series", "mode_mesh", "write_mode"]

FEATURE = "flexmb.export"
SUFFIXES = {".vtu": "vtu", ".vtk": "vtk"}  # suffix -> meshio file_format
KIND_BEAM, KIND_RIGID = 0, 1


def to_meshio(solution: Solution, *, undeformed: bool = False):
    """The configuration of ``solution`` as a `meshio.Mesh` (layout: see the module docstring).

    Parameters
    ----------
    solution
        A finite-element solution (conventional, KSD-full or KSD-reduced: any strategy whose
        model has beam elements); a non-converged one gives the configuration at the load factor
        reached (field data ``converged`` 0, ``load_factor`` < 1).
    undeformed
        Write the undeformed configuration instead: undeformed positions [m], zero
        displacement, rotation and stress.

    Returns
    -------
    meshio.Mesh
        Points (P, 3) [m], two ``"line"`` cell blocks (beams, rigid connections), point, cell
        and field data.

    Raises
    ------
    MissingExtraError
        meshio is not installed (``pip install 'flexmb[export]'``).
    ParameterError
        ``solution`` is not a `Solution`.
    UnsupportedStrategyError
        ``solution`` has no finite-element model (``method="newton"``).
    """
    meshio = require("meshio", "export", FEATURE)
    model = _fe_model("to_meshio", solution)
    state = model.initial_state() if undeformed else solution.state
    P = len(model.point_master)

    x = model.point_x0 if undeformed else model.point_positions(state)
    disp = np.zeros((P, model.dim)) if undeformed else x - model.point_x0
    if model.dim == 2:
        rot = np.zeros((P, 3))
        rot[:, 2] = state.rotations[model.point_master]
    else:
        rot = logm_so3(state.rotations)[model.point_master]

    el = model.elements
    E = len(el.L0)
    try:
        stress = peak_normal_stress(model, state)
    except ModelError:  # a plugin's section without ymax / zmax: export the geometry anyway
        stress = np.full(E, np.nan)

    n_links = len(solution.compiled.link_node)
    joint_names = list(solution.compiled.joint_elements)
    rigid, master = _rigid_connections(model)
    joint_of_node = np.full(model.n_nodes, -1)
    for j, name in enumerate(joint_names):
        joint_of_node[solution.compiled.joint_nodes.get(name, [])] = j
    is_link = master < n_links

    i32 = np.int32
    cells = [("line", np.asarray(el.ends, dtype=np.int64))]
    cell_data = {
        "kind": [np.full(E, KIND_BEAM, dtype=i32)],
        "joint": [np.asarray(el.owner, dtype=i32)],
        "link": [np.full(E, -1, dtype=i32)],
        "peak_stress": [np.asarray(stress, dtype=float)],
    }
    if len(rigid):  # an empty block would only confuse readers of cell_data
        cells.append(("line", rigid))
        R = len(rigid)
        for key, value in (("kind", np.full(R, KIND_RIGID)), ("joint", joint_of_node[master]),
                           ("link", np.where(is_link, master, -1)), ("peak_stress", np.zeros(R))):
            cell_data[key].append(value.astype(float if key == "peak_stress" else i32))

    return meshio.Mesh(
        _pad3(x), cells,
        point_data={"displacement": _pad3(disp), "rotation": rot},
        cell_data=cell_data,
        field_data={"converged": np.array([int(bool(solution.converged))], dtype=i32),
                    "load_factor": np.array([float(solution.load_factor)]),
                    "iterations": np.array([int(solution.iterations)], dtype=i32),
                    "undeformed": np.array([int(bool(undeformed))], dtype=i32)},
        info={"method": solution.method, "converged": bool(solution.converged), "undeformed": bool(undeformed),
              "message": solution.message,
              "links": sorted(solution.compiled.link_node, key=solution.compiled.link_node.get),
              "joints": joint_names},
    )


def write_vtk(solution: Solution, path: str | os.PathLike, *, undeformed: bool = False) -> pathlib.Path:
    """Write the configuration of ``solution`` to ``path`` for ParaView; returns ``path``.

    Parameters
    ----------
    solution
        A finite-element `Solution` (see `to_meshio`).
    path
        Output file; its suffix picks the format: ``.vtu`` (XML unstructured grid, compressed,
        with field data) or ``.vtk`` (legacy binary). The directory must exist. The file is
        written under a temporary name and renamed: a failed write leaves no partial file and
        an earlier file at ``path`` unchanged.
    undeformed
        Write the undeformed configuration (see `to_meshio`).

    Raises
    ------
    ParameterError
        ``path`` has another suffix or cannot be written (a missing or read-only folder, a full
        disk), or ``solution`` is not a `Solution`.
    UnsupportedStrategyError, MissingExtraError
        As `to_meshio`.
    """
    require("meshio", "export", FEATURE)
    path = _checked_path("write_vtk", path, SUFFIXES)
    mesh = to_meshio(solution, undeformed=undeformed)
    return _write_atomically("write_vtk", mesh, path)


def write_series(solutions: Iterable[Solution], path: str | os.PathLike, *,
                 times: Sequence[float] | None = None) -> pathlib.Path:
    """Write a sequence of solutions (a sweep) as a ParaView collection; returns ``path``.

    Writes ``<stem>_0000.vtu``, ``<stem>_0001.vtu``, ... next to ``path`` (one per solution,
    see `write_vtk`) and the collection ``path`` itself, a ``.pvd`` file listing them with their
    time steps; open the ``.pvd`` in ParaView and step through the sweep with the time controls.
    All files are written under temporary names first and renamed into place only when every one
    was written (the collection last): a failure leaves no partial series and an earlier series
    of that name unchanged.

    Parameters
    ----------
    solutions
        Finite-element `Solution` objects, e.g. the result of `flexmb.sweep`; at least one.
    path
        The collection file, suffix ``.pvd``; its directory must exist.
    times
        Time step of each solution, e.g. the sweep's forces [N] or rotations [rad]; finite,
        one per solution; default 0, 1, 2, ...

    Raises
    ------
    ParameterError
        No solutions, an item that is not a `Solution`, a suffix other than ``.pvd``,
        ``times`` of the wrong length or not finite, or a file that cannot be written.
    UnsupportedStrategyError, MissingExtraError
        As `to_meshio`.
    """
    require("meshio", "export", FEATURE)
    path = _checked_path("write_series", path, {".pvd": None})
    if isinstance(solutions, Solution):
        raise ParameterError("write_series: solutions must be a sequence of Solution objects, got one "
                             "Solution; use write_vtk for a single configuration")
    try:
        solutions = list(solutions)
    except TypeError:
        raise ParameterError(f"write_series: solutions must be a sequence of Solution objects, "
                             f"got {type(solutions).__name__}") from None
    if not solutions:
        raise ParameterError("write_series: solutions is empty; give at least one Solution")
    for i, s in enumerate(solutions):
        _fe_model(f"write_series: solutions[{i}]", s)  # check all before writing any file
    n = len(solutions)
    if times is None:
        times = list(range(n))
    else:
        try:
            times = [float(t) for t in times]
        except (TypeError, ValueError):
            raise ParameterError(f"write_series: times must be a sequence of {n} numbers, got {times!r}") from None
        if len(times) != n or not all(math.isfinite(t) for t in times):
            raise ParameterError(f"write_series: times must hold {n} finite numbers (one per solution), "
                                 f"got {len(times)}: {times!r}")

    width = max(4, len(str(n - 1)))
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    staged = []  # (temporary, final): every file is written aside first, then all are renamed
    try:
        for i, (s, t) in enumerate(zip(solutions, times)):
            name = f"{path.stem}_{i:0{width}d}.vtu"
            staged.append((_staged(path.with_name(name)), path.with_name(name)))
            _write(to_meshio(s), staged[-1][0])
            ET.SubElement(collection, "DataSet", timestep=repr(t), group="", part="0", file=name)
        tree = ET.ElementTree(root)
        ET.indent(tree)
        staged.append((_staged(path), path))
        tree.write(staged[-1][0], xml_declaration=True, encoding="utf-8")
        for tmp, final in staged:  # the collection last: it never lists a file not yet in place
            os.replace(tmp, final)
    except OSError as exc:
        raise ParameterError(f"write_series: cannot write {str(path)!r}: {exc.strerror or exc}; nothing was "
                             "written") from None
    finally:
        for tmp, _ in staged:
            _discard(tmp)
    return path


def mode_mesh(modes, k: int, *, solution: Solution | None = None, scale: float | None = None,
              sections: bool = True):
    """Mode ``k`` of ``modes`` (`flexmb.modes`) about its equilibrium as a `meshio.Mesh`.

    Layout
    ------
    Points
        The model's points at the equilibrium [m] (as `to_meshio`), then, with ``sections``, the
        corners of the rectangle-section elements' end sections and the outline points of the
        circle-section ones (`flexmb.fe.section_geometry`; a point shared by consecutive elements
        of one leaf or wire is one point).
    Cells
        With ``sections``: one ``"hexahedron"`` per rectangle-section element, the box between its
        end sections, its real width and thickness (planar models: the width out of the plane,
        z = +-width/2). Hexahedra rather than quads of the mid-surface: the thickness is seen, a
        twisting leaf's four faces are, and ParaView's solid filters (slice, surface, volume)
        apply. A circle-section element is the prism on the 16-gon of its diameter, as 8
        hexahedra about its centreline (each the element's end points and three consecutive
        outline points per end; `flexmb.fe.section_geometry.CIRCLE_POINTS`), those of
        rectangles first. Then ``"line"`` cells for the other beam elements (every element
        without ``sections``) and the rigid connections (as `to_meshio`).
    Point data
        ``"mode"`` (P, 3): the linearised displacement of each point in the mass-normalised shape,
        ``du + dphi x r`` (units: length / sqrt(mass)); ``"mode_scaled"`` = ``scale * mode``
        [m]; ``"mode_rotation"`` (P, 3): the spin of the point's body (2D: ``(0, 0, dtheta)``).
        ParaView: Warp By Vector on ``mode_scaled`` (scale factor 1 shows the default picture;
        animate the factor between -1 and 1 to play the vibration).
    Cell data
        ``"kind"`` (0 beam element, 1 rigid connection) and ``"joint"`` (as `to_meshio`).
    Field data
        ``"frequency"`` [Hz], ``"mode"`` (k), ``"scale"``.

    ``scale`` default: the largest point displacement is 10 % of the mechanism's size
    (`flexmb.fe.section_geometry.mode_scale`, as `flexmb.plot.plot_mode`: small parasitic motions
    magnified). ``solution``: the
    equilibrium, for `Modes` that carry none.
    """
    from .modal import Modes

    owner = "mode_mesh"
    meshio = require("meshio", "export", FEATURE)
    if not isinstance(modes, Modes):
        raise ParameterError(f"{owner}: modes must be a flexmb.Modes (from flexmb.modes), got {type(modes).__name__}")
    n = len(modes.frequencies)
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < n:
        raise ParameterError(f"{owner}: k={k!r} must be an integer in [0, {n - 1}] (the modes computed)")
    sol = solution if solution is not None else modes.solution
    if sol is None:
        raise ParameterError(f"{owner}: these modes carry no solution; pass solution= (their equilibrium)")
    model = _fe_model(owner, sol)
    state = sol.state
    shape = np.asarray(modes.shapes[k], dtype=float)
    if shape.shape != (model.n_nodes, model.ndof):
        raise ParameterError(f"{owner}: the mode shape {shape.shape} does not fit the solution's model "
                             f"({model.n_nodes} nodes x {model.ndof} DOFs)")
    x = _pad3(model.point_positions(state))
    master = np.asarray(model.point_master)
    el = model.elements
    shaped = shaped_elements(model) if sections else {}
    solids = np.concatenate([np.zeros(0, dtype=np.int64), *shaped.values()])
    lines = np.setdiff1d(np.arange(len(el.L0)), solids)
    points, owners = [x], [master]
    cells, kind, joint = [], [], []
    key, corner_pts, corner_master = {}, [], []
    for form, idx in shaped.items():
        C = section_outlines(model, state, idx, form)  # (E, 2, K, 3)
        # right-hand normal of outline points 0-1-2 towards the far end, as VTK's hexahedron wants
        nrm = np.cross(C[:, 0, 1] - C[:, 0, 0], C[:, 0, 2] - C[:, 0, 1])
        flip = np.einsum("ei,ei->e", nrm, C[:, 1].mean(axis=1) - C[:, 0].mean(axis=1)) < 0
        C[flip] = C[flip][:, :, ::-1]
        ends = el.ends[idx]
        K = C.shape[2]
        ids = np.empty((len(idx), 2, K), dtype=np.int64)  # the outline points' indices in the mesh
        for e, i in enumerate(idx):
            sec = el.sections[i]
            for end in range(2):
                for c in range(K):
                    ident = (int(ends[e, end]), id(sec), bool(flip[e]), c, tuple(np.round(C[e, end, c], 12)))
                    if ident not in key:
                        key[ident] = len(x) + len(corner_pts)
                        corner_pts.append(C[e, end, c])
                        corner_master.append(master[ends[e, end]])
                    ids[e, end, c] = key[ident]
        if form == "rectangle":  # the box between the end sections
            hexes = ids.reshape(len(idx), 8)
            owner = np.asarray(el.owner)[idx]
        else:  # the polygon's prism as K/2 hexahedra about the centreline: (centre, k, k+1, k+2) per end
            fan = (np.arange(0, K, 2)[:, None] + np.arange(3)) % K
            centre = np.broadcast_to(ends[:, :, None, None], (len(idx), 2, K // 2, 1))
            quads = np.concatenate([centre, ids[:, :, fan]], axis=3)  # (E, 2, K/2, 4)
            hexes = quads.transpose(0, 2, 1, 3).reshape(-1, 8)
            owner = np.repeat(np.asarray(el.owner)[idx], K // 2)
        cells.append(("hexahedron", hexes))
        kind.append(np.full(len(hexes), KIND_BEAM))
        joint.append(owner)
    if corner_pts:
        points.append(np.array(corner_pts))
        owners.append(np.array(corner_master, dtype=np.int64))
    if len(lines):
        cells.append(("line", np.asarray(el.ends, dtype=np.int64)[lines]))
        kind.append(np.full(len(lines), KIND_BEAM))
        joint.append(np.asarray(el.owner)[lines])
    rigid, rmaster = _rigid_connections(model)
    if len(rigid):
        joint_of_node = np.full(model.n_nodes, -1)
        for j, name in enumerate(sol.compiled.joint_elements):
            joint_of_node[sol.compiled.joint_nodes.get(name, [])] = j
        cells.append(("line", rigid))
        kind.append(np.full(len(rigid), KIND_RIGID))
        joint.append(joint_of_node[rmaster])
    X = np.concatenate(points)
    M = np.concatenate(owners)
    u = point_motion(model, state, shape, X, M)
    spin = np.zeros((len(X), 3))
    if model.dim == 3:
        spin[:] = shape[M, 3:6]
    else:
        spin[:, 2] = shape[M, 2]
    if scale is None:
        scale = mode_scale(model, state, shape, x, u[:len(x)])
    else:
        scale = finite(owner, "scale", scale)
    i32 = np.int32
    return meshio.Mesh(
        X, cells,
        point_data={"mode": u, "mode_scaled": scale * u, "mode_rotation": spin},
        cell_data={"kind": [a.astype(i32) for a in kind], "joint": [a.astype(i32) for a in joint]},
        field_data={"frequency": np.array([float(modes.frequencies[k])]), "mode": np.array([int(k)], dtype=i32),
                    "scale": np.array([scale])},
        info={"method": sol.method, "converged": bool(sol.converged), "undeformed": False,
              "frequency": float(modes.frequencies[k]), "mode": int(k), "scale": scale},
    )


def write_mode(modes, k: int, path: str | os.PathLike, *, solution: Solution | None = None,
               scale: float | None = None, sections: bool = True) -> pathlib.Path:
    """Write mode ``k`` of ``modes`` (layout: `mode_mesh`) to ``path`` (``.vtu`` or ``.vtk``, written
    aside and renamed as `write_vtk`); returns ``path``. In ParaView: Warp By Vector on
    ``mode_scaled``."""
    require("meshio", "export", FEATURE)
    path = _checked_path("write_mode", path, SUFFIXES)
    mesh = mode_mesh(modes, k, solution=solution, scale=scale, sections=sections)
    return _write_atomically("write_mode", mesh, path)


# -- helpers -----------------------------------------------------------------------------------
def _fe_model(where: str, solution) -> FEModel:
    """The `FEModel` of ``solution``, or the error that says why there is none."""
    if not isinstance(solution, Solution):
        raise ParameterError(f"{where}: solution must be a flexmb Solution (from flexmb.solve), "
                             f"got {type(solution).__name__}")
    model = getattr(getattr(solution.compiled, "problem", None), "model", None)
    if not isinstance(model, FEModel):
        raise UnsupportedStrategyError(
            f"{where}: export needs a finite-element solution, but method={solution.method!r} solved a "
            "model without beam elements (the closed-form linkage of method='newton' has links only): "
            "solve with method='conventional'")
    return model


def _checked_path(where: str, path, suffixes: dict) -> pathlib.Path:
    try:
        p = pathlib.Path(path)
    except TypeError:
        raise ParameterError(f"{where}: path must be a file path, got {type(path).__name__}") from None
    if p.suffix.lower() not in suffixes:
        raise ParameterError(f"{where}: path={str(p)!r} has suffix {p.suffix!r}; valid: {', '.join(suffixes)}")
    return p


def _write_atomically(where: str, mesh, path: pathlib.Path) -> pathlib.Path:
    """Write ``mesh`` aside and rename it to ``path`` (a failed write leaves no partial file)."""
    tmp = _staged(path)
    try:
        _write(mesh, tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise ParameterError(f"{where}: cannot write {str(path)!r}: {exc.strerror or exc}") from None
    finally:
        _discard(tmp)
    return path


def _staged(path: pathlib.Path) -> pathlib.Path:
    """A temporary name next to ``path`` with its suffix (meshio picks the format by it): files are
    written there and renamed into place, so a failed write leaves no partial file and an earlier
    file of that name as it was."""
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


def _discard(path: pathlib.Path) -> None:
    """Remove a temporary file if it is there (its folder may not even exist)."""
    try:
        path.unlink()
    except OSError:
        pass


def _write(mesh, path: pathlib.Path) -> pathlib.Path:
    meshio = require("meshio", "export", FEATURE)
    fmt = SUFFIXES[path.suffix.lower()]
    meshio.write(path, mesh, file_format=fmt)
    if fmt == "vtu":
        _add_field_data(path, mesh)
    return path


def _add_field_data(path: pathlib.Path, mesh) -> None:
    """Put ``mesh.field_data`` into the ``.vtu`` file meshio wrote (meshio 5.3 drops it) as
    ASCII ``FieldData`` of the grid, where VTK readers (ParaView, meshio.read) look for it, and
    a comment naming the solver."""
    tree = ET.parse(path, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    root = tree.getroot()
    grid = root.find("UnstructuredGrid")
    if grid is None:  # not the layout this was written for: leave meshio's file as it is
        return
    fields = ET.Element("FieldData")
    for name, value in mesh.field_data.items():
        a = np.asarray(value).ravel()
        vtk_type, fmt = ("Float64", repr) if a.dtype.kind == "f" else ("Int32", str)
        arr = ET.SubElement(fields, "DataArray", type=vtk_type, Name=name, NumberOfTuples=str(a.size),
                            format="ascii")
        arr.text = " ".join(fmt(v.item()) for v in a)
    fields.tail = "\n"
    grid.insert(0, fields)
    info = mesh.info
    comment = ET.Comment(f"flexmb.export: method={info['method']}, converged={info['converged']}, "
                         f"undeformed={info['undeformed']}")
    comment.tail = "\n"
    root.insert(0, comment)
    tree.write(path, xml_declaration=True, encoding="utf-8")


def _rigid_connections(model: FEModel) -> tuple[np.ndarray, np.ndarray]:
    """Lines (R, 2) from each FE node's reference point to the other points rigidly attached to
    it, and the node (R,) of each line.

    A node's reference point is its attached point with the smallest undeformed offset (the
    node itself: a link's reference point, or the first point of a joint's rigid body).
    """
    master = model.point_master
    P = len(master)
    offset = np.linalg.norm(model.point_offset, axis=1)
    order = np.lexsort((np.arange(P), offset, master))  # by node, then offset, then index
    first = np.unique(master[order], return_index=True)[1]
    node_point = np.full(model.n_nodes, -1, dtype=np.int64)
    node_point[master[order[first]]] = order[first]
    # coincident points (a leaf clamped at the reference point) would give zero-length lines
    scale = float(np.ptp(model.point_x0, axis=0).max()) if P > 1 else 0.0
    tol = 1e-9 * (scale if scale > 0 else 1.0)
    ref = node_point[master]
    keep = (np.arange(P) != ref) & (np.linalg.norm(model.point_x0 - model.point_x0[ref], axis=1) > tol)
    lines = np.stack([ref[keep], np.flatnonzero(keep)], axis=1).astype(np.int64)
    return lines, master[keep]


def _pad3(a: np.ndarray) -> np.ndarray:
    """(n, 2) or (n, 3) -> (n, 3) float, z = 0 for planar models."""
    a = np.asarray(a, dtype=float)
    return a if a.shape[1] == 3 else np.concatenate([a, np.zeros((len(a), 3 - a.shape[1]))], axis=1)
