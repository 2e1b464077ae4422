"""`Mechanism`: rigid `Link` s (graph nodes) joined by flexure `Joint` s (graph edges)."""

from __future__ import annotations

import functools

import attrs
import networkx as nx
import numpy as np

from . import _validate as v
from .errors import ModelError, ParameterError, TopologyError, UnsupportedStrategyError
from .fe.beam2d import local_stiffness as local_stiffness_2d
from .fe.beam3d import local_stiffness as local_stiffness_3d
from .closed_form.flexures import FlexureSet
from .closed_form.problem import LinkageModel, LinkageProblem
from .fe.mass import RigidMasses
from .fe.model import BeamElements, FEModel
from .joints._base import FLEXURE_MODELS, INTERNAL, SIDE_A, SIDE_B, ClosedForm, Joint
from .problem import PointLoads, StaticProblem
from .registry import joint as make_joint
from .rotations import chain_rotation, cross, expm_so3, logm_so3, rot2

__all__ = ["Link", "Mechanism", "Placement", "Compiled"]


@attrs.frozen(eq=False)
class Link:
    """A rigid link: a graph node. ``position`` [m] is its reference point in the undeformed state.

    ``mass`` [kg], ``inertia`` about the centre of mass [kg m^2] ((3, 3) in 3D, a scalar about z
    in 2D) and ``center`` [m] (the centre of mass's offset from the reference point), all in the
    link's frame: global axes in the undeformed configuration, turning with the link.
    """

    name: str
    position: np.ndarray
    fixed: bool = False
    mass: float = 0.0
    inertia: np.ndarray | float = 0.0
    center: np.ndarray | None = None


@attrs.frozen(eq=False)
class Placement:
    """Where a joint sits: its frame's origin [m] and rotation (matrix (dim, dim)) in global axes."""

    origin: np.ndarray
    rotation: np.ndarray

    def to_global(self, local: np.ndarray) -> np.ndarray:
        """Points (..., dim) [m] of the joint frame in global coordinates."""
        return self.origin + local @ self.rotation.T


@attrs.frozen(eq=False)
class Compiled:
    """A mechanism turned into a `StaticProblem`, with the maps back to links and points."""

    problem: StaticProblem
    link_node: dict
    points: dict  # named points: name -> (link, offset)
    joint_elements: dict  # joint name -> element indices
    actuation: tuple | None = None  # (row of the actuation in problem.loads, unit direction)
    joint_nodes: dict = attrs.field(factory=dict)  # joint name -> FE node indices of its internal nodes
    joints: tuple = ()  # (name, joint, placement, side A link, side B link) at compile time
    fixed: tuple = ()  # names of the fixed links (the ground)


class Mechanism:
    """A planar (``dim=2``: x, y, theta per link) or spatial (``dim=3``: 6 DOF per link) mechanism.

    The topology lives in one ``networkx.MultiGraph`` (`graph`): nodes are link names with a
    ``link`` attribute, edges carry the ``joint`` instance and its `Placement`, keyed by the
    joint name. Solving never modifies the mechanism.

    Examples
    --------
    >>> import flexmb
    >>> m = flexmb.Mechanism(dim=2)
    >>> _ = m.add_link("A", fixed=True)
    >>> _ = m.add_link("B", position=(0.0, 0.1 * 2**-0.5))
    >>> _ = m.add_joint("A", "B", "cross_flexure", elements_per_leaf=2)
    >>> m.prescribe("B", rotation=0.1)
    """

    def __init__(self, dim: int = 3):
        if isinstance(dim, bool) or dim not in (2, 3) or not isinstance(dim, (int, np.integer)):
            raise ParameterError(f"Mechanism: dim={dim!r} must be 2 (planar) or 3 (spatial)")
        self.dim = dim
        self.graph = nx.MultiGraph()
        self._loads: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]] = []
        self._prescribed: dict[str, dict[str, float | np.ndarray]] = {}
        self._points: dict[str, tuple[str, np.ndarray]] = {}
        self._actuation: tuple[str, np.ndarray, np.ndarray, float] | None = None

    # -- building ----------------------------------------------------------------------------
    @property
    def links(self) -> dict[str, Link]:
        """The links by name, in the order they were added."""
        return {n: d["link"] for n, d in self.graph.nodes(data=True)}

    @property
    def joints(self) -> dict[str, Joint]:
        """The joints by name, in the order they were added."""
        return {k: d["joint"] for _, _, k, d in self.graph.edges(keys=True, data=True)}

    def link(self, name: str) -> Link:
        """The `Link` called ``name`` (`ModelError` listing the links if there is none)."""
        try:
            return self.graph.nodes[name]["link"]
        except (KeyError, TypeError):
            raise ModelError(f"no link named {name!r}; links: {', '.join(map(repr, self.graph.nodes)) or 'none'}") from None

    def add_link(self, name: str, position=None, *, fixed: bool = False, mass: float = 0.0, inertia=None,
                 center=None) -> Link:
        """Add a rigid link with reference point ``position`` [m] (default: the origin).

        ``mass`` [kg] >= 0, ``inertia`` [kg m^2] about the centre of mass (3D: a symmetric positive
        semi-definite (3, 3) tensor whose principal moments satisfy the triangle inequality; 2D:
        a scalar >= 0 about z; default 0) and ``center`` [m], the centre of mass relative to
        ``position`` (default: ``position``), in the link's frame (global axes, undeformed).
        """
        if not isinstance(name, str) or not name:
            raise ModelError(f"link name must be a non-empty string, got {name!r}")
        if name in self.graph:
            raise ModelError(f"a link named {name!r} exists already")
        pos = np.zeros(self.dim) if position is None else v.vector(f"link {name!r}", "position", position, self.dim)
        lk = Link(name, pos, v.flag(f"link {name!r}", "fixed", fixed),
                  *v.rigid_body(f"link {name!r}", mass, inertia, center, self.dim))
        self.graph.add_node(name, link=lk)
        return lk

    def fix(self, name: str) -> None:
        """Fix a link to the ground (all its DOFs held at zero displacement)."""
        lk = self.link(name)
        if self._prescribed.get(name):
            raise ModelError(f"link {name!r} has a prescribed motion; a fixed link cannot have one")
        self.graph.nodes[name]["link"] = attrs.evolve(lk, fixed=True)

    def add_joint(self, a: str, b: str, joint: Joint | str, *, name: str | None = None, origin=None,
                  rotation=None, **params) -> Joint:
        """Join links ``a`` (the joint's side A) and ``b`` (side B) with a flexure joint.

        ``joint`` is a `Joint` instance or a registered name (then ``params`` go to its constructor).
        The joint frame is placed at ``origin`` [m] (default: link ``a``'s reference point) with
        ``rotation`` (2D: angle [rad]; 3D: rotation vector [rad] or a 3x3 matrix; default none).
        """
        self.link(a), self.link(b)
        if a == b:
            raise TopologyError(f"joint between link {a!r} and itself: a joint must connect two different links")
        if isinstance(joint, str):
            joint = make_joint(joint, **params)
        elif params:
            raise ModelError("joint parameters are given with a joint name, not with a Joint instance")
        if not isinstance(joint, Joint):
            raise ModelError(f"{joint!r} is not a flexmb.Joint")
        if self.dim not in type(joint).dims:
            raise UnsupportedStrategyError(
                f"joint kind {joint.kind!r} supports dim in {type(joint).dims}, not a dim={self.dim} mechanism")
        name = name or f"{joint.kind}_{self.graph.number_of_edges()}"
        if name in self.joints:
            raise ModelError(f"a joint named {name!r} exists already")
        where = f"joint {name!r}"
        org = self.link(a).position if origin is None else v.vector(where, "origin", origin, self.dim)
        self.graph.add_edge(a, b, key=name, joint=joint, placement=Placement(org, self._rotation(where, rotation)),
                            sides=(a, b))
        return joint

    def _rotation(self, where: str, rotation) -> np.ndarray:
        if rotation is None:
            return np.eye(self.dim)
        if self.dim == 2:
            return rot2(v.finite(where, "rotation", rotation))
        try:
            r = np.asarray(rotation, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"{where}: rotation={rotation!r} is not a rotation vector (3,) or matrix (3, 3)") from None
        if r.shape == (3, 3):
            if not np.allclose(r.T @ r, np.eye(3), atol=1e-9) or np.linalg.det(r) < 0:
                raise ParameterError(f"{where}: rotation matrix is not a proper rotation")
            u, _, vt = np.linalg.svd(r)  # the nearest exact rotation: meshes are turned with it
            return u @ vt
        return expm_so3(v.vector(where, "rotation", rotation, 3))

    def prescribe(self, name: str, **motion) -> None:
        """Prescribe displacements/rotations of a link (displacement control).

        Keywords: ``x``, ``y`` (and ``z`` in 3D) displacements [m]; ``rotation`` [rad]: an angle in
        2D, a rotation vector (3,) in 3D (all three rotation components are then prescribed), or
        in 3D a sequence (k, 3) of rotation vectors ``w_i`` whose product ``exp(w_1) ... exp(w_k)``
        is the link's orientation: a serial chain of joint rotations about axes fixed in the
        undeformed configuration (a manipulator link), which the load steps of the conventional
        method follow as ``exp(lam w_1) ... exp(lam w_k)``. Unprescribed components are free.
        Repeated calls update the given components.
        """
        lk = self.link(name)
        if lk.fixed:
            raise ModelError(f"link {name!r} is fixed; a prescribed motion on a fixed link is contradictory")
        allowed = ("x", "y", "rotation") if self.dim == 2 else ("x", "y", "z", "rotation")
        where = f"link {name!r}"
        current = dict(self._prescribed.get(name, {}))
        for key, val in motion.items():
            if key not in allowed:
                raise ModelError(f"{where}: cannot prescribe {key!r}; valid components: {', '.join(allowed)}")
            if val is None:
                current.pop(key, None)
            elif key == "rotation" and self.dim == 3:
                if np.ndim(val) == 2:  # a chain of rotation vectors
                    current[key] = np.array([v.vector(where, f"rotation[{i}]", w, 3) for i, w in enumerate(val)])
                    if len(current[key]) == 0:
                        raise ParameterError(f"{where}: rotation is an empty sequence of rotation vectors")
                else:
                    current[key] = v.vector(where, "rotation", val, 3)
            else:
                current[key] = v.finite(where, key, val)
        self._prescribed[name] = current

    def prescribed(self, name: str) -> dict:
        """A copy of the prescribed components of link ``name`` (``{"x": ..., "rotation": ...}``)."""
        return dict(self._prescribed.get(name, {}))

    def apply_force(self, name: str, force, point=None) -> None:
        """Dead force [N] (global axes) at ``point`` [m] (undeformed global position; default the link's reference)."""
        lk = self.link(name)
        where = f"link {name!r}"
        f = v.vector(where, "force", force, self.dim)
        p = lk.position if point is None else v.vector(where, "point", point, self.dim)
        self._loads.append((name, p - lk.position, f, np.zeros(1 if self.dim == 2 else 3)))

    def apply_moment(self, name: str, moment) -> None:
        """Dead moment [N m]: a scalar (about z) in 2D, a vector (3,) in global axes in 3D."""
        self.link(name)
        where = f"link {name!r}"
        m = np.array([v.finite(where, "moment", moment)]) if self.dim == 2 else v.vector(where, "moment", moment, 3)
        self._loads.append((name, np.zeros(self.dim), np.zeros(self.dim), m))

    def clear_loads(self) -> None:
        """Remove the applied forces and moments (the actuation stays; set its value to 0 to remove it)."""
        self._loads.clear()

    def set_actuation(self, link: str, direction, value: float = 0.0, point=None) -> None:
        """Declare the actuation force: ``value`` [N] along the unit vector ``direction`` (global,
        dead load) at ``point`` [m] of ``link`` (undeformed position; default its reference point).

        It acts with the other loads; `flexmb.sweep` varies ``value``. Replaces an earlier actuation.
        """
        lk = self.link(link)
        where = f"actuation on link {link!r}"
        if lk.fixed:
            raise ModelError(f"{where}: link {link!r} is fixed; an actuation force on it would do nothing")
        d = v.vector(where, "direction", direction, self.dim)
        d = d / np.abs(d).max() if np.abs(d).max() > 0 else d  # scale first: no overflow in the norm
        norm = float(np.linalg.norm(d))
        if not norm > 0.0:
            raise ParameterError(f"{where}: direction={direction!r} must be a non-zero vector")
        p = lk.position if point is None else v.vector(where, "point", point, self.dim)
        self._actuation = (link, p - lk.position, d / norm, v.finite(where, "value", value))

    @property
    def actuation(self) -> dict | None:
        """The declared actuation (link, point offset [m], unit direction, value [N]) or None."""
        if self._actuation is None:
            return None
        link, offset, d, val = self._actuation
        return {"link": link, "offset": offset.copy(), "direction": d.copy(), "value": val}

    def add_point(self, link: str, name: str, position) -> None:
        """Name a point of a link (undeformed global position [m]), e.g. an end-effector."""
        lk = self.link(link)
        if not isinstance(name, str) or not name:
            raise ModelError(f"point name must be a non-empty string, got {name!r}")
        self._points[name] = (link, v.vector(f"point {name!r}", "position", position, self.dim) - lk.position)

    # -- checks and compilation ---------------------------------------------------------------
    def check(self) -> None:
        """Raise a `TopologyError` unless the mechanism is grounded and connected."""
        self._check(self.links)

    def _check(self, links: dict) -> None:
        if not links:
            raise TopologyError("the mechanism has no links")
        fixed = [n for n, lk in links.items() if lk.fixed]
        if not fixed:
            raise TopologyError("the mechanism has no fixed link; fix one with add_link(..., fixed=True) or fix()")
        adj = self.graph.adj  # a plain search: networkx's dispatching costs more than the search
        grounded, stack = set(fixed), list(fixed)
        while stack:
            for nb in adj[stack.pop()]:
                if nb not in grounded:
                    grounded.add(nb)
                    stack.append(nb)
        loose = [n for n in adj if n not in grounded]
        if loose:
            raise TopologyError(f"links {loose} are not connected to a fixed link through joints")
        for n, nbrs in adj.items():
            if not nbrs and not links[n].fixed:
                raise TopologyError(f"link {n!r} has no joint")

    def compile(self, capability: str = "fe_model") -> Compiled:
        """Build the full finite-element `StaticProblem` of the mechanism (``"fe_model"``) or the
        links-only closed-form `LinkageProblem` (``"closed_form"``, planar)."""
        links = self.links
        self._check(links)
        if capability == "closed_form":
            return self._compile_closed_form()
        dim = self.dim
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
        for j, (a, b, key, data) in enumerate(self.graph.edges(keys=True, data=True)):
            jt: Joint = data["joint"]
            side_a, side_b = data["sides"]
            if capability not in jt.capabilities:
                raise UnsupportedStrategyError(
                    f"joint {key!r} ({jt.kind}) does not offer {capability!r}; it offers {sorted(jt.capabilities)}")
            mesh = _joint_mesh(key, jt, dim)
            pl: Placement = data["placement"]
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

        pres, vals, loads, paths = self._boundary(link_node, links)
        return Compiled(StaticProblem(model, pres, vals, loads, rotation_paths=paths), link_node, dict(self._points), joint_elements,
                        self._actuation_row(loads), joint_nodes,
                        tuple((k, d["joint"], d["placement"], *d["sides"])
                              for _, _, k, d in self.graph.edges(keys=True, data=True)),
                        tuple(n for n, lk in links.items() if lk.fixed))

    def _actuation_row(self, loads: PointLoads) -> tuple | None:
        return None if self._actuation is None else (len(loads.node) - 1, self._actuation[2].copy())

    def _boundary(self, link_node: dict, links: dict | None = None):
        """Prescribed DOFs (sorted), their values and the `PointLoads`, for links numbered by ``link_node``."""
        links = self.links if links is None else links
        dim = self.dim
        ndof = 3 if dim == 2 else 6
        pres, vals, paths = [], [], []
        comp = {"x": 0, "y": 1, "z": 2}
        for n, lk in links.items():
            base = link_node[n] * ndof
            if lk.fixed:
                pres.extend(range(base, base + ndof))
                vals.extend([0.0] * ndof)
                continue
            for key, val in self._prescribed.get(n, {}).items():
                if key == "rotation":
                    pres.extend(range(base + dim, base + ndof))
                    if np.ndim(val) == 2:  # a chain of rotations: its product, and the path to it
                        paths.append((np.arange(base + dim, base + ndof), np.array(val)))
                        val = logm_so3(chain_rotation(val))
                    vals.extend(np.atleast_1d(val))
                else:
                    pres.append(base + comp[key])
                    vals.append(val)
        pres = np.array(pres, dtype=np.int64)
        order = np.argsort(pres)
        nrot = ndof - dim
        rows = list(self._loads)
        if self._actuation is not None:  # the last row, so that sweeps can replace it
            link, offset, d, val = self._actuation
            rows.append((link, offset, val * d, np.zeros(nrot)))
        loads = PointLoads(
            node=np.array([link_node[n] for n, *_ in rows], dtype=np.int64),
            offset=np.array([o for _, o, _, _ in rows]).reshape(-1, dim),
            force=np.array([f for *_, f, _ in rows]).reshape(-1, dim),
            moment=np.array([m for *_, m in rows]).reshape(-1, nrot),
        )
        return pres[order], np.array(vals, dtype=float)[order], loads, paths

    def _compile_closed_form(self) -> Compiled:
        """The links-only model of Cammarata et al. (2022): every joint a constant-stiffness flexure."""
        if self.dim != 2:
            raise UnsupportedStrategyError("the closed-form (method='newton') model is planar: use a dim=2 mechanism")
        names = list(self.graph.nodes)
        link_node = {n: i for i, n in enumerate(names)}
        x0 = np.array([self.links[n].position for n in names]).reshape(-1, 2)
        rows = []
        for a, b, key, data in self.graph.edges(keys=True, data=True):
            jt: Joint = data["joint"]
            if "closed_form" not in jt.capabilities:
                raise UnsupportedStrategyError(
                    f"joint {key!r} ({jt.kind}) has no closed-form model (method='newton'); it offers "
                    f"{sorted(jt.capabilities)}: use method='conventional'")
            cf = _checked_closed_form(key, jt)
            side_a, side_b = data["sides"]
            pl: Placement = data["placement"]
            ia, ib = link_node[side_a], link_node[side_b]
            end = pl.to_global(cf.end)
            B_j = pl.rotation @ rot2(cf.end_angle)
            rows.append((ia, ib, pl.origin - x0[ia], end - x0[ib], pl.rotation, B_j, rot2(cf.end_angle),
                         rot2(cf.end_angle).T @ cf.end, pl.rotation @ cf.end, cf.stiffness,
                         cf.model == "partial-nonlinear"))
        if not rows:
            raise TopologyError("the mechanism has no joints")
        cols = [np.array(c) for c in zip(*rows)]
        flex = FlexureSet(*[c.astype(np.int64) if k < 2 else c for k, c in enumerate(cols)])
        pres, vals, loads, _ = self._boundary(link_node)  # planar: no rotation chains
        problem = LinkageProblem(LinkageModel(x0, flex), pres, vals, loads)
        return Compiled(problem, link_node, dict(self._points), {}, self._actuation_row(loads))

    def __repr__(self) -> str:
        return (f"Mechanism(dim={self.dim}, links={list(self.graph.nodes)}, "
                f"joints={[f'{k}: {a}-{b}' for a, b, k in self.graph.edges(keys=True)]})")


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


def _checked_closed_form(key: str, joint: Joint) -> ClosedForm:
    """The joint's `ClosedForm`, checked (a plugin's mistakes named here)."""
    cf = joint.closed_form(2)
    where = f"joint {key!r} ({joint.kind})"
    K = np.asarray(cf.stiffness, dtype=float)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ModelError(f"{where}: closed-form stiffness must be a finite (3, 3) array, got shape {K.shape}")
    if np.shape(cf.end) != (2,) or not np.all(np.isfinite(cf.end)) or not np.isfinite(cf.end_angle):
        raise ModelError(f"{where}: closed-form end must be a finite (2,) position and a finite angle")
    if cf.model not in FLEXURE_MODELS:
        raise ModelError(f"{where}: closed-form model {cf.model!r}; valid: {', '.join(FLEXURE_MODELS)}")
    return ClosedForm(K, np.asarray(cf.end, dtype=float), float(cf.end_angle), cf.model)
