"""Joint database (Dwarshuis et al. 2020, Secs. 2.1, 3.1, 4.1): training, fits, file format, refusals."""

import json
import warnings

import numpy as np
import pytest

import flexmb
from flexmb import database as db
from flexmb.errors import DatabaseError, ExtrapolationWarning


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n", [1, 3, 5])
def test_shipped_data_load_and_match_the_joint(dim, n):
    j = flexmb.CrossFlexure(elements_per_leaf=n)
    data = db.shipped(j, dim)
    assert data.kind == "cross_flexure" and data.dim == dim and data.key["elements_per_leaf"] == n
    assert np.degrees(data.range[0]) == -75.0 and np.degrees(data.range[1]) == 75.0
    # 2D: one angle per element (2 leaves); 3D: a rotation vector per element (3 leaves, Sec. 3.1)
    assert data.elements.coefficients.shape == (2 * n if dim == 2 else 9 * n, 5)


@pytest.mark.parametrize("dim", [2, 3])
def test_fits_reproduce_fe_runs_between_the_samples(dim):
    """The fits interpolate: at rotations between the 5-degree samples, fresh FE runs agree with
    the shipped polynomials within the fit residuals stated in the file (x 2 for interpolation):
    B's position to 2.2e-4 D0, D/D0 (Eq. 4.1) to 4.2e-5, element rotations (Eq. 4.2, fifth
    order) to 4e-4 rad."""
    j = flexmb.CrossFlexure(elements_per_leaf=3)
    data = db.shipped(j, dim)
    theta = np.radians([-72.5, -37.5, 2.5, 22.5, 57.5])
    run = db.simulate(j, dim, theta)
    D0 = data.length
    for k, name in enumerate(("x/D0", "y/D0")):
        f = data.function(name)
        np.testing.assert_allclose(f(theta), run.b_position[:, k] / D0, rtol=0, atol=2 * f.max_residual)
        assert f.max_residual < 1.2e-4
    g = data.function("D/D0-1")
    np.testing.assert_allclose(g(theta), np.linalg.norm(run.b_position, axis=1) / D0 - 1, rtol=0,
                               atol=2 * g.max_residual)
    np.testing.assert_allclose(data.elements(theta), run.element_rotation.reshape(len(theta), -1), rtol=0,
                               atol=2 * data.elements.max_residual)
    assert data.elements.max_residual < 2e-4
    if dim == 3:
        assert run.max_unintended_reaction < 1e-6  # the held z and tilts need no force (symmetric joint)


def test_length_ratio_is_even_as_eq_4_1():
    """Eq. (4.1): D/D0 = 1 + g1 t^2 + g2 t^4 + g3 t^6, symmetric in the rotation. flexmb measures
    g1 = +0.0508 (Table 1, 3 el./leaf): the interface nodes move apart, D/D0 = 1.042 at 60 deg."""
    data = db.shipped(flexmb.CrossFlexure(elements_per_leaf=3), 3)
    f = data.function("D/D0-1")
    np.testing.assert_array_equal(f.powers, [2, 4, 6])
    assert f.coefficients[0] == pytest.approx(0.0508, abs=1e-4)
    t = np.radians(60)
    assert f(t) == pytest.approx(f(-t)) == pytest.approx(0.0418, abs=1e-4)


def test_round_trip_is_exact(tmp_path):
    j = flexmb.CrossFlexure(elements_per_leaf=2)
    data = db.train(j, 2, range_deg=(-20, 20), step_deg=10)
    back = db.load(db.save(data, tmp_path / "x.json"))
    assert back.key == data.key and back.mesh_hash == data.mesh_hash and back.range == data.range
    for name, f in data.functions.items():
        np.testing.assert_array_equal(back.functions[name].coefficients, f.coefficients)
    np.testing.assert_array_equal(back.elements.coefficients, data.elements.coefficients)
    np.testing.assert_array_equal(back.nodes.coefficients, data.nodes.coefficients)


def _copy(tmp_path, mutate):
    j = flexmb.CrossFlexure()
    src = db.data_path() / db.file_name(j.kind, 3, j.database_key())
    body = json.loads(src.read_text())
    mutate(body)
    (tmp_path / src.name).write_text(json.dumps(body))
    return j


def test_corrupted_file_is_refused(tmp_path):
    j = _copy(tmp_path, lambda b: b["functions"]["D/D0-1"]["coefficients"].__setitem__(0, 0.0))
    with pytest.raises(DatabaseError, match="corrupted.*checksum"):
        db.shipped(j, 3, folder=tmp_path)


def test_truncated_file_is_refused(tmp_path):
    j = flexmb.CrossFlexure()
    name = db.file_name(j.kind, 3, j.database_key())
    (tmp_path / name).write_text((db.data_path() / name).read_text()[:200])
    with pytest.raises(DatabaseError, match="corrupted"):
        db.shipped(j, 3, folder=tmp_path)


def test_stale_file_is_refused(tmp_path):
    """A file whose checksum is right but whose mesh is not the one flexmb builds today."""
    from flexmb.database.store import _checksum

    def mutate(b):
        b["mesh_hash"] = "0" * 16
        b["checksum"] = _checksum(b)

    j = _copy(tmp_path, mutate)
    with pytest.raises(DatabaseError, match="stale"):
        db.shipped(j, 3, folder=tmp_path)


def test_other_format_version_is_refused(tmp_path):
    from flexmb.database.store import _checksum

    def mutate(b):
        b["format_version"] = 99
        b["checksum"] = _checksum(b)

    j = _copy(tmp_path, mutate)
    with pytest.raises(DatabaseError, match="format version 99"):
        db.shipped(j, 3, folder=tmp_path)


def test_missing_data_names_the_training_command():
    with pytest.raises(DatabaseError, match="flexmb train cross_flexure"):
        db.shipped(flexmb.CrossFlexure(angle=0.6), 3)
    with pytest.raises(flexmb.UnsupportedStrategyError, match="no joint database"):
        db.shipped(flexmb.LeafSpring(), 2)


def test_queries_outside_the_range_warn_or_fail():
    data = db.shipped(flexmb.CrossFlexure(), 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        data.check_range(np.radians(74.9))  # inside: silent
    with pytest.warns(ExtrapolationWarning, match="outside the trained range"):
        data.check_range(np.radians(80))
    with pytest.raises(DatabaseError, match="80.00 deg"):
        data.check_range(np.radians(80), strict=True)


def test_train_command_writes_a_loadable_file(tmp_path, capsys):
    from flexmb import cli

    assert cli.main(["train", "--dim", "2", "--elements", "1", "--range", "10", "--out", str(tmp_path)]) == 0
    files = list(tmp_path.glob("*.json"))
    assert len(files) == 1 and db.load(files[0]).dim == 2
    assert "max fit residuals" in capsys.readouterr().out


# -- content validation after the checksum (issue 20, class 4) -------------------------------

def _forged(tmp_path, mutate, dim=2, n=2):
    """A copy of the shipped file with ``mutate`` applied and the checksum recomputed (so only
    the content checks can refuse it); returns the joint it claims to describe."""
    from flexmb.database.store import _checksum

    j = flexmb.CrossFlexure(elements_per_leaf=n)
    src = db.data_path() / db.file_name(j.kind, dim, j.database_key())
    body = json.loads(src.read_text())
    mutate(body)
    body["checksum"] = _checksum(body)
    (tmp_path / src.name).write_text(json.dumps(body))
    return j


_DROP = object()


def _set(*path_and_value):
    """A mutation setting ``body[p0][p1]... = value`` (a function of the old value when callable;
    `_DROP` deletes the entry)."""
    *path, value = path_and_value

    def mutate(body):
        d = body
        for k in path[:-1]:
            d = d[k]
        if value is _DROP:
            del d[path[-1]]
        else:
            d[path[-1]] = value(d[path[-1]]) if callable(value) else value
    return mutate


FORGERIES = {
    # each raised a raw exception on main (the kind in the comment) or was accepted
    "functions not an object": (_set("functions", []), "'functions' must be dict"),  # AttributeError
    "a function missing": (_set("functions", "x/D0", _DROP), "missing"),
    "range text": (_set("range", "ab"), "'range' must be list"),  # TypeError
    "range one number": (_set("range", [1.0]), "range must be"),  # ValueError (unpacking)
    "range NaN": (_set("range", [float("nan"), 1.0]), "range must be a list of numbers|non-finite|range must be"),
    "element rows dropped": (_set("elements", "coefficients", lambda c: c[:-1]), "element rotations|row"),  # IndexError
    "powers text": (_set("elements", "powers", "x"), "'powers' must be list"),
    # converged to -16946 N m on main:
    "negative powers": (_set("elements", "powers", [-1, -2, -3, -4, -5]), "powers must be distinct integers"),
    "nested parameters": (_set("parameters", "angle", [[[[1]]]]), "parameters"),
    "key not an object": (_set("key", []), "'key' must be dict"),
    "dimension 7": (_set("dim", 7), "dim=7"),
    "dimension as text": (_set("dim", "x"), "'dim' must be int"),
    "samples as text": (_set("samples", "x"), "'samples' must be list"),
    "residual missing": (_set("nodes", "max_residual", _DROP), "max_residual"),  # KeyError
    "residual None": (_set("elements", "max_residual", None), "elements.'max_residual' must be"),
    "huge integer": (_set("length", 10**400), "length is too large"),  # OverflowError
    "position fit scaled": (_set("functions", "x/D0", "coefficients", lambda c: [1.2 * x for x in c]),
                            "disagree|at rest"),
    "D0 scaled": (_set("length", lambda v: 1.2 * v), "D0"),
    "coefficient column missing": (_set("functions", "y/D0", "coefficients", lambda c: c[:-1]), "columns"),
    "boolean dimension": (_set("dim", True), "'dim' must be int"),
}


@pytest.mark.parametrize("name", list(FORGERIES))
def test_a_file_with_a_recomputed_checksum_is_checked_for_content(tmp_path, name):
    """Malformed structures behind a valid checksum raise `DatabaseError` naming the fault, from
    `load`, `shipped` and a KSD solve alike (main raised AttributeError, TypeError, ValueError,
    IndexError, KeyError, OverflowError, or converged to a wrong answer)."""
    mutate, match = FORGERIES[name]
    j = _forged(tmp_path, mutate)
    with pytest.raises(DatabaseError, match=match):
        db.shipped(j, 2, folder=tmp_path)
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.3)
    with pytest.raises(DatabaseError):
        flexmb.solve(m, method="ksd-reduced", database=str(tmp_path))


def test_deeply_nested_json_is_refused_not_a_recursion_error(tmp_path):
    (tmp_path / "deep.json").write_text('{"format": ' + "[" * 200_000 + "]" * 200_000 + "}")
    with pytest.raises(DatabaseError, match="not readable JSON"):
        db.load(tmp_path / "deep.json")


def test_a_consistently_edited_file_is_caught_by_verify(tmp_path):
    """Element rotations scaled by 1.2 pass every self-consistency check (they are not tied to B's
    position in the file) and move the KSD-reduced moment by 0.5 %; `verify` re-runs the FE model
    at three trained rotations and finds the fits off by far more than they state."""
    j = _forged(tmp_path, _set("elements", "coefficients", lambda c: [[1.2 * x for x in r] for r in c]))
    db.shipped(j, 2, folder=tmp_path)  # accepted by the loader: only the FE model can tell
    with pytest.raises(DatabaseError, match="elements differs from the FE model"):
        db.verify(j, 2, folder=tmp_path)
    assert db.verify(j, 2).key == j.database_key()  # the shipped file passes


def _finishes(call, seconds=10.0):
    """Run ``call`` in a thread; its outcome, or "hung" when it does not return in ``seconds``."""
    import threading

    out = []

    def run():
        try:
            out.append(call())
        except BaseException as exc:  # noqa: BLE001 - the test inspects whatever came out
            out.append(exc)
    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    return out[0] if out else "hung"


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="POSIX FIFOs")
def test_a_fifo_at_the_path_is_refused_without_blocking(tmp_path):
    import os

    j = flexmb.CrossFlexure()
    os.mkfifo(tmp_path / db.file_name(j.kind, 3, j.database_key()))
    outcome = _finishes(lambda: db.shipped(j, 3, folder=tmp_path))  # main: blocked forever in open()
    assert isinstance(outcome, DatabaseError) and "not a regular file" in str(outcome)


@pytest.mark.skipif(not __import__("os").path.exists("/dev/zero"), reason="needs /dev/zero")
def test_a_link_to_an_endless_device_is_refused_without_reading_it(tmp_path):
    j = flexmb.CrossFlexure()
    (tmp_path / db.file_name(j.kind, 3, j.database_key())).symlink_to("/dev/zero")
    outcome = _finishes(lambda: db.shipped(j, 3, folder=tmp_path))  # main: read until MemoryError
    assert isinstance(outcome, DatabaseError) and "not a regular file" in str(outcome)


def test_an_oversized_file_is_refused_before_it_is_read(tmp_path):
    from flexmb.database.store import MAX_BYTES

    path = tmp_path / "big.json"
    with path.open("wb") as f:
        f.truncate(MAX_BYTES + 1)  # sparse: nothing is written
    with pytest.raises(DatabaseError, match="bytes"):
        db.load(path)


def test_the_template_cache_follows_the_content_not_the_time_stamp(tmp_path):
    """A file replaced by another with its modification time restored (as `cp -p`, rsync or a
    checkout do): KSD uses the new content (main kept the old template, keyed on mtime)."""
    import os

    from flexmb.ksd.reduced import template

    j = _forged(tmp_path, lambda b: None)
    path = tmp_path / db.file_name(j.kind, 2, j.database_key())
    before = template(j, 2, tmp_path)
    stamp = path.stat().st_mtime_ns
    _forged(tmp_path, _set("elements", "coefficients", lambda c: [[1.1 * x for x in r] for r in c]))
    os.utime(path, ns=(stamp, stamp))
    after = template(j, 2, tmp_path)
    assert after is not before
    np.testing.assert_allclose(after.data.elements.coefficients, 1.1 * before.data.elements.coefficients, rtol=1e-15)
    assert template(j, 2, tmp_path) is after  # unchanged content: cached


def test_loaded_arrays_are_read_only(tmp_path):
    """The parsed data are shared by every reader of the same content: nobody can change them."""
    data = db.shipped(flexmb.CrossFlexure(), 2)
    with pytest.raises(ValueError, match="read-only"):
        data.elements.coefficients[0, 0] = 1.0


# -- where the data live: user folder, search order, the shipped data never written ----------

def test_user_path_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("FLEXMB_DATABASE", str(tmp_path / "mine"))
    assert db.user_path() == tmp_path / "mine"
    assert db.search_path() == [tmp_path / "mine", db.data_path()]
    assert db.search_path(tmp_path) == [tmp_path, tmp_path / "mine", db.data_path()]
    monkeypatch.delenv("FLEXMB_DATABASE")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    if __import__("sys").platform.startswith("linux"):
        assert db.user_path() == tmp_path / "xdg" / "flexmb" / "database"


def test_data_are_found_in_the_documented_order(monkeypatch, tmp_path):
    """database=FOLDER first, then the user folder, then the shipped data; the first file wins."""
    user, mine = tmp_path / "user", tmp_path / "mine"
    user.mkdir(), mine.mkdir()
    monkeypatch.setenv("FLEXMB_DATABASE", str(user))
    j = flexmb.CrossFlexure(elements_per_leaf=1)
    name = db.file_name(j.kind, 2, j.database_key())
    assert db.locate(j, 2) == db.data_path() / name
    db.save(db.train(j, 2, range_deg=(-20, 20), step_deg=10), user / name)
    assert db.locate(j, 2) == user / name and db.shipped(j, 2).range == pytest.approx(np.radians((-20, 20)))
    db.save(db.train(j, 2, range_deg=(-30, 30), step_deg=10), mine / name)
    assert db.locate(j, 2, mine) == mine / name
    assert db.shipped(j, 2, mine).range == pytest.approx(np.radians((-30, 30)))
    with pytest.raises(DatabaseError, match=f"in {mine}, {user}, "):
        db.shipped(flexmb.CrossFlexure(angle=0.6), 2, mine)


def _shipped_files():
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in db.data_path().iterdir()}


def test_train_without_out_writes_the_user_folder_not_the_shipped_data(monkeypatch, tmp_path, capsys):
    """Main rewrote the shipped file inside the installed package (then KSD above the trained
    20 deg failed for everyone); now the user data folder gets it, and KSD finds it there."""
    from flexmb import cli

    monkeypatch.setenv("FLEXMB_DATABASE", str(tmp_path / "user"))
    before = _shipped_files()
    assert cli.main(["train", "--dim", "2", "--elements", "1", "--range", "20", "--step", "10"]) == 0
    assert _shipped_files() == before
    j = flexmb.CrossFlexure(elements_per_leaf=1)
    written = tmp_path / "user" / db.store.joint_file_name(j, 2)  # named by the design (issue 32)
    assert db.load(written).range == pytest.approx(np.radians((-20, 20)))
    out = capsys.readouterr().out
    assert str(written) in out and "takes precedence over the shipped" in out
    assert db.locate(j, 2) == written


def test_save_is_atomic_and_reports_an_unwritable_folder(tmp_path):
    data = db.shipped(flexmb.CrossFlexure(), 2)
    with pytest.raises(DatabaseError, match="cannot write"):
        db.save(data, tmp_path / "no-such-folder" / "x.json")
    path = db.save(data, tmp_path / "x.json")
    assert db.load(path).key == data.key and [p.name for p in tmp_path.iterdir()] == ["x.json"]


def test_train_s_precedence_hint_only_where_the_shipped_data_has_the_joint(monkeypatch, tmp_path, capsys):
    """The hint says the new file comes before the shipped data of the same joint: printed when
    `locate` would find a shipped file for the design (its own or the key-only name: a thinner
    cross flexure shares the shipped 1 el./leaf kinematics), not for a mesh the shipped data lack."""
    from flexmb import cli

    monkeypatch.setenv("FLEXMB_DATABASE", str(tmp_path / "user"))
    assert cli.main(["train", "--dim", "2", "--elements", "1", "--range", "20", "--step", "10",
                     "--param", "thickness=0.0002"]) == 0
    assert "takes precedence over the shipped" in capsys.readouterr().out
    j = flexmb.CrossFlexure(elements_per_leaf=7)
    assert not any((db.data_path() / n).exists() for n in db.store.candidate_names(j, 2))
    assert cli.main(["train", "--dim", "2", "--elements", "7", "--range", "20", "--step", "10"]) == 0
    out = capsys.readouterr().out
    assert str(tmp_path / "user" / db.store.joint_file_name(j, 2)) in out
    assert "takes precedence over the shipped" not in out
