"""`Compiled`: a mechanism turned into a problem a strategy can solve, with the maps back to links;
`compiled_for`: the compiled problem of a mechanism, built once while the mechanism is unchanged."""

from __future__ import annotations

import operator
import threading
import weakref

import attrs
import networkx as nx
import numpy as np

from ._validate import hashable

__all__ = ["Compiled", "compiled_for", "fingerprint", "adopt", "structure_key"]


@attrs.frozen(eq=False)
class Compiled:
    """A mechanism turned into a problem (a `flexmb.problem.StaticProblem` from `flexmb.fe.build`,
    a `flexmb.closed_form.problem.LinkageProblem` from `flexmb.closed_form.build`), with the maps
    back to links and points."""

    problem: object
    link_node: dict  # link name -> node index
    points: dict  # named points: name -> (link, offset [m])
    joint_elements: dict  # joint name -> element indices
    actuation: tuple | None = None  # (row of the actuation in problem.loads, unit direction)
    joint_nodes: dict = attrs.field(factory=dict)  # joint name -> FE node indices of its internal nodes
    joints: tuple = ()  # (name, joint, placement, side A link, side B link) at compile time
    fixed: tuple = ()  # names of the fixed links (the ground)
    joint_points: dict = attrs.field(factory=dict)  # points inside joints: name -> FE node (`flexmb.fe.joint_points`)
    units: object = None  # the mechanism's declared flexmb.units.UnitSystem (None: undeclared), for labels
    #: what strategies derive from this problem alone and keep with it (KSD's set-up, by database
    #: folder); a new dict in every copy (`attrs.evolve` with another problem starts empty)
    derived: dict = attrs.field(init=False, factory=dict, repr=False)


def fingerprint(mechanism) -> tuple:
    """What compiling ``mechanism`` (a `flexmb.Mechanism`) reads: ``(key, objects)``, ``key``
    comparable with ``==`` (the counts that give the structure, then the identities of the
    objects), ``objects`` to keep alive with it (so their ids are not reused).

    Links, joints, placements, load rows, prescribed-motion dicts and their values, points, the
    actuation, names: all are immutable (frozen attrs, read-only arrays, strings) or replaced,
    never changed, by the mechanism's methods (`Mechanism.prescribe` builds a new dict per call).
    The graph's own node and edge data dicts are read item by item, so replacing a link or a joint
    in ``mechanism.graph`` directly is seen too. An equal value in a new object counts as a change
    (a needless compile, never a stale one)."""
    counts, objs = _reads(mechanism)
    return (counts, tuple(map(id, objs))), objs


def _reads(mechanism) -> tuple:
    """`fingerprint`'s counts (a tuple) and objects (a list), without the objects' ids: two reads
    are the same when their counts are equal and their objects identical one by one (while the
    first read's objects are kept alive)."""
    graph = mechanism.graph
    objs, counts = [], [mechanism.dim, len(graph)]
    add, extend, count = objs.append, objs.extend, counts.append  # bound once
    plain = type(graph) is nx.MultiGraph  # its dicts read directly, in the views' order (`_edges`)
    for name, data in (graph._node.items() if plain else graph.nodes(data=True)):
        add(name)
        extend(data)
        extend(data.values())
        count(len(data))
    edges = 0
    for a, b, name, data in (_edges(graph._adj) if plain else graph.edges(keys=True, data=True)):
        extend((a, b, name))
        extend(data)
        extend(data.values())
        count(len(data))
        edges += 1
    state = vars(mechanism)
    loads, prescribed, points = state.get("_loads", ()), state.get("_prescribed", {}), state.get("_points", {})
    extend(loads)
    extend(prescribed)
    for motion in prescribed.values():  # a link's prescribed components: floats or read-only arrays
        add(motion)
        extend(motion)
        extend(motion.values())
        count(len(motion))
    extend(points)
    extend(points.values())
    add(state.get("_actuation"))
    add(state.get("_inside"))  # points inside joints: a new tuple at every change
    counts += (edges, len(loads), len(prescribed), len(points))
    return tuple(counts), objs


def _edges(adj: dict) -> list:
    """``graph.edges(keys=True, data=True)`` of a networkx ``MultiGraph`` from its adjacency dict
    ``adj``, in the view's order (the views' nested generators cost a few microseconds a solve, more after
    other work)."""
    out, seen = [], set()
    for a, nbrs in adj.items():
        for b, keyed in nbrs.items():
            if b not in seen:
                out += [(a, b, k, d) for k, d in keyed.items()]
        seen.add(a)
    return out


def _values_only(mechanism) -> bool:
    """Whether every joint of ``mechanism`` is an immutable value (`flexmb._validate.hashable`:
    hashed by value): a plugin joint that is not one could change unseen, so its mechanism is
    compiled every time."""
    return all(hashable(joint) for *_, joint in mechanism.graph.edges(data="joint"))


def _read_only(compiled: Compiled) -> None:
    """Make the arrays of a compiled problem that describe the mechanism read-only (the prescribed
    DOFs and values, the loads, the reference positions, the maps to links and joints): a
    `Compiled` shared by the solves of one mechanism cannot be changed through one
    `Solution.compiled`. The element batches stay as they are (the numba kernels are typed on
    writeable arrays)."""
    problem = compiled.problem
    model = getattr(problem, "model", None)
    arrays = [getattr(problem, k, None) for k in ("prescribed", "values", "free")]
    arrays += [getattr(model, k, None) for k in ("x0", "point_x0", "point_master", "point_offset")]
    loads = getattr(problem, "loads", None)
    arrays += [getattr(loads, k, None) for k in ("node", "offset", "force", "moment")]
    arrays += list(compiled.joint_elements.values()) + list(compiled.joint_nodes.values())
    arrays += [offset for _, offset in compiled.points.values()]
    for a in arrays:
        if isinstance(a, np.ndarray):
            a.flags.writeable = False


_LOCAL = threading.local()  # one cache per thread: a compiled problem carries its solver's analysis


def compiled_for(mechanism, capability: str = "fe_model") -> Compiled:
    """``mechanism.compile(capability)``, kept while the mechanism is unchanged (its `fingerprint`)
    and reused by the next solve of it: compiling is a sizeable part of a KSD-reduced solve
    (BENCHMARKS.md, Design loops). Any change through the mechanism's methods or its graph compiles anew; a
    mechanism with a joint that is not a value is compiled every time. The cached problem's
    arrays are read-only. One cache per thread and per mechanism (held weakly)."""
    try:
        cache = _LOCAL.cache
    except AttributeError:
        cache = _LOCAL.cache = weakref.WeakKeyDictionary()
    if getattr(type(mechanism).compile, "__qualname__", "") != "Mechanism.compile":  # not flexmb's own compile
        return mechanism.compile(capability)
    try:
        counts, pins = _reads(mechanism)
    except (AttributeError, TypeError):  # not a flexmb.Mechanism's data: no cache
        return mechanism.compile(capability)
    entry = cache.get(mechanism)
    # unchanged: the same counts and the same objects one by one (`fingerprint`'s key, compared
    # without building ~100 ids: the kept entry holds its objects alive)
    same = entry is not None and entry[0] == counts and len(entry[1]) == len(pins) and all(
        map(operator.is_, entry[1], pins))
    if same and capability in entry[2]:
        return entry[2][capability]
    compiled = mechanism.compile(capability)
    if not _values_only(mechanism):
        return compiled
    _read_only(compiled)
    _reuse_structure(compiled)
    built = entry[2] if same else {}
    built[capability] = compiled
    cache[mechanism] = (counts, pins, built)
    return compiled


#: The structures kept per thread for `_reuse_structure`: the last few distinct topologies (a
#: design loop alternating a few mechanisms keeps all of theirs), together at most
#: `STRUCTURE_ELEMENTS` beam elements (each keeps its compiled problem alive: a few kB per element)
STRUCTURES_KEPT = 8
STRUCTURE_ELEMENTS = 20_000


def structure_key(compiled: Compiled) -> tuple | None:
    """What identifies the structure of a compiled finite-element problem cheaply: its problem
    type, dimension, DOF and element counts, link and joint names and sides, prescribed DOFs and
    loaded nodes; None for another kind of problem (the closed-form linkage: nothing to keep).
    `adopt` checks the element connectivity itself before sharing anything."""
    problem = compiled.problem
    model = getattr(problem, "model", None)
    if model is None or not hasattr(model, "element_dofs"):
        return None
    return (type(problem), model.dim, model.n_dofs, len(model.element_dofs), tuple(compiled.link_node),
            tuple((k, a, b) for k, _, _, a, b in compiled.joints), problem.prescribed.tobytes(),
            problem.loads.node.tobytes(), model.hinges is None)


def adopt(compiled: Compiled, previous: Compiled) -> bool:
    """Give ``compiled`` what ``previous``, a problem of the same structure, derived from its
    structure alone: the tangent's sparsity pattern, the linear solver with its
    ordering and symbolic factorisation, and KSD's set-up moved to ``compiled``'s numbers (`rebind`
    of what ``previous.derived`` holds). Only when both have the same element connectivity (the
    elements' DOFs), hinges' DOFs, prescribed DOFs and loaded nodes; returns whether it adopted.
    A solve of ``compiled`` then gives the same numbers as without: the pattern and the analysis
    are the ones its own first evaluation would build (tests/test_structure_reuse.py)."""
    new, old = compiled.problem, previous.problem
    m, m0 = new.model, old.model
    if not (m.n_dofs == m0.n_dofs and np.array_equal(m.element_dofs, m0.element_dofs)
            and np.array_equal(new.prescribed, old.prescribed) and np.array_equal(new.loads.node, old.loads.node)
            and (m.hinges is None) == (m0.hinges is None)
            and (m.hinges is None or np.array_equal(m.hinge_dofs, m0.hinge_dofs))):
        return False
    kept = vars(old)
    for name in ("_pattern", "_tangent_solver"):  # functools.cached_property values, once built
        if name in kept:
            vars(new).setdefault(name, kept[name])
    _share_section_table(m.elements, m0.elements)
    for key, setup in previous.derived.items():
        rebind = getattr(setup, "rebind", None)
        moved = rebind(compiled) if rebind is not None else None
        if moved is not None:
            compiled.derived.setdefault(key, moved)
    return True


def _share_section_table(elements, previous) -> None:
    """``previous``'s `flexmb.fe.stress.section_table` for ``elements`` too when both batches hold
    the same section objects on the same joints with the same lengths (the table reads nothing
    else): a design that moves joints, not their meshes."""
    from .fe import stress

    table = stress._TABLES.get(previous)
    if (table is not None and len(elements.sections) == len(previous.sections)
            and all(map(operator.is_, elements.sections, previous.sections))
            and np.array_equal(elements.owner, previous.owner) and np.array_equal(elements.L0, previous.L0)):
        stress._TABLES[elements] = table


def _reuse_structure(compiled: Compiled) -> None:
    """`adopt` from the last compiled problem of the same `structure_key` in this thread (a design
    loop's previous mechanism, found by its structure, not its identity), then keep ``compiled``
    in its place."""
    key = structure_key(compiled)
    if key is None:
        return
    try:
        kept = _LOCAL.structures
    except AttributeError:
        kept = _LOCAL.structures = {}
    previous = kept.pop(key, None)
    if previous is not None:
        adopt(compiled, previous)
    kept[key] = compiled
    size = lambda c: len(c.problem.model.element_dofs)  # noqa: E731
    while len(kept) > STRUCTURES_KEPT or sum(map(size, kept.values())) > STRUCTURE_ELEMENTS:
        del kept[next(iter(kept))]  # the least recently used first (a model too large is not kept)
