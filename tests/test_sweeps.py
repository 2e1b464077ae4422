"""Motion sweeps (warm-started continuation), results as arrays and CSV, and parameter studies
through executors: serial, a local process pool and a dask LocalCluster give the same numbers."""

import functools

import numpy as np
import pytest

import flexmb
from flexmb import models
from flexmb.errors import ModelError, ParameterError
from flexmb.joint_characteristics import joint_characteristics
from flexmb.study import grid, parameter_study
from flexmb.table import Table, read_csv

ANGLES = np.radians([10.0, 25.0, 40.0, 55.0, 70.0])


def _pivot(dim, rotation=0.0):
    return models.cross_flexure_pivot(elements_per_leaf=3, dim=dim, rotation=rotation)


def _rotations(dim):
    return ANGLES if dim == 2 else np.outer(ANGLES, [0.0, 0.0, 1.0])


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("start", ["previous", "undeformed"])
def test_motion_sweep_equals_one_solve_per_value(dim, start):
    """Reference: one independent conventional solve per rotation (same equations, same tol)."""
    result = flexmb.sweep(_pivot(dim), _rotations(dim), motion=("B", "rotation"), start=start)
    assert len(result) == len(ANGLES) and result.converged.all()
    for sol, theta in zip(result, ANGLES):
        ref = flexmb.solve(_pivot(dim, theta))
        np.testing.assert_allclose(sol.node_positions(), ref.node_positions(), rtol=0, atol=1e-10)
        # both within the residual tolerance 5e-7 N m of the same equilibrium
        np.testing.assert_allclose(sol.reaction("B"), ref.reaction("B"), rtol=0, atol=1e-6)
        assert sol.rotation_vector("B")[-1] == pytest.approx(theta, abs=1e-14)  # prescribed exactly


def test_warm_start_takes_fewer_iterations_than_cold_starts():
    """Continuation: each solve starts 15 deg from its answer instead of 10-70 deg (measured: 37 vs 59 iterations)."""
    warm = flexmb.sweep(_pivot(2), ANGLES, motion=("B", "rotation"), start="previous")
    cold = flexmb.sweep(_pivot(2), ANGLES, motion=("B", "rotation"), start="undeformed")
    assert sum(s.iterations for s in warm) < sum(s.iterations for s in cold)


def test_ksd_motion_sweep_matches_the_full_model():
    """KSD-full converges to the conventional equilibrium (Dwarshuis et al. 2020, step 5)."""
    ksd = flexmb.sweep(_pivot(3), _rotations(3), motion=("B", "rotation"), method="ksd-full")
    conv = flexmb.sweep(_pivot(3), _rotations(3), motion=("B", "rotation"))
    for a, b in zip(ksd, conv):
        np.testing.assert_allclose(a.node_positions(), b.node_positions(), rtol=0, atol=1e-9)


def test_sweep_table_holds_the_solutions_numbers_and_round_trips_through_csv(tmp_path):
    result = flexmb.sweep(_pivot(2), ANGLES, motion=("B", "rotation"))
    table = result.table()
    assert table.n_rows == len(ANGLES)
    np.testing.assert_allclose(table["B.rotation"], ANGLES, rtol=0, atol=1e-15)  # summed increments: roundoff
    np.testing.assert_array_equal(table["B.Mz"], [s.reaction("B")[2] for s in result])
    np.testing.assert_array_equal(table["B.x"], [s.pose("B")[0][0] for s in result])
    np.testing.assert_array_equal(table["iterations"], [s.iterations for s in result])
    back = read_csv(result.to_csv(tmp_path / "sweep.csv"))
    assert list(back) == list(table)
    for name in table:
        np.testing.assert_array_equal(back[name], table[name])  # repr() of floats: exact


def test_force_sweep_table_names_the_force_column():
    m = models.gripper()
    result = flexmb.sweep(m, [0.0, 20.0, 40.0], method="newton")
    table = result.table(links=["body4"], points=["end_effector"] if "end_effector" in
                         result[0].compiled.points else ())
    np.testing.assert_array_equal(table["force"], [0.0, 20.0, 40.0])
    assert "body4.rotation" in table and "body1.x" not in table


def test_sweep_results_drop_into_pandas():
    pd = pytest.importorskip("pandas")
    result = flexmb.sweep(_pivot(2), ANGLES[:2], motion=("B", "rotation"))
    frame = result.table().to_pandas()  # pandas 3 builds a frame from a dict, not any mapping
    assert frame.shape[0] == 2 and frame["B.rotation"].tolist() == ANGLES[:2].tolist()
    assert pd.DataFrame(dict(result.table())).equals(frame)


@pytest.mark.parametrize("call, match", [
    (lambda m: flexmb.sweep(m, ANGLES, motion=("B", "spin")), "component one of x, y, z, rotation"),
    (lambda m: flexmb.sweep(m, ANGLES, motion=("C", "rotation")), "no link named 'C'"),
    (lambda m: flexmb.sweep(m, ANGLES, motion=("B", "x")), "x of link 'B' is not prescribed"),
    (lambda m: flexmb.sweep(m, ANGLES, motion=("B", "rotation")), r"shape \(n, 3\)"),
    (lambda m: flexmb.sweep(m, [[0, 0, np.nan]], motion=("B", "rotation")), "finite numbers"),
    (lambda m: flexmb.sweep(m, ANGLES), "no actuation"),
])
def test_bad_sweeps_name_what_is_wrong(call, match):
    with pytest.raises((ModelError, ParameterError), match=match):
        call(_pivot(3))


# -- tables ----------------------------------------------------------------------------------

def test_table_csv_round_trip_keeps_types_and_special_values(tmp_path):
    t = Table({"n": [1, 2, 3], "x": [0.1, np.nan, -np.inf], "ok": [True, False, True], "name": ["a", "b,c", "d"]})
    back = read_csv(t.to_csv(tmp_path / "t.csv"))
    np.testing.assert_array_equal(back["n"], [1, 2, 3])
    assert back["n"].dtype.kind == "i"
    np.testing.assert_array_equal(back["x"], [0.1, np.nan, -np.inf])
    assert back["ok"].tolist() == [True, False, True] and back["name"].tolist() == ["a", "b,c", "d"]


def test_table_rejects_ragged_columns_and_unknown_names():
    with pytest.raises(ParameterError, match="'b' has 1 rows"):
        Table({"a": [1, 2], "b": [1]})
    with pytest.raises(ModelError, match="no column 'c'"):
        Table({"a": [1]})["c"]


# -- parameter studies -------------------------------------------------------------------------

STIFFNESS = functools.partial(joint_characteristics, "cross_flexure", rotation=0.2, elements_per_leaf=2)
DESIGNS = grid(thickness=[0.2e-3, 0.3e-3], angle=[0.6, 0.9])


@pytest.fixture(scope="module")
def serial():
    return parameter_study(STIFFNESS, DESIGNS, executor="serial")


def test_grid_varies_the_last_name_fastest():
    assert grid(a=[1, 2], b=[3, 4]) == [{"a": 1, "b": 3}, {"a": 1, "b": 4}, {"a": 2, "b": 3}, {"a": 2, "b": 4}]


def test_study_rows_are_the_designs_in_order_with_their_outputs(serial):
    np.testing.assert_array_equal(serial["thickness"], [0.2e-3, 0.2e-3, 0.3e-3, 0.3e-3])
    np.testing.assert_array_equal(serial["angle"], [0.6, 0.9, 0.6, 0.9])
    one = joint_characteristics("cross_flexure", rotation=0.2, elements_per_leaf=2, thickness=0.3e-3, angle=0.9)
    assert serial["k_rotation"][3] == one["k_rotation"]
    # bending stiffness ~ t^3 (E I / L with I = w t^3 / 12): 1.5x thicker -> ~3.4x stiffer
    assert serial["k_rotation"][2] / serial["k_rotation"][0] == pytest.approx(1.5 ** 3, rel=0.02)


def test_study_in_a_process_pool_gives_the_serial_numbers(serial):
    pooled = parameter_study(STIFFNESS, DESIGNS, max_workers=2)
    for name in serial:
        np.testing.assert_array_equal(pooled[name], serial[name])


@pytest.mark.slow
def test_study_on_a_dask_local_cluster_gives_the_serial_numbers(serial):
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    with cluster, distributed.Client(cluster) as client:
        remote = parameter_study(STIFFNESS, DESIGNS, executor=client.get_executor())
    for name in serial:
        np.testing.assert_array_equal(remote[name], serial[name])


def test_study_rejects_bad_designs_and_executors():
    with pytest.raises(ParameterError, match="keyword dicts"):
        parameter_study(STIFFNESS, {"thickness": 1e-4})
    with pytest.raises(ParameterError, match="executor"):
        parameter_study(STIFFNESS, DESIGNS, executor="threads")
    with pytest.raises(ParameterError, match="names of inputs"):
        parameter_study(lambda k_rotation: {"k_rotation": 1.0}, [{"k_rotation": 1.0}], executor="serial")


def test_progress_bar_shows_on_request_and_stays_quiet_off_a_terminal(capsys):
    """tqdm writes to stderr; with progress=None it is disabled unless stderr is a terminal
    (pytest's captured stderr is not)."""
    flexmb.sweep(_pivot(2), ANGLES[:2], motion=("B", "rotation"))
    assert capsys.readouterr().err == ""
    flexmb.sweep(_pivot(2), ANGLES[:2], motion=("B", "rotation"), progress=True)
    assert "sweep:" in capsys.readouterr().err  # tqdm, "0/2 [...]"; cleared when done (leave=False)
    parameter_study(STIFFNESS, DESIGNS[:1], executor="serial", progress=True)
    assert "designs:" in capsys.readouterr().err


@pytest.mark.parametrize("method", ["ksd-reduced", "ksd-full"])
def test_ksd_motion_sweep_builds_its_set_up_once_and_equals_one_solve_per_value(method):
    """A KSD motion sweep moves one set-up (joint frames, templates, step 1's start) to each value
    (`ReducedMechanism.with_values`): the same numbers as an independent `flexmb.solve` of the
    mechanism prescribed to that value (the same arithmetic: to 1e-12 m), on a 3D manipulator
    whose end point is swept along x (its location case, Dwarshuis et al. 2020 Sec. 4.4, moved
    +-20 mm: no paper sweeps it)."""
    from flexmb.solvers.ksd import reduced_mechanism

    m = models.manipulator("location", np.radians(30))
    end = {k: v for k, v in m._prescribed["link3"].items() if k != "path"}  # the end point (its path led there)
    xs = end["x"] + np.array([-0.02, 0.0, 0.02])
    result = flexmb.sweep(m, xs, motion=("link3", "x"), method=method)
    assert result.converged.all()
    reds = [reduced_mechanism(sol.compiled) for sol in result]
    assert all(r.frames is reds[0].frames and r._templates is reds[0]._templates for r in reds)  # built once
    for r, sol, x in zip(reds, result, xs):  # each moved to its own value
        assert r.compiled is sol.compiled and np.array_equal(r.values, sol.compiled.problem.values)
        assert x in r.values
    for sol, x in zip(result, xs):
        ref_m = models.manipulator("location", np.radians(30))
        ref_m.prescribe("link3", **{**end, "x": float(x)})
        ref = flexmb.solve(ref_m, method=method)
        np.testing.assert_allclose(sol.node_positions(), ref.node_positions(), rtol=0, atol=1e-12)
        assert sol.iterations == ref.iterations
