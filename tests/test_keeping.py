"""Sweeps keep every value and tables never overwrite (issue 20, classes 2 and 3)."""

import numpy as np
import pytest

import flexmb
from flexmb import ModelError, ParameterError, models
from flexmb.sweeps import iter_sweep


def _pivot():
    return models.cross_flexure_pivot(elements_per_leaf=2, dim=2)


ANGLES = [0.2, 0.4, 1.4, 0.6]  # 1.4 rad: 80 deg, outside the shipped database's +-75 deg


@pytest.mark.parametrize("run", [flexmb.sweep, lambda *a, **k: list(iter_sweep(*a, **k))],
                         ids=["sweep", "iter_sweep"])
def test_a_value_the_strategy_refuses_is_kept_with_the_reason_and_the_others_solve(run):
    """The issue's reproducer: one DatabaseError and the sweep returned nothing."""
    result = run(_pivot(), ANGLES, motion=("B", "rotation"), method="ksd-full")
    assert [s.converged for s in result] == [True, True, False, True]
    assert "at [1.4]: DatabaseError" in result[2].message and "trained range" in result[2].message
    assert np.isnan(result[2].reaction("B")).all() and np.isnan(result[2].node_positions()).all()
    # the values around it: the conventional answer (KSD-full converges to it, Dwarshuis et al. 2020 step 5)
    for sol, theta in zip([result[0], result[1], result[3]], [0.2, 0.4, 0.6]):
        m = _pivot()
        m.prescribe("B", rotation=theta)
        np.testing.assert_allclose(sol.reaction("B"), flexmb.solve(m).reaction("B"), rtol=0, atol=1e-6)


def test_a_sweep_table_shows_a_refused_value_as_nan_not_as_a_number():
    table = flexmb.sweep(_pivot(), ANGLES, motion=("B", "rotation"), method="ksd-full").table()
    np.testing.assert_array_equal(table["converged"], [True, True, False, True])
    assert np.isnan(table["B.Mz"][2]) and np.isnan(table["B.rotation#2"][2])
    np.testing.assert_array_equal(table["B.rotation"], ANGLES)  # the swept values, all of them


def test_ksd_step_one_failure_is_a_non_converged_solution_not_an_exception():
    """The issue's reproducer raised ConvergenceError without raise_on_failure."""
    sol = flexmb.solve(models.fourbar(elements_per_leaf=1, displacement=0.5), method="ksd-full")
    assert not sol.converged and "KSD step 1" in sol.message
    with pytest.raises(flexmb.ConvergenceError, match="KSD step 1") as info:
        flexmb.solve(models.fourbar(elements_per_leaf=1, displacement=0.5), method="ksd-full", raise_on_failure=True)
    assert info.value.solution is not None and not info.value.solution.converged


def test_a_swept_displacement_keeps_its_column_next_to_the_links_position():
    """The issue: ``table()["tip.x"]`` held the link's absolute position, not the swept x."""
    m = models.cantilever(dim=2)
    m.prescribe("tip", x=0.0)
    table = flexmb.sweep(m, [-1e-4, -2e-4], motion=("tip", "x")).table()
    np.testing.assert_array_equal(table["tip.x"], [-1e-4, -2e-4])
    # the link's position: its reference point 0.1 m (cantilever's default length) plus the motion
    np.testing.assert_allclose(table["tip.x#2"], [0.1 - 1e-4, 0.1 - 2e-4], rtol=0, atol=1e-15)


def test_a_point_named_like_a_link_does_not_replace_the_links_columns():
    m = _pivot()
    m.add_point("B", "A", m.link("B").position + np.array([0.0, 0.01]))  # a point called like link A
    m.prescribe("B", rotation=0.0)
    result = flexmb.sweep(m, [0.1], motion=("B", "rotation"))
    table = result.table(points=["A"])
    assert table["A.x"][0] == 0.0 and table["A.y"][0] == 0.0  # the fixed link A stays at the origin
    np.testing.assert_array_equal([table["A.x#2"][0], table["A.y#2"][0]], result[0].point("B", "A"))


def test_adding_a_point_twice_is_refused_not_a_silent_replacement():
    m = _pivot()
    m.add_point("B", "P", (0.0, 0.01))
    with pytest.raises(ModelError, match="a point named 'P' exists already"):
        m.add_point("A", "P", (0.0, 0.0))
    assert m.points["P"][0] == "B"


def test_table_refuses_two_names_with_the_same_text():
    with pytest.raises(ParameterError, match="two columns are named '1'"):
        flexmb.Table({1: [1.0], "1": [2.0]})


def test_csv_keeps_text_that_looks_like_a_number_as_text(tmp_path):
    table = flexmb.Table({"code": np.array(["007", "+7", "1_000", " 7"], dtype=object), "n": [7, -7, 0, 10],
                          "f": [0.25, 1e-05, float("nan"), -float("inf")]})
    back = flexmb.read_csv(table.to_csv(tmp_path / "t.csv"))
    assert list(back["code"]) == ["007", "+7", "1_000", " 7"]
    assert back["n"].dtype.kind == "i" and list(back["n"]) == [7, -7, 0, 10]
    np.testing.assert_array_equal(back["f"], table["f"])
