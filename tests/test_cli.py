"""The `flexmb` command and the example script (scikit-fem style: examples are tests too)."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import cli

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_demo_prints_the_table_and_exits_zero(tmp_path, capsys):
    assert cli.main(["demo", "--quick", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "theta [deg]" in out and "reference" in out and "75 |" in out
    assert "partial NL (closed form)               77.035" in out  # gripper closing force, flexmb's value
    assert "Manipulator of three three_x_infinity joints" in out and "ksd-reduced" in out
    if importlib.util.find_spec("matplotlib"):
        for name in ("cross_flexure", "gripper_models", "fourbar_shape", "fourbar_strategies", "manipulator_shape",
                     "manipulator_fig15"):
            assert (tmp_path / f"{name}.png").stat().st_size > 10_000  # a real figure, not an empty file


def test_joints_lists_the_shipped_plugins(capsys):
    assert cli.main(["joints"]) == 0
    out = capsys.readouterr().out
    assert "cross_flexure" in out and "leaf_spring" in out and "elements_per_leaf = 24" in out  # the default


def _watch_clock(monkeypatch, module, name: str, real, size):
    """Replace ``module``'s ``name`` (a solve or sweep) by ``real`` noting ``size(args)`` per call,
    and its ``time.perf_counter`` by one noting the calls made before each reading."""
    import time as _time

    calls, readings = [], []

    def noted(*a, **k):
        calls.append(size(a))
        return real(*a, **k)

    class Clock:
        @staticmethod
        def perf_counter():
            readings.append(list(calls))
            return _time.perf_counter()

    monkeypatch.setattr(module, name, noted)
    monkeypatch.setattr(module, "time", Clock)
    return calls, readings


def test_demo_cross_flexure_times_exclude_the_sessions_first_solve(monkeypatch):
    """The first solve of a session loads the compiled kernels (measured: 0.41 s for the 1 el./leaf
    curve against 0.035 s warm), so the demo's "time [s]" row starts its clock after an untimed
    solve; the ratios and iterations it prints are those of the timed solves alone."""
    import flexmb.studies.demo as demo

    solves, readings = _watch_clock(monkeypatch, demo, "solve", flexmb.solve, lambda a: 1)
    ratios, iterations, seconds = demo.cross_flexure_curve(1, angles_deg=(5, 10))
    assert [len(r) for r in readings] == [1, 3] and len(solves) == 3 and seconds > 0
    per_angle = [flexmb.solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=1, rotation=np.radians(d)))
                 for d in (5, 10)]
    assert iterations == sum(s.iterations for s in per_angle)


def test_demo_gripper_sweep_time_excludes_the_sessions_first_sweep(monkeypatch):
    """A session's first compiled force sweep loads its kernels (measured: the linear gripper's 131
    forces 23 ms, warm 2.5 ms; the demo printed the linear model 10x slower than the partial
    non-linear one), so `opening_closing` times its sweep after an untimed one of two forces."""
    import flexmb.studies.gripper as gripper

    _, readings = _watch_clock(monkeypatch, gripper, "sweep", flexmb.sweep, lambda a: len(a[1]))
    r = gripper.opening_closing("silicon", "linear", "newton", points=5, upper=60.0)
    assert readings == [[2], [2, 5]] and len(r["forces"]) == 5 and r["converged"].all()


def test_errors_are_one_line_with_exit_code_1(monkeypatch, capsys):
    import flexmb.studies.demo

    def broken(*a, **k):
        flexmb.models.cross_flexure_pivot(rotation=float("nan"))

    monkeypatch.setattr(flexmb.studies.demo, "cross_flexure_curve", broken)
    assert cli.main(["demo", "--quick"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("flexmb: error:") and err.count("\n") == 1 and "rotation" in err


def test_usage_error_exits_2():
    with pytest.raises(SystemExit) as exc:
        cli.main(["no-such-command"])
    assert exc.value.code == 2


def test_train_with_a_shape_parameter_feeds_ksd(tmp_path, capsys):
    """`flexmb train --param angle=0.6 --out DIR` makes the database a non-default joint needs;
    KSD then finds it with database=DIR, and KSD-full equals the conventional solution."""
    import flexmb

    j = flexmb.CrossFlexure(elements_per_leaf=1, angle=0.6)
    m = flexmb.Mechanism(2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=j.interface_b(2))
    m.add_joint("A", "B", j, name="cf")
    m.prescribe("B", rotation=0.3)
    with pytest.raises(flexmb.FlexmbError, match=r"joint 'cf'.*--param angle=0\.6 --out FOLDER"):
        flexmb.solve(m, method="ksd-reduced")
    assert cli.main(["train", "--dim", "2", "--elements", "1", "--param", "angle=0.6", "--range", "30",
                     "--step", "10", "--out", str(tmp_path)]) == 0
    full = flexmb.solve(m, method="ksd-full", database=str(tmp_path))
    conv = flexmb.solve(m)
    assert full.converged
    np.testing.assert_allclose(full.node_positions(), conv.node_positions(), rtol=0, atol=1e-9)


# -- flexmb solve / run / bench ------------------------------------------------------------

def test_solve_json_parses_and_carries_the_solution(capsys):
    import json

    import flexmb

    assert cli.main(["solve", "cross_flexure", "--param", "rotation=0.5", "--param", "dim=2", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    ref = flexmb.solve(flexmb.models.cross_flexure_pivot(rotation=0.5, dim=2))
    assert report["converged"] is True and report["case"] == "cross_flexure"
    assert report["parameters"] == {"rotation": 0.5, "dim": 2}
    assert report["iterations"] == ref.iterations
    np.testing.assert_allclose(report["links"]["B"]["reaction"], ref.reaction("B"), rtol=0, atol=1e-12)
    np.testing.assert_allclose(report["links"]["B"]["position"], ref.pose("B")[0], rtol=0, atol=1e-15)


def test_solve_with_another_method_and_a_solver_option(capsys):
    import json

    assert cli.main(["solve", "fourbar", "--method", "ksd-full", "--param", "displacement=0.05",
                     "--param", "elements_per_leaf=1", "--option", "tol=1e-7", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["method"] == "ksd-full" and report["residual_history"][-1] < 1e-7


def test_solve_that_does_not_converge_prints_the_result_and_exits_1(capsys):
    import json

    code = cli.main(["solve", "cross_flexure", "--param", "rotation=1.2", "--param", "dim=2",
                     "--option", "max_iter=1", "--option", "min_step=0.5", "--json"])
    captured = capsys.readouterr()
    assert code == 1
    assert json.loads(captured.out)["converged"] is False
    assert captured.err.startswith("flexmb: error: cross_flexure did not converge")


def test_solve_with_an_unknown_parameter_names_it_in_one_line(capsys):
    assert cli.main(["solve", "fourbar", "--param", "bogus=1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bogus" in err


def test_solve_help_and_unknown_case_are_usage(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["solve", "--help"])
    assert exc.value.code == 0 and "--json" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        cli.main(["solve", "no-such-case"])
    assert exc.value.code == 2


def test_run_executes_a_script_with_its_arguments(tmp_path, capsys):
    script = tmp_path / "case.py"
    script.write_text("import sys\nprint('args', sys.argv[1:])\nsys.exit(int(sys.argv[1]))\n")
    assert cli.main(["run", str(script), "0"]) == 0
    assert "args ['0']" in capsys.readouterr().out
    assert cli.main(["run", str(script), "3"]) == 3
    assert cli.main(["run", str(tmp_path / "missing.py")]) == 1
    assert "no script" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_lists_and_regenerates_benchmarks_md_in_a_checkout(tmp_path, capsys):
    import shutil

    shutil.copytree(ROOT / "benchmarks", tmp_path / "benchmarks")
    assert cli.main(["bench", "--list", "--root", str(tmp_path)]) == 0
    # every benchmarks/bench_<name>.py, in name order (the paper's four among them)
    listed = capsys.readouterr().out.split()
    assert listed == sorted(p.stem.removeprefix("bench_") for p in (ROOT / "benchmarks").glob("bench_*.py"))
    assert {"core", "fourbar", "gripper", "manipulator"} <= set(listed)
    assert cli.main(["bench", "--quick", "--only", "core", "--root", str(tmp_path)]) == 0
    text = (tmp_path / "BENCHMARKS.md").read_text()
    assert "<!-- begin core -->" in text and "<!-- begin fourbar -->" not in text
    assert cli.main(["bench", "--only", "nope", "--root", str(tmp_path)]) == 1
    assert cli.main(["bench", "--root", str(tmp_path / "empty")]) == 1
    assert "no benchmarks/bench_*.py" in capsys.readouterr().err


# -- every bad argument: one line on stderr and the documented exit code (issue 20, class 5) --

def _exit_code(argv):
    """``cli.main(argv)``'s exit code, whether returned or raised by argparse as SystemExit."""
    try:
        return cli.main(argv)
    except SystemExit as exc:
        return exc.code


BAD_ARGUMENTS = {
    "demo --out is a file": lambda f: ["demo", "--quick", "--out", str(f)],  # main: traceback after the solves
    "demo --out under a file": lambda f: ["demo", "--quick", "--out", str(f / "figures")],
    "train --out under a file": lambda f: ["train", "--dim", "2", "--elements", "1", "--out", str(f / "db")],
    "train --range text": lambda f: ["train", "--range", "abc"],
    "train --range negative": lambda f: ["train", "--range", "-5"],
    "train --range NaN": lambda f: ["train", "--range", "nan"],
    "train --range above 180": lambda f: ["train", "--range", "200"],
    "train --step 0": lambda f: ["train", "--dim", "2", "--elements", "1", "--step", "0", "--out", str(f.parent)],
    "train --elements 0": lambda f: ["train", "--dim", "2", "--elements", "0", "--out", str(f.parent)],
    "solve --param without value": lambda f: ["solve", "cantilever", "--param", "rotation"],  # main: exit 1
    "solve --option without value": lambda f: ["solve", "cantilever", "--option", "tol"],
    "train --param without value": lambda f: ["train", "--param", "angle", "--out", str(f.parent)],
    "solve --option method": lambda f: ["solve", "cantilever", "--option", "method=newton"],  # main: TypeError
}


@pytest.mark.parametrize("name", list(BAD_ARGUMENTS))
def test_every_bad_argument_is_one_line_with_exit_code_2(name, tmp_path, capsys):
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    code = _exit_code(BAD_ARGUMENTS[name](a_file))
    out, err = capsys.readouterr()
    assert code == 2
    assert err.startswith("flexmb: error:") and err.count("\n") == 1 and "Traceback" not in err
    assert out == ""  # refused before any work (the demo used to solve for minutes, then fail)
    assert a_file.read_text() == "not a folder" and sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_train_refuses_to_write_the_shipped_data(capsys):
    from flexmb import database

    before = {p.name: p.read_bytes() for p in database.data_path().iterdir()}
    argv = ["train", "--dim", "2", "--elements", "1", "--range", "10", "--out", str(database.data_path())]
    assert cli.main(argv) == 2
    assert "never writes" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in database.data_path().iterdir()} == before


def test_train_writes_the_elements_asked_for(tmp_path, capsys):
    """``--elements 2`` trains 2 el./leaf (main silently trained the default 3 for ``--elements 0``,
    which is now refused above)."""
    assert cli.main(["train", "--dim", "2", "--elements", "2", "--range", "10", "--out", str(tmp_path)]) == 0
    import flexmb
    from flexmb.database import store

    name = store.joint_file_name(flexmb.CrossFlexure(elements_per_leaf=2), 2)  # the design's own name (issue 32)
    assert name.startswith("cross_flexure-2d-angle0.785398-elements_per_leaf2-")
    assert [p.name for p in tmp_path.iterdir()] == [name]


@pytest.mark.slow
def test_a_closed_pipe_ends_quietly(tmp_path):
    """``flexmb solve cantilever --json | head -c1``: the reader is gone before flexmb writes; main
    printed a BrokenPipeError traceback, now nothing is printed and the exit code is 141 (SIGPIPE)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "flexmb.cli", "solve", "cantilever", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp_path)
    proc.stdout.close()  # the reader went away
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141
    assert err == b""


def test_a_closed_pipe_in_process(monkeypatch, capsys):
    import sys

    class Closed:
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    assert cli.main(["joints"]) == 141
    assert capsys.readouterr().err == ""


def test_json_is_strict_with_non_finite_numbers_as_null(capsys):
    """A diverged solve (a 1e150 m stroke): main printed ``NaN``, which JSON parsers reject."""
    import json

    def refuse(token):
        raise AssertionError(f"not JSON: {token}")

    assert cli.main(["solve", "fourbar", "--param", "displacement=1e150", "--json"]) == 1
    out, err = capsys.readouterr()
    report = json.loads(out, parse_constant=refuse)
    *warnings, error = err.splitlines()  # numpy's overflow warnings and the error, one line each
    assert all(w.startswith("flexmb: warning: ") for w in warnings) and error.startswith("flexmb: error:")
    assert report["converged"] is False
    assert None in report["residual_history"]  # the diverged iterations' residuals, as null
    assert cli.strict_json({"a": [float("inf"), -float("inf"), float("nan"), 1.5], "b": (2, "x")}) == \
        {"a": [None, None, None, 1.5], "b": [2, "x"]}


def test_run_prints_the_message_of_sys_exit(tmp_path, capsys):
    script = tmp_path / "fails.py"
    script.write_text("import sys\nsys.exit('the load case is missing')\n")
    assert cli.main(["run", str(script)]) == 1  # main: exit 1 without the message
    assert capsys.readouterr().err == "the load case is missing\n"
    script.write_text("import sys\nsys.exit()\n")
    assert cli.main(["run", str(script)]) == 0


@pytest.mark.slow  # fast-set budget: >= 0.9 s measured under load
def test_train_by_default_reproduces_the_shipped_cross_flexure_databases(tmp_path, capsys):
    """``flexmb train`` trains the shipped meshes, 1-5, 10 and the joint's default 24 el./leaf (its
    default ``--elements 1..5`` missed the 10 el./leaf files the joint looked up), in 2D and
    3D; the fits equal the shipped ones to the training solves' convergence (measured: largest
    coefficient difference 3.6e-11, the 10 el./leaf node angles; each fit's own residual is
    ~1e-4, so 1e-10 is a millionth of it)."""
    import flexmb
    from flexmb import database

    assert cli._shipped_meshes("cross_flexure", {}, 3) == [1, 2, 3, 4, 5, 10, 24]
    assert cli._shipped_meshes("cross_flexure", {"angle": 0.6}, 2) == [24]  # nothing shipped: the default mesh
    assert flexmb.CrossFlexure().elements_per_leaf == 24
    assert cli.main(["train", "--out", str(tmp_path)]) == 0
    shipped = sorted(p.name for p in database.data_path().glob("cross_flexure-*.json"))
    # written under the design's own name: the shipped file's stem, then the hash of the joint's
    # parameters (today's, which add density, nu and yield_stress to those the shipped files record)
    trained = {}
    for name in shipped:
        data = database.load(database.data_path() / name)
        joint = flexmb.CrossFlexure(elements_per_leaf=data.key["elements_per_leaf"])
        trained[name] = database.store.joint_file_name(joint, data.dim)
        assert trained[name].startswith(name[:-len(".json")] + "-")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(trained.values()) and len(shipped) == 14
    for name in shipped:
        new, old = database.load(tmp_path / trained[name]), database.load(database.data_path() / name)
        for fit in [*old.functions, "elements", "nodes"]:
            a, b = (new.function(fit), old.function(fit)) if fit in old.functions else \
                (getattr(new, fit), getattr(old, fit))
            np.testing.assert_allclose(a.coefficients, b.coefficients, rtol=0, atol=1e-10, err_msg=f"{name} {fit}")


def test_train_a_spatial_joint_by_default_in_3d_only(tmp_path, capsys):
    """``flexmb train three_x_infinity`` failed at once ("dim=2 must be 3": the default ``--dim``
    was 2 and 3 for every joint); now the joint's own dimensions and meshes: the shipped 3 and
    its default 24 el./leaf."""
    assert cli.main(["train", "three_x_infinity", "--range", "5", "--step", "5", "--out", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert [n.rpartition("-")[0] for n in names] == [
        f"three_x_infinity-3d-angle0.785398-elements_per_leaf{n}-length_ratio0.625-stages3" for n in (24, 3)]


def test_the_training_command_a_missing_database_names_builds_that_database(tmp_path):
    """three_x_infinity's database key holds ``length_ratio`` (length over the axis distance), not
    a constructor parameter: the command the `DatabaseError` names must be the joint's own
    parameters (here a non-default ``length``), which `flexmb train` accepts and KSD then finds."""
    import shlex

    import flexmb

    j = flexmb.ThreeXInfinity(elements_per_leaf=1, length=0.035)
    m = flexmb.Mechanism(3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=j.interface_b(3))
    m.add_joint("A", "B", j, name="hinge")
    m.prescribe("B", rotation=(0.0, 0.0, 0.1))
    with pytest.raises(flexmb.DatabaseError, match=r"--param length=0\.035 --out FOLDER") as err:
        flexmb.solve(m, method="ksd-reduced")
    command = shlex.split(str(err.value).split("`")[1].replace("FOLDER", str(tmp_path)))
    assert command[:2] == ["flexmb", "train"] and "length_ratio" not in str(err.value).split("`")[1]
    assert cli.main(command[1:] + ["--range", "10", "--step", "5"]) == 0
    assert flexmb.solve(m, method="ksd-reduced", database=tmp_path).converged


