"""The finite-element builder: a `flexmb.Mechanism` -> the `StaticProblem` of its full model.

Every link is one node (6 DOFs in 3D, 3 in 2D); every joint adds its `JointMesh`: beam elements,
internal nodes, and points rigidly attached to a link or to an internal rigid body (Appendix B of
Dwarshuis et al. 2020). Joint meshes are checked once per joint value and cached (joints are
immutable), so a mechanism of identical joints and repeated solves build each mesh once.
"""

from __future__ import annotations

import functools
import os

import attrs
import numpy as np

from .. import _validate as v
from ..boundary import actuation_row, boundary, motion_paths
from ..compiled import Compiled
from ..errors import ModelError, TopologyError, UnsupportedStrategyError
from ..joints._base import INTERNAL, SIDE_A, SIDE_B, Joint
from ..problem import StaticProblem
from ..rotations import cross
from .beam2d import hypot_atan2
from .beam2d import local_stiffness as local_stiffness_2d
from .beam3d import local_stiffness as local_stiffness_3d
from .ideal import ROWS, Hinges, dense_rows, free_motions, independent_rows, lock_rows, row_names
from .mass import RigidMasses
from .model import BeamElements, FEModel

__all__ = ["build", "numbers", "CAPABILITY", "BYTES_PER_ELEMENT", "check_size", "memory_bytes"]

CAPABILITY = "fe_model"  # what a joint must offer (`Joint.capabilities`) to be built here
IDEAL = "ideal"  # an ideal joint (`flexmb.Hinge`): exact constraints between its two links


#: Peak memory of a conventional solve per beam element [bytes]: measured on ThreeXInfinity
#: (stages=100, 3D) between 30 and 100 elements per leaf (9000 -> 30000 elements: 314 -> 795 MB
#: peak RSS), 23 KB per element, rounded up.
BYTES_PER_ELEMENT = 24_000


def memory_bytes() -> int:
    """This machine's physical memory [bytes] (0 when the OS does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return 0


def check_size(n_elements: int, what: str = "the model") -> None:
    """Refuse (`ModelError`) a model whose solve needs more memory than the machine has, from its
    element count, before allocating it."""
    need, have = n_elements * BYTES_PER_ELEMENT, memory_bytes()
    if have and need > have:
        raise ModelError(f"{what} has {n_elements} beam elements: solving it needs about {need / 1e9:.3g} GB "
                         f"({BYTES_PER_ELEMENT // 1000} kB per element, measured), more than this machine's "
                         f"{have / 1e9:.3g} GB; use fewer elements (elements_per_leaf, elements, stages)")


def build(mechanism) -> Compiled:
    """The full finite-element `StaticProblem` of ``mechanism`` (a `flexmb.Mechanism`): one node
    per link, the joints' beam elements and internal nodes, rigidly attached points, the
    prescribed DOFs and dead loads (Appendix B of Dwarshuis et al. 2020)."""
    links = mechanism.links
    mechanism.check(links)
    dim = mechanism.dim
    names = list(links)
    link_node = {n: i for i, n in enumerate(names)}
    a = _assemble(mechanism, links, link_node)
    elements = _elements(a, dim)
    node_x0 = a["node_x0"]
    rigid = RigidMasses.of_bodies([(link_node[n], lk.mass, lk.inertia, lk.center) for n, lk in links.items()], dim)
    pres, vals, loads, paths = boundary(mechanism, link_node, links)
    ideal = None
    if a["hinges"]:
        ideal = _hinges(mechanism, a["hinges"], node_x0[:len(names)], elements, pres, names)
    model = FEModel(dim, node_x0, a["pt_master"], a["pt_x0"], elements, rigid_masses=rigid, hinges=ideal)

    return Compiled(StaticProblem(model, pres, vals, loads, rotation_paths=paths,
                                  motion_paths=motion_paths(mechanism, link_node, links)), link_node, mechanism.points,
                    a["joint_elements"], actuation_row(mechanism, loads), a["joint_nodes"],
                    tuple((k, d["joint"], d["placement"], *d["sides"])
                          for _, _, k, d in mechanism.graph.edges(keys=True, data=True)),
                    tuple(n for n, lk in links.items() if lk.fixed))


def numbers(mechanism, link_node: dict) -> dict:
    """The numbers of ``mechanism``'s finite-element model without the model (no problem, no
    sparsity pattern, no solver set-up): what `flexmb.design` differentiates, for links numbered by
    ``link_node`` (a compiled model's `Compiled.link_node`, whose structure the caller compares).

    Keys: ``x0`` (N, dim) nodes' and ``point_x0`` (P, dim) points' reference positions,
    ``point_master`` (P,), ``L0``, ``S``, ``ny0``, ``nz0``, ``alpha0`` (as `BeamElements`),
    ``sections``, ``ends``, ``rigid`` (`RigidMasses` or None), ``values``, ``loads``
    (`PointLoads`), ``chains`` (the prescribed chains' rotation vectors) and ``points`` (named
    points' offsets), ``joint_elements``. Complex numbers in the mechanism (the complex step) stay complex; a joint
    mesh that drops them raises where it does (``docs/plugins.md``). Ideal hinges and points
    inside joints are not covered (`flexmb.ModelError`)."""
    links = mechanism.links
    dim = mechanism.dim
    if getattr(mechanism, "joint_points", None):
        raise ModelError("points inside joints (Mechanism.add_joint_point) have no numbers-only model")
    a = _assemble(mechanism, links, link_node)
    if a["hinges"]:
        raise ModelError("ideal joints (flexmb.Hinge) have no numbers-only model")
    elements = _elements(a, dim)
    rigid = RigidMasses.of_bodies([(link_node[n], lk.mass, lk.inertia, lk.center) for n, lk in links.items()], dim)
    pres, vals, loads, paths = boundary(mechanism, link_node, links)
    return {"x0": a["node_x0"], "point_x0": a["pt_x0"], "point_master": a["pt_master"], "L0": elements.L0,
            "S": elements.S, "ny0": elements.ny0, "nz0": elements.nz0, "alpha0": elements.alpha0,
            "sections": elements.sections, "ends": elements.ends, "rigid": rigid, "prescribed": pres, "values": vals,
            "loads": loads, "chains": paths, "points": mechanism.points, "joint_elements": a["joint_elements"]}


def _assemble(mechanism, links: dict, link_node: dict) -> dict:
    """The joints' meshes placed in the mechanism: nodes, points, elements and their data (`build`)."""
    dim = mechanism.dim
    names = list(links)
    positions = [lk.position for lk in links.values()]
    node_x0 = [np.array(positions, dtype=v.real_or_complex(positions)).reshape(-1, dim)]
    n_nodes = len(names)
    pt_master = [np.arange(n_nodes)]
    pt_x0 = list(node_x0)
    n_points = n_nodes
    ends, sections, L0, S, ny, nz, owner, recovery = [], [], [], [], [], [], [], []
    joint_elements, joint_nodes = {}, {}
    n_elements = 0
    counts = [_element_count(d["joint"], dim) for _, _, d in mechanism.graph.edges(data=True)]
    check_size(sum(counts), "the mechanism's finite-element model")  # before meshing anything
    hinges, meshes = [], []
    for j, (a, b, key, data) in enumerate(mechanism.graph.edges(keys=True, data=True)):
        jt: Joint = data["joint"]
        side_a, side_b = data["sides"]
        if IDEAL in jt.capabilities:
            hinges.append((key, jt, data["placement"], link_node[side_a], link_node[side_b]))
            joint_elements[key], joint_nodes[key] = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
            continue
        if CAPABILITY not in jt.capabilities:
            raise UnsupportedStrategyError(
                f"joint {key!r} ({jt.kind}) does not offer {CAPABILITY!r}; it offers {sorted(jt.capabilities)}")
        mesh = _joint_mesh(key, jt, dim)
        meshes.append(mesh)
        pl = data["placement"]  # a flexmb.mechanism.Placement
        gx = pl.to_global(mesh.points)
        master = np.where(mesh.on_a, link_node[side_a], link_node[side_b])
        n_int = len(mesh.first)
        joint_nodes[key] = n_nodes + np.arange(n_int)
        master[mesh.internal] = n_nodes + mesh.node_of
        node_x0.append(gx[mesh.first])
        pt_master.append(master)
        pt_x0.append(gx)
        ends.append(n_points + mesh.elements)
        n_nodes += n_int
        n_points += len(gx)
        sections.extend(mesh.sections)
        recovery.extend(mesh.stress_sections)
        L0.append(mesh.L0)
        S.append(mesh.S)
        n_el = len(mesh.elements)
        owner.append(np.zeros(n_el, dtype=np.int64) + j)
        if dim == 3:
            ny.append(mesh.ny0 @ pl.rotation.T)
            nz.append(mesh.nz0 @ pl.rotation.T)
        joint_elements[key] = n_elements + np.arange(n_el)
        n_elements += n_el
        check_size(n_elements, "the mechanism's finite-element model")  # joints that cannot count ahead
    # the sections stresses are recovered at (JointMesh.stress_sections), None where they are the elements' own
    own = all(m.stress_sections is m.sections for m in meshes)  # every element's own section (no per-element scan)
    recovery = tuple(recovery) if not own and any(r is not s for r, s in zip(recovery, sections)) else None
    if n_elements == 0 and not hinges:
        raise TopologyError("the mechanism has no joints with beam elements")
    if n_elements == 0:  # links and hinges only
        nS = 3 if dim == 2 else 6
        ends, L0, S, owner = [np.zeros((0, 2), dtype=np.int64)], [np.zeros(0)], [np.zeros((0, nS, nS))], [np.zeros(0, dtype=np.int64)]
        ny, nz = [np.zeros((0, 3))], [np.zeros((0, 3))]
    return {"node_x0": np.concatenate(node_x0), "pt_master": np.concatenate(pt_master), "pt_x0": np.concatenate(pt_x0),
            "ends": np.concatenate(ends), "sections": tuple(sections), "recovery": recovery,
            "L0": np.concatenate(L0), "S": np.concatenate(S), "owner": np.concatenate(owner),
            "ny": np.concatenate(ny) if dim == 3 else None, "nz": np.concatenate(nz) if dim == 3 else None,
            "joint_elements": joint_elements, "joint_nodes": joint_nodes, "hinges": hinges}


def _elements(a: dict, dim: int) -> BeamElements:
    """The `BeamElements` of `_assemble`'s arrays ``a`` (2D: the elements' undeformed angles)."""
    if dim == 3:
        return BeamElements(a["ends"], a["L0"], a["S"], a["sections"], a["owner"], ny0=a["ny"], nz0=a["nz"],
                            stress_sections=a["recovery"])
    chord = a["pt_x0"][a["ends"][:, 1]] - a["pt_x0"][a["ends"][:, 0]]
    alpha0 = hypot_atan2(chord)[1] if np.iscomplexobj(chord) else np.arctan2(chord[:, 1], chord[:, 0])
    return BeamElements(a["ends"], a["L0"], a["S"], a["sections"], a["owner"], alpha0=alpha0,
                        stress_sections=a["recovery"])


def _element_count(joint: Joint, dim: int) -> int:
    """A joint's element count if it knows it ahead (`Joint.element_count`), else 0."""
    try:
        n = joint.element_count(dim) if CAPABILITY in joint.capabilities else None
    except Exception:  # a plugin's estimate is advice: the mesh is checked when built
        n = None
    return int(n) if isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n > 0 else 0


@attrs.frozen(eq=False)
class _Mesh:
    """A checked `JointMesh` as arrays, with what compiling needs of it that does not depend on
    where the joint sits: the points on side A, the internal points and their FE nodes."""

    points: np.ndarray  # (n, dim) float
    elements: np.ndarray  # (E, 2) int64
    sections: tuple
    stress_sections: tuple  # where each element's stresses are recovered (JointMesh.stress_sections)
    ny0: np.ndarray | None  # (E, 3) float in 3D: the cross-section's y axis, perpendicular to the element
    nz0: np.ndarray | None  # (E, 3) float in 3D: element axis x ny0
    L0: np.ndarray  # (E,) element lengths [m]
    S: np.ndarray  # (E, 6, 6) or (E, 3, 3) local stiffness
    on_a: np.ndarray  # (n,) bool
    internal: np.ndarray  # (n,) bool
    first: np.ndarray  # point index of every internal FE node
    node_of: np.ndarray  # internal FE node of every internal point


@functools.lru_cache(maxsize=256)
def _cached_mesh(joint: Joint, dim: int) -> _Mesh:
    return _checked_mesh("?", joint, dim)


def _joint_mesh(key: str, joint: Joint, dim: int) -> _Mesh:
    """The joint's checked mesh; cached per joint value (joints are immutable), so a mechanism of
    identical joints and repeated solves build it once."""
    if not v.hashable(joint) or (v.accepts_complex() and _complex_step(joint)):  # complex only in a complex step
        return _checked_mesh(key, joint, dim)
    try:
        return _cached_mesh(joint, dim)
    except ModelError:
        return _checked_mesh(key, joint, dim)  # repeat to name the joint in the error


def _complex_step(joint: Joint) -> bool:
    """Whether an attrs joint holds complex numbers (a complex-step build of `flexmb.design`): its
    mesh is built for one gradient and not kept in the cache of meshes."""
    values = attrs.astuple(joint, recurse=False) if attrs.has(type(joint)) else ()
    material = getattr(joint, "material", None)
    if attrs.has(type(material)):
        values += attrs.astuple(material, recurse=False)
    return any(isinstance(x, (complex, np.complexfloating)) for x in values)


def _internal_nodes(side: np.ndarray, body) -> tuple[np.ndarray, np.ndarray]:
    """FE nodes of a joint's internal points: the point index of every node (a free point, or the
    first point of a rigid body; in mesh order) and the node of every internal point."""
    inner = np.flatnonzero(side == INTERNAL)
    b = np.full(len(side), -1) if body is None else np.asarray(body)
    group = np.where(b[inner] >= 0, -1 - b[inner], np.arange(len(inner)))
    _, first, inverse = np.unique(group, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    return inner[np.sort(first)], rank[inverse.ravel()]


def _checked_mesh(key: str, joint: Joint, dim: int) -> _Mesh:
    """The joint's `JointMesh`, checked for shapes and indices (a plugin's mistakes named here)."""
    mesh = joint.mesh(dim)
    where = f"joint {key!r} ({joint.kind})"
    pts, side, el = v.array(mesh.points), np.asarray(mesh.side), np.asarray(mesh.elements)  # complex: the complex step
    if pts.ndim != 2 or pts.shape[1] != dim or not np.all(np.isfinite(pts)):
        raise ModelError(f"{where}: mesh points must be a finite (n, {dim}) array, got shape {pts.shape}")
    if side.shape != (len(pts),) or not np.isin(side, (INTERNAL, SIDE_A, SIDE_B)).all():
        raise ModelError(f"{where}: mesh side must be ({len(pts)},) codes in (INTERNAL, SIDE_A, SIDE_B)")
    if mesh.body is not None:
        body = np.asarray(mesh.body)
        if body.shape != (len(pts),) or body.dtype.kind not in "iu" or np.any(body[side != INTERNAL] >= 0):
            raise ModelError(f"{where}: mesh body must be ({len(pts)},) ints, >= 0 only on INTERNAL points")
    if el.ndim != 2 or el.shape[1] != 2 or el.min(initial=0) < 0 or el.max(initial=0) >= len(pts):
        raise ModelError(f"{where}: mesh elements must be (E, 2) indices into its {len(pts)} points")
    if len(mesh.sections) != len(el):
        raise ModelError(f"{where}: {len(mesh.sections)} sections for {len(el)} elements")
    sections = tuple(mesh.sections)
    recovery = sections if getattr(mesh, "stress_sections", None) is None else tuple(mesh.stress_sections)
    if len(recovery) != len(el):
        raise ModelError(f"{where}: {len(recovery)} stress_sections for {len(el)} elements")
    if dim == 3 and (mesh.ny0 is None or np.shape(mesh.ny0) != (len(el), 3)):
        raise ModelError(f"{where}: a 3D mesh needs ny0 of shape ({len(el)}, 3)")
    first, node_of = _internal_nodes(side, mesh.body)
    attached = np.zeros(len(first), dtype=bool)  # every internal node must be an element's end
    inner = np.flatnonzero(side == INTERNAL)
    node = np.full(len(pts), -1)
    node[inner] = node_of
    attached[node[el.ravel()][node[el.ravel()] >= 0]] = True
    if not attached.all():
        k = int(first[np.flatnonzero(~attached)[0]])
        raise ModelError(f"{where}: internal mesh point {k} at {pts[k].tolist()} is attached to no beam element "
                         f"(its node would have no stiffness); remove it or connect it")
    chord = pts[el[:, 1]] - pts[el[:, 0]]
    L0 = v.norms(chord)  # complex chords (the complex step): sqrt(c . c), never the modulus
    if np.any(~(v.real(L0) > 0)):
        raise ModelError(f"{where}: beam element {int(np.flatnonzero(~(v.real(L0) > 0))[0])} has zero length")
    ny = nz = None
    if dim == 3:
        # the cross-section axis must be perpendicular to the element: project, normalise
        ex = chord / L0[:, None]
        ny = v.array(mesh.ny0)
        ny = ny - np.einsum("ei,ei->e", ny, ex)[:, None] * ex
        norm = v.norms(ny)
        if np.any(~(v.real(norm) > 1e-6)):
            raise ModelError(f"{where}: element {int(np.flatnonzero(~(v.real(norm) > 1e-6))[0])}'s ny0 is (nearly) parallel "
                             "to its axis or zero; give the cross-section's local y axis")
        ny = ny / norm[:, None]
        nz = cross(ex, ny)
    S = (local_stiffness_3d if dim == 3 else local_stiffness_2d)(mesh.sections, L0)
    return _Mesh(pts, el.astype(np.int64), sections, recovery, ny, nz, L0, S, side == SIDE_A, side == INTERNAL,
                 first, node_of)


def _hinges(mechanism, hinges: list, link_x0: np.ndarray, elements: BeamElements, prescribed: np.ndarray,
            names: list) -> Hinges:
    """The `Hinges` of ``hinges`` ((name, joint, placement, node A, node B)), their dependent
    constraint rows dropped; a `TopologyError` naming the links when the hinges leave a motion that
    deforms nothing (a mechanism, not a structure: the tangent would be singular).

    Both questions are answered on the links' DOFs at the undeformed state (SPACAR's approach: the
    rank of the constraint Jacobian): the hinges' rows, every other joint as a weld between its two
    links (a flexure resists all its relative motions), the springs of hinges with ``k > 0``, on
    the DOFs that are neither fixed nor prescribed."""
    dim = mechanism.dim
    nd, R = (3 if dim == 2 else 6), ROWS[dim]
    H = len(hinges)
    node = np.array([[a, b] for *_, a, b in hinges], dtype=np.int64)
    origin = np.array([pl.origin for _, _, pl, _, _ in hinges], dtype=float).reshape(H, dim)
    offset = origin[:, None, :] - link_x0[node]
    frame = np.array([pl.rotation for _, _, pl, _, _ in hinges], dtype=float).reshape(H, dim, dim)
    for (key, jt, *_), P in zip(hinges, frame):
        if not (np.all(np.isfinite(P)) and np.allclose(P.T @ P, np.eye(dim), atol=1e-9) and np.linalg.det(P) > 0):
            raise ModelError(f"joint {key!r} (hinge): its frame's rotation is not a proper rotation, so its axis is "
                             "undefined; place it with a finite rotation vector or a rotation matrix")
    k = np.array([jt.k for _, jt, *_ in hinges], dtype=float)
    angle = np.array([jt.motor for _, jt, *_ in hinges], dtype=float)
    active = np.ones((H, R), dtype=bool)
    active[:, -1] = np.isfinite(angle)
    scale = _row_scales(dim, elements, k, link_x0)
    probe = Hinges(dim, tuple(h[0] for h in hinges), node, offset, frame, k, angle, active, scale)
    rot = np.zeros(len(link_x0)) if dim == 2 else np.tile(np.eye(3), (len(link_x0), 1, 1))
    _, g, _ = probe.residual_rows(link_x0, rot, 0.0)
    n_cols = len(link_x0) * nd
    free = np.setdiff1d(np.arange(n_cols), prescribed)
    size = float(np.ptp(np.vstack([link_x0, origin]), axis=0).max()) or 1.0
    col = np.where(free % nd < dim, 1.0, 1.0 / size)  # rotations as arc lengths of the model's size
    row = np.where(np.arange(R) < dim, 1.0, size)
    J = (dense_rows(g * row[None, :, None], node, nd, n_cols)[:, free] * col)
    keep = independent_rows(J, active.ravel()).reshape(H, R)
    # other joints as welds, hinges with springs hold their relative rotation
    welds = [(link_node, pl.origin) for link_node, pl in _other_joints(mechanism, names)]
    blocks = [J[keep.ravel()]]
    if welds:
        wn = np.array([w[0] for w in welds], dtype=np.int64)
        wo = np.array([w[1] for w in welds], dtype=float).reshape(len(welds), dim)
        gw = lock_rows(dim, wo - link_x0[wn[:, 0]], wo - link_x0[wn[:, 1]])
        wrow = np.where(np.arange(nd) < dim, 1.0, size)
        blocks.append(dense_rows(gw * wrow[None, :, None], wn, nd, n_cols)[:, free] * col)
    sprung = k > 0
    if sprung.any():
        gt = probe._angle_derivatives(rot, False)[0][sprung][:, None, :]
        blocks.append(dense_rows(gt * size, node[sprung], nd, n_cols)[:, free] * col)
    Z = free_motions(np.vstack(blocks))
    if Z.shape[1]:
        moving = sorted({names[i] for i in np.unique(free[np.any(np.abs(Z) > 1e-6, axis=1)] // nd)})
        joints = [h[0] for h in hinges if names[h[3]] in moving or names[h[4]] in moving]
        raise TopologyError(
            f"the hinges {joints} leave {Z.shape[1]} free motion(s) of links {moving}: they move without deforming "
            "any flexure (a mechanism, not a structure; its tangent is singular). Prescribe the motion "
            "(Mechanism.prescribe, a hinge's angle=) or give a hinge a torsional stiffness k")
    dropped = [f"{hinges[h][0]}.{row_names(dim)[r]}" for h, r in zip(*np.nonzero(active & ~keep))]
    return attrs.evolve(probe, active=keep, dropped=tuple(dropped), dropped_rows=active & ~keep)


def _other_joints(mechanism, names: list):
    """(link nodes (2,), placement) of every joint that is not ideal."""
    index = {n: i for i, n in enumerate(names)}
    for a, b, _, d in mechanism.graph.edges(keys=True, data=True):
        if IDEAL not in d["joint"].capabilities:
            yield (index[d["sides"][0]], index[d["sides"][1]]), d["placement"]


def _row_scales(dim: int, elements: BeamElements, k: np.ndarray, link_x0: np.ndarray) -> np.ndarray:
    """Scales of a hinge's constraint rows: the model's stiffest axial stiffness ``EA/L`` [N/m] for
    positions and that times the elements' mean length squared [N m/rad] for rotations, so the
    constraint rows weigh like the stiffest element rows. Links and hinges only: the largest
    spring stiffness (1 if none) for rotations and that over the model size squared for positions."""
    R = ROWS[dim]
    rows = np.arange(R) < dim
    if len(elements.L0):
        t = float(np.max(elements.S[:, 0, 0]))
        r = t * float(np.mean(elements.L0)) ** 2
    else:
        size = float(np.ptp(link_x0, axis=0).max()) if len(link_x0) > 1 else 1.0
        r = float(np.max(k)) if np.max(k) > 0 else 1.0
        t = r / (size or 1.0) ** 2
    return np.where(rows, t, r)
