"""The `flexmb` command and the example script (scikit-fem style: examples are tests too)."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from flexmb import cli

ROOT = Path(__file__).resolve().parents[1]


def test_demo_prints_the_table_and_exits_zero(tmp_path, capsys):
    assert cli.main(["demo", "--quick", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "theta [deg]" in out and "reference" in out and "75 |" in out
    assert "partial NL (closed form)               77.035" in out  # gripper closing force, flexmb's value
    if importlib.util.find_spec("matplotlib"):
        assert (tmp_path / "cross_flexure.png").stat().st_size > 10_000  # a real figure, not an empty file
        assert (tmp_path / "gripper_models.png").stat().st_size > 10_000


def test_joints_lists_the_shipped_plugins(capsys):
    assert cli.main(["joints"]) == 0
    out = capsys.readouterr().out
    assert "cross_flexure" in out and "leaf_spring" in out and "elements_per_leaf = 3" in out


def test_errors_are_one_line_with_exit_code_1(monkeypatch, capsys):
    import flexmb.demo

    def broken(*a, **k):
        flexmb.models.cross_flexure_pivot(rotation=float("nan"))

    monkeypatch.setattr(flexmb.demo, "cross_flexure_curve", broken)
    assert cli.main(["demo", "--quick"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("flexmb: error:") and err.count("\n") == 1 and "rotation" in err


def test_usage_error_exits_2():
    with pytest.raises(SystemExit) as exc:
        cli.main(["no-such-command"])
    assert exc.value.code == 2


@pytest.mark.slow
def test_cross_flexure_example_runs_and_converges_with_elements():
    spec = importlib.util.spec_from_file_location("ex_cross_flexure", ROOT / "examples" / "cross_flexure.py")
    ex = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ex)
    curves, reference = ex.run(dim=2)
    at75 = [curves[n][0][-1] for n in ex.ELEMENTS]
    assert all(a > b for a, b in zip(at75, at75[1:]))  # monotone towards the reference with more elements
    assert np.all(at75 > reference[-1])
    assert abs(at75[-1] / reference[-1] - 1) < 0.01  # 5 el./leaf within 1 % (measured +0.88 %) at 75 deg


@pytest.mark.slow
def test_gripper_example_prints_the_study_and_saves_its_figures(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    spec = importlib.util.spec_from_file_location("ex_gripper", ROOT / "examples" / "gripper.py")
    ex = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ex)
    res = ex.main(tmp_path, quick=True)
    out = capsys.readouterr().out
    for table in ("Table 2", "Table 3", "Table 4", "Table 5", "Table 6", "Table 7", "constant tangent converges up to"):
        assert table in out
    c = res["closing"]
    assert c["silicon"]["linear"] < c["silicon"]["fe"] < c["silicon"]["partial-nonlinear"]
    assert c["nylon"]["fe"] == pytest.approx(0.0384 * c["silicon"]["fe"], rel=1e-6)  # F / E is the only parameter
    for name in ("workspace", "models", "strategies", "cross_section"):
        assert (tmp_path / f"gripper_{name}.png").stat().st_size > 10_000
