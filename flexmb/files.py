"""Mechanism files: `save` and `load` a `flexmb.Mechanism` as a versioned JSON document.

The format (``docs/files.md``) is plain JSON (RFC 8259), written with the standard library:
floats are written by ``repr`` (the shortest text that reads back to the same double), so a
loaded mechanism is the same mechanism bit for bit and solves to the same numbers. A file is
data, never code: nothing in it is evaluated or imported; joints are named by the kind they are
registered under (`flexmb.available_joints`: the shipped ones and installed plugins) and built
with their constructor and its checks. Reading is strict: a missing or unknown key, a value of
the wrong type or shape, NaN or infinity where a finite number belongs, a file from a newer
format version, and whatever the constructors refuse raise one `MechanismFileError` naming the
place in the file (``joints[2].parameters.thickness: ...``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import attrs
import numpy as np

from . import _validate as v
from .errors import FlexmbError, ModelError
from .joints._base import UNSET
from .materials import Material, material
from .mechanism import Mechanism, Placement
from .registry import _shipped, available_joints, joint_from_params
from .sections import Section
from .units import SYSTEMS

__all__ = ["save", "load", "dumps", "loads", "to_dict", "from_dict", "MechanismFileError", "FORMAT", "VERSION",
           "MAX_BYTES"]

#: The ``"format"`` marker of a mechanism file and its current version (a reader refuses newer ones).
#: Version 2 adds points inside joints (``joint_points``, ``joint_point_loads``); a mechanism
#: without them is written as version 1, which older readers read.
FORMAT, VERSION = "flexmb-mechanism", 2
#: Largest file `load` reads [bytes]: far above any mechanism (the manipulator: 9 kB) and small
#: enough that a hostile file cannot exhaust memory.
MAX_BYTES = 16 * 2**20
_TOP = {"format", "version", "dim", "units", "materials", "links", "joints", "prescribed", "loads", "points",
        "actuation", "joint_points", "joint_point_loads"}
#: The keys a file needs version 2 for (points inside joints, `Mechanism.add_joint_point`)
_V2 = ("joint_points", "joint_point_loads")


class MechanismFileError(ModelError):
    """A mechanism file that cannot be read or written: the message names the place in the file."""


# -- writing ------------------------------------------------------------------------------------

def to_dict(mechanism: Mechanism) -> dict:
    """The mechanism as the JSON-ready document `save` writes (see ``docs/files.md``)."""
    if not isinstance(mechanism, Mechanism):
        raise MechanismFileError(f"save: {type(mechanism).__name__} is not a flexmb.Mechanism")
    materials: dict = {}
    inside, inside_loads, inside_motions = mechanism._inside  # points inside joints: version 2
    doc = {"format": FORMAT, "version": VERSION if inside else 1, "dim": mechanism.dim,
           "units": None if mechanism.units is None else mechanism.units.name, "materials": materials}
    doc["links"] = [_link_dict(lk) for lk in mechanism.links.values()]
    doc["joints"] = [_joint_dict(mechanism, a, b, name, data, materials)
                     for a, b, name, data in mechanism.graph.edges(keys=True, data=True)]
    doc["prescribed"] = {name: {k: _encode(x, f"prescribed.{name}.{k}") for k, x in mechanism.prescribed(name).items()}
                         for name in mechanism.links if mechanism.prescribed(name)}
    doc["prescribed"].update({name: {k: _encode(x, f"prescribed.{name}.{k}") for k, x in motion.items()}
                              for name, motion in inside_motions if motion})
    doc["loads"] = [{"link": link, "offset": o.tolist(), "force": f.tolist(), "moment": m.tolist()}
                    for link, o, f, m in mechanism.loads]
    doc["points"] = [{"name": name, "link": link, "offset": o.tolist()} for name, (link, o) in mechanism.points.items()]
    act = mechanism.actuation
    doc["actuation"] = None if act is None else {"link": act["link"], "offset": act["offset"].tolist(),
                                                 "direction": act["direction"].tolist(), "value": act["value"]}
    if inside:
        doc["joint_points"] = [{"name": n, "joint": j, "leaf": leaf, "fraction": float(f)} for n, j, leaf, f in inside]
        doc["joint_point_loads"] = [{"point": n, "force": np.asarray(f, dtype=float).tolist(),
                                     "moment": np.asarray(mo, dtype=float).tolist()} for n, f, mo in inside_loads]
    _check_finite(doc)
    return doc


def _link_dict(lk) -> dict:
    """A link: its name, position and, where they are not (positive) zeros, fixed, mass, inertia, center."""
    out = {"name": lk.name, "position": lk.position.tolist()}
    if lk.fixed:
        out["fixed"] = True
    for key, value in (("mass", lk.mass), ("inertia", lk.inertia), ("center", lk.center)):
        a = np.asarray(value, dtype=float) if value is not None else None
        if a is not None and (np.any(a) or np.any(np.signbit(a))):
            out[key] = a.tolist() if a.ndim else float(a)
    return out


def _joint_dict(mechanism, a, b, name, data, materials: dict) -> dict:
    joint, placement = data["joint"], data["placement"]
    a, b = data.get("sides", (a, b))
    where = f"joint {name!r}"
    kind = joint.kind
    if _joint_classes().get(kind) is not type(joint):
        raise MechanismFileError(f"save: {where}: its class {type(joint).__qualname__} is not the joint registered as "
                                 f"{kind!r}; a file names joints by their registered kind (register it, or install "
                                 "its plugin)")
    if not attrs.has(type(joint)):
        raise MechanismFileError(f"save: {where}: {type(joint).__qualname__} is not an attrs class: its parameters "
                                 "cannot be read (write plugin joints as attrs classes, docs/plugins.md)")
    params = {}
    for f in attrs.fields(type(joint)):
        value = getattr(joint, f.name)
        if not f.init or value is UNSET:
            continue
        if isinstance(value, Material):
            params[f.alias] = _material_ref(value, materials)
        else:
            params[f.alias] = _encode(value, f"{where}.{f.alias}")
    return {"name": name, "kind": kind, "a": a, "b": b, "origin": placement.origin.tolist(),
            "rotation": placement.rotation.tolist(), "parameters": params}


def _joint_classes() -> dict:
    """The joint classes a file may name: the registered ones (installed entry points, this
    session's registrations) and flexmb's own (an editable install's metadata may predate one)."""
    return {**_shipped(), **available_joints()}


def _material_ref(m: Material, materials: dict) -> str:
    """The key of ``m`` in the file's material table (added if new): its catalogue name, else
    ``material_<k>``; equal numbers share one entry."""
    entry = {"E": m.E, "G": m.G, "density": m.density, "yield_stress": m.yield_stress}
    for key, old in materials.items():
        if {k: old[k] for k in entry} == entry:
            return key
    key = m.name if m.name and m.name not in materials else f"material_{len(materials) + 1}"
    materials[key] = {**entry, "units": m.units}
    return key


def _encode(value, where: str):
    """A joint parameter or motion as JSON: numbers, text, booleans, null, lists (arrays, tuples),
    ``{"section": {...}}``, ``{"float": "inf"}`` for an infinite float (a shear coefficient)."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, np.bool_):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if math.isinf(x):
            return {"float": "inf" if x > 0 else "-inf"}
        if math.isnan(x):
            raise MechanismFileError(f"save: {where} is NaN")
        return x
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (np.ndarray, list, tuple)):
        return [_encode(x, f"{where}[{i}]") for i, x in enumerate(np.asarray(value).tolist()
                                                                  if isinstance(value, np.ndarray) else value)]
    if isinstance(value, Section):
        return {"section": {f.name: _encode(getattr(value, f.name), f"{where}.{f.name}") for f in attrs.fields(Section)}}
    raise MechanismFileError(f"save: {where}: a {type(value).__name__} cannot be written to a mechanism file (numbers, "
                             "text, booleans, arrays, flexmb.Section and flexmb.Material can)")


def _check_finite(doc) -> None:
    """Refuse NaN and infinity outside ``{"float": ...}`` (JSON has no such numbers)."""
    def walk(x, where):
        if isinstance(x, float) and not math.isfinite(x):
            raise MechanismFileError(f"save: {where} is {x!r}; a mechanism file holds finite numbers")
        if isinstance(x, dict):
            for k, y in x.items():
                walk(y, f"{where}.{k}")
        elif isinstance(x, list):
            for i, y in enumerate(x):
                walk(y, f"{where}[{i}]")
    walk(doc, "mechanism")


def dumps(mechanism: Mechanism) -> str:
    """The mechanism file's text (`save` writes it): JSON, objects one key a line, lists of
    numbers on one line."""
    return _pretty(to_dict(mechanism), "") + "\n"


def _pretty(x, pad: str) -> str:
    if isinstance(x, dict) and x and not (len(x) == 1 and not isinstance(next(iter(x.values())), (dict, list))):
        inner = pad + "  "
        items = [f"{inner}{json.dumps(k)}: {_pretty(y, inner)}" for k, y in x.items()]
        return "{\n" + ",\n".join(items) + f"\n{pad}}}"
    if isinstance(x, list) and x and not _flat(x):
        inner = pad + "  "
        return "[\n" + ",\n".join(inner + _pretty(y, inner) for y in x) + f"\n{pad}]"
    return json.dumps(x, allow_nan=False)


def _flat(x) -> bool:
    """A list of numbers (or of lists of numbers): written on one line."""
    return all(not isinstance(y, (dict, list)) or (isinstance(y, list) and _flat(y)) for y in x)


def save(mechanism: Mechanism, path) -> Path:
    """Write ``mechanism`` to ``path`` (a mechanism file, ``docs/files.md``; ``.json`` by
    convention). Returns the path. `MechanismFileError` if a part cannot be written (a joint
    that is not registered, a parameter of a type the format has no place for)."""
    text = dumps(mechanism)
    path = Path(path)
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise MechanismFileError(f"save: cannot write {str(path)!r}: {exc.strerror or exc}") from None
    return path


# -- reading ------------------------------------------------------------------------------------

def load(path) -> Mechanism:
    """The mechanism in the file ``path`` (`save`'s format). Raises `MechanismFileError` naming the
    place in the file for anything it refuses (see the module notes)."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise MechanismFileError(f"{path}: {size} bytes, larger than a mechanism file can be ({MAX_BYTES})")
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise MechanismFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise MechanismFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        return loads(text)
    except MechanismFileError as exc:
        raise MechanismFileError(f"{path}: {exc}") from None


def loads(text: str) -> Mechanism:
    """The mechanism in a mechanism file's ``text``."""
    if len(text) > MAX_BYTES:
        raise MechanismFileError(f"{len(text)} characters, larger than a mechanism file can be ({MAX_BYTES})")
    try:
        doc = json.loads(text, parse_constant=_refuse_constant, object_pairs_hook=_unique_keys)
    except MechanismFileError:
        raise
    except json.JSONDecodeError as exc:
        raise MechanismFileError(f"not JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except (RecursionError, ValueError) as exc:  # nesting too deep, an integer too long
        raise MechanismFileError(f"not a mechanism file: {exc}") from None
    return from_dict(doc)


def _refuse_constant(name: str):
    raise MechanismFileError(f"{name} is not a number a mechanism file may hold (JSON has no NaN or infinity; write "
                             '{"float": "inf"} where an infinite value is meant)')


def _unique_keys(pairs):
    out = {}
    for k, x in pairs:
        if k in out:
            raise MechanismFileError(f"the key {k!r} appears twice in one object")
        out[k] = x
    return out


def from_dict(doc) -> Mechanism:
    """The mechanism described by the document ``doc`` (what `to_dict` gives)."""
    _header(doc)
    _keys(doc, "mechanism", _TOP, _TOP - {"units", "materials", "prescribed", "loads", "points", "actuation", *_V2})
    for key in _V2:
        if key in doc and doc["version"] < 2:
            raise MechanismFileError(f"{key}: points inside joints need format version 2 (the file says version "
                                     f"{doc['version']})")
    dim = doc["dim"]
    if dim not in (2, 3) or isinstance(dim, bool):
        raise MechanismFileError(f"dim: {dim!r} must be 2 or 3")
    units = doc.get("units")
    if units is not None and units not in SYSTEMS:
        raise MechanismFileError(f"units: {units!r}; valid: {', '.join(SYSTEMS)} or null")
    m = Mechanism(dim=dim, units=units)
    materials = _materials(doc.get("materials", {}), units)
    for i, lk in enumerate(_list(doc, "links")):
        _at(f"links[{i}]", lambda: _add_link(m, lk))
    for i, jd in enumerate(_list(doc, "joints")):
        _at(f"joints[{i}]", lambda: _add_joint(m, jd, materials, f"joints[{i}]"))
    for i, d in enumerate(_list(doc, "joint_points")):
        _at(f"joint_points[{i}]", lambda: _add_joint_point(m, d))
    prescribed = doc.get("prescribed", {})
    if not isinstance(prescribed, dict):
        raise MechanismFileError("prescribed: must be an object {link: {component: value}}")
    for name, motion in prescribed.items():
        where = f"prescribed.{name}"
        if not isinstance(motion, dict):
            raise MechanismFileError(f"{where}: must be an object {{component: value}}")
        _at(where, lambda: m.prescribe(name, **{k: _decode(x, f"{where}.{k}") for k, x in motion.items()}))
    _restore_loads(m, doc)
    _restore_joint_point_loads(m, doc)
    return m


def _add_joint_point(m: Mechanism, d) -> None:
    """A point inside a joint (`Mechanism.add_joint_point`), its leaf checked against the joint's."""
    from .fe.joint_points import leaf_path

    _keys(d, "", {"name", "joint", "leaf", "fraction"}, {"name", "joint", "fraction"})
    leaf = d.get("leaf", 0)
    m.add_joint_point(d["joint"], d["name"], d["fraction"], leaf=leaf)
    leaf_path(m.joints[d["joint"]], m.dim, leaf, f"joint point {d['name']!r}")


def _restore_joint_point_loads(m: Mechanism, doc: dict) -> None:
    """The loads at points inside joints as written (force and moment bit for bit)."""
    dim, nm = m.dim, (1 if m.dim == 2 else 3)
    for i, d in enumerate(_list(doc, "joint_point_loads")):
        where = f"joint_point_loads[{i}]"
        _keys(d, where, {"point", "force", "moment"}, {"point"})
        if not m._is_joint_point(d["point"]):
            raise MechanismFileError(f"{where}.point: no joint point named {d['point']!r}; joint points: "
                                     f"{', '.join(m.joint_points) or 'none'}")
        force = _number_list(d.get("force", [0.0] * dim), f"{where}.force", (dim,))
        moment = _number_list(d.get("moment", [0.0] * nm), f"{where}.moment", (nm,))
        m._inside_load(d["point"], force, moment)


def _header(doc) -> None:
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise MechanismFileError(f'not a flexmb mechanism file (its "format" must be "{FORMAT}")')
    version = doc.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise MechanismFileError(f"version: {version!r} must be a whole number >= 1")
    if version > VERSION:
        raise MechanismFileError(f"version: the file is format version {version}, written by a newer flexmb; this "
                                 f"flexmb reads versions up to {VERSION}: upgrade flexmb (pip install -U flexmb)")


def _keys(d, where: str, valid: set, required: set) -> None:
    if not isinstance(d, dict):
        raise MechanismFileError(f"{where}: must be an object, got {_kind(d)}")
    unknown = sorted(set(d) - valid)
    if unknown:
        raise MechanismFileError(f"{where}: unknown key(s) {', '.join(map(repr, unknown))}; valid: "
                                 f"{', '.join(sorted(valid))}")
    missing = sorted(required - set(d))
    if missing:
        raise MechanismFileError(f"{where}: missing key(s) {', '.join(map(repr, missing))}")


def _kind(x) -> str:
    return {dict: "an object", list: "a list", str: "text", bool: "a boolean", type(None): "null"}.get(
        type(x), "a number")


def _list(doc: dict, key: str) -> list:
    x = doc.get(key, [])
    if not isinstance(x, list):
        raise MechanismFileError(f"{key}: must be a list, got {_kind(x)}")
    return x


def _at(where: str, fn):
    """``fn()``, with what flexmb refuses re-raised as a `MechanismFileError` naming ``where``
    (and the parameter, where the message names one of the place's parameters)."""
    try:
        return fn()
    except MechanismFileError as exc:
        msg = str(exc)
        raise MechanismFileError(msg if msg.startswith(where) else f"{where}{msg}" if msg.startswith(":")
                                 else f"{where}.{msg}") from None
    except FlexmbError as exc:
        raise MechanismFileError(f"{where}: {exc}") from None
    except (TypeError, ValueError, OverflowError, RecursionError) as exc:
        raise MechanismFileError(f"{where}: {exc}") from None


def _number_list(x, where: str, shape: tuple) -> np.ndarray:
    """``x`` as a float array of ``shape``, refusing other shapes and non-numbers by name."""
    if not _nested_numbers(x, len(shape)):
        raise MechanismFileError(f"{where}: must be {_shape_text(shape)}, got {_kind(x)}")
    a = np.array(x, dtype=float)
    if a.shape != shape:
        raise MechanismFileError(f"{where}: must be {_shape_text(shape)}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise MechanismFileError(f"{where}: must be finite")
    return a


def _shape_text(shape: tuple) -> str:
    return "a number" if not shape else f"a list of {shape[0]} numbers" if len(shape) == 1 else \
        f"a {' x '.join(map(str, shape))} list of lists of numbers"


def _nested_numbers(x, depth: int) -> bool:
    if depth == 0:
        return isinstance(x, (int, float)) and not isinstance(x, bool)
    return isinstance(x, list) and len(x) <= 16 and all(_nested_numbers(y, depth - 1) for y in x)


def _add_link(m: Mechanism, d) -> None:
    _keys(d, "", {"name", "position", "fixed", "mass", "inertia", "center"}, {"name", "position"})
    inertia = d.get("inertia")
    if m.dim == 3 and inertia is not None:
        inertia = _number_list(inertia, "inertia", (3, 3))
    center = None if d.get("center") is None else _number_list(d["center"], "center", (m.dim,))
    m.add_link(d["name"], _number_list(d["position"], "position", (m.dim,)), fixed=d.get("fixed", False),
               mass=d.get("mass", 0.0), inertia=inertia, center=center)


def _materials(table, units) -> dict:
    if not isinstance(table, dict):
        raise MechanismFileError(f"materials: must be an object {{name: {{E, G, density, yield_stress}}}}, got "
                                 f"{_kind(table)}")
    out = {}
    for key, d in table.items():
        where = f"materials.{key}"
        _keys(d, where, {"E", "G", "nu", "density", "yield_stress", "units", "name"}, {"E"})
        if d.get("units") is not None and d["units"] not in SYSTEMS:
            raise MechanismFileError(f"{where}.units: {d['units']!r}; valid: {', '.join(SYSTEMS)} or null")
        out[key] = _at(where, lambda: Material(d["E"], d.get("G"), nu=d.get("nu"), density=d.get("density", 0.0),
                                               yield_stress=d.get("yield_stress"), units=d.get("units"),
                                               name=d.get("name", key), owner=where))
    return out


def _add_joint(m: Mechanism, d, materials: dict, where: str) -> None:
    _keys(d, "", {"name", "kind", "a", "b", "origin", "rotation", "parameters"}, {"kind", "a", "b"})
    kind = d["kind"]
    known = _joint_classes()
    if not isinstance(kind, str) or kind not in known:
        raise MechanismFileError(f"{where}.kind: no joint {kind!r} is registered; known: {', '.join(sorted(known))} "
                                 "(a plugin joint needs its package installed)")
    params = d.get("parameters", {})
    if not isinstance(params, dict):
        raise MechanismFileError(f"{where}.parameters: must be an object, got {_kind(params)}")
    values = {k: _param(x, f"{where}.parameters.{k}", materials, m.units) for k, x in params.items()}
    try:
        joint = joint_from_params(known[kind], **values)
    except FlexmbError as exc:
        text = str(exc).split("; valid")[0]
        named = next((k for k in params if f"{k}=" in text), None) or next((k for k in params if f"'{k}'" in text),
                                                                          None)
        raise MechanismFileError(f"{where}.parameters{'.' + named if named else ''}: {exc}") from None
    origin = None if d.get("origin") is None else _number_list(d["origin"], f"{where}.origin", (m.dim,))
    rotation = d.get("rotation")
    exact = None
    if isinstance(rotation, list) and rotation and isinstance(rotation[0], list):
        exact = _rotation_matrix(rotation, f"{where}.rotation", m.dim)
        rotation = None
    elif rotation is not None:
        rotation = _number_list(rotation, f"{where}.rotation", () if m.dim == 2 else (3,))
    name = d.get("name")
    m.add_joint(d["a"], d["b"], joint, name=name, origin=origin, rotation=rotation)
    if exact is not None:  # the matrix as written, bit for bit (add_joint would re-orthonormalise it)
        key = name if name is not None else list(m.joints)[-1]
        data = m.graph.edges[d["a"], d["b"], key]
        data["placement"] = Placement(data["placement"].origin, exact)


def _param(x, where: str, materials: dict, units):
    if where.endswith(".material") and isinstance(x, str):
        if x in materials:
            return materials[x]
        try:
            return material(x, units or "SI")
        except FlexmbError:
            raise MechanismFileError(f"{where}: {x!r} is neither in the file's materials "
                                     f"({', '.join(materials) or 'none'}) nor a named material") from None
    return _decode(x, where)


def _decode(x, where: str, depth: int = 0):
    if depth > 4:
        raise MechanismFileError(f"{where}: nested deeper than any parameter is")
    if isinstance(x, dict):
        if set(x) == {"float"} and x["float"] in ("inf", "-inf"):
            return float(x["float"])
        if set(x) == {"section"} and isinstance(x["section"], dict):
            fields = {k: _decode(y, f"{where}.section.{k}", depth + 1) for k, y in x["section"].items()}
            try:
                return Section(**fields)
            except TypeError as exc:
                raise MechanismFileError(f"{where}.section: {exc}") from None
        raise MechanismFileError(f'{where}: an object must be {{"float": "inf"}} or {{"section": {{...}}}}, got keys '
                                 f"{sorted(x)}")
    if isinstance(x, list):
        if len(x) > 10_000:
            raise MechanismFileError(f"{where}: a list of {len(x)} items; no parameter has that many")
        return [_decode(y, f"{where}[{i}]", depth + 1) for i, y in enumerate(x)]
    return x


def _rotation_matrix(rows, where: str, dim: int) -> np.ndarray:
    R = _number_list(rows, where, (dim, dim))
    if not (np.allclose(R.T @ R, np.eye(dim), rtol=0.0, atol=1e-9) and np.linalg.det(R) > 0):
        raise MechanismFileError(f"{where}: not a rotation matrix (orthonormal, determinant +1, to 1e-9)")
    R.flags.writeable = False
    return R


def _restore_loads(m: Mechanism, doc: dict) -> None:
    """Loads, points and the actuation as written: offsets, forces and the unit direction bit for
    bit (`Mechanism.apply_force` and `set_actuation` would recompute them from global points)."""
    dim, nm = m.dim, (1 if m.dim == 2 else 3)
    for i, d in enumerate(_list(doc, "loads")):
        where = f"loads[{i}]"
        _keys(d, where, {"link", "offset", "force", "moment"}, {"link"})
        _at(where, lambda: m.link(d["link"]))
        offset = _number_list(d.get("offset", [0.0] * dim), f"{where}.offset", (dim,))
        force = _number_list(d.get("force", [0.0] * dim), f"{where}.force", (dim,))
        moment = _number_list(d.get("moment", [0.0] * nm), f"{where}.moment", (nm,))
        m._loads.append((d["link"], offset, force, moment))
    for i, d in enumerate(_list(doc, "points")):
        where = f"points[{i}]"
        _keys(d, where, {"name", "link", "offset"}, {"name", "link", "offset"})
        offset = _number_list(d["offset"], f"{where}.offset", (dim,))
        lk = _at(where, lambda: m.link(d["link"]))
        _at(where, lambda: m.add_point(d["link"], d["name"], lk.position + offset))
        m._points[d["name"]] = (d["link"], offset)
    act = doc.get("actuation")
    if act is not None:
        _keys(act, "actuation", {"link", "offset", "direction", "value"}, {"link", "direction"})
        offset = _number_list(act.get("offset", [0.0] * dim), "actuation.offset", (dim,))
        direction = _number_list(act["direction"], "actuation.direction", (dim,))
        value = _at("actuation.value", lambda: v.finite("actuation", "value", act.get("value", 0.0)))
        lk = _at("actuation", lambda: m.link(act["link"]))
        _at("actuation", lambda: m.set_actuation(act["link"], direction, value, point=lk.position + offset))
        if abs(float(np.linalg.norm(direction)) - 1.0) < 1e-12:  # a unit vector as written stays as written
            m._actuation = (act["link"], offset, direction, value)
