"""Parameter studies: many independent designs evaluated through any `concurrent.futures.Executor`
(an embedded local process pool by default, ``dask.distributed`` for a cluster).

Nothing finished is lost: every design gets its row, its outputs or an error record, whatever
the other designs, the workers or the user's Ctrl-C do.
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import os
import pickle
import signal
import threading
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import Executor, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from . import _warnings
from ._validate import positive
from .errors import FlexmbError, ParameterError
from .table import Table, column

__all__ = ["grid", "parameter_study", "StudyError", "StudyInterrupted", "ON_ERROR", "ERROR_COLUMN", "joint_range",
           "CONVERGED_COLUMN", "WARNINGS_COLUMN"]

ON_ERROR = ("record", "raise")
#: The column holding each design's error record, ``""`` when the design finished
ERROR_COLUMN = "error"
#: The column saying whether each design finished and converged: False for a design with an
#: error, else its output ``converged`` where it returns one (e.g. `joint_range`), else True
CONVERGED_COLUMN = "converged"
#: The column of the warnings each design raised in its worker, ``"Category: message"`` joined by
#: ``" | "`` (``""``: none); recorded there, not printed
WARNINGS_COLUMN = "warnings"
#: Joins a design's warnings in `WARNINGS_COLUMN`
WARNING_SEPARATOR = _warnings.SEPARATOR


class StudyError(FlexmbError):
    """A design failed under ``on_error="raise"``. ``index`` and ``design`` name it; ``table``
    holds every design's row (finished ones with their outputs, the others with their error)."""

    def __init__(self, message: str, table: Table, index: int | None = None, design: dict | None = None):
        super().__init__(message)
        self.table, self.index, self.design = table, index, design


class StudyInterrupted(KeyboardInterrupt):
    """Ctrl-C during a study: queued designs were cancelled; ``table`` holds what finished (the
    other rows name their design and say ``"cancelled"``). A `KeyboardInterrupt`, so an
    ``except KeyboardInterrupt`` still stops the program."""

    def __init__(self, message: str, table: Table):
        super().__init__(message)
        self.table = table


def grid(**axes) -> list[dict]:
    """Every combination of the named 1-D value sequences, the last name varying fastest:
    ``grid(thickness=[1e-4, 2e-4], angle=[0.6, 0.8])`` -> four dicts."""
    arrays = {}
    for name, values in axes.items():
        try:
            a = np.atleast_1d(np.asarray(values, dtype=float)) if not isinstance(values, (str, bytes)) else None
        except (TypeError, ValueError):
            a = None
        if a is None or a.ndim != 1 or len(a) == 0:
            raise ParameterError(f"grid: {name} must be a non-empty 1-D sequence of numbers, got {values!r}")
        arrays[name] = a
    return [dict(zip(arrays, (float(x) for x in combo))) for combo in itertools.product(*arrays.values())]


def parameter_study(function, designs, *, executor: Executor | str | None = None, max_workers: int | None = None,
                    progress: bool | None = None, on_error: str = "record", timeout: float | None = None) -> Table:
    """Evaluate ``function(**design)`` for every design (keyword dicts, e.g. from `grid`) and
    collect the inputs and outputs as a `flexmb.table.Table`, one row per design in the given
    order, with the column ``"error"``: ``""`` for a design that finished, else its error record
    ``"<exception type>: <message>"`` (its outputs are then NaN; its inputs are in its row).

    ``function`` returns a mapping of scalars (its keys become columns; e.g.
    `flexmb.joint_characteristics.joint_characteristics`) or one scalar (column ``"value"``). Outputs named like
    an input or ``"error"`` are refused (`ParameterError`, carrying the whole table as
    ``exc.table`` with those outputs as ``"output.<name>"``).

    Two more columns: ``"converged"`` (`CONVERGED_COLUMN`: False for a design with an error, else
    the design's own ``converged`` output where it returns one, else True) and ``"warnings"``
    (`WARNINGS_COLUMN`): every warning the design raised in its worker (a `PlausibilityWarning` of
    an implausible strain, a `ConvergenceWarning` ...), recorded there instead of printed, with
    the design's own ``warnings`` output where it returns one; ``""`` when none.

    ``executor``: None runs an embedded ``ProcessPoolExecutor`` (``max_workers`` >= 1, default
    the CPU count) and shuts it down; ``"serial"`` runs in this process; any other
    `concurrent.futures.Executor` is used as given and left running, e.g. a dask cluster's
    ``distributed.Client(...).get_executor()``. A process pool needs a picklable ``function``
    (a module-level function or a ``functools.partial`` of one; a lambda is refused before any
    design runs); dask pickles lambdas too.

    Faults: ``on_error="record"`` (default) records a failing design and runs the others;
    ``"raise"`` stops at the first failure with a `StudyError` naming the design and carrying
    the table. ``timeout`` [s]: a design still running that long after it started is stopped
    (``TimeoutError`` in its row; in a dask worker thread it is abandoned, not stopped). A
    worker process that dies (killed, crashed) breaks the embedded pool: the designs it held are
    rerun one at a time in a fresh pool, and one that kills its worker again is recorded as
    ``BrokenProcessPool`` (dask retries on other workers, then records ``KilledWorker``).
    Ctrl-C cancels the queued designs, stops the embedded pool's workers and raises
    `StudyInterrupted` carrying the table of what finished. ``progress``: a progress bar on
    stderr (None = only on a terminal).
    """
    from tqdm.auto import tqdm

    if not callable(function):
        raise ParameterError(f"parameter_study: function must be callable, got {function!r}")
    designs = _checked_designs(designs)
    if on_error not in ON_ERROR:
        raise ParameterError(f"parameter_study: on_error={on_error!r}; valid: {', '.join(ON_ERROR)}")
    if timeout is not None:
        timeout = positive("parameter_study", "timeout", timeout)  # [s]
    if max_workers is not None and (isinstance(max_workers, bool) or not isinstance(max_workers, (int, np.integer))
                                    or max_workers < 1):
        raise ParameterError(f"parameter_study: max_workers={max_workers!r} must be an integer >= 1 (or None: the "
                             "CPU count)")
    if not (executor is None or isinstance(executor, Executor) or (isinstance(executor, str) and executor == "serial")):
        raise ParameterError(f"parameter_study: executor must be None, 'serial' or a concurrent.futures.Executor, "
                             f"got {executor!r}")
    if executor is None or isinstance(executor, ProcessPoolExecutor):
        _check_picklable(function)

    outcomes: list = [None] * len(designs)  # per design: ("ok", outputs[, warnings]) or ("error", record[, warnings])
    bar = tqdm(total=len(designs), desc="designs", unit="design", leave=False,
               disable=None if progress is None else not progress)
    run = _Run(function, designs, outcomes, timeout, on_error == "raise", bar)
    try:
        if isinstance(executor, str):
            run.serial()
        elif executor is None:
            run.own_pool(max_workers or os.cpu_count() or 1)
        else:
            run.on(executor)
    except KeyboardInterrupt:
        table = _table(designs, outcomes, "cancelled (interrupted)")
        done = sum(o is not None and o[0] == "ok" for o in outcomes)
        raise StudyInterrupted(f"parameter_study interrupted: {done} of {len(designs)} designs finished; their "
                               "results are in exc.table", table) from None
    finally:
        bar.close()
    if run.failed is not None:
        i = run.failed
        table = _table(designs, outcomes, "cancelled (on_error='raise')")
        raise StudyError(f"parameter_study: design {i} {designs[i]!r} failed: {outcomes[i][1]} (the other designs' "
                         "results are in exc.table)", table, i, designs[i])
    return _table(designs, outcomes, "cancelled")


def _checked_designs(designs) -> list[dict]:
    """``designs`` as a new list of dicts, refused (`ParameterError`) unless a non-empty sequence of
    keyword dicts whose names are text and not those of the table's own columns."""
    if isinstance(designs, (Mapping, str, bytes)) or not isinstance(designs, Iterable):
        raise ParameterError("parameter_study: designs must be a sequence of keyword dicts, e.g. flexmb.study.grid(...)")
    designs = list(designs)  # a generator is read once, here
    if not all(isinstance(d, Mapping) for d in designs):
        raise ParameterError("parameter_study: designs must be a sequence of keyword dicts, e.g. flexmb.study.grid(...)")
    designs = [dict(d) for d in designs]
    if not designs:
        raise ParameterError("parameter_study: designs is empty")
    bad = [k for d in designs for k in d if not isinstance(k, str)]
    if bad:
        raise ParameterError(f"parameter_study: design keys must be parameter names (text), got {bad[0]!r}")
    taken = sorted({k for d in designs for k in d} & {ERROR_COLUMN, CONVERGED_COLUMN, WARNINGS_COLUMN})
    if taken:
        raise ParameterError(f"parameter_study: design parameters {taken} have the names of the table's own "
                             f"columns ({ERROR_COLUMN}, {CONVERGED_COLUMN}, {WARNINGS_COLUMN}); rename them")
    return designs


def _check_picklable(function) -> None:
    """Refuse, before any design runs, a function a process pool cannot send to its workers."""
    try:
        pickle.dumps(function)
    except Exception as exc:  # PicklingError, AttributeError (a local object), TypeError ...
        raise ParameterError(
            f"parameter_study: function {function!r} cannot be sent to worker processes ({type(exc).__name__}: "
            f"{exc}); define it with def at module level (not a lambda or a function inside a function), or "
            "functools.partial of one, or run with executor='serial'") from None


# -- running one design ----------------------------------------------------------------------

class _Timeout(BaseException):
    """A design's time is up (a BaseException: a design's ``except Exception`` cannot swallow it)."""


def _call(function, design: dict, timeout: float | None):
    """``("ok", outputs, warnings)`` or ``("error", "Type: message", warnings)``: plain data that
    always pickles; ``warnings`` the design's warnings as text (`flexmb._warnings.recording`).

    ``timeout`` stops the design with SIGALRM where this runs in a main thread (this process,
    a process-pool worker); elsewhere (a dask worker thread) the design runs in a thread that is
    abandoned when it overruns."""
    with _warnings.recording() as caught:
        try:
            if timeout is None:
                out = function(**design)
            elif threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
                out = _with_alarm(function, design, timeout)
            else:
                out = _with_thread(function, design, timeout)
            outcome = "ok", _outputs(out)
        except _Timeout:
            outcome = "error", f"TimeoutError: the design ran longer than its timeout of {timeout:g} s and was stopped"
        except (Exception, SystemExit) as exc:
            outcome = "error", _record(exc)
    return (*outcome, _warnings.as_text(caught))


def _record(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _with_alarm(function, design, timeout):
    def alarm(signum, frame):
        raise _Timeout

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        return function(**design)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _with_thread(function, design, timeout):
    box = {}
    records = _warnings.current()  # the design's warnings, raised in its own thread

    def target():
        _warnings.adopt(records)
        try:
            box["out"] = function(**design)
        except BaseException as exc:  # handed to the calling thread
            box["exc"] = exc

    t = threading.Thread(target=target, daemon=True, name="flexmb-design")
    t.start()
    t.join(timeout)
    if t.is_alive():
        raise _Timeout
    if "exc" in box:
        raise box["exc"]
    return box["out"]


def _outputs(out) -> dict:
    """The outputs as a dict of scalars (numbers, booleans, text)."""
    row = dict(out) if isinstance(out, Mapping) else {"value": out}
    for k, x in row.items():
        if not isinstance(k, str):
            raise ParameterError(f"output names must be text, got {k!r}")
        if not (isinstance(x, (str, bool, int, float, np.number, np.bool_)) or (isinstance(x, np.ndarray)
                                                                                 and x.ndim == 0)):
            raise ParameterError(f"output {k!r} = {x!r} is not a scalar (a number, a boolean or text)")
        row[k] = x.item() if isinstance(x, (np.ndarray, np.generic)) else x
    return row


# -- running the designs ---------------------------------------------------------------------

class _Run:
    """The designs' loop on an executor; fills ``outcomes`` in place, so an interrupt keeps them."""

    POLL = 0.2  # [s] wait granularity: how soon a Ctrl-C or a dead pool is acted on

    def __init__(self, function, designs, outcomes, timeout, stop_on_error, bar):
        self.function, self.designs, self.outcomes = function, designs, outcomes
        self.timeout, self.stop_on_error, self.bar = timeout, stop_on_error, bar
        self.failed = None  # index of the design that stopped the study (on_error="raise")

    def done(self, i: int, outcome) -> bool:
        """Record design ``i``; True when the study must stop."""
        self.outcomes[i] = outcome
        self.bar.update()
        if outcome[0] == "error" and self.stop_on_error:
            self.failed = i
            return True
        return False

    def serial(self):
        for i, d in enumerate(self.designs):
            if self.done(i, _call(self.function, d, self.timeout)):
                return

    def on(self, executor):
        """A user's executor: everything submitted at once, left running afterwards."""
        futures = {executor.submit(_call, self.function, d, self.timeout): i for i, d in enumerate(self.designs)}
        try:
            self._collect(futures)
        finally:
            for f in futures:
                f.cancel()

    def _collect(self, futures: dict) -> None:
        """Wait for ``futures`` (future -> design index), recording each as it finishes."""
        pending = set(futures)
        while pending:
            finished, pending = cf.wait(pending, timeout=self.POLL, return_when=cf.FIRST_COMPLETED)
            for f in finished:
                if not f.cancelled() and self.done(futures[f], _outcome(f)):
                    return

    def own_pool(self, workers: int):
        """The embedded pool: designs fed as workers free up (so Ctrl-C has little to cancel);
        after a worker died, the designs it may have held are rerun one at a time."""
        queue = list(range(len(self.designs)))
        suspects = []
        while queue or suspects:
            if suspects:  # alone: a design that kills its worker again is the culprit
                i = suspects.pop(0)
                died = self._pool_run([i], 1)
                if died:
                    if self.done(i, ("error", "BrokenProcessPool: the worker process running this design died "
                                              "(killed by a signal, or crashed) twice, the second time alone")):
                        return
            else:
                died = self._pool_run(queue, min(workers, len(queue)))
                queue = [i for i in queue if self.outcomes[i] is None and i not in died]
                suspects = died
            if self.failed is not None:
                return

    def _pool_run(self, indices: list[int], workers: int) -> list[int]:
        """Run ``indices`` in a fresh pool of ``workers``; the designs lost to a dead worker."""
        pool = ProcessPoolExecutor(max_workers=workers, initializer=_one_blas_thread)
        futures, todo = {}, iter(indices)
        try:
            for i in itertools.islice(todo, workers):
                futures[pool.submit(_call, self.function, self.designs[i], self.timeout)] = i
            died = []
            while futures:
                finished, _ = cf.wait(futures, timeout=self.POLL, return_when=cf.FIRST_COMPLETED)
                for f in finished:
                    i = futures.pop(f)
                    if isinstance(f.exception(), BrokenProcessPool):
                        died.append(i)
                    elif self.done(i, _outcome(f)):
                        return died
                if died:  # the pool is broken: what it still held died with it
                    return died + list(futures.values())
                for i in itertools.islice(todo, len(finished)):
                    futures[pool.submit(_call, self.function, self.designs[i], self.timeout)] = i
            return died
        finally:
            _stop(pool)


def _outcome(future) -> tuple:
    exc = future.exception()
    return future.result() if exc is None else ("error", _record(exc))


def _stop(pool: ProcessPoolExecutor) -> None:
    """Shut the embedded pool down now: queued designs cancelled, running ones' workers ended."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + 5.0
    for p in processes:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()


# -- the table -------------------------------------------------------------------------------

def _table(designs: list[dict], outcomes: list, unfinished: str) -> Table:
    """One row per design: inputs, outputs (NaN where a design has none), the error record, whether
    it converged and its warnings (`_status`). Outputs named like an input or the error column are
    refused, with the table attached."""
    inputs = list(dict.fromkeys(k for d in designs for k in d))
    rows = [dict(o[1]) if o is not None and o[0] == "ok" else {} for o in outcomes]
    errors = ["" if o is not None and o[0] == "ok" else (o[1] if o is not None else unfinished) for o in outcomes]
    converged, warned = _status(rows, errors, outcomes)
    outputs = list(dict.fromkeys(k for r in rows for k in r))
    clash = [k for k in outputs if k in inputs or k == ERROR_COLUMN]  # (converged, warnings: merged above)
    names = {k: (f"output.{k}" if k in clash else k) for k in outputs}
    cols = {n: column([d.get(n, np.nan) for d in designs]) for n in inputs}
    cols.update({names[k]: column([r.get(k, np.nan) for r in rows]) for k in outputs})
    cols[ERROR_COLUMN] = column(errors)
    cols[CONVERGED_COLUMN] = np.array(converged, dtype=bool)
    cols[WARNINGS_COLUMN] = column(warned)
    table = Table(cols)
    if clash:
        exc = ParameterError(f"parameter_study: outputs {sorted(clash)} have the names of inputs or of the "
                             f"{ERROR_COLUMN!r} column; rename them (all results are in exc.table, those outputs as "
                             f"{', '.join(repr(names[k]) for k in clash)})")
        exc.table = table
        raise exc
    return table


def _status(rows: list[dict], errors: list[str], outcomes: list) -> tuple[list, list]:
    """Each design's `CONVERGED_COLUMN` and `WARNINGS_COLUMN` cells: its own ``converged`` and
    ``warnings`` outputs (taken out of ``rows``) joined with its error and the warnings recorded
    in its worker (an outcome's third item)."""
    converged, warned = [], []
    for row, error, outcome in zip(rows, errors, outcomes):
        converged.append(not error and bool(row.pop(CONVERGED_COLUMN, True)))
        texts = [str(row.pop(WARNINGS_COLUMN, "") or ""), outcome[2] if outcome is not None and len(outcome) > 2 else ""]
        warned.append(WARNING_SEPARATOR.join(dict.fromkeys(w for t in texts for w in t.split(WARNING_SEPARATOR) if w)))
    return converged, warned


def joint_range(kind: str, rotations, *, which=("modes", "stress"), n_modes: int = 3, held=(("B", "rz"),),
                limit=None, concentration=None, **params) -> dict:
    """The design properties of the registered joint ``kind`` (shape ``params``, SI units) over
    its intended rotations ``rotations`` [rad]: link A fixed, B's orientation prescribed to the
    turn about the joint's z axis (`flexmb.testing.joint_mechanism`), swept with continuation;
    linearised with ``held`` (default: B's rotation about z held, B otherwise free, the
    prescription's reactions kept as dead loads) and the leaves' own mass (``density`` > 0).
    Returns `summary` of the `properties` (the lowest parasitic frequencies ``f1.min`` ..., the
    peak stresses ...) and ``converged``: one design of a parameter study
    (`flexmb.study.parameter_study`), picklable as ``functools.partial(joint_range, kind,
    rotations)``."""
    from .design_properties import properties, summary
    from .registry import joint
    from .sweeps import sweep
    from .testing import joint_mechanism

    try:
        angles = None if isinstance(rotations, (str, bytes)) else np.atleast_1d(np.asarray(rotations, dtype=float))
    except (TypeError, ValueError):
        angles = None
    if angles is None or angles.ndim != 1 or not len(angles) or not np.all(np.isfinite(angles)):
        raise ParameterError(f"joint_range: rotations={rotations!r} must be a non-empty 1-D sequence of finite "
                             "rotations [rad]")
    m = joint_mechanism(joint(kind, **params), 3)
    m.prescribe("B", rotation=(0.0, 0.0, 0.0))
    zeros = np.zeros_like(angles)
    res = sweep(m, np.column_stack([zeros, zeros, angles]), motion=("B", "rotation"), progress=False)
    out = summary(properties(res, which, n_modes=n_modes, held=held, limit=limit, concentration=concentration))
    out["converged"] = bool(np.all(res.converged))
    return out


def _one_blas_thread() -> None:
    """Process-pool initialiser: one BLAS thread per worker (the workers already fill the cores;
    flexmb.linear.single_threaded)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
