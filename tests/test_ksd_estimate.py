"""KSD-reduced's a-posteriori error estimate (issue 32, `flexmb.ksd.estimate`).

The reference for every true error is the conventional method on the same mechanism (the full
finite-element model KSD approximates, Dwarshuis et al. 2020 Sec. 2), converged to 1e-9 of the
force scale."""

import json
import warnings

import numpy as np
import pytest

import flexmb
from flexmb import models
from flexmb.errors import AccuracyError, AccuracyWarning, ParameterError
from flexmb.ksd.estimate import ErrorEstimate
from flexmb.studies import ksd_accuracy as accuracy


def _issue_pivot(dim=3):
    """The issue's reproducer: the Table 1 cross flexure turned 0.5 rad, 3000 N compressing B."""
    m = models.cross_flexure_pivot(rotation=0.5, dim=dim)
    m.apply_force("B", (0.0, -3000.0) + ((0.0,) if dim == 3 else ()))
    return m


def test_the_issues_pivot_under_3000_n_warns_with_an_honest_estimate():
    """KSD-reduced answered -10.36 N m where the conventional method gives -38.39 N m (73 % off),
    converged and without a word; now it warns, and its estimate is that error (within 3x)."""
    m = _issue_pivot()
    with pytest.warns(AccuracyWarning, match=r"estimated error .* above error_tol=0.01.*cross_flexure-3d"):
        sol = flexmb.solve(m, method="ksd-reduced")
    assert sol.converged and sol.reaction("B")[5] == pytest.approx(-10.355, abs=1e-3)
    est = sol.stages["estimate"]
    assert isinstance(est, ErrorEstimate) and est.exceeded and est.tolerance == 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = flexmb.solve(m, method="conventional")
    assert ref.reaction("B")[5] == pytest.approx(-38.389, abs=1e-3)
    moment_error = abs(sol.reaction("B")[5] - ref.reaction("B")[5]) / abs(ref.reaction("B")[5])  # 0.730
    assert moment_error / 3 <= est.reaction <= 3 * moment_error
    assert est.moment == pytest.approx(abs(sol.reaction("B")[5] - ref.reaction("B")[5]), rel=0.2)  # 28.0 N m
    motion, reaction = accuracy.true_error(sol, ref)
    assert max(motion, reaction) / 3 <= est.relative <= 3 * max(motion, reaction)


def test_strict_error_refuses_naming_the_estimate_and_the_database_file():
    with pytest.raises(AccuracyError, match=r"estimated error [0-9.]+ % .* above error_tol=0.01: .*data: .*cross_flexure-3d-"
                                            r"angle0.785398-elements_per_leaf3.json") as info:
        flexmb.solve(_issue_pivot(), method="ksd-reduced", strict_error=True)
    assert info.value.solution is not None and info.value.solution.converged


def test_a_tolerance_set_by_the_user_decides_and_none_switches_the_estimate_off():
    m = _issue_pivot(dim=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning at all
        quiet = flexmb.solve(m, method="ksd-reduced", error_tol=1.0)  # 69 % < 100 %
        off = flexmb.solve(m, method="ksd-reduced", error_tol=None)
    assert not quiet.stages["estimate"].exceeded and quiet.stages["estimate"].tolerance == 1.0
    assert "estimate" not in off.stages
    np.testing.assert_array_equal(quiet.state.positions, off.state.positions)  # the answer itself unchanged
    for bad in (0.0, -0.01, float("nan"), "1%"):
        with pytest.raises(ParameterError, match="error_tol"):
            flexmb.solve(m, method="ksd-reduced", error_tol=bad)


def test_the_paper_cases_within_their_assumptions_do_not_warn():
    """The four-bar at d = 0.3 m (Sec. 4.3) and the manipulator's joint case (Sec. 4.4): KSD-reduced
    is within 0.34 % and 2e-6 of the conventional method (BENCHMARKS.md); no warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        for m in (models.fourbar(displacement=0.3), models.manipulator(rotation=0.6)):
            sol = flexmb.solve(m, method="ksd-reduced")
            assert sol.stages["estimate"].relative < 0.005



@pytest.mark.slow  # the process's first placed manipulator builds its EOB force tables (3.4 s CPU)
def test_a_placed_manipulator_at_rest_is_not_judged_on_its_fit_error():
    """The optimisation's manipulator (`flexmb.studies.optimization.manipulator`, placements of its
    own) at 0 deg: KSD-reduced's links sit 2.5e-11 rad off rest, the shipped kinematics' fit error
    (the fit residuals `flexmb train` prints), which read 2.5 % of the former 1e-9 floor and warned
    on every design of the loop; a motion below `MOTION_FLOOR` (1e-7 rad, 1 nm over 10 mm) is no
    error of the design. The turned configuration is still judged against its own motion."""
    from flexmb.ksd.estimate import MOTION_FLOOR
    from flexmb.studies import optimization

    problem = optimization.manipulator(quick=True)
    estimates = []
    for turn in (0.0, np.radians(30.0)):
        m = problem.build(problem.p0)
        optimization.manipulator_configure(m, turn)
        with warnings.catch_warnings():
            warnings.simplefilter("error", AccuracyWarning)
            estimates.append(flexmb.solve(m, method="ksd-reduced").stages["estimate"])
    rest, turned = estimates
    assert 1e-13 < rest.rotation < 1e-9 and rest.motion < 1e-3  # 2.5e-11 rad over the 1e-7 floor
    assert turned.relative < 0.01 and turned.rotation > MOTION_FLOOR  # 1.3e-5 rad of a 0.5 rad turn

SELECTED = ("pivot 3D, 0.5 rad, 0 N", "pivot 3D, 0.5 rad, 200 N", "pivot 3D, 0.5 rad, 300 N compression",
            "pivot 3D, 0.5 rad, 3000 N compression", "pivot 3D, 0.5 rad, 1000 N across", "pivot 2D, 0.5 rad, 1000 N",
            "four-bar d = 0.3 m", "four-bar d = 0.2 m, 1000 N", "manipulator joints 0.6 rad",
            "manipulator joints 0.6 rad, 30 N", "manipulator end point where joints at -45 deg")


@pytest.mark.parametrize("label", SELECTED)
def test_estimate_within_a_factor_3_and_the_warning_exactly_above_the_tolerance(label):
    """Cases of `flexmb.studies.ksd_accuracy` (the whole table: benchmarks/bench_estimate.py, 31 of 31),
    chosen to straddle the 1 % tolerance: 0.78 % (200 N), 1.08 % (four-bar, 1000 N), 1.84 %
    (manipulator, 30 N) among them, and the manipulator's location case at -45 deg, where one
    correction overestimated 4x; the estimate within a factor 3 of the true error (both below
    `accuracy.RESOLUTION`, the reference's round-off, agreeing) and the warning where the truth
    exceeds the tolerance, and only there."""
    build, _ = accuracy.cases()[next(k for k in accuracy.cases() if k.startswith(label))]
    row = accuracy.compare(build)
    assert row["converged"]
    assert accuracy.agrees(row), row


def test_ksd_full_records_the_estimate_of_its_start_and_never_warns():
    """KSD-full converges to the conventional answer; the estimate is that of its step 1-4 start
    (KSD-reduced's answer), the same as KSD-reduced reports."""
    m = _issue_pivot()
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        full = flexmb.solve(m, method="ksd-full")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        reduced = flexmb.solve(m, method="ksd-reduced")
    assert full.converged and full.reaction("B")[5] == pytest.approx(-38.389, abs=1e-3)
    assert full.stages["estimate"].relative == pytest.approx(reduced.stages["estimate"].relative, rel=1e-6)


def test_flexmb_solve_json_prints_the_estimate_and_the_database_files(capsys):
    from flexmb import cli

    assert cli.main(["solve", "fourbar", "--method", "ksd-reduced", "--param", "displacement=0.1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    est = report["error_estimate"]
    assert est["relative"] < 0.01 and est["exceeded"] is False and est["tolerance"] == 0.01
    assert set(report["database"]) == {"bottom_left", "bottom_right", "top_left", "top_right"}
    for entry in report["database"].values():
        assert entry["source"] == "shipped" and entry["path"].endswith("cross_flexure-3d-angle0.785398-elements_per_leaf3.json")
