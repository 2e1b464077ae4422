"""`Mechanism`: rigid `Link` s (graph nodes) joined by flexure `Joint` s (graph edges)."""

from __future__ import annotations


import weakref

import attrs
import networkx as nx
import numpy as np

from . import _validate as v
from . import units as _units
from .materials import check_joint, params_in_units
from .closed_form import build as closed_form_build
from .compiled import Compiled
from .errors import ModelError, ParameterError, TopologyError, UnsupportedStrategyError
from .fe import build as fe_build
from .fe import joint_points
from .joints._base import Joint
from .registry import joint as make_joint
from .rotations import expm_so3, rot2

__all__ = ["Link", "Mechanism", "Placement", "Compiled", "BUILDERS"]

#: The mechanism each finite-element model was compiled from, held weakly (`flexmb.accuracy`
#: builds a result's companion mesh from it)
COMPILED_FROM: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

# The model builders by the capability a strategy asks for (`Strategy.capability`); each lives
# beside its model and reads the mechanism's data through its public accessors.
BUILDERS = {fe_build.CAPABILITY: fe_build.build, closed_form_build.CAPABILITY: closed_form_build.build}


def _frozen_or_none(a):
    return None if a is None else v.frozen(a)


def _frozen_unless_scalar(a):
    return a if np.ndim(a) == 0 else v.frozen(a)


def _motion_path(where: str, path, dim: int) -> np.ndarray:
    """``Mechanism.prescribe``'s ``path``, checked: finite numbers, shape (m, dim), m >= 1 (read-only copy)."""
    try:
        out = v.frozen(path)
    except (TypeError, ValueError):
        out = None
    if out is None or out.ndim != 2 or out.shape[1] != dim or len(out) == 0 or not np.all(np.isfinite(out)):
        raise ParameterError(f"{where}: path must be finite displacements of shape (m, {dim}) at the load "
                             f"factors (1 - cos(k pi / m)) / 2, k = 1..m, m >= 1; got {np.shape(path) if out is None else out.shape}")
    return out


@attrs.frozen(eq=False)
class Link:
    """A rigid link: a graph node. ``position`` [length] is its reference point in the undeformed state.

    ``mass`` [mass], ``inertia`` about the centre of mass [inertia] ((3, 3) in 3D, a scalar about z
    in 2D) and ``center`` [length] (the centre of mass's offset from the reference point), all in the
    link's frame: global axes in the undeformed configuration, turning with the link.
    """

    name: str
    position: np.ndarray = attrs.field(converter=v.frozen)  # read-only copies: no caller can change a link
    fixed: bool = False
    mass: float = 0.0
    inertia: np.ndarray | float = attrs.field(default=0.0, converter=_frozen_unless_scalar)
    center: np.ndarray | None = attrs.field(default=None, converter=_frozen_or_none)


@attrs.frozen(eq=False)
class Placement:
    """Where a joint sits: its frame's origin [length] and rotation (matrix (dim, dim)) in global axes."""

    origin: np.ndarray = attrs.field(converter=v.frozen)  # read-only copies
    rotation: np.ndarray = attrs.field(converter=v.frozen)

    def to_global(self, local: np.ndarray) -> np.ndarray:
        """Points (..., dim) [length] of the joint frame in global coordinates."""
        return self.origin + local @ self.rotation.T


class Mechanism:
    """A planar (``dim=2``: x, y, theta per link) or spatial (``dim=3``: 6 DOF per link) mechanism.

    The topology lives in one ``networkx.MultiGraph`` (`graph`): nodes are link names with a
    ``link`` attribute, edges carry the ``joint`` instance and its `Placement`, keyed by the
    joint name. Solving never modifies the mechanism. ``units``: the declared unit system (a name of
    `flexmb.units.SYSTEMS`, e.g. ``"mm-N-MPa"``; None: undeclared, SI assumed), in which named
    materials resolve and numbers are checked (``docs/units.md``); brackets such as [length] name
    the quantity, in those units.

    Examples
    --------
    >>> import flexmb
    >>> m = flexmb.Mechanism(dim=2)
    >>> _ = m.add_link("A", fixed=True)
    >>> _ = m.add_link("B", position=(0.0, 0.1 * 2**-0.5))
    >>> _ = m.add_joint("A", "B", "cross_flexure", elements_per_leaf=2)
    >>> m.prescribe("B", rotation=0.1)
    """

    def __init__(self, dim: int = 3, units: str | None = None):
        if isinstance(dim, bool) or dim not in (2, 3) or not isinstance(dim, (int, np.integer)):
            raise ParameterError(f"Mechanism: dim={dim!r} must be 2 (planar) or 3 (spatial)")
        self.dim = dim
        #: The declared `flexmb.units.UnitSystem` (``units``: a name of `flexmb.units.SYSTEMS`), or
        #: None: undeclared, SI assumed for labels and named materials (``docs/units.md``).
        self.units = _units.system(units)
        self.graph = nx.MultiGraph()
        self._loads: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]] = []
        self._prescribed: dict[str, dict[str, float | np.ndarray]] = {}
        self._points: dict[str, tuple[str, np.ndarray]] = {}
        self._actuation: tuple[str, np.ndarray, np.ndarray, float] | None = None
        #: points inside joints (`add_joint_point`): (points, loads, motions), a new tuple at every change
        self._inside: tuple = ((), (), ())

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
        """Add a rigid link with reference point ``position`` [length] (default: the origin).

        ``mass`` [mass] >= 0, ``inertia`` [inertia] about the centre of mass (3D: a symmetric positive
        semi-definite (3, 3) tensor whose principal moments satisfy the triangle inequality; 2D:
        a scalar >= 0 about z; default 0) and ``center`` [length], the centre of mass relative to
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
        The joint frame is placed at ``origin`` [length] (default: link ``a``'s reference point) with
        ``rotation`` (2D: angle [rad]; 3D: rotation vector [rad] or a 3x3 matrix; default none).
        ``name``: a non-empty string, or None for ``"<kind>_<k>"`` with the first k from the number
        of joints that no joint has taken.
        """
        self.link(a), self.link(b)
        if a == b:
            raise TopologyError(f"joint between link {a!r} and itself: a joint must connect two different links")
        if isinstance(joint, str):
            joint = make_joint(joint, **params_in_units(params, self.units))
        elif params:
            raise ModelError("joint parameters are given with a joint name, not with a Joint instance")
        if not isinstance(joint, Joint):
            raise ModelError(f"{joint!r} is not a flexmb.Joint")
        if self.dim not in type(joint).dims:
            raise UnsupportedStrategyError(
                f"joint kind {joint.kind!r} supports dim in {type(joint).dims}, not a dim={self.dim} mechanism")
        names = [k for _, _, k in self.graph.edges(keys=True)]  # the joints' names (not a dict of their objects)
        taken = set(names)
        if name is None:  # the first free "<kind>_<k>", k from the joint count: never a user's name
            k = len(names)
            while f"{joint.kind}_{k}" in taken:
                k += 1
            name = f"{joint.kind}_{k}"
        elif not isinstance(name, str) or not name:
            raise ModelError(f"joint name must be a non-empty string (or None for an automatic one), got {name!r}")
        if name in taken:
            raise ModelError(f"a joint named {name!r} exists already")
        where = f"joint {name!r}"
        check_joint(joint, self.units, where, self.dim)  # its material in the declared units, plausible sizes
        org = self.link(a).position if origin is None else v.vector(where, "origin", origin, self.dim)
        self.graph.add_edge(a, b, key=name, joint=joint, placement=Placement(org, self._rotation(where, rotation)),
                            sides=(a, b))
        return joint

    def _rotation(self, where: str, rotation) -> np.ndarray:
        if rotation is None:
            return np.eye(self.dim)
        _units.check_angle(where, "rotation", rotation, stacklevel=4)
        if self.dim == 2:
            return rot2(v.finite(where, "rotation", rotation))
        try:
            r = v.array(rotation)  # complex: the complex step (`flexmb.design`)
        except (TypeError, ValueError):
            raise ParameterError(f"{where}: rotation={rotation!r} is not a rotation vector (3,) or matrix (3, 3)") from None
        if r.shape == (3, 3):
            r0 = r.real if np.iscomplexobj(r) else r
            if not np.allclose(r0.T @ r0, np.eye(3), atol=1e-9) or np.linalg.det(r0) < 0:
                raise ParameterError(f"{where}: rotation matrix is not a proper rotation")
            u, _, vt = np.linalg.svd(r0)  # the nearest exact rotation: meshes are turned with it
            if np.iscomplexobj(r):  # its change projected on the rotations' tangent space, R0 skew(.)
                a = (u @ vt).T @ r.imag
                return u @ vt + 1j * ((u @ vt) @ (0.5 * (a - a.T)))
            return u @ vt
        return expm_so3(v.vector(where, "rotation", rotation, 3))

    # -- points inside a joint ----------------------------------------------------------------
    def add_joint_point(self, joint: str, name: str, fraction: float, *, leaf: int = 0) -> None:
        """Name a point inside ``joint``: at ``fraction`` (0 ... 1) of the length of its leaf
        ``leaf`` from side A (a cross flexure's leaves as `CrossFlexure.leaves` lists them; a joint
        without ``leaves``: its beam from A to B), without splitting the joint. The point then
        takes `apply_force`, `apply_moment` and `prescribe` like a link, and a `Solution`'s
        `displacement`, `reaction` and `pose` (finite-element model only: ``method="conventional"``
        and `flexmb.trace`). Its mesh gets a node there (the element split in two)."""
        if joint not in self.joints:
            raise ModelError(f"no joint named {joint!r}; joints: {', '.join(map(repr, self.joints)) or 'none'}")
        if not isinstance(name, str) or not name:
            raise ModelError(f"joint point name must be a non-empty string, got {name!r}")
        if name in self.graph or self._is_joint_point(name):
            raise ModelError(f"a link or joint point named {name!r} exists already")
        where = f"joint point {name!r}"
        fraction = v.finite(where, "fraction", fraction)
        if not 0.0 < fraction < 1.0:
            raise ParameterError(f"{where}: fraction={fraction!r} must be in (0, 1) (its ends are the links)")
        leaf = v.integer(where, "leaf", leaf, 0)
        points, loads, motions = self._inside
        self._inside = (points + ((name, joint, leaf, fraction),), loads, motions)

    @property
    def joint_points(self) -> dict:
        """The points inside joints: name -> (joint, leaf, fraction)."""
        return {n: (j, leaf, f) for n, j, leaf, f in self._inside[0]}

    def _joint_point_names(self) -> set:
        return {p[0] for p in self._inside[0]}

    def _is_joint_point(self, name) -> bool:
        return isinstance(name, str) and any(p[0] == name for p in self._inside[0])

    def _inside_load(self, name: str, force, moment) -> None:
        points, loads, motions = self._inside
        self._inside = (points, loads + ((name, force, moment),), motions)

    def _inside_motion(self, name: str, motion: dict) -> None:
        where = f"joint point {name!r}"
        allowed = ("x", "y", "rotation") if self.dim == 2 else ("x", "y", "z", "rotation")
        points, loads, motions = self._inside
        current = dict(dict(motions).get(name, {}))
        for key, val in motion.items():
            if key not in allowed:
                raise ModelError(f"{where}: cannot prescribe {key!r}; valid components: {', '.join(allowed)}")
            if val is None:
                current.pop(key, None)
            elif key == "rotation" and self.dim == 3:
                current[key] = v.frozen(v.vector(where, "rotation", val, 3))
            else:
                current[key] = v.finite(where, key, val)
        self._inside = (points, loads, tuple((n, m) for n, m in motions if n != name) + ((name, current),))

    def prescribe(self, name: str, **motion) -> None:
        """Prescribe displacements/rotations of a link (displacement control).

        Keywords: ``x``, ``y`` (and ``z`` in 3D) displacements [length]; ``rotation`` [rad]: an angle in
        2D, a rotation vector (3,) in 3D (all three rotation components are then prescribed), or
        in 3D a sequence (k, 3) of rotation vectors ``w_i`` whose product ``exp(w_1) ... exp(w_k)``
        is the link's orientation: a serial chain of joint rotations about axes fixed in the
        undeformed configuration (a manipulator link), which the load steps of the conventional
        method follow as ``exp(lam w_1) ... exp(lam w_k)``. ``path``: the way the displacements
        get there, an array (m, dim) of the link's displacement at the load factors
        `flexmb.problem.path_load_factors` (m) (all of x, y (z) prescribed, the last row, at 1,
        equal to them), which the load steps of the conventional method's continuation follow
        (`flexmb.problem.motion_path`; Fig. 18's control, ``step_control="paper"``, keeps the
        straight line, as published): the same equilibrium, reached along a curve the mechanism
        follows easily (the manipulator's location case: its kinematic path); a later x, y or z
        without a path drops it. Unprescribed components are free. Repeated calls update the
        given components. A point inside a joint (`add_joint_point`) takes ``x``, ``y`` (``z``) and
        ``rotation`` (a vector in 3D) the same way.
        """
        if self._is_joint_point(name):
            return self._inside_motion(name, motion)
        lk = self.link(name)
        if lk.fixed:
            raise ModelError(f"link {name!r} is fixed; a prescribed motion on a fixed link is contradictory")
        allowed = ("x", "y", "rotation", "path") if self.dim == 2 else ("x", "y", "z", "rotation", "path")
        where = f"link {name!r}"
        current = dict(self._prescribed.get(name, {}))
        if "path" not in motion and any(k in motion for k in "xyz"):
            current.pop("path", None)  # the way to the old displacement: the new one goes straight
        for key, val in motion.items():
            if key not in allowed:
                raise ModelError(f"{where}: cannot prescribe {key!r}; valid components: {', '.join(allowed)}")
            if key == "rotation" and val is not None:
                _units.check_angle(where, "rotation", val)
            if val is None:
                current.pop(key, None)
            elif key == "rotation" and self.dim == 3:
                if np.ndim(val) == 2:  # a chain of rotation vectors
                    current[key] = v.frozen([v.vector(where, f"rotation[{i}]", w, 3) for i, w in enumerate(val)])
                    if len(current[key]) == 0:
                        raise ParameterError(f"{where}: rotation is an empty sequence of rotation vectors")
                else:
                    current[key] = v.frozen(v.vector(where, "rotation", val, 3))
            elif key == "path":
                current[key] = _motion_path(where, val, self.dim)
            else:
                current[key] = v.finite(where, key, val)
        self._prescribed[name] = current

    def prescribed(self, name: str) -> dict:
        """A copy of the prescribed components of link ``name`` (``{"x": ..., "rotation": ...}``;
        rotation arrays are read-only copies of what was given)."""
        return dict(self._prescribed.get(name, {}))

    def apply_force(self, name: str, force, point=None) -> None:
        """Dead force [force] (global axes) at ``point`` [length] (undeformed global position; default the
        link's reference), or at a point inside a joint (`add_joint_point`, no ``point``)."""
        if self._is_joint_point(name):
            f = v.vector(f"joint point {name!r}", "force", force, self.dim)
            return self._inside_load(name, f, np.zeros(1 if self.dim == 2 else 3))
        lk = self.link(name)
        where = f"link {name!r}"
        f = v.vector(where, "force", force, self.dim)
        p = lk.position if point is None else v.vector(where, "point", point, self.dim)
        self._loads.append((name, p - lk.position, f, np.zeros(1 if self.dim == 2 else 3)))

    def apply_moment(self, name: str, moment) -> None:
        """Dead moment [moment]: a scalar (about z) in 2D, a vector (3,) in global axes in 3D (at a link
        or a point inside a joint)."""
        inside = self._is_joint_point(name)
        if not inside:
            self.link(name)
        where = f"{'joint point' if inside else 'link'} {name!r}"
        m = np.array([v.finite(where, "moment", moment)]) if self.dim == 2 else v.vector(where, "moment", moment, 3)
        if inside:
            return self._inside_load(name, np.zeros(self.dim), m)
        self._loads.append((name, np.zeros(self.dim), np.zeros(self.dim), m))

    def clear_loads(self) -> None:
        """Remove the applied forces and moments (the actuation stays; set its value to 0 to remove it)."""
        self._loads.clear()
        points, _, motions = self._inside
        self._inside = (points, (), motions)

    def set_actuation(self, link: str, direction, value: float = 0.0, point=None) -> None:
        """Declare the actuation force: ``value`` [force] along the unit vector ``direction`` (global,
        dead load) at ``point`` [length] of ``link`` (undeformed position; default its reference point).

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
        """The declared actuation (link, point offset [length], unit direction, value [force]) or None."""
        if self._actuation is None:
            return None
        link, offset, d, val = self._actuation
        return {"link": link, "offset": offset.copy(), "direction": d.copy(), "value": val}

    @property
    def points(self) -> dict:
        """The named points: name -> (link, offset [length] from the link's reference point, a copy)."""
        return {name: (link, offset.copy()) for name, (link, offset) in self._points.items()}

    @property
    def loads(self) -> tuple:
        """The applied dead loads in the order given: (link, offset [length] of the point from the
        link's reference point, force [force], moment [moment]), global axes, copies."""
        return tuple((link, o.copy(), f.copy(), m.copy()) for link, o, f, m in self._loads)

    def add_point(self, link: str, name: str, position) -> None:
        """Name a point of a link (undeformed global position [length]), e.g. an end-effector. A name
        already given to a point is refused (`ModelError`), never replaced."""
        lk = self.link(link)
        if not isinstance(name, str) or not name:
            raise ModelError(f"point name must be a non-empty string, got {name!r}")
        if name in self._points:
            raise ModelError(f"a point named {name!r} exists already (on link {self._points[name][0]!r}); "
                             "choose another name")
        self._points[name] = (link, v.vector(f"point {name!r}", "position", position, self.dim) - lk.position)

    # -- checks and compilation ---------------------------------------------------------------
    def check(self, links: dict | None = None) -> None:
        """Raise a `TopologyError` unless the mechanism is grounded (a fixed link, or a link whose
        position is prescribed) and connected (``links``: the `links` mapping when the caller has
        it already)."""
        links = self.links if links is None else links
        if not links:
            raise TopologyError("the mechanism has no links")
        # a link whose position is prescribed (a pin support: x, y (, z) held, rotation free) anchors too
        position = {"x", "y"} if self.dim == 2 else {"x", "y", "z"}
        fixed = [n for n, lk in links.items() if lk.fixed or position <= self._prescribed.get(n, {}).keys()]
        if not fixed:
            raise TopologyError("the mechanism has no fixed link; fix one with add_link(..., fixed=True) or fix(), "
                                "or prescribe a link's position (a pin support)")
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
        """The problem a strategy solves, from the builder of ``capability``: the full
        finite-element `StaticProblem` (``"fe_model"``, `flexmb.fe.build`) or the links-only
        closed-form `LinkageProblem` (``"closed_form"``, planar, `flexmb.closed_form.build`)."""
        try:
            builder = BUILDERS[capability]
        except (KeyError, TypeError):
            raise UnsupportedStrategyError(
                f"no model builder for capability {capability!r}; builders: {', '.join(BUILDERS)}") from None
        points, loads, motions = self._inside
        if not points:
            compiled = builder(self)
        elif capability != fe_build.CAPABILITY:
            raise UnsupportedStrategyError(f"points inside a joint ({', '.join(p[0] for p in points)}) need the "
                                           "finite-element model (method='conventional' or flexmb.trace)")
        else:
            mech, where = joint_points.refined(self, points)
            compiled = joint_points.attach(builder(mech), self, where, loads, dict(motions))
        if hasattr(getattr(compiled.problem, "model", None), "elements"):  # flexmb.accuracy's companion mesh
            COMPILED_FROM[compiled.problem.model] = weakref.ref(self)
        return compiled if self.units is None else attrs.evolve(compiled, units=self.units)

    def __repr__(self) -> str:
        return (f"Mechanism(dim={self.dim}, links={list(self.graph.nodes)}, "
                f"joints={[f'{k}: {a}-{b}' for a, b, k in self.graph.edges(keys=True)]})")
