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
from ..boundary import actuation_row, boundary
from ..compiled import Compiled
from ..errors import ModelError, TopologyError, UnsupportedStrategyError
from ..joints._base import INTERNAL, SIDE_A, SIDE_B, Joint
from ..problem import StaticProblem
from ..rotations import cross
from .beam2d import local_stiffness as local_stiffness_2d
from .beam3d import local_stiffness as local_stiffness_3d
from .mass import RigidMasses
from .model import BeamElements, FEModel

__all__ = ["build", "CAPABILITY", "BYTES_PER_ELEMENT", "check_size", "memory_bytes"]

CAPABILITY = "fe_model"  # what a joint must offer (`Joint.capabilities`) to be built here


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
    node_x0 = [np.array([lk.position for lk in links.values()], dtype=float).reshape(-1, dim)]
    n_nodes = len(names)
    pt_master = [np.arange(n_nodes)]
    pt_x0 = list(node_x0)
    n_points = n_nodes
    ends, sections, L0, S, ny, nz, owner = [], [], [], [], [], [], []
    joint_elements, joint_nodes = {}, {}
    n_elements = 0
    counts = [_element_count(d["joint"], dim) for _, _, d in mechanism.graph.edges(data=True)]
    check_size(sum(counts), "the mechanism's finite-element model")  # before meshing anything
    for j, (a, b, key, data) in enumerate(mechanism.graph.edges(keys=True, data=True)):
        jt: Joint = data["joint"]
        side_a, side_b = data["sides"]
        if CAPABILITY not in jt.capabilities:
            raise UnsupportedStrategyError(
                f"joint {key!r} ({jt.kind}) does not offer {CAPABILITY!r}; it offers {sorted(jt.capabilities)}")
        mesh = _joint_mesh(key, jt, dim)
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
    if n_elements == 0:
        raise TopologyError("the mechanism has no joints with beam elements")
    ends = np.concatenate(ends)
    pt_x0 = np.concatenate(pt_x0)
    node_x0 = np.concatenate(node_x0)
    owner = np.concatenate(owner)
    L0, S = np.concatenate(L0), np.concatenate(S)
    if dim == 3:
        elements = BeamElements(ends, L0, S, tuple(sections), owner, ny0=np.concatenate(ny), nz0=np.concatenate(nz))
    else:
        chord = pt_x0[ends[:, 1]] - pt_x0[ends[:, 0]]
        elements = BeamElements(ends, L0, S, tuple(sections), owner, alpha0=np.arctan2(chord[:, 1], chord[:, 0]))
    rigid = RigidMasses.of_bodies([(link_node[n], lk.mass, lk.inertia, lk.center) for n, lk in links.items()], dim)
    model = FEModel(dim, node_x0, np.concatenate(pt_master), pt_x0, elements, rigid_masses=rigid)

    pres, vals, loads, paths = boundary(mechanism, link_node, links)
    return Compiled(StaticProblem(model, pres, vals, loads, rotation_paths=paths), link_node, mechanism.points,
                    joint_elements, actuation_row(mechanism, loads), joint_nodes,
                    tuple((k, d["joint"], d["placement"], *d["sides"])
                          for _, _, k, d in mechanism.graph.edges(keys=True, data=True)),
                    tuple(n for n, lk in links.items() if lk.fixed))


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
    if not v.hashable(joint):
        return _checked_mesh(key, joint, dim)
    try:
        return _cached_mesh(joint, dim)
    except ModelError:
        return _checked_mesh(key, joint, dim)  # repeat to name the joint in the error


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
    pts, side, el = np.asarray(mesh.points, dtype=float), np.asarray(mesh.side), np.asarray(mesh.elements)
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
    L0 = np.linalg.norm(chord, axis=1)
    if np.any(~(L0 > 0)):
        raise ModelError(f"{where}: beam element {int(np.flatnonzero(~(L0 > 0))[0])} has zero length")
    ny = nz = None
    if dim == 3:
        # the cross-section axis must be perpendicular to the element: project, normalise
        ex = chord / L0[:, None]
        ny = np.asarray(mesh.ny0, dtype=float)
        ny = ny - np.einsum("ei,ei->e", ny, ex)[:, None] * ex
        norm = np.linalg.norm(ny, axis=1)
        if np.any(~(norm > 1e-6)):
            raise ModelError(f"{where}: element {int(np.flatnonzero(~(norm > 1e-6))[0])}'s ny0 is (nearly) parallel "
                             "to its axis or zero; give the cross-section's local y axis")
        ny = ny / norm[:, None]
        nz = cross(ex, ny)
    S = (local_stiffness_3d if dim == 3 else local_stiffness_2d)(mesh.sections, L0)
    return _Mesh(pts, el.astype(np.int64), tuple(mesh.sections), ny, nz, L0, S, side == SIDE_A, side == INTERNAL,
                 first, node_of)
