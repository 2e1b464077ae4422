"""``flexmb solve FILE`` (a solve, a sweep over a prescribed motion, properties, a traced path,
``--json`` / ``--csv`` with unit labels) and ``flexmb run`` with the script's folder importable
(issue 30 item 1)."""

import csv
import io
import json

import numpy as np
import pytest

import flexmb
from flexmb import cli


@pytest.fixture
def stage_file(tmp_path):
    from test_units import guided_stage

    return flexmb.save(guided_stage("mm-N-MPa"), tmp_path / "stage.json")


def test_solve_a_file_prints_the_solution_with_its_units(stage_file, capsys):
    assert cli.main(["solve", str(stage_file), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    ref = flexmb.solve(flexmb.load(stage_file))
    assert report["units"] == "mm-N-MPa" and report["unit_labels"]["length"] == "mm"
    assert report["links"]["block"]["reaction"] == ref.reaction("block").tolist()  # exact: repr round trip
    assert cli.main(["solve", str(stage_file)]) == 0
    out = capsys.readouterr().out
    assert "units mm-N-MPa" in out and "mm, rotation" in out and "[N, N mm]" in out


def test_sweep_a_prescribed_motion_of_a_file_as_csv_with_unit_labels(stage_file, capsys):
    assert cli.main(["solve", str(stage_file), "--sweep", "block.x=0:2:5", "--csv"]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    header, values = rows[0], rows[1:]
    assert header[0] == "block.x [mm]" and "block.Fx [N]" in header and "block.Mz [N mm]" in header
    assert [float(r[0]) for r in values] == [0.0, 0.5, 1.0, 1.5, 2.0]
    ref = flexmb.sweep(flexmb.load(stage_file), np.linspace(0, 2, 5), motion=("block", "x"), progress=False)
    k = header.index("block.Fx [N]")
    assert [float(r[k]) for r in values] == ref.table()["block.Fx"].tolist()


def test_properties_of_a_file_sweep_as_json(stage_file, capsys):
    assert cli.main(["solve", str(stage_file), "--sweep", "block.x=0,1", "--properties", "modes,stress",
                     "--n-modes", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["column_units"]["f1"] == "Hz" and out["column_units"]["von_mises"] == "MPa"
    assert len(out["columns"]["f1"]) == 2 and out["columns"]["f1"][0] > 0


def test_trace_a_file(tmp_path, capsys):
    m = flexmb.models.cantilever(elements=4)
    m.apply_force("tip", (0.0, -20.0))
    path = flexmb.save(m, tmp_path / "c.json")
    assert cli.main(["solve", str(path), "--trace", "--steps", "6", "--csv"]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    assert "load_factor" in rows[0] and "tip.y [m]" in rows[0] and len(rows) > 2


@pytest.mark.parametrize("argv, message", [
    (["--sweep", "block.x"], "expected LINK.COMPONENT=START:STOP:N"),
    (["--sweep", "block.x=0:1:x"], "expected LINK.COMPONENT"),
    (["--properties", "colour"], "unknown colour"),
    (["--param", "a=1"], "--param sets a ready-made model's parameters"),
    (["--sweep", "block.x=0,1", "--trace"], "give one"),
])
def test_bad_file_options_are_usage_errors(stage_file, capsys, argv, message):
    assert cli.main(["solve", str(stage_file), *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_file_options_on_a_ready_made_model_are_usage_errors(capsys):
    assert cli.main(["solve", "cantilever", "--csv"]) == 2
    assert "take a mechanism file" in capsys.readouterr().err


def test_run_puts_the_scripts_folder_on_the_import_path(tmp_path, capsys):
    import sys

    (tmp_path / "helper_for_flexmb_run.py").write_text("VALUE = 42\n")
    script = tmp_path / "main.py"
    script.write_text("import helper_for_flexmb_run\nprint('value', helper_for_flexmb_run.VALUE)\n")
    before = list(sys.path)
    try:
        assert cli.main(["run", str(script)]) == 0
    finally:
        sys.modules.pop("helper_for_flexmb_run", None)
    assert "value 42" in capsys.readouterr().out
    assert sys.path == before  # restored


def test_a_misspelt_model_parameter_is_named_with_the_model_and_the_closest_name(capsys):
    assert cli.main(["solve", "fourbar", "--param", "displacment=0.2"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "solve fourbar: unknown parameter 'displacment'; did you mean 'displacement'?" in err
