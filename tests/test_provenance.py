"""Joint database files keyed on the design, written atomically, and the provenance of every KSD
solution's joint data (issue 32 items 2, 3 and 6)."""

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import attrs
import numpy as np
import pytest

import flexmb
from flexmb import cli, database, models
from flexmb.database import store
from flexmb.database.eob_format import plain_parameters
from flexmb.errors import DatabaseError, FlexmbError

ROOT = Path(__file__).resolve().parents[1]


def _as_trained(joint, dim):
    """The shipped data of ``joint``'s key as `flexmb train` would record them for ``joint`` (its
    own parameters: the shipped files predate the density and yield-stress fields)."""
    return attrs.evolve(store.shipped(joint, dim), parameters=plain_parameters(joint.describe()))


def _train(out, *extra):
    args = ["train", "--dim", "2", "--elements", "2", "--range", "20", "--step", "10", "--out", str(out), *extra]
    assert cli.main(args) == 0


def test_training_another_design_into_the_same_folder_keeps_the_first(tmp_path, capsys):
    """The issue's reproducer: ``flexmb train --dim 2 --elements 2 --out db``, then the same with
    ``--param length=0.05``, left one file (names held the angle and the mesh only): the first
    training was lost and a KSD solve of the first design refused. Now two files, the first
    untouched, and each design's KSD solve reads its own."""
    db = tmp_path / "db"
    _train(db)
    (first,) = db.glob("*.json")
    before = first.read_bytes()
    _train(db, "--param", "length=0.05")
    files = sorted(p.name for p in db.glob("*.json"))
    assert len(files) == 2 and first.read_bytes() == before
    for params in ({}, {"length": 0.05}):
        joint = flexmb.CrossFlexure(elements_per_leaf=2, **params)
        m = models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.2, **params)
        sol = flexmb.solve(m, method="ksd-reduced", database=db)
        entry = sol.stages["setup"]["files"]["cross_flexure"]
        assert entry == {"path": str(db / store.joint_file_name(joint, 2)), "source": "database="}
        assert sol.converged and store.load(entry["path"]).parameters["length"] == joint.length
    # retraining the same design replaces its own file (atomically), nothing else
    _train(db, "--param", "length=0.05")
    assert sorted(p.name for p in db.glob("*.json")) == files and first.read_bytes() == before
    assert not [p for p in db.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_write_refuses_to_replace_a_file_of_another_design(tmp_path):
    """A file under a design's name that holds another design (a hash collision, a file renamed by
    hand) is neither replaced by `store.write` nor used by KSD: both name it."""
    a = store.shipped(flexmb.CrossFlexure(elements_per_leaf=2), 2)
    b = store.shipped(flexmb.CrossFlexure(elements_per_leaf=3), 2)
    name = store.design_file_name(a.kind, 2, a.key, a.parameters)
    store.save(b, tmp_path / name)
    kept = (tmp_path / name).read_bytes()
    with pytest.raises(DatabaseError, match=f"{name} holds another design .* not replaced"):
        store.write(a, tmp_path)
    assert (tmp_path / name).read_bytes() == kept
    # under a's design name with a's key but other parameters: refused when read for a
    renamed = tmp_path / "renamed"
    renamed.mkdir()
    other = store.load(store.write(_as_trained(flexmb.CrossFlexure(elements_per_leaf=2, gap=0.001), 2), renamed))
    os.replace(other.path, renamed / name)
    a_joint = flexmb.CrossFlexure(elements_per_leaf=2)
    os.replace(renamed / name, renamed / store.joint_file_name(a_joint, 2))
    with pytest.raises(DatabaseError, match="holds the data of another design"):
        store.shipped(a_joint, 2, renamed)


_WRITER = textwrap.dedent("""
    import sys
    from flexmb.database import store
    data = store.load(sys.argv[1])
    data.eob_table is None or data.eob_table.values  # read before the race
    for _ in range(int(sys.argv[3])):
        store.write(data, sys.argv[2])
    """)


@pytest.mark.slow
def test_two_processes_writing_one_folder_leave_whole_files(tmp_path):
    """Two ``flexmb train`` processes writing the same design (with its 1.3 MB EOB table) into one
    folder, and a third design beside them, 15 times each, while this process reads: every read
    sees a whole file, and at the end each design's file and the side file it names are intact
    (atomic rename of uniquely named temporary files; the side file named by its content)."""
    tx = store.locate(flexmb.ThreeXInfinity(elements_per_leaf=3), 3)  # shipped, with its EOB table
    cf = store.locate(flexmb.CrossFlexure(elements_per_leaf=2), 2)
    out = tmp_path / "db"
    out.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    procs = [subprocess.Popen([sys.executable, "-c", _WRITER, str(src), str(out), "15"], env=env,
                              stderr=subprocess.PIPE) for src in (tx, tx, cf)]
    original = store.load(tx)
    target = out / store.design_file_name(original.kind, 3, original.key, original.parameters)
    reads = 0
    while any(p.poll() is None for p in procs):
        if target.exists():
            data = store.load(target)  # a whole file, checksum verified
            assert data.eob_table is not None
            reads += 1
        time.sleep(0.005)
    errors = [p.stderr.read().decode() for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], errors
    data = store.load(target)
    np.testing.assert_array_equal(data.eob_table.values, original.eob_table.values)
    names = sorted(p.name for p in out.iterdir())
    cf_name = store.design_file_name("cross_flexure", 2, store.load(cf).key, store.load(cf).parameters)
    assert names == sorted([target.name, store.side_file(target).name, cf_name]), names  # nothing left over
    assert reads > 0


def test_every_ksd_solution_names_the_file_of_each_joints_data(tmp_path, monkeypatch):
    """shipped, the user folder (FLEXMB_DATABASE), ``database=``: recorded per joint, in that order
    of precedence; ``flexmb solve --json`` prints it."""
    joint = flexmb.CrossFlexure(elements_per_leaf=3)
    m = models.fourbar(displacement=0.1)
    sol = flexmb.solve(m, method="ksd-reduced")
    files = sol.stages["setup"]["files"]
    assert set(files) == {"bottom_left", "bottom_right", "top_left", "top_right"}
    assert {e["source"] for e in files.values()} == {"shipped"}
    assert {Path(e["path"]) for e in files.values()} == {store.data_path() / store.file_name(joint.kind, 3,
                                                                                          joint.database_key())}
    user = tmp_path / "user"
    user.mkdir()
    store.write(_as_trained(joint, 3), user)
    monkeypatch.setenv("FLEXMB_DATABASE", str(user))
    sol = flexmb.solve(m, method="ksd-full")
    assert {(e["source"], Path(e["path"]).parent) for e in sol.stages["setup"]["files"].values()} == {("user", user)}
    mine = tmp_path / "mine"
    mine.mkdir()
    store.write(_as_trained(joint, 3), mine)
    sol = flexmb.solve(m, method="ksd-reduced", database=mine)
    assert {(e["source"], Path(e["path"]).parent) for e in sol.stages["setup"]["files"].values()} == {("database=", mine)}


def test_refusals_name_the_file(tmp_path):
    """A motion beyond the trained range, refused by ``strict_range``, names the file whose range it
    is (a user's file quietly taking precedence over the shipped one was the issue's trouble)."""
    mine = tmp_path / "mine"
    mine.mkdir()
    _train(mine)  # +-20 deg
    m = models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.5)
    path = mine / store.joint_file_name(flexmb.CrossFlexure(elements_per_leaf=2), 2)
    with pytest.raises(DatabaseError, match=f"outside its trained range .* deg of {path}"):
        flexmb.solve(m, method="ksd-reduced", database=mine)
    with pytest.warns(flexmb.ExtrapolationWarning, match=f"outside its trained range .* deg of {path}"):
        flexmb.solve(m, method="ksd-reduced", database=mine, strict_range=False, error_tol=None)


def test_a_home_that_cannot_be_expanded_is_a_flexmb_error(monkeypatch):
    """``FLEXMB_DATABASE='~nosuchuser/x'`` made every KSD solve raise a raw RuntimeError ("Could
    not determine home directory")."""
    monkeypatch.setenv("FLEXMB_DATABASE", "~nosuchuser_flexmb/x")
    with pytest.raises(FlexmbError, match="FLEXMB_DATABASE='~nosuchuser_flexmb/x': cannot expand"):
        database.user_path()
    with pytest.raises(FlexmbError, match="cannot expand"):
        flexmb.solve(models.fourbar(displacement=0.1), method="ksd-reduced")
