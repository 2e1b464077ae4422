"""`Table`: named columns of equal length (1-D numpy arrays), the result format of sweeps and
parameter studies; drops into numpy (``table["force"]``) and pandas (``table.to_pandas()``)
and round-trips through CSV."""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .errors import ModelError, ParameterError, require

__all__ = ["Table", "read_csv", "column"]


class Table(dict):
    """Columns ``name -> 1-D array``, all of one length, in insertion order. Names are text:
    two names with the same text (``1`` and ``"1"``) are refused, never merged.

    A read-only mapping: ``table["force"]`` is a numpy array (a copy), ``list(table)`` the column names,
    ``len(table)`` their number and `n_rows` the number of rows. A `dict` underneath, so that
    ``pandas.DataFrame(table)`` reads it as columns (pandas 3 takes only a dict so; any other
    mapping became one column of names); the methods that would change it raise `TypeError`.
    """

    def __init__(self, columns: Mapping):
        super().__init__()
        n = None
        for name, values in columns.items():
            if isinstance(values, np.ndarray) or not _scalars(values):
                a = _array(name, values)  # a copy; more than 1-D is refused below
            else:
                a = column(values)  # a copy: the caller's values stay theirs
            if a.ndim != 1:
                raise ParameterError(f"Table: column {name!r} must be one-dimensional, got shape {a.shape}")
            if n is not None and len(a) != n:
                raise ParameterError(f"Table: column {name!r} has {len(a)} rows, the others {n}")
            n = len(a)
            if dict.__contains__(self, str(name)):
                raise ParameterError(f"Table: two columns are named {str(name)!r}; column names must be distinct "
                                     "as text")
            a.flags.writeable = False  # dict's own readers ({**table}, pandas) get the column itself
            dict.__setitem__(self, str(name), a)
        self.n_rows = 0 if n is None else n

    @property
    def _columns(self) -> dict:
        """The columns themselves (not copies), in order."""
        return dict(dict.items(self))

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return dict.__getitem__(self, name).copy()  # a copy: the table is not changed through it
        except (KeyError, TypeError):
            raise ModelError(f"no column {name!r}; columns: {', '.join(self)}") from None

    def get(self, name, default=None):
        return self[name] if dict.__contains__(self, name) else default

    def values(self):
        return [self[k] for k in self]

    def items(self):
        return [(k, self[k]) for k in self]

    def __repr__(self) -> str:
        return f"Table({self.n_rows} rows: {', '.join(self)})"

    def __reduce__(self):
        return type(self), (self._columns,)

    def copy(self) -> Table:
        return Table(self._columns)

    def _read_only(self, *args, **kwargs):
        """Refused with `TypeError`: a Table is read-only (build a new one)."""
        raise TypeError("a flexmb Table is read-only: build a new one, e.g. Table({**table, 'name': values})")

    __setitem__ = __delitem__ = __ior__ = _read_only
    clear = pop = popitem = setdefault = update = _read_only

    def to_pandas(self):
        """The table as a `pandas.DataFrame` (columns in order, each a copy; text stays text, so an
        empty ``error`` or ``warnings`` cell is ``""``, not NaN as a CSV read by pandas gives).
        pandas is optional: ``pip install "flexmb[pandas]"``; without it `flexmb.errors.MissingExtraError`
        (a `FlexmbError`) says so."""
        pandas = require("pandas", "pandas", "Table.to_pandas")
        return pandas.DataFrame({name: values.copy() for name, values in self._columns.items()})

    def to_csv(self, path) -> Path:
        """Write the columns to ``path`` as UTF-8 (comma-separated, a header row of names, floats
        with 17 significant digits so `read_csv` gives the same numbers back, text in quotes so
        that a text ``"1"`` or ``"True"`` comes back as text). Returns the path."""
        path = _path("to_csv", path)
        try:
            with path.open("w", newline="", encoding="utf-8") as f:
                w = csv.writer(f, quoting=csv.QUOTE_NONNUMERIC)  # numbers and booleans bare, the rest quoted
                w.writerow(self._columns)
                cols = [c.tolist() for c in self._columns.values()]
                for row in zip(*cols):
                    w.writerow(row)  # a float as repr writes it: the shortest text that reads back exactly
        except OSError as exc:
            raise ParameterError(f"to_csv: cannot write {str(path)!r}: {exc.strerror or exc}") from None
        return path


def _scalars(values) -> bool:
    """Whether ``values`` is a sequence (not text) of scalar cells."""
    if isinstance(values, (str, bytes, Mapping)) or not hasattr(values, "__iter__"):
        return False
    return all(np.ndim(x) == 0 and not isinstance(x, (list, tuple, dict)) for x in values)


def _array(name, values) -> np.ndarray:
    try:
        return np.array(values)
    except (TypeError, ValueError):  # ragged
        raise ParameterError(f"Table: column {name!r} must be a 1-D sequence of scalars") from None


def column(values) -> np.ndarray:
    """A new 1-D array of ``values``: numbers as numbers, booleans as booleans, text as text, and
    a mix (or sequences) as objects, one per cell: never a silent conversion of numbers to text."""
    values = list(values) if not isinstance(values, (str, bytes)) and hasattr(values, "__iter__") else values
    if not isinstance(values, list):
        return np.array(values)  # a scalar: refused by the caller (not 1-D)
    if all(isinstance(x, (bool, np.bool_)) for x in values) or all(
            isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))
            for x in values):
        return np.array(values)
    if all(isinstance(x, str) for x in values):
        return np.array(values, dtype=str)
    out = np.empty(len(values), dtype=object)
    for i, x in enumerate(values):  # one by one: a list stays one cell
        out[i] = x
    return out


def read_csv(path) -> Table:
    """Read a `Table.to_csv` file back: columns of integers, floats (``nan``/``inf`` included),
    booleans or text, each as the narrowest of those that holds every entry. A number is read as
    one only when written as Python writes it: ``7``, ``-7``, ``0.25``, ``1e-05``; text such as
    ``007``, ``+7``, ``1_000`` or `` 7`` stays text. A column with a quoted cell is text: `Table.to_csv`
    quotes text, so a text column holding ``1``, ``2`` or ``True`` comes back as text.

    The file is read as UTF-8. `ParameterError` when it cannot be read or is not a regular file
    (a folder, FIFO or device), is not UTF-8 text, or is
    not CSV the `csv` module accepts (a field longer than ``csv.field_size_limit()``,
    131072 characters by default), naming the line."""
    path = _path("read_csv", path)
    try:
        if path.exists() and not path.is_file():  # a folder, FIFO or device: opening could block or never end
            raise ParameterError(f"read_csv: {str(path)!r} is not a regular file")
        with path.open(newline="", encoding="utf-8") as f:
            text = f.read()
            reader = csv.reader(io.StringIO(text, newline=""))
            try:
                rows = list(reader)
            except csv.Error as exc:
                hint = "; csv.field_size_limit() raises the limit" if "field larger" in str(exc) else ""
                raise ParameterError(f"read_csv: {str(path)!r} line {reader.line_num}: not readable CSV "
                                     f"({exc}{hint})") from None
    except OSError as exc:
        raise ParameterError(f"read_csv: cannot read {str(path)!r}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ParameterError(f"read_csv: {str(path)!r} is not UTF-8 text (byte {exc.start}: {exc.reason}); "
                             "save it as UTF-8") from None
    if not rows:
        raise ParameterError(f"read_csv: {str(path)!r} is empty (expected a header row)")
    head, body = rows[0], rows[1:]
    if any(len(r) != len(head) for r in body):
        raise ParameterError(f"read_csv: {str(path)!r}: every row must have {len(head)} fields")
    quoted = _quoted_fields(text)
    if [len(r) for r in quoted] != [len(r) for r in rows]:  # not the csv module's reading: no quotes known
        quoted = [[False] * len(r) for r in rows]
    return Table({name: _parse([r[i] for r in body], any(q[i] for q in quoted[1:]))
                  for i, name in enumerate(head)})


def _quoted_fields(text: str) -> list[list[bool]]:
    """Per record of the CSV ``text`` (the `csv` module's default dialect), whether each field
    began with a quote: text `Table.to_csv` wrote (quoted) as opposed to a number (bare)."""
    rows, row, quoted, inside, start, i, n = [], [], False, False, True, 0, len(text)
    while i < n:
        c = text[i]
        if inside:
            if c == '"':
                if text.startswith('"', i + 1):
                    i += 1  # a doubled quote inside quotes
                else:
                    inside = False
        elif c == '"' and start:
            quoted = inside = True
        elif c == ",":
            row.append(quoted)
            quoted, start, i = False, True, i + 1
            continue
        elif c in "\r\n":
            rows.append(row + [quoted] if row or quoted or not start else [])  # an empty line: no field
            row = []
            i += 2 if c == "\r" and text.startswith("\n", i + 1) else 1
            quoted, start = False, True
            continue
        start = False
        i += 1
    if row or quoted or not start:  # the last record has no line end
        rows.append(row + [quoted])
    return rows


def _path(owner: str, path) -> Path:
    if not isinstance(path, (str, os.PathLike)) or "\0" in str(path):
        raise ParameterError(f"{owner}: path={path!r} must be a file path")
    return Path(path)


#: Numbers as ``repr`` writes them: no leading zeros, sign only "-", no "_" or spaces
_INT = re.compile(r"-?(0|[1-9][0-9]*)")
_FLOAT = re.compile(r"-?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)?|-?inf|nan")


def _parse(cells: list[str], text: bool = False) -> np.ndarray:
    """A column's cells as the narrowest of booleans, integers, floats and text that holds them
    all; ``text``: a cell of it was quoted in the file (`Table.to_csv` quotes text): text."""
    if text:
        return np.array(cells, dtype=object)
    if cells and all(c in ("True", "False") for c in cells):
        return np.array([c == "True" for c in cells])
    for kind, form in ((int, _INT), (float, _FLOAT)):
        if all(form.fullmatch(c) for c in cells):
            try:
                return np.array([kind(c) for c in cells], dtype=kind)
            except (ValueError, OverflowError):  # an integer beyond int64: read as text
                break
    return np.array(cells, dtype=object)
