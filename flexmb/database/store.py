"""Joint database files: a versioned JSON format with a checksum, and the shipped data.

Format ``flexmb-joint-database`` version 2 (one file per joint kind, dimension and mesh)::

    {"format": "flexmb-joint-database", "format_version": 1, "flexmb_version": "...",
     "kind": "cross_flexure", "dim": 3, "parameters": {...training joint...},
     "key": {...shape parameters the data belong to...}, "mesh_hash": "...",
     "intended": "rotation about z [rad]", "range": [lo, hi], "samples": [...],
     "length": D0 [m],
     "functions": {name: {"powers": [...], "coefficients": [...], "max_residual": r}},
     "elements": {"powers": [...], "coefficients": [[...]...], "max_residual": r},
     "nodes": {...same...}, "checksum": sha256 of everything else}

Functions are dimensionless (positions over D0, the undeformed distance of the interface nodes).
Element and internal-node orientations (Eq. 3.1) are angles [rad] in 2D and rotation vectors
[rad] in 3D (Sec. 3.1), one row per element or node and component (element-major: e0x, e0y, e0z,
e1x, ...). Version 1 stored 3D orientations as angles about z only; such files are refused.
"""

from __future__ import annotations

import functools
import hashlib
import json
import warnings
from importlib import resources
from pathlib import Path

import attrs
import numpy as np

from .._version import __version__
from ..errors import DatabaseError, ExtrapolationWarning

__all__ = ["FORMAT", "FORMAT_VERSION", "Polynomial", "JointData", "save", "load", "mesh_hash", "data_path",
           "shipped"]

FORMAT = "flexmb-joint-database"
FORMAT_VERSION = 2


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

    def check_range(self, theta, *, strict: bool = False) -> None:
        """Warn (``ExtrapolationWarning``) or, with ``strict``, raise when ``theta`` leaves the range."""
        t = np.atleast_1d(np.asarray(theta, dtype=float))
        lo, hi = self.range
        if np.any((t < lo - 1e-12) | (t > hi + 1e-12)):
            msg = (f"{self.kind} database ({self.dim}D, {self.key}): intended rotation "
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

    def to_json(self) -> dict:
        """The whole record as a JSON-ready dict (format name and version, joint, fits, checksum)."""

        body = {"format": FORMAT, "format_version": FORMAT_VERSION, "flexmb_version": __version__,
                "kind": self.kind, "dim": self.dim, "parameters": self.parameters, "key": self.key,
                "mesh_hash": self.mesh_hash, "intended": "rotation of node B about z relative to node A [rad]",
                "range": list(self.range), "samples": np.asarray(self.samples).tolist(), "length": self.length,
                "functions": {k: f.to_json() for k, f in self.functions.items()},
                "elements": self.elements.to_json(), "nodes": self.nodes.to_json()}
        body["checksum"] = _checksum(body)
        return body


def _checksum(body: dict) -> str:
    payload = {k: v for k, v in body.items() if k != "checksum"}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def mesh_hash(joint, dim: int) -> str:
    """Fingerprint of a joint's mesh in the plane of motion (x, y over D0, sides, elements): the
    kinematic data belong to it; data trained on another in-plane mesh are stale."""
    mesh = joint.mesh(dim)
    D0 = float(np.linalg.norm(joint.interface_b(dim)))
    pts = np.round(np.asarray(mesh.points, float)[:, :2] / D0, 9) + 0.0
    parts = [pts.tolist(), np.asarray(mesh.side).tolist(), np.asarray(mesh.elements).tolist()]
    if mesh.body is not None:
        parts.append(np.asarray(mesh.body).tolist())
    blob = json.dumps(parts)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def save(data: JointData, path) -> Path:
    """Write ``data`` as JSON to ``path`` (format of `JointData.to_json`); returns the path."""
    path = Path(path)
    path.write_text(json.dumps(data.to_json(), indent=1, sort_keys=True) + "\n")
    return path


def load(path) -> JointData:
    """Read and verify a database file (format, version, checksum); `DatabaseError` otherwise."""
    path = Path(path)
    try:
        body = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise DatabaseError(f"joint database {path} does not exist; create it with `flexmb train`") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DatabaseError(f"joint database {path} is corrupted (not readable JSON: {exc}); "
                            "re-create it with `flexmb train`") from None
    if not isinstance(body, dict) or body.get("format") != FORMAT:
        raise DatabaseError(f"{path} is not a flexmb joint database (format {FORMAT!r})")
    if body.get("format_version") != FORMAT_VERSION:
        raise DatabaseError(f"joint database {path} has format version {body.get('format_version')!r}; this flexmb "
                            f"reads version {FORMAT_VERSION}: re-create it with `flexmb train`")
    if body.get("checksum") != _checksum(body):
        raise DatabaseError(f"joint database {path} is corrupted (checksum mismatch): it was edited or damaged; "
                            "re-create it with `flexmb train`")
    try:
        return JointData(kind=body["kind"], dim=int(body["dim"]), parameters=body["parameters"], key=body["key"],
                         mesh_hash=body["mesh_hash"], range=tuple(body["range"]), samples=np.asarray(body["samples"]),
                         length=float(body["length"]),
                         functions={k: Polynomial.from_json(f) for k, f in body["functions"].items()},
                         elements=Polynomial.from_json(body["elements"]), nodes=Polynomial.from_json(body["nodes"]),
                         flexmb_version=body.get("flexmb_version", ""))
    except (KeyError, TypeError, ValueError) as exc:
        raise DatabaseError(f"joint database {path} is incomplete ({exc!r})") from None


@functools.cache
def data_path() -> Path:
    """Folder of the shipped, pre-trained database files."""
    return Path(str(resources.files("flexmb.database") / "data"))


def file_name(kind: str, dim: int, key: dict) -> str:
    """The file name of a database: ``<kind>-<dim>d-<key items>.json`` (keys sorted)."""
    parts = "-".join(f"{k}{_fmt(v)}" for k, v in sorted(key.items()))
    return f"{kind}-{dim}d-{parts}.json"


def _fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def shipped(joint, dim: int, folder=None) -> JointData:
    """The trained data for ``joint`` in a ``dim`` mechanism (from ``folder``, default the shipped
    data); refuses missing, corrupted and stale files with a `DatabaseError`."""
    key = joint.database_key()
    path = Path(folder or data_path()) / file_name(joint.kind, dim, key)
    if not path.exists():
        params = " ".join(f"--param {k}={v}" for k, v in key.items() if k != "elements_per_leaf")
        elements = f" --elements {key['elements_per_leaf']}" if "elements_per_leaf" in key else ""
        raise DatabaseError(f"no trained data for {joint.kind} ({dim}D, {key}) in {path.parent}; train it with "
                            f"`flexmb train {joint.kind} --dim {dim}{elements} {params} --out FOLDER` and solve with "
                            f"database=FOLDER (present: {sorted(p.name for p in path.parent.glob('*.json'))})")
    data = load(path)
    if data.kind != joint.kind or data.dim != dim or data.key != key:
        raise DatabaseError(f"joint database {path} holds {data.kind} {data.dim}D {data.key}, not {joint.kind} "
                            f"{dim}D {key}")
    if data.mesh_hash != mesh_hash(joint, dim):
        raise DatabaseError(f"joint database {path} is stale: it was trained on another mesh of {joint.kind} "
                            f"(flexmb {data.flexmb_version or '?'}); re-train with `flexmb train {joint.kind} --dim {dim}`")
    return data
