"""Parameter studies never lose work (issue 20, class 2): one row per design, in order, with its
outputs or its error record, whatever a design, a worker, a clock or Ctrl-C does; the same
serially, on the embedded process pool and on a dask LocalCluster (loopback only).

The fault-injection designs below are module-level functions, so worker processes can import them.
"""

import os
import signal
import time

import numpy as np
import pytest

import flexmb
from flexmb import ParameterError
from flexmb.study import StudyError, StudyInterrupted, parameter_study


def design(x, fault=None, pid=None):
    """``{"y": 2 x}``, or the fault asked for."""
    if fault == "raise":
        raise ValueError(f"bad design x={x}")
    if fault == "kill":
        os.kill(os.getpid(), signal.SIGKILL)  # the worker dies mid-design
    if fault == "hang":
        time.sleep(30)
    if fault == "interrupt":
        time.sleep(1.0)  # the designs before it are done
        os.kill(pid, signal.SIGINT)  # Ctrl-C in the process that runs the study
        time.sleep(30)
    if fault == "slow":
        time.sleep(1.0)
    return {"y": 2.0 * x}


FAULTS = [None, "raise", None, "kill", None, "hang", None, None]
DESIGNS = [{"x": float(i), "fault": f} for i, f in enumerate(FAULTS)]
EXPECTED = {"raise": "ValueError: bad design x=1.0", "kill": None, "hang": "TimeoutError"}


def _check_every_design_kept_or_named(table, killed: str):
    """Rows in design order; finished designs have y = 2 x and no error; failed ones NaN and their error."""
    np.testing.assert_array_equal(table["x"], [d["x"] for d in DESIGNS])
    for i, fault in enumerate(FAULTS):
        if fault is None:
            assert table["error"][i] == "" and table["y"][i] == 2.0 * i, (i, table["error"][i])
        else:
            assert np.isnan(table["y"][i])
            assert table["error"][i].startswith(EXPECTED[fault] or killed), (fault, table["error"][i])


def test_the_issue_reproducer_keeps_the_other_designs():
    """The issue: a bare ZeroDivisionError and nothing returned."""
    table = parameter_study(lambda x: 1 / x, [{"x": 1.0}, {"x": 0.0}, {"x": 2.0}], executor="serial")
    np.testing.assert_array_equal(table["value"], [1.0, np.nan, 0.5])
    assert list(table["error"]) == ["", "ZeroDivisionError: float division by zero", ""]


def test_on_error_raise_names_the_design_and_carries_what_finished():
    with pytest.raises(StudyError, match=r"design 1 \{'x': 0.0\} failed: ZeroDivisionError") as info:
        parameter_study(lambda x: 1 / x, [{"x": 1.0}, {"x": 0.0}, {"x": 2.0}], executor="serial", on_error="raise")
    assert info.value.index == 1 and info.value.design == {"x": 0.0}
    assert info.value.table["value"][0] == 1.0 and "cancelled" in info.value.table["error"][2]


def test_a_serial_design_over_its_timeout_is_stopped_and_the_study_goes_on():
    t0 = time.perf_counter()
    table = parameter_study(design, [{"x": 0.0}, {"x": 1.0, "fault": "hang"}, {"x": 2.0}], executor="serial",
                            timeout=0.5)
    assert time.perf_counter() - t0 < 20  # the hung design sleeps 30 s
    assert table["error"][1].startswith("TimeoutError") and list(table["y"][[0, 2]]) == [0.0, 4.0]


@pytest.mark.slow
def test_a_process_pool_keeps_every_finished_design_through_an_error_a_kill_and_a_timeout():
    table = parameter_study(design, DESIGNS, max_workers=2, timeout=3.0)
    _check_every_design_kept_or_named(table, killed="BrokenProcessPool")


@pytest.mark.slow
def test_a_dask_local_cluster_keeps_every_finished_design_through_an_error_a_kill_and_a_timeout():
    distributed = pytest.importorskip("distributed")
    import dask

    # one task per worker thread and one retry of a task whose worker died (dask's default: 3):
    # the killer is named after two deaths; a design that only shared a dying worker is rerun
    with dask.config.set({"distributed.scheduler.allowed-failures": 1,
                          "distributed.scheduler.worker-saturation": 1.0}):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                           dashboard_address=None)
        with cluster, distributed.Client(cluster) as client:
            table = parameter_study(design, DESIGNS, executor=client.get_executor(), timeout=3.0)
    _check_every_design_kept_or_named(table, killed="KilledWorker")


def _interrupted(**kw):
    designs = ([{"x": 0.0}, {"x": 1.0}] + [{"x": 2.0, "fault": "interrupt", "pid": os.getpid()}]
               + [{"x": float(i), "fault": "slow"} for i in range(3, 13)])
    t0 = time.perf_counter()
    with pytest.raises(StudyInterrupted) as info:
        parameter_study(design, designs, **kw)
    elapsed = time.perf_counter() - t0
    table = info.value.table
    assert isinstance(info.value, KeyboardInterrupt)
    assert table.n_rows == len(designs)
    for i, (y, err) in enumerate(zip(table["y"], table["error"])):  # finished: its result; else named
        assert (err == "" and y == 2.0 * designs[i]["x"]) or (err != "" and np.isnan(y)), (i, err)
    return table, elapsed


@pytest.mark.slow
def test_ctrl_c_in_a_process_pool_returns_what_finished_and_cancels_the_queue():
    table, elapsed = _interrupted(max_workers=2)
    assert list(table["error"][:2]) == ["", ""]
    # the queue (10 designs of 1 s on 2 workers: 5 s) is cancelled, not waited for
    assert sum(e.startswith("cancelled") for e in table["error"]) >= 8 and elapsed < 5.0


@pytest.mark.slow
def test_ctrl_c_on_a_dask_cluster_returns_what_finished_and_cancels_the_queue():
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address=None)
    with cluster, distributed.Client(cluster) as client:
        table, _ = _interrupted(executor=client.get_executor())
    assert sum(e.startswith("cancelled") for e in table["error"]) >= 7


def test_a_lambda_on_a_process_pool_is_refused_before_running_with_the_fix():
    with pytest.raises(ParameterError, match="module level.*functools.partial.*executor='serial'"):
        parameter_study(lambda x: x, [{"x": 1.0}])


def test_designs_may_be_a_generator():
    table = parameter_study(design, ({"x": float(i)} for i in range(3)), executor="serial")
    np.testing.assert_array_equal(table["y"], [0.0, 2.0, 4.0])


@pytest.mark.parametrize("workers", [-1, 0, 1.5, True, "2"])
def test_max_workers_must_be_a_positive_integer(workers):
    with pytest.raises(ParameterError, match="max_workers"):
        parameter_study(abs, [{"x": 1.0}], max_workers=workers)


@pytest.mark.parametrize("bad", [dict(on_error="ignore"), dict(timeout=0.0), dict(timeout=float("nan")),
                                 dict(timeout="1")])
def test_bad_fault_options_are_refused(bad):
    with pytest.raises(ParameterError, match=next(iter(bad))):
        parameter_study(abs, [{"x": 1.0}], executor="serial", **bad)


def test_an_output_named_like_an_input_in_any_row_is_refused_keeping_every_result():
    """The issue: the clash was checked on the first row only, and ``x`` was overwritten from row 2."""
    def f(x):
        return {"y": x} if x < 1 else {"y": x, "x": -x}

    with pytest.raises(ParameterError, match="names of inputs") as info:
        parameter_study(f, [{"x": 0.0}, {"x": 1.0}, {"x": 2.0}], executor="serial")
    table = info.value.table
    np.testing.assert_array_equal(table["x"], [0.0, 1.0, 2.0])  # the inputs as given
    np.testing.assert_array_equal(table["output.x"], [np.nan, -1.0, -2.0])


def test_a_non_scalar_output_is_an_error_record_of_its_design():
    table = parameter_study(lambda x: {"y": [x, x]} if x else {"y": 1.0}, [{"x": 0}, {"x": 1}], executor="serial")
    assert table["y"][0] == 1.0 and table["error"][1].startswith("ParameterError: output 'y'")


def test_the_study_table_round_trips_through_csv_with_its_error_records(tmp_path):
    table = parameter_study(lambda x: 1 / x, [{"x": 1.0}, {"x": 0.0}], executor="serial")
    back = flexmb.read_csv(table.to_csv(tmp_path / "study.csv"))
    assert list(back["error"]) == list(table["error"])
    np.testing.assert_array_equal(back["value"], table["value"])
