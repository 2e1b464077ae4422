"""The small reproducers of issue 32 (items 4, 5, 7, 8), each failing before its fix."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import cli, models

ROOT = Path(__file__).resolve().parents[1]


def test_a_cantilever_in_tension_does_not_buckle():
    """``buckling`` of a cantilever pulled along its axis returned [1.17e18] (-1/mu of a round-off
    mu = -3.9e-19 beside 0.012); the documentation says inf where no positive multiplier exists.
    Pushed, the same cantilever buckles at the Euler load: pi^2 EI / (4 L^2) = 82.25 N for the
    0.1 x 0.02 x 0.001 m steel leaf (multiplier 82.3 of 1 N, 16 elements)."""
    for force, expected in ((1.0, np.inf), (-1.0, np.pi**2 * 200e9 * 0.02 * 0.001**3 / 12 / (4 * 0.1**2))):
        m = models.cantilever(dim=2, elements=16)
        m.apply_force("tip", (force, 0.0))
        lam = flexmb.buckling(flexmb.solve(m), n_buckling=1)
        if np.isinf(expected):
            assert np.all(np.isinf(lam))
        else:
            assert lam[0] == pytest.approx(expected, rel=2e-3)
    m = models.cantilever(dim=3, elements=16)
    m.apply_force("tip", (1000.0, 0.0, 0.0))
    assert np.all(np.isinf(flexmb.buckling(flexmb.solve(m), n_buckling=3)))


def _leaf_at(x: float):
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True, position=(x, 0.0))
    m.add_link("tip", position=(x + 0.1, 0.0))
    m.add_joint("ground", "tip", flexmb.LeafSpring(), name="leaf")
    m.apply_force("tip", (0.0, 1.0))
    return m


def test_a_leaf_far_from_the_origin_says_that_the_absolute_coordinates_round_off():
    """A 0.1 m leaf 300 m from the origin stopped with "step halved below min_step" and no cause:
    the round-off of its absolute coordinates (eps 300 m = 6.7e-14 m) is a sizeable part of its
    deformation. The message now says so; at the origin the same leaf converges, no such words."""
    with pytest.warns(flexmb.ConvergenceWarning):
        far = flexmb.solve(_leaf_at(300.0))
    assert not far.converged
    assert "300 (length units) from the origin, 3e+03 times its own size" in far.message
    assert "round-off of its absolute coordinates" in far.message and "near the origin" in far.message
    near = flexmb.solve(_leaf_at(0.0))
    assert near.converged and "origin" not in near.message


def test_a_training_step_that_needs_terabytes_is_a_usage_error(tmp_path, capsys):
    """``flexmb train --dim 2 --elements 1 --step 1e-9 --out x``: a traceback (_ArrayMemoryError,
    1.09 TiB for 1.5e11 samples); now exit 2 and one line, nothing trained."""
    assert cli.main(["train", "--dim", "2", "--elements", "1", "--step", "1e-9", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--step 1e-09: 1.5e+11 training runs over [-75, 75] deg" in err
    assert not list((tmp_path / "x").glob("*.json")) if (tmp_path / "x").exists() else True


@pytest.mark.slow
def test_json_output_to_a_full_disk_ends_with_one_line():
    """``flexmb solve fourbar --json > /dev/full``: an OSError traceback; now exit 1 and one line."""
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    with open("/dev/full", "w") as full:
        run = subprocess.run([sys.executable, "-m", "flexmb.cli", "solve", "fourbar", "--json"], stdout=full,
                             stderr=subprocess.PIPE, env=env, timeout=300, text=True)
    assert run.returncode == 1
    assert run.stderr == "flexmb: error: cannot write the output: No space left on device\n"


def test_a_parameter_given_twice_is_refused(capsys):
    """``--param rotation=0.3 --param rotation=0.6`` silently took the last value."""
    assert cli.main(["solve", "cross_flexure", "--param", "rotation=0.3", "--param", "rotation=0.6"]) == 2
    err = capsys.readouterr().err
    assert "--param rotation is given twice (rotation=0.3 and rotation=0.6)" in err and err.count("\n") == 1
    assert cli.main(["solve", "cross_flexure", "--option", "tol=1e-9", "--option", "tol=1e-8"]) == 2


def test_text_columns_holding_numbers_or_booleans_come_back_as_text(tmp_path):
    """A text column holding '1', '2' or 'True' read back as numbers or booleans ('007' already
    survived); numbers, booleans and other text keep their types."""
    table = flexmb.Table({"label": ["1", "2", "True"], "flag": ["True", "False", "True"], "n": [1, 2, 3],
                          "ok": [True, False, True], "x": [0.1, np.nan, -np.inf], "name": ["a,b", 'say "x"', "ä"]})
    back = flexmb.read_csv(table.to_csv(tmp_path / "t.csv"))
    assert back["label"].tolist() == ["1", "2", "True"] and back["flag"].tolist() == ["True", "False", "True"]
    assert all(isinstance(v, str) for v in back["label"].tolist() + back["flag"].tolist())
    assert back["n"].dtype.kind == "i" and back["ok"].dtype.kind == "b" and back["x"].dtype.kind == "f"
    np.testing.assert_array_equal(back["x"], table["x"])
    assert back["name"].tolist() == ["a,b", 'say "x"', "ä"]


@pytest.mark.slow
def test_to_csv_writes_utf_8_whatever_the_locale(tmp_path):
    """``to_csv`` wrote in the locale's encoding while ``read_csv`` reads UTF-8: under the C locale
    (ASCII, UTF-8 mode and locale coercion off) writing 'ä' failed; under Latin-1 it was written
    and could not be read back."""
    script = ("import flexmb, sys\n"  # ASCII source: the C locale cannot pass other text to -c
              "flexmb.Table({'name': ['\\u00e4', '\\u00b5N', '\\u2192']}).to_csv(sys.argv[1])\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONIOENCODING": "latin-1", "LC_ALL": "C", "LANG": "C",
           "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
    path = tmp_path / "t.csv"
    subprocess.run([sys.executable, "-X", "utf8=0", "-c", script, str(path)], env=env, check=True, timeout=300)
    assert path.read_bytes().decode("utf-8").splitlines()[1:] == ['"ä"', '"µN"', '"→"']
    assert flexmb.read_csv(path)["name"].tolist() == ["ä", "µN", "→"]
