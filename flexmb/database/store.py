"""Joint database files: a versioned JSON format with a checksum, and the shipped data.

Format ``flexmb-joint-database`` version 3 (one file per joint kind, dimension and mesh)::

    {"format": "flexmb-joint-database", "format_version": 3, "flexmb_version": "...",
     "kind": "cross_flexure", "dim": 3, "parameters": {...training joint...},
     "key": {...shape parameters the data belong to...}, "mesh_hash": "...",
     "intended": "rotation about z [rad]", "range": [lo, hi], "samples": [...],
     "length": D0 [m],
     "functions": {name: {"powers": [...], "coefficients": [...], "max_residual": r}},
     "elements": {"powers": [...], "coefficients": [[...]...], "max_residual": r},
     "nodes": {...same...}, "eob_table": {...} or null, "checksum": sha256 of everything else}

Functions are dimensionless (positions over D0, the undeformed distance of the interface nodes).
Element and internal-node orientations (Eq. 3.1) are angles [rad] in 2D and rotation vectors
[rad] in 3D (Sec. 3.1), one row per element or node and component (element-major: e0x, e0y, e0z,
e1x, ...). Version 1 stored 3D orientations as angles about z only; such files are refused.
Version 3 adds ``eob_table``: the EOB condensation tabulated against theta for the training joint
(`flexmb.database.eob_format`); a version 2 file is read as version 3 without a table
(its data are unchanged: KSD then condenses per solve, as before) and `flexmb train` rewrites it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import secrets
import stat
import sys
import warnings
from importlib import resources
from pathlib import Path

import attrs
import numpy as np

from .._validate import hashable
from .._version import __version__
from . import eob_format
from ..errors import DatabaseError, ExtrapolationWarning

__all__ = ["FORMAT", "FORMAT_VERSION", "Polynomial", "JointData", "save", "write", "load", "mesh_hash", "data_path",
           "shipped", "user_path", "search_path", "locate", "read_bytes", "ENVIRONMENT", "MAX_BYTES", "file_name",
           "design_hash", "design_file_name", "joint_file_name", "candidate_names", "side_file", "source", "SOURCES"]

FORMAT = "flexmb-joint-database"
FORMAT_VERSION = 3
#: Versions read: 3, and 2 migrated on reading (no EOB table).
READABLE_VERSIONS = (2, 3)
#: Environment variable naming the user data folder (`user_path`).
ENVIRONMENT = "FLEXMB_DATABASE"
#: Largest database file read [bytes]: the shipped files are 3-20 kB; a 10-stage joint at 20
#: el./leaf stays below 1 MB. A larger file is refused before it is read.
MAX_BYTES = 16 * 2**20
#: Largest fit residual a usable file may state (positions over D0, rotations [rad]): the shipped
#: fits stay below 2.3e-4; a fit 5 % off is no kinematic data.
MAX_RESIDUAL = 0.05
#: Highest polynomial power read (the shipped fits use 6).
MAX_POWER = 30


@attrs.frozen(eq=False)
class Polynomial:
    """``sum_k c_k t^{p_k}`` for one or many functions: ``coefficients`` (..., len(powers))."""

    powers: np.ndarray
    coefficients: np.ndarray
    max_residual: float

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return (t[..., None] ** self.powers) @ np.asarray(self.coefficients).T

    def derivative(self, t) -> np.ndarray:
        """d/dt of the polynomial at ``t`` (same shape as `__call__`)."""
        t = np.asarray(t, dtype=float)
        p = self.powers
        with np.errstate(divide="ignore", invalid="ignore"):
            basis = np.where(p > 0, p * t[..., None] ** np.maximum(p - 1, 0), 0.0)
        return basis @ np.asarray(self.coefficients).T

    def to_json(self) -> dict:
        """The polynomial as a JSON-ready dict (powers, coefficients, max_residual)."""
        return {"powers": self.powers.tolist(), "coefficients": np.asarray(self.coefficients).tolist(),
                "max_residual": self.max_residual}

    @classmethod
    def from_json(cls, d: dict) -> Polynomial:
        return cls(np.asarray(d["powers"], dtype=float), np.asarray(d["coefficients"], dtype=float),
                   float(d["max_residual"]))

    @classmethod
    def fit(cls, t, y, powers) -> Polynomial:
        """Least-squares fit of ``y`` (S,) or (S, m) sampled at ``t`` (S,)."""
        t, y = np.asarray(t, float), np.asarray(y, float)
        A = t[:, None] ** np.asarray(powers, float)[None]
        c, *_ = np.linalg.lstsq(A, y, rcond=None)
        err = np.abs(A @ c - y)
        res = float(err.max()) if err.size else 0.0
        return cls(np.asarray(powers, float), c.T, res)


@attrs.frozen(eq=False)
class JointData:
    """Trained kinematic data of one joint kind, dimension and mesh (see the module docstring)."""

    kind: str
    dim: int
    parameters: dict
    key: dict
    mesh_hash: str
    range: tuple[float, float]
    samples: np.ndarray
    length: float
    functions: dict
    elements: Polynomial
    nodes: Polynomial
    flexmb_version: str = ""
    eob_table: object = None  # a flexmb.database.eob_format.EOBTable, or None (version 2, or not tabulated)
    #: the file the data were read from (`load`); None when built in memory (`flexmb.database.train`)
    path: str | None = None

    def check_range(self, theta, *, strict: bool = False) -> None:
        """Warn (``ExtrapolationWarning``) or, with ``strict``, raise when ``theta`` leaves the range."""
        t = np.atleast_1d(np.asarray(theta, dtype=float))
        lo, hi = self.range
        if np.any((t < lo - 1e-12) | (t > hi + 1e-12)):
            msg = (f"{self.kind} database {self.path or ''} ({self.dim}D, {self.key}): intended rotation "
                   f"{np.degrees(t[(t < lo) | (t > hi)][0]):.2f} deg is outside the trained range "
                   f"[{np.degrees(lo):.1f}, {np.degrees(hi):.1f}] deg")
            if strict:
                raise DatabaseError(msg)
            warnings.warn(msg + "; the fits are extrapolated", ExtrapolationWarning, stacklevel=3)

    def function(self, name: str) -> Polynomial:
        """The fitted constraint function ``name`` (e.g. ``"x"``); `DatabaseError` naming those held if absent."""
        try:
            return self.functions[name]
        except KeyError:
            raise DatabaseError(f"{self.kind} database holds {sorted(self.functions)}, not {name!r}") from None

    def to_json(self, values_file: str | None = None) -> dict:
        """The whole record as a JSON-ready dict (format name and version, joint, fits, checksum);
        ``values_file`` names the EOB table's side file (default: `side_file_name` of the design's file)."""
        if values_file is None and self.eob_table is not None:
            values_file = side_file_name(design_file_name(self.kind, self.dim, self.key, self.parameters), self.eob_table)

        body = {"format": FORMAT, "format_version": FORMAT_VERSION, "flexmb_version": __version__,
                "kind": self.kind, "dim": self.dim, "parameters": self.parameters, "key": self.key,
                "mesh_hash": self.mesh_hash, "intended": "rotation of node B about z relative to node A [rad]",
                "range": list(self.range), "samples": np.asarray(self.samples).tolist(), "length": self.length,
                "functions": {k: f.to_json() for k, f in self.functions.items()},
                "elements": self.elements.to_json(), "nodes": self.nodes.to_json(),
                "eob_table": eob_format.to_json(self.eob_table, values_file)}
        body["checksum"] = _checksum(body)
        return body


def _checksum(body: dict) -> str:
    payload = {k: v for k, v in body.items() if k != "checksum"}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def mesh_hash(joint, dim: int) -> str:
    """Fingerprint of a joint's mesh in the plane of motion (x, y over D0, sides, elements): the
    kinematic data belong to it; data trained on another in-plane mesh are stale."""
    return _mesh_facts(joint, dim)[0]


def _mesh_facts(joint, dim: int) -> tuple[str, int]:
    """(`mesh_hash`, number of elements) of the joint's mesh; cached per joint value, as joints
    are frozen values: building the mesh took ~60 % of a KSD-reduced manipulator solve when it
    was done on every solve."""
    return _cached_mesh_facts(joint, dim) if hashable(joint) else _compute_mesh_facts(joint, dim)


def _compute_mesh_facts(joint, dim: int) -> tuple[str, int]:
    mesh = joint.mesh(dim)
    D0 = float(np.linalg.norm(joint.interface_b(dim)))
    pts = np.round(np.asarray(mesh.points, float)[:, :2] / D0, 9) + 0.0
    parts = [pts.tolist(), np.asarray(mesh.side).tolist(), np.asarray(mesh.elements).tolist()]
    if mesh.body is not None:
        parts.append(np.asarray(mesh.body).tolist())
    blob = json.dumps(parts)
    return hashlib.sha256(blob.encode()).hexdigest()[:16], len(mesh.elements)


_cached_mesh_facts = functools.lru_cache(maxsize=256)(_compute_mesh_facts)


def side_file_name(name: str, table) -> str:
    """The EOB table's side file of the database file ``name``: ``<stem>.<sha256 of its samples,
    16 digits>.eob.bin``. Named by content, so a database file always finds the samples its
    checksum covers, whichever of two concurrent writers renamed last."""
    digest = hashlib.sha256(eob_format.sample_bytes(table)).hexdigest()[:16]
    return f"{name[:-len('.json')] if name.endswith('.json') else name}.{digest}{eob_format.SUFFIX}"


def _temporary(path: Path) -> Path:
    """A temporary name beside ``path``, unique per process, thread and call (two writers of one
    folder never share one)."""
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp")


def _atomic_write(path: Path, payload: bytes) -> None:
    """``payload`` to ``path`` through a unique temporary file and `os.replace`: a reader sees the
    old file or the new one, never half of one (POSIX rename; Windows' MoveFileEx)."""
    tmp = _temporary(path)
    try:
        with open(tmp, "xb") as f:
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def save(data: JointData, path) -> Path:
    """Write ``data`` as JSON to ``path`` (format of `JointData.to_json`); returns the path.

    The EOB table's samples go first to their side file, named by content (`side_file_name`);
    then the JSON is written under a temporary name unique to this call and renamed over
    ``path``, so a reader never sees half a file, a failed write leaves the old file as it was and
    two concurrent writers leave one whole file (the last rename's) whose side file exists. The
    side file the replaced JSON named is removed when no longer named. `DatabaseError` when the
    folder cannot be written. `write` names the file by the design; this writes where told."""
    path = Path(path)
    side = None if data.eob_table is None else path.with_name(side_file_name(path.name, data.eob_table))
    text = json.dumps(data.to_json(None if side is None else side.name), indent=1, sort_keys=True) + "\n"
    try:
        old = side_file(path)
        if side is not None and not side.exists():
            _atomic_write(side, eob_format.sample_bytes(data.eob_table))
        _atomic_write(path, text.encode("utf-8"))
    except OSError as exc:
        raise DatabaseError(f"cannot write joint database {path}: {exc.strerror or exc}") from None
    if old is not None and (side is None or old != side):
        old.unlink(missing_ok=True)
    return path


def side_file(path) -> Path | None:
    """The EOB side file the database file ``path`` names (None: no file there, no table, not
    readable as a database body)."""
    path = Path(path)
    try:
        name = json.loads(path.read_bytes())["eob_table"]["values_file"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if isinstance(name, str) and Path(name).name == name and name.endswith(eob_format.SUFFIX):
        return path.with_name(name)
    return None


def write(data: JointData, folder) -> Path:
    """Write ``data`` into ``folder`` under its design's name (`design_file_name`: kind, dimension,
    key and a hash of the training joint's full parameters) and return the path: what
    ``flexmb train`` does. Atomic as `save`. Replaces only a file of the same design (retraining);
    a file there holding another design (a hash collision, a file renamed by hand) is refused with
    a `DatabaseError` naming both, never replaced."""
    folder = Path(folder)
    path = folder / design_file_name(data.kind, data.dim, data.key, data.parameters)
    if os.path.lexists(path):
        try:
            held = load(path)
        except DatabaseError:
            held = None  # damaged or unreadable: replaced by the same design's new training
        if held is not None and (held.kind, held.dim, held.parameters) != (data.kind, data.dim, data.parameters):
            raise DatabaseError(f"joint database {path} holds another design ({held.kind} {held.dim}D "
                                f"{held.parameters}), not {data.kind} {data.dim}D {data.parameters}; it is not "
                                "replaced: move it away or train into another folder")
    return save(data, path)


def read_bytes(path) -> bytes:
    """The bytes of the database file ``path``: a regular file (a FIFO, device or folder is
    refused without blocking on it) of at most `MAX_BYTES`; `DatabaseError` otherwise."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except FileNotFoundError:
        raise DatabaseError(f"joint database {path} does not exist; create it with `flexmb train`") from None
    except OSError as exc:
        raise DatabaseError(f"joint database {path} cannot be opened: {exc.strerror or exc}") from None
    with os.fdopen(fd, "rb") as f:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise DatabaseError(f"joint database {path} is not a regular file (a folder, pipe or device); give "
                                "the path of a .json file written by `flexmb train`")
        if info.st_size > MAX_BYTES:
            raise DatabaseError(f"joint database {path} has {info.st_size} bytes, more than any database "
                                f"(at most {MAX_BYTES}); it is not a flexmb joint database")
        try:
            raw = f.read(MAX_BYTES + 1)
        except OSError as exc:
            raise DatabaseError(f"joint database {path} cannot be read: {exc.strerror or exc}") from None
    if len(raw) > MAX_BYTES:  # grew while being read
        raise DatabaseError(f"joint database {path} has more than {MAX_BYTES} bytes; it is not a flexmb joint "
                            "database")
    return raw


def load(path) -> JointData:
    """Read and verify a database file: a regular file of at most `MAX_BYTES`, the format, version
    and checksum, then its content (types, shapes, finite values, consistent sizes, ranges and
    the consistency of its fits, `_validate`); `DatabaseError` naming the first fault otherwise."""
    path = Path(path)
    return _parse(read_bytes(path), str(path))  # `JointData.path`: ``str(path)``


@functools.lru_cache(maxsize=64)
def _parse(raw: bytes, where: str) -> JointData:
    """The `JointData` held by the bytes ``raw`` of file ``where`` (cached on the content, so a
    replaced file is read anew whatever its time stamps)."""
    try:
        body = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:  # JSONDecodeError is a ValueError
        raise DatabaseError(f"joint database {where} is corrupted (not readable JSON: {str(exc)[:200]}); "
                            "re-create it with `flexmb train`") from None
    if not isinstance(body, dict) or body.get("format") != FORMAT:
        raise DatabaseError(f"{where} is not a flexmb joint database (format {FORMAT!r})")
    if body.get("format_version") not in READABLE_VERSIONS:
        raise DatabaseError(f"joint database {where} has format version {body.get('format_version')!r}; this "
                            f"flexmb reads versions {READABLE_VERSIONS} (2 migrated on reading): re-create it with "
                            "`flexmb train`")
    try:
        intact = body.get("checksum") == _checksum(body)
    except (TypeError, ValueError, RecursionError):
        intact = False
    if not intact:
        raise DatabaseError(f"joint database {where} is corrupted (checksum mismatch): it was edited or damaged; "
                            "re-create it with `flexmb train`")
    try:
        data = _validate(body, where)
        table = _eob_table(body, Path(where).parent)
        return data if table is None else attrs.evolve(data, eob_table=table)
    except _Invalid as exc:
        raise DatabaseError(f"joint database {where} is invalid: {exc}; re-create it with `flexmb train`") from None
    except RecursionError:
        raise DatabaseError(f"joint database {where} is invalid: nested too deeply; re-create it with "
                            "`flexmb train`") from None


class _Invalid(Exception):
    """A field of a database body that is not what `JointData.to_json` writes."""


def _field(body: dict, name: str, types: type | tuple, owner: str = ""):
    if name not in body:
        raise _Invalid(f"field {owner}{name!r} is missing")
    value = body[name]
    types = types if isinstance(types, tuple) else (types,)
    if not isinstance(value, types) or isinstance(value, bool) and bool not in types:
        raise _Invalid(f"field {owner}{name!r} must be {_names(types)}, got {type(value).__name__}")
    return value


def _names(types: tuple) -> str:
    return " or ".join(t.__name__ for t in types)


def _array(value, name: str, ndim: int) -> np.ndarray:
    """``value`` as a finite float array of ``ndim`` dimensions (an empty list counts as any)."""
    if not isinstance(value, list) or not _numbers_only(value):
        raise _Invalid(f"{name} must be a list of numbers")
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise _Invalid(f"{name} must be a rectangular list of numbers") from None
    if a.size == 0 and ndim == 2:
        a = a.reshape(0, 0)
    if a.ndim != ndim:
        raise _Invalid(f"{name} must have {ndim} dimension(s), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise _Invalid(f"{name} holds non-finite numbers")
    return a


def _numbers_only(value, depth: int = 0) -> bool:
    if depth > 2:
        return False
    return all(_numbers_only(v, depth + 1) if isinstance(v, list) else
               isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)


def _scalar(value, name: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _Invalid(f"{name} must be a number, got {type(value).__name__}")
    try:
        x = float(value)
    except OverflowError:
        raise _Invalid(f"{name} is too large") from None
    if not lo <= x <= hi:  # NaN fails too
        raise _Invalid(f"{name}={x!r} must lie in [{lo}, {hi}]")
    return x


def _polynomial(value, name: str, ndim: int) -> Polynomial:
    if not isinstance(value, dict):
        raise _Invalid(f"{name} must be an object with powers, coefficients and max_residual")
    powers = _array(_field(value, "powers", list, name + "."), f"{name}.powers", 1)
    if len(powers) == 0 or np.any(powers < 0) or np.any(powers > MAX_POWER) or np.any(powers != np.round(powers)) \
            or len(np.unique(powers)) != len(powers):
        raise _Invalid(f"{name}.powers must be distinct integers in [0, {MAX_POWER}], got {powers.tolist()}")
    coef = _array(_field(value, "coefficients", list, name + "."), f"{name}.coefficients", ndim)
    if coef.shape[-1] != len(powers) and coef.size:
        raise _Invalid(f"{name}.coefficients must have {len(powers)} columns (one per power), got shape {coef.shape}")
    residual = _scalar(_field(value, "max_residual", (int, float), name + "."), f"{name}.max_residual", 0.0,
                       MAX_RESIDUAL)
    if ndim == 2 and coef.size == 0:
        coef = np.zeros((0, len(powers)))
    return Polynomial(powers, coef, residual)


def _plain_dict(value, name: str) -> dict:
    if not isinstance(value, dict):
        raise _Invalid(f"field {name!r} must be an object")
    for k, v in value.items():
        if isinstance(v, float) and not math.isfinite(v):
            raise _Invalid(f"{name}[{k!r}] is not finite")
        if not isinstance(v, (str, int, float, bool)) and v is not None:
            raise _Invalid(f"{name}[{k!r}] must be a number, text or boolean, got {type(v).__name__}")
    return value


def _validate(body: dict, where: str | None = None) -> JointData:
    """`JointData` from a checksummed body after checking every field (types, shapes, finite values,
    consistent sizes, ranges) and the consistency of its fits: the positions of B at rest (D/D0
    - 1 = 0 at theta = 0), D/D0 - 1 against the norm of the position fits at every sample (both
    fitted to the same runs, so they agree within the sum of their stated residuals) and zero
    element and node rotations at rest. `_Invalid` names the first fault."""
    kind = _field(body, "kind", str)
    if not kind:
        raise _Invalid("field 'kind' is empty")
    dim = _field(body, "dim", int)
    if dim not in (2, 3):
        raise _Invalid(f"dim={dim!r} must be 2 or 3")
    parameters = _plain_dict(_field(body, "parameters", dict), "parameters")
    key = _plain_dict(_field(body, "key", dict), "key")
    mesh = _field(body, "mesh_hash", str)
    rng = _array(_field(body, "range", list), "range", 1)
    if len(rng) != 2 or not -math.pi <= rng[0] < rng[1] <= math.pi:
        raise _Invalid(f"range must be [lo, hi] with -pi <= lo < hi <= pi [rad], got {rng.tolist()}")
    samples = _array(_field(body, "samples", list), "samples", 1)
    if len(samples) < 2 or np.any(np.diff(samples) <= 0) or abs(samples[0] - rng[0]) > 1e-12 \
            or abs(samples[-1] - rng[1]) > 1e-12:
        raise _Invalid("samples must increase strictly from range[0] to range[1]")
    length = _scalar(_field(body, "length", (int, float)), "length", 0.0)
    if not length > 0 or not math.isfinite(length):
        raise _Invalid(f"length={length!r} must be positive and finite [m]")
    raw = _field(body, "functions", dict)
    names = ("x/D0", "y/D0", "z/D0")[:dim] + ("D/D0-1",)
    missing = [n for n in names if n not in raw]
    if missing:
        raise _Invalid(f"functions {missing} are missing (a {dim}D database holds {list(names)})")
    functions = {str(k): _polynomial(f, f"functions[{k!r}]", 1) for k, f in raw.items()}
    c = 1 if dim == 2 else 3
    elements = _polynomial(_field(body, "elements", dict), "elements", 2)
    nodes = _polynomial(_field(body, "nodes", dict), "nodes", 2)
    for name, poly, least in (("elements", elements, 1), ("nodes", nodes, 0)):
        rows = poly.coefficients.shape[0]
        if rows < least or rows % c:
            raise _Invalid(f"{name} must hold {c} row(s) per {name[:-1]} ({'at least one' if least else 'or none'}), "
                           f"got {rows}")
    version = body.get("flexmb_version", "")
    if not isinstance(version, str):
        raise _Invalid("field 'flexmb_version' must be text")
    # the fits describe one set of runs: their values must agree where the runs fix them
    pos = [functions[n] for n in names[:-1]]
    spread = sum(f.max_residual for f in pos) + functions["D/D0-1"].max_residual
    norm = np.linalg.norm(np.stack([f(samples) for f in pos], axis=-1), axis=-1) - 1.0
    gap = float(np.abs(norm - functions["D/D0-1"](samples)).max())
    if gap > spread + 1e-9:
        raise _Invalid(f"the position fits and D/D0 - 1 disagree by {gap:.3g} at the samples (the fits state at "
                       f"most {spread:.3g})")
    for name, poly in (("D/D0-1", functions["D/D0-1"]), ("elements", elements), ("nodes", nodes)):
        rest = np.abs(poly(0.0)).max() if poly.coefficients.size else 0.0
        if rest > poly.max_residual + 1e-9:
            raise _Invalid(f"{name} is {rest:.3g} at rest (theta = 0); the runs start undeformed")
    for a in (samples, elements.powers, elements.coefficients, nodes.powers, nodes.coefficients,
              *(x for f in functions.values() for x in (f.powers, f.coefficients))):
        a.flags.writeable = False  # shared by every reader of this content (`_parse` caches it)
    return JointData(kind=kind, dim=dim, parameters=parameters, key=key, mesh_hash=mesh,
                     range=(float(rng[0]), float(rng[1])), samples=samples, length=length, functions=functions,
                     elements=elements, nodes=nodes, flexmb_version=version, path=where)


def _eob_table(body: dict, folder: Path):
    """The version 3 ``eob_table`` (None in version 2 files or when absent), checked; its samples
    are read from ``folder`` when first used."""
    if body.get("format_version") == 2:
        return None
    try:
        return eob_format.from_json(body.get("eob_table"), folder, lambda d: _plain_dict(d, "eob_table.parameters"))
    except ValueError as exc:
        raise _Invalid(str(exc)) from None


@functools.cache
def data_path() -> Path:
    """Folder of the shipped, pre-trained database files (read only: flexmb never writes it)."""
    return Path(str(resources.files("flexmb.database") / "data"))


def user_path() -> Path:
    """Folder of the user's trained database files: `flexmb train` writes here unless told
    otherwise, and KSD looks here before the shipped data (`search_path`).

    The environment variable ``FLEXMB_DATABASE`` when set; otherwise the platform's user data
    folder: ``$XDG_DATA_HOME/flexmb/database`` (default ``~/.local/share/flexmb/database``) on
    Linux, ``~/Library/Application Support/flexmb/database`` on macOS,
    ``%LOCALAPPDATA%\\flexmb\\database`` on Windows. The folder need not exist."""
    env = os.environ.get(ENVIRONMENT)
    if env:
        try:
            return Path(env).expanduser()
        except RuntimeError:  # "~nosuchuser/x": Python cannot expand it
            raise DatabaseError(f"{ENVIRONMENT}={env!r}: cannot expand {env.split(os.sep)[0]!r} (no such user's home "
                                "folder); give an absolute path") from None
    try:
        home = Path.home()
    except RuntimeError:  # no HOME and no password entry for this user
        raise DatabaseError(f"the user data folder is unknown: no home folder (set HOME or {ENVIRONMENT} to a "
                            "folder)") from None
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or home / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = home / "Library" / "Application Support"
    else:
        xdg = os.environ.get("XDG_DATA_HOME", "")
        base = Path(xdg) if os.path.isabs(xdg) else home / ".local" / "share"
    return base / "flexmb" / "database"


def search_path(folder=None) -> list[Path]:
    """The folders searched for a joint's database file, in order (the first holding the file
    wins): ``folder`` when given (KSD's ``database=`` option), then `user_path`, then the shipped
    data (`data_path`)."""
    out = [Path(folder)] if folder is not None else []
    for p in (user_path(), data_path()):
        if p not in out:
            out.append(p)
    return out


def file_name(kind: str, dim: int, key: dict) -> str:
    """The key-only file name ``<kind>-<dim>d-<key items>.json`` (keys sorted): the shipped files'
    and those older flexmb wrote, still read (`locate`), no longer written by training."""
    parts = "-".join(f"{k}{_fmt(v)}" for k, v in sorted(key.items()))
    return f"{kind}-{dim}d-{parts}.json"


def _fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def design_hash(kind: str, dim: int, parameters: dict) -> str:
    """16 hex digits of the SHA-256 of the canonical JSON of the training joint's kind, dimension and
    full plain parameters (`flexmb.database.eob_format.plain_parameters` of its `describe`, as
    `JointData.parameters` records them): two designs share a file name only by a hash collision."""
    blob = json.dumps({"kind": kind, "dim": int(dim), "parameters": parameters}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def design_file_name(kind: str, dim: int, key: dict, parameters: dict) -> str:
    """The file name `write` gives a design's data: `file_name`'s stem, then `design_hash`
    (``cross_flexure-2d-angle0.785398-elements_per_leaf2-<16 hex>.json``)."""
    return f"{file_name(kind, dim, key)[:-len('.json')]}-{design_hash(kind, dim, parameters)}.json"


def joint_file_name(joint, dim: int) -> str:
    """`design_file_name` of ``joint`` in ``dim`` (its key and plain parameters)."""
    return design_file_name(joint.kind, dim, joint.database_key(), eob_format.plain_parameters(joint.describe()))


def candidate_names(joint, dim: int) -> tuple[str, str]:
    """The names `locate` tries in each folder, in order: the design's own (`joint_file_name`),
    then the key-only `file_name` (the shipped data, older trainings)."""
    return joint_file_name(joint, dim), file_name(joint.kind, dim, joint.database_key())


#: Where a database file was found (`source`): the ``database=`` folder, the user's, the shipped data.
SOURCES = ("database=", "user", "shipped")


def source(path, folder=None) -> str:
    """Which of `SOURCES` the file ``path`` came from: ``"database="`` when it lies in ``folder``
    (KSD's ``database=`` option), ``"shipped"`` in `data_path`, ``"user"`` in `user_path`; where
    a folder is several of these, the first in search order."""
    where = Path(path).parent
    for name, f in zip(SOURCES, (folder, user_path(), data_path())):
        if f is not None and _same_folder(where, Path(f)):
            return name
    return "file"  # elsewhere: a file given by path (`load`)


def _same_folder(a: Path, b: Path) -> bool:
    try:
        return a == b or os.path.samefile(a, b)
    except OSError:
        return False


def locate(joint, dim: int, folder=None) -> Path:
    """The database file of ``joint`` in ``dim``: in each folder of `search_path` in turn, the
    design's own file, then the key-only name (`candidate_names`); `DatabaseError` naming the
    folders searched and the training command otherwise."""
    key = joint.database_key()
    names = candidate_names(joint, dim)
    folders = search_path(folder)
    for f in folders:
        for name in names:
            if os.path.lexists(f / name):
                return f / name
    params = "".join(f" --param {k}={v}" for k, v in _train_params(joint, key).items())
    elements = f" --elements {key['elements_per_leaf']}" if "elements_per_leaf" in key else ""
    present = sorted({p.name for f in folders if f.is_dir() for p in f.glob(f"{joint.kind}-*.json")})
    raise DatabaseError(f"no trained data for {joint.kind} ({dim}D, {key}, design {names[0][-21:-5]}) in "
                        f"{', '.join(map(str, folders))}; train it with `flexmb train {joint.kind} --dim {dim}{elements}"
                        f"{params} --out FOLDER` and solve with database=FOLDER, or without --out into {user_path()} "
                        f"(present: {present})")


def _train_params(joint, key: dict) -> dict:
    """The ``flexmb train --param`` values that build ``joint``: its constructor's parameters
    that differ from their defaults (the database key may hold derived quantities, e.g.
    three_x_infinity's ``length_ratio``, which the constructor refuses); the key's items for a
    joint that is not an attrs class. The mesh parameter goes to ``--elements``."""
    if not attrs.has(type(joint)):
        return {k: v for k, v in key.items() if k != "elements_per_leaf"}
    out = {}
    for f in attrs.fields(type(joint)):
        if not f.init or f.name == "elements_per_leaf":
            continue
        default = f.default.factory() if isinstance(f.default, attrs.Factory) else f.default
        value = getattr(joint, f.name)
        if default is attrs.NOTHING or not (value is default or value == default):
            out[f.alias or f.name] = value
    return out


def shipped(joint, dim: int, folder=None) -> JointData:
    """The trained data for ``joint`` in a ``dim`` mechanism: the first file found along
    `search_path` (``folder``, the user data folder, the shipped data); refuses missing,
    corrupted, invalid and stale files, and files of another joint, with a `DatabaseError`."""
    key = joint.database_key()
    path = locate(joint, dim, folder)
    data = load(path)
    if data.kind != joint.kind or data.dim != dim or data.key != key:
        raise DatabaseError(f"joint database {path} holds {data.kind} {data.dim}D {data.key}, not {joint.kind} "
                            f"{dim}D {key}")
    if path.name != file_name(joint.kind, dim, key) and path.name != design_file_name(data.kind, dim, key,
                                                                                      data.parameters):
        raise DatabaseError(f"joint database {path} holds the data of another design ({data.parameters}) than its "
                            "name says (renamed by hand?); re-create it with `flexmb train`")
    if data.mesh_hash != mesh_hash(joint, dim):
        raise DatabaseError(f"joint database {path} is stale: it was trained on another mesh of {joint.kind} "
                            f"(flexmb {data.flexmb_version or '?'}); re-train with `flexmb train {joint.kind} --dim {dim}`")
    _check_joint(data, joint, dim, path)
    return data


def _check_joint(data: JointData, joint, dim: int, path: Path) -> None:
    """The fits belong to this joint: its D0, its rest position of B (the position fits at
    theta = 0, within their residuals) and its number of elements (one row, 3 in 3D, each)."""
    b0 = np.asarray(joint.interface_b(dim), dtype=float)
    D0 = float(np.linalg.norm(b0))
    if abs(data.length - D0) > 1e-9 * D0:
        raise DatabaseError(f"joint database {path} states D0 = {data.length!r}, the joint's is {D0!r} (the distance "
                            "A to B in the model's length unit)")
    for k, name in enumerate(("x/D0", "y/D0", "z/D0")[:dim]):
        f = data.functions[name]
        if abs(float(f(0.0)) - b0[k] / D0) > f.max_residual + 1e-9:
            raise DatabaseError(f"joint database {path}: {name} at rest is {float(f(0.0)):.6g}, the joint's "
                                f"{b0[k] / D0:.6g}; the file does not describe this joint")
    E = _mesh_facts(joint, dim)[1] * (1 if dim == 2 else 3)
    if data.elements.coefficients.shape[0] != E:
        raise DatabaseError(f"joint database {path} holds {data.elements.coefficients.shape[0]} element "
                            f"rotations; the joint's mesh has {E}")
