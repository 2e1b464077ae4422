"""`Compiled`: a mechanism turned into a problem a strategy can solve, with the maps back to links;
`compiled_for`: the compiled problem of a mechanism, built once while the mechanism is unchanged."""

from __future__ import annotations

import threading
import weakref

import attrs
import numpy as np

__all__ = ["Compiled", "compiled_for", "fingerprint"]


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


_VALUES = (str, int, float, bool, type(None), np.floating, np.integer)


def fingerprint(mechanism) -> tuple | None:
    """What compiling ``mechanism`` (a `flexmb.Mechanism`) reads, as a tuple comparable with ``==``,
    and the objects it names (kept alive, so their ids are not reused); None when it cannot be
    told (a joint that is not an immutable value).

    Scalars by value; links, joints, placements, load rows, prescribed-motion dicts, points and
    the actuation by identity: all are immutable (frozen attrs, read-only arrays) or replaced, never
    changed, by the mechanism's methods (`Mechanism.prescribe` builds a new dict per call). The
    graph's own node and edge data dicts are read item by item, so replacing a link or a joint in
    ``mechanism.graph`` directly is seen too."""
    key, pins = [mechanism.dim], []

    def put(obj):
        if isinstance(obj, _VALUES):
            key.append(obj)
        else:
            key.append(id(obj))
            pins.append(obj)

    graph = mechanism.graph
    key.append(len(graph))
    for name, data in graph.nodes(data=True):
        put(name)
        key.append(len(data))
        for k, val in data.items():
            put(k), put(val)
    key.append(graph.number_of_edges())
    for a, b, name, data in graph.edges(keys=True, data=True):
        put(a), put(b), put(name)
        key.append(len(data))
        for k, val in data.items():
            if k == "joint":
                try:
                    hash(val)
                except TypeError:  # a plugin joint that is not a value: it could change unseen
                    return None
            put(k), put(val)
    state = vars(mechanism)
    for attr in ("_loads", "_prescribed", "_points", "_actuation"):
        val = state.get(attr)
        put(attr)
        if isinstance(val, list):
            key.append(len(val))
            for item in val:
                put(item)
        elif isinstance(val, dict):
            key.append(len(val))
            for k, item in val.items():
                put(k), put(item)
                if isinstance(item, dict):  # a link's prescribed components: values or read-only arrays
                    key.append(len(item))
                    for c, x in item.items():
                        put(c), put(x)
        else:
            put(val)
    return tuple(key), pins


def _read_only(compiled: Compiled) -> None:
    """Make the arrays of a compiled problem that describe the mechanism read-only (the prescribed
    DOFs and values, the loads, the reference positions, the maps to links and joints): a
    `Compiled` shared by the solves of one mechanism cannot be changed through one
    `Solution.compiled`. The element batches stay as they are (the compiled kernels are typed on
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
    and reused by the next solve of it: compiling the manipulator costs ~0.3 ms, a KSD-reduced
    solve ~1 ms. Any change through the mechanism's methods or its graph compiles anew; a
    mechanism with a joint that is not a value is compiled every time. The cached problem's
    arrays are read-only. One cache per thread and per mechanism (held weakly)."""
    try:
        cache = _LOCAL.cache
    except AttributeError:
        cache = _LOCAL.cache = weakref.WeakKeyDictionary()
    fp = None
    if getattr(type(mechanism).compile, "__qualname__", "") == "Mechanism.compile":  # flexmb's own compile
        try:
            fp = fingerprint(mechanism)
        except (AttributeError, TypeError):  # not a flexmb.Mechanism's data: no cache
            fp = None
    if fp is None:
        return mechanism.compile(capability)
    entry = cache.get(mechanism)
    if entry is not None and entry[0] == fp[0] and capability in entry[2]:
        return entry[2][capability]
    compiled = mechanism.compile(capability)
    _read_only(compiled)
    built = entry[2] if entry is not None and entry[0] == fp[0] else {}
    built[capability] = compiled
    cache[mechanism] = (fp[0], fp[1], built)
    return compiled
