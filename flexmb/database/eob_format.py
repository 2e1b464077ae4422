"""The tabulated EOB condensation of a database file (format version 3): data and file form.

A joint's Craig-Bampton condensation with node A held (Dwarshuis et al. 2020, Eqs. 2.4-2.6,
`flexmb.ksd.eob`) depends on the intended rotation theta alone, except for node B's near
position ``b``, in which the force term and the recovery of the internal nodes are exactly
linear (measured: 4e-13 and 4e-11 relative). So per theta: ``K_T`` (nd, nd); ``F0`` (nd, 1) and
``G`` (nd, dim) with ``F_hat_T = F0 + G b``; ``RK`` (ni, nd), ``r0`` (ni, 1), ``rG`` (ni, dim) with
``recover = [RK, r0 + rG b]``; ``P0`` (N - 2, dim) the internal nodes' near positions with
``b = 0``. `flexmb.ksd.eob_table` computes them on a grid and interpolates; this module holds them.

In the database file: ``"eob_table": {"parameters": {...the joint's...}, "theta": [...],
"degree": k, "layout": [[name, rows, cols], ...], "values_file": "<file>.eob.bin",
"values_sha256": "...", "shape": [S, m]}`` or ``null`` (no table: KSD condenses per solve). The
samples (S, m) are little-endian float64 in the side file next to it (1.3 MB for the
manipulator's joint: kept out of the JSON, which KSD reads on every solve); the main file's
checksum covers their SHA-256, so the pair is verified as one. They are read once per content.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import attrs
import numpy as np

from ..errors import DatabaseError

__all__ = ["EOBTable", "to_json", "from_json", "sample_bytes", "plain_parameters", "NAMES", "SUFFIX"]

#: The tabulated quantities, in column order (see the module docstring).
NAMES = ("K_T", "F0", "G", "RK", "r0", "rG", "P0")
#: Suffix of a database file's side file (`flexmb.database.store.side_file_name`; the shipped one: ``<stem>.eob.bin``).
SUFFIX = ".eob.bin"

_LOADED: dict[str, np.ndarray] = {}  # samples by SHA-256: read once per content


def plain_parameters(d: dict) -> dict:
    """The JSON-plain entries of a joint's `describe` (numbers, text, booleans, None): what a
    database records of the joint it was trained on, and what a table is matched against."""
    return {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in d.items()
            if isinstance(v, (int, float, str, bool, np.floating)) or v is None}


@attrs.frozen(eq=False)
class EOBTable:
    """Samples of the condensation at intended rotations ``theta`` (S,) [rad] of the joint with
    ``parameters`` (its `Joint.describe`, plain values), interpolated by splines of ``degree``;
    ``layout`` the (name, rows, cols) of each quantity's columns (`NAMES`). The samples are
    ``values`` (S, m) when built, or read on first use from ``source`` (the side file) and
    checked against ``sha256``."""

    parameters: dict
    theta: np.ndarray
    degree: int
    layout: tuple
    data: np.ndarray | None = None
    source: Path | None = None
    sha256: str = ""

    @property
    def width(self) -> int:
        """Columns of the samples: the numbers tabulated per angle."""
        return sum(r * c for _, r, c in self.layout)

    @property
    def values(self) -> np.ndarray:
        """The samples (S, m); `DatabaseError` when the side file is missing, altered or damaged."""
        if self.data is not None:
            return self.data
        if self.sha256 not in _LOADED:
            try:
                raw = Path(self.source).read_bytes()
            except OSError as exc:
                raise DatabaseError(f"EOB table {self.source} cannot be read ({exc.strerror or exc}); re-create "
                                    "the database with `flexmb train`") from None
            shape = (len(self.theta), self.width)
            if hashlib.sha256(raw).hexdigest() != self.sha256 or len(raw) != 8 * shape[0] * shape[1]:
                raise DatabaseError(f"EOB table {self.source} does not match its database file (checksum or size): "
                                    "it was edited or damaged; re-create the database with `flexmb train`")
            values = np.frombuffer(raw, dtype="<f8").reshape(shape).astype(float)
            if not np.all(np.isfinite(values)):
                raise DatabaseError(f"EOB table {self.source} holds non-finite values; re-create it with "
                                    "`flexmb train`")
            values.flags.writeable = False
            _LOADED[self.sha256] = values
        return _LOADED[self.sha256]

    def split(self, rows: np.ndarray) -> dict:
        """``rows`` (J, m) of values -> {name: (J, rows, cols)}."""
        out, at = {}, 0
        for name, r, c in self.layout:
            out[name] = rows[:, at:at + r * c].reshape(len(rows), r, c)
            at += r * c
        return out


def sample_bytes(table: EOBTable) -> bytes:
    """The side file's content: the samples as little-endian float64, row-major."""
    return np.ascontiguousarray(table.values, dtype="<f8").tobytes()


def to_json(table: EOBTable | None, values_file: str):
    """The JSON form of ``table`` (None -> None) with its samples in side file ``values_file``."""
    if table is None:
        return None
    return {"parameters": table.parameters, "theta": np.asarray(table.theta, float).tolist(),
            "degree": int(table.degree), "layout": [list(x) for x in table.layout], "values_file": values_file,
            "values_sha256": hashlib.sha256(sample_bytes(table)).hexdigest(), "shape": [len(table.theta), table.width]}


def from_json(d, folder: Path | None, parameters_check) -> EOBTable | None:
    """An `EOBTable` from its JSON form (None -> None), every field checked (the samples when
    first used); ``ValueError`` naming the fault. ``folder``: where the side file lies;
    ``parameters_check(d)`` validates the parameters (the database's rule)."""
    if d is None:
        return None
    if not isinstance(d, dict):
        raise ValueError("eob_table must be an object or null")
    missing = [k for k in ("parameters", "theta", "degree", "layout", "values_file", "values_sha256", "shape")
               if k not in d]
    if missing:
        raise ValueError(f"eob_table lacks {missing}")
    params = parameters_check(d["parameters"])
    try:
        theta = np.asarray(d["theta"], dtype=float) if isinstance(d["theta"], list) else None
    except (TypeError, ValueError):
        theta = None
    if theta is None or theta.ndim != 1 or len(theta) < 2 or not np.all(np.isfinite(theta)) \
            or np.any(np.diff(theta) <= 0):
        raise ValueError("eob_table.theta must be a strictly increasing list of finite angles [rad]")
    degree = d["degree"]
    if not isinstance(degree, int) or isinstance(degree, bool) or degree not in (1, 3, 5, 7) or len(theta) <= degree:
        raise ValueError(f"eob_table.degree={degree!r} must be 1, 3, 5 or 7 and below the number of samples")
    layout = d["layout"]
    if not isinstance(layout, list) or [x[0] if isinstance(x, list) and x else None for x in layout] != list(NAMES) \
            or not all(len(x) == 3 and all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in x[1:])
                       for x in layout):
        raise ValueError(f"eob_table.layout must list {list(NAMES)} with their (rows, cols)")
    layout = tuple((str(n), int(r), int(c)) for n, r, c in layout)
    name, sha = d["values_file"], d["values_sha256"]
    if not isinstance(name, str) or not name.endswith(SUFFIX) or Path(name).name != name:
        raise ValueError(f"eob_table.values_file must be a file name ending in {SUFFIX!r}, got {name!r}")
    if not isinstance(sha, str) or len(sha) != 64:
        raise ValueError("eob_table.values_sha256 must be a SHA-256 hex digest")
    if d["shape"] != [len(theta), sum(r * c for _, r, c in layout)]:
        raise ValueError(f"eob_table.shape={d['shape']!r} disagrees with theta and layout")
    theta.flags.writeable = False
    return EOBTable(params, theta, degree, layout, None, None if folder is None else Path(folder) / name, sha)
