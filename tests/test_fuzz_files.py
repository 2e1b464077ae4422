"""Fuzzing what flexmb reads and the command line (issue 20: files and the command line under faults).

Hypothesis damages joint database files (a field replaced by junk, removed, or the bytes cut or
garbled; with or without a recomputed checksum), writes arbitrary bytes as CSV, and assembles
command lines from valid and invalid pieces. The contract checked everywhere: only `FlexmbError`s
come out of the library (a database file: `DatabaseError`), the command exits with a documented
code and, on an error, one line on stderr; nothing the user had is changed: the file read, the
shipped database and files in the working folder stay byte for byte as they were.
"""

import hashlib
import json
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flexmb
from flexmb import FlexmbError, cli
from flexmb import database as db
from flexmb.database.store import _checksum
from flexmb.errors import DatabaseError

FUZZ = settings(deadline=None, database=None,  # examples and derandomisation: the active profile
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

JOINT = flexmb.CrossFlexure(elements_per_leaf=1)
NAME = db.file_name(JOINT.kind, 2, JOINT.database_key())
BODY = json.loads((db.data_path() / NAME).read_text())


def _shipped_digest() -> str:
    h = hashlib.sha256()
    for p in sorted(db.data_path().iterdir()):
        h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()


SHIPPED = _shipped_digest()


@pytest.fixture(autouse=True)
def _user_folder(tmp_path, monkeypatch):
    """Every test here has its own user data folder, and leaves the shipped data as they were."""
    monkeypatch.setenv("FLEXMB_DATABASE", str(tmp_path / "user"))
    yield
    assert _shipped_digest() == SHIPPED, "the shipped database was changed"


# -- joint database files -------------------------------------------------------------------------

json_junk = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70), st.text(max_size=5),
              st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0, -1, 1e308, 5e-324, 2**1100])),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=3), inner, max_size=3)),
    max_leaves=8)


def _paths(value, prefix=()):
    """Every path (tuple of keys/indices) into a JSON value, the root excluded."""
    out = []
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for k, v in items:
        out.append(prefix + (k,))
        out.extend(_paths(v, prefix + (k,)))
    return out


PATHS = [p for p in _paths(BODY) if p[0] != "checksum"]


def _damaged(path, junk, delete: bool, rechecksum: bool) -> bytes:
    body = json.loads(json.dumps(BODY))
    holder = body
    for k in path[:-1]:
        holder = holder[k]
    if delete and isinstance(holder, dict):
        del holder[path[-1]]
    else:
        holder[path[-1]] = junk
    if rechecksum:
        try:
            body["checksum"] = _checksum(body)
        except (TypeError, ValueError):  # junk json cannot serialise (2**1100 as a float...): leave it
            pass
    try:
        return json.dumps(body).encode()
    except (TypeError, ValueError):
        return json.dumps(BODY).encode()[:-7]


@FUZZ
@given(path=st.sampled_from(PATHS), junk=json_junk, delete=st.booleans(), rechecksum=st.booleans())
def test_a_damaged_database_file_gives_a_database_error_or_valid_data(tmp_path_factory, path, junk, delete,
                                                                     rechecksum):
    folder = tmp_path_factory.mktemp("db")
    raw = _damaged(path, junk, delete, rechecksum)
    (folder / NAME).write_bytes(raw)
    try:
        data = db.shipped(JOINT, 2, folder)
    except DatabaseError as exc:
        assert str(exc).strip()
    else:  # accepted: then KSD works with it or refuses it cleanly
        assert np.all(np.isfinite(data.elements.coefficients))
        m = flexmb.models.cross_flexure_pivot(elements_per_leaf=1, dim=2, rotation=0.2)
        try:
            sol = flexmb.solve(m, method="ksd-reduced", database=str(folder))
        except FlexmbError:
            pass
        else:
            assert not sol.converged or np.all(np.isfinite(sol.node_positions()))
    assert (folder / NAME).read_bytes() == raw  # read, never written


@FUZZ
@given(cut=st.integers(0, 4000), garble=st.binary(max_size=16), at=st.integers(0, 4000))
def test_cut_or_garbled_bytes_give_a_database_error(tmp_path_factory, cut, garble, at):
    folder = tmp_path_factory.mktemp("db")
    raw = (db.data_path() / NAME).read_bytes()
    raw = raw[:min(at, len(raw))] + garble + raw[min(at, len(raw)) + len(garble):]
    raw = raw[:cut] if cut < len(raw) else raw
    (folder / NAME).write_bytes(raw)
    try:
        db.shipped(JOINT, 2, folder)
    except DatabaseError:
        pass
    assert (folder / NAME).read_bytes() == raw


# -- CSV --------------------------------------------------------------------------------------------

csv_text = st.lists(st.lists(st.one_of(st.text(max_size=6), st.sampled_from(["nan", "inf", "-0.0", "1e400", "True",
                                                                             '"', '""', "a,b", "\n", "\r"])),
                             min_size=1, max_size=4), min_size=0, max_size=5)


@FUZZ
@given(raw=st.one_of(st.binary(max_size=200),
                     csv_text.map(lambda rows: "\n".join(",".join(r) for r in rows).encode()),
                     st.text(max_size=60).map(lambda t: t.encode("utf-16")),
                     st.text(alphabet="äöüéß,\n", max_size=30).map(lambda t: t.encode("latin-1"))))
def test_any_bytes_read_as_csv_give_a_table_or_a_parameter_error(tmp_path_factory, raw):
    path = tmp_path_factory.mktemp("csv") / "t.csv"
    path.write_bytes(raw)
    try:
        table = flexmb.read_csv(path)
    except FlexmbError as exc:
        assert str(exc).strip()
    else:
        assert all(table[name].ndim == 1 and len(table[name]) == table.n_rows for name in table)
    assert path.read_bytes() == raw


@FUZZ
@given(columns=st.lists(st.one_of(
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=3, max_size=3),
    st.lists(st.integers(-2**62, 2**62), min_size=3, max_size=3),
    st.lists(st.booleans(), min_size=3, max_size=3)), min_size=1, max_size=4))
def test_numbers_round_trip_through_csv(tmp_path_factory, columns):
    """Floats (17 digits, NaN and inf included), integers and booleans come back exactly."""
    table = flexmb.Table({f"c{i}": c for i, c in enumerate(columns)})
    back = flexmb.read_csv(table.to_csv(tmp_path_factory.mktemp("csv") / "t.csv"))
    for name in table:
        np.testing.assert_array_equal(back[name], table[name])


# -- the command line -------------------------------------------------------------------------------

values = st.sampled_from(["0", "-1", "1", "2", "5", "nan", "inf", "-inf", "1e400", "x", "", "1,2", "0.3", "=", "1e150"])
names = st.sampled_from(["rotation", "elements", "elements_per_leaf", "displacement", "angle", "bogus", "", "tol",
                         "max_iter", "method"])
param = st.one_of(st.tuples(names, values).map(lambda nv: f"{nv[0]}={nv[1]}"), names, values)


def _solve_argv():
    return st.tuples(st.sampled_from(["cantilever", "cross_flexure", "nope"]),
                     st.lists(st.tuples(st.sampled_from(["--param", "--option"]), param), max_size=3),
                     st.sampled_from([[], ["--json"], ["--method", "newton"], ["--method", "ksd-full"],
                                      ["--method", "nope"], ["--json", "--method", "conventional"]])).map(
        lambda t: ["solve", t[0], *[x for pair in t[1] for x in pair], *t[2]])


def _train_argv(out):
    option = st.sampled_from(["--range", "--step", "--elements", "--dim", "--param"])
    return st.tuples(st.lists(st.tuples(option, values), max_size=3),
                     st.sampled_from([[], ["--out", out], ["--out", "/dev/null/x"], ["--out", str(db.data_path())]])).map(
        lambda t: ["train", "--dim", "2", "--elements", "1", "--range", "10", "--step", "5",
                   *[x for pair in t[0] for x in pair], *t[1]])


def _run_cli(argv):
    try:
        return cli.main(argv)
    except SystemExit as exc:
        return exc.code


@settings(FUZZ, max_examples=max(5, settings.default.max_examples // 2))
@given(data=st.data())
def test_the_command_line_exits_with_a_documented_code_and_one_line(tmp_path_factory, capsys, data):
    """Solve and train with valid and invalid pieces: exit 0, 1 or 2 (documented), an error is one
    line on stderr (after any warnings, one line each), and files in the working folder are not
    touched."""
    work = tmp_path_factory.mktemp("work")
    (work / "keep.txt").write_text("the user's file")
    argv = data.draw(st.one_of(_solve_argv(), _train_argv(str(work / "out"))))
    code = _run_cli(argv)
    out, err = capsys.readouterr()
    assert code in (0, 1, 2), (argv, code, err)
    lines = err.splitlines()
    assert all(x.startswith("flexmb: warning: ") for x in lines[:-1 if code else None]), (argv, err)
    if code:  # the error: the last line, one line
        assert lines and lines[-1].startswith("flexmb: error:") and err.endswith("\n"), (argv, err)
    if code == 0 and "--json" in argv:
        json.loads(out, parse_constant=lambda c: pytest.fail(f"not strict JSON: {c}"))
    assert (work / "keep.txt").read_text() == "the user's file"


@FUZZ
@given(code=st.one_of(st.none(), st.integers(-3, 300), st.text(max_size=8), st.just([1, 2])))
def test_run_passes_on_the_scripts_exit(tmp_path_factory, capsys, code):
    """``sys.exit(code)`` in a script: an integer is the exit code, None is 0, anything else is
    printed on stderr and gives 1 (as the interpreter does)."""
    script = tmp_path_factory.mktemp("run") / "s.py"
    script.write_text(f"import sys\nsys.exit({code!r})\n")
    got = cli.main(["run", str(script)])
    err = capsys.readouterr().err
    if code is None or isinstance(code, int):
        assert got == (code or 0) and err == ""
    else:
        assert got == 1 and err == f"{code}\n"


def test_the_user_folder_gets_only_the_trained_file(tmp_path, capsys):
    assert cli.main(["train", "--dim", "2", "--elements", "1", "--range", "10"]) == 0
    assert [p.name for p in (tmp_path / "user").iterdir()] == [db.store.joint_file_name(JOINT, 2)]  # the design's name
    assert os.environ["FLEXMB_DATABASE"] == str(tmp_path / "user")
