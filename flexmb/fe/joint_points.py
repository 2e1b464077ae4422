"""Points inside a joint: a load, a prescribed motion or a response at a fraction of a leaf.

`Mechanism.add_joint_point` names a point along a leaf of a joint without splitting the joint:
here its finite-element side. `refined` gives the mechanism the builder sees, each such joint a
`Remeshed` one whose mesh has a node at the point (the element there split in two, the same
section; an existing node is used as it is); `attach` then puts the point's loads and prescribed
motion on that node and names it in `Compiled.joint_points`, so `Solution.displacement`,
`reaction` and `pose` read it like a link.
"""

from __future__ import annotations

import copy
from collections import deque
from typing import ClassVar

import attrs
import numpy as np

from ..compiled import Compiled
from ..errors import ModelError, UnsupportedStrategyError
from ..joints._base import INTERNAL, Joint, JointMesh
from ..problem import PointLoads, StaticProblem

__all__ = ["Remeshed", "leaf_path", "refined", "attach", "ON_NODE"]

#: A point within this fraction of an element's length of one of its ends is that end's node.
ON_NODE = 1e-9


@attrs.frozen(eq=False)
class Remeshed(Joint):
    """A joint whose mesh has extra nodes at given points of its elements (`refined`):
    ``splits`` ((element, t) per point, t in (0, 1) along the element from its first point) in
    the order the points are named; ``offsets`` (n, dim) [m] moves the base mesh's points in the
    joint frame (a geometric imperfection, `flexmb.imperfection`); the joint's own mesh
    otherwise. Offers ``"fe_model"`` only; its other attributes (``leaves``) are the base's."""

    kind: ClassVar[str] = "remeshed"
    base: Joint
    splits: tuple = ()
    offsets: np.ndarray | None = None

    def __getattr__(self, name):
        if name in ("base", "splits", "offsets") or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.base, name)

    def interface_b(self, dim: int) -> np.ndarray:
        return self.base.interface_b(dim)

    def mesh(self, dim: int) -> JointMesh:
        m = self.base.mesh(dim)
        pts, side, el = np.asarray(m.points, float), np.asarray(m.side), np.asarray(m.elements)
        if self.offsets is not None:
            pts = pts + self.offsets
        sections, ny = list(m.sections), None if m.ny0 is None else np.asarray(m.ny0, float)
        body = None if m.body is None else np.asarray(m.body)
        for e, t in self.splits:  # each split appends its point and its second half-element
            i, j = el[e]
            pts = np.vstack([pts, (1 - t) * pts[i] + t * pts[j]])
            side = np.append(side, INTERNAL)
            body = None if body is None else np.append(body, -1)
            k = len(pts) - 1
            el = np.vstack([el, [k, j]])
            el[e] = [i, k]
            sections.append(sections[e])
            ny = None if ny is None else np.vstack([ny, ny[e]])
        return JointMesh(points=pts, side=side, elements=el, sections=tuple(sections), ny0=ny, body=body)


def leaf_path(joint: Joint, dim: int, leaf: int, where: str):
    """The elements (in order, each with its direction +1/-1) and their lengths [m] along leaf
    ``leaf`` of ``joint``'s mesh: from the mesh point at the leaf's start to the one at its end
    (`Joint.leaves` where the joint has it, else the whole joint from A to B)."""
    mesh = joint.mesh(dim)
    pts, el = np.asarray(mesh.points, float), np.asarray(mesh.elements)
    ends = [(np.zeros(dim), joint.interface_b(dim))]
    if hasattr(joint, "leaves"):
        ends = [(s, e) for s, e, *_ in joint.leaves(dim)]
    if not 0 <= leaf < len(ends):
        raise ModelError(f"{where}: leaf={leaf!r}; joint {joint.kind!r} has leaves 0 ... {len(ends) - 1}")
    start, end = (int(np.argmin(np.linalg.norm(pts - p, axis=1))) for p in ends[leaf])
    adjacent = {}
    for k, (i, j) in enumerate(el):
        adjacent.setdefault(int(i), []).append((int(j), k, 1))
        adjacent.setdefault(int(j), []).append((int(i), k, -1))
    came = {start: None}
    queue = deque([start])
    while queue and end not in came:  # breadth first: the leaf's chain of elements
        a = queue.popleft()
        for b, k, sign in adjacent.get(a, ()):
            if b not in came:
                came[b] = (a, k, sign)
                queue.append(b)
    if end not in came or start == end:
        raise ModelError(f"{where}: no chain of beam elements along leaf {leaf} of joint {joint.kind!r}")
    chain, a = [], end
    while came[a] is not None:
        a, k, sign = came[a]
        chain.append((k, sign))
    chain.reverse()
    lengths = np.array([np.linalg.norm(pts[el[k, 1]] - pts[el[k, 0]]) for k, _ in chain])
    return chain, lengths


def _split_at(joint: Joint, dim: int, leaf: int, fraction: float, where: str):
    """``(element, t)`` of the point at ``fraction`` of the leaf's length, or ``(point, None)``
    when it is an internal node already."""
    chain, lengths = leaf_path(joint, dim, leaf, where)
    mesh = joint.mesh(dim)
    s = fraction * lengths.sum()
    cum = np.concatenate([[0.0], np.cumsum(lengths)])
    k = int(min(np.searchsorted(cum, s, side="right") - 1, len(chain) - 1))
    e, sign = chain[k]
    t = (s - cum[k]) / lengths[k]
    t = t if sign > 0 else 1 - t
    i, j = np.asarray(mesh.elements)[e]
    node = i if t <= ON_NODE else (j if t >= 1 - ON_NODE else None)
    if node is None:
        return e, float(t)
    if np.asarray(mesh.side)[node] != INTERNAL:
        raise ModelError(f"{where}: fraction={fraction!r} of leaf {leaf} is at the joint's interface, on a link; "
                         "load or prescribe that link")
    return int(node), None


def refined(mechanism, points: tuple):
    """The mechanism the builder sees for joint ``points`` ((name, joint, leaf, fraction), the
    order named): each joint with points a `Remeshed` one; returns ``(mechanism, where)``,
    ``where[name] = (joint, index)``: the index among the joint's added points (a split), or
    ``("node", point)`` for a point that is a mesh node already."""
    dim = mechanism.dim
    splits, where = {}, {}
    for name, joint_name, leaf, fraction in points:
        joint = mechanism.joints[joint_name]
        at, t = _split_at(joint, dim, leaf, fraction, f"joint point {name!r}")
        if t is None:
            where[name] = (joint_name, ("node", at))
            continue
        done = splits.setdefault(joint_name, [])
        if any(e == at and abs(u - t) <= ON_NODE for e, u in done):
            raise ModelError(f"joint point {name!r}: another point of joint {joint_name!r} is there already")
        if any(e == at for e, _ in done):
            raise ModelError(f"joint point {name!r}: two points in one element of joint {joint_name!r}; "
                             "refine the joint's mesh")
        done.append((at, t))
        where[name] = (joint_name, len(done) - 1)
    if not splits:
        return mechanism, where
    out = copy.copy(mechanism)
    out.graph = mechanism.graph.copy()
    for a, b, key, data in out.graph.edges(keys=True, data=True):
        if key in splits:
            out.graph.edges[a, b, key]["joint"] = Remeshed(data["joint"], tuple(splits[key]))
    return out, where


def attach(compiled: Compiled, mechanism, where: dict, loads: tuple, motions: dict) -> Compiled:
    """``compiled`` with the joint points named (`Compiled.joint_points`: name -> FE node), their
    dead ``loads`` ((name, force, moment) rows) before the actuation's row and their prescribed
    ``motions`` ({name: {component: value}}) added to the problem."""
    problem = compiled.problem
    if not isinstance(problem, StaticProblem):
        raise UnsupportedStrategyError("points inside a joint need the finite-element model (method='conventional')")
    model, dim = problem.model, mechanism.dim
    nodes = {}
    for name, (joint_name, at) in where.items():
        if isinstance(at, tuple):  # a mesh node: its FE node among the joint's internal ones (the builder's order)
            from .build import _internal_nodes

            mesh = mechanism.joints[joint_name].mesh(dim)
            side = np.asarray(mesh.side)
            inner = np.flatnonzero(side == INTERNAL)
            node_of = _internal_nodes(side, mesh.body)[1]
            nodes[name] = int(compiled.joint_nodes[joint_name][node_of[int(np.searchsorted(inner, at[1]))]])
        else:
            added = sum(1 for j, a in where.values() if j == joint_name and not isinstance(a, tuple))
            nodes[name] = int(compiled.joint_nodes[joint_name][len(compiled.joint_nodes[joint_name]) - added + at])
    pres, vals = _prescribed(problem, model, nodes, motions, dim)
    rows, actuation = _load_rows(problem.loads, compiled.actuation, nodes, loads, model)
    new = StaticProblem(model, pres, vals, rows, rotation_paths=problem.rotation_paths)
    return attrs.evolve(compiled, problem=new, actuation=actuation, joint_points=nodes)


def _prescribed(problem, model, nodes: dict, motions: dict, dim: int):
    """The prescribed DOFs and values with the joint points' motions added (sorted)."""
    comp = {"x": [0], "y": [1], "z": [2], "rotation": list(range(dim, model.ndof))}
    pres, vals = list(problem.prescribed), list(problem.values)
    for name, motion in motions.items():
        base = nodes[name] * model.ndof
        for key, value in motion.items():
            pres += [base + c for c in comp[key]]
            vals += list(np.atleast_1d(value).astype(float))
    order = np.argsort(pres)
    return np.asarray(pres, dtype=np.int64)[order], np.asarray(vals, dtype=float)[order]


def _load_rows(ld: PointLoads, actuation, nodes: dict, loads: tuple, model):
    """The point loads with the joint points' rows inserted before the actuation's (the last
    row, which sweeps replace) and the actuation's new row."""
    if not loads:
        return ld, actuation
    nrot = model.ndof - model.dim
    at = len(ld.node) if actuation is None else actuation[0]
    new_node = np.array([nodes[n] for n, _, _ in loads], dtype=np.int64)
    force = np.array([f for _, f, _ in loads], dtype=float).reshape(-1, model.dim)
    moment = np.array([m for *_, m in loads], dtype=float).reshape(-1, nrot)

    def insert(a, b):
        return np.concatenate([a[:at], b, a[at:]])

    rows = PointLoads(insert(ld.node, new_node), insert(ld.offset, np.zeros((len(loads), model.dim))),
                      insert(ld.force, force), insert(ld.moment, moment))
    return rows, None if actuation is None else (actuation[0] + len(loads), actuation[1])
