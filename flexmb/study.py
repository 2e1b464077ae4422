"""Parameter studies: many independent designs evaluated through any `concurrent.futures.Executor`
(an embedded local process pool by default, ``dask.distributed`` for a cluster)."""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterable, Mapping
from concurrent.futures import Executor, ProcessPoolExecutor

import numpy as np

from .errors import ParameterError
from .table import Table

__all__ = ["grid", "parameter_study"]


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
                    progress: bool | None = None) -> Table:
    """Evaluate ``function(**design)`` for every design (a list of keyword dicts, e.g. from
    `grid`) and collect the inputs and outputs as a `flexmb.table.Table`, one row per design in
    the given order.

    ``function`` returns a mapping of scalars (its keys become columns; e.g.
    `flexmb.analysis.joint_properties`) or one number (column ``"value"``); it must be picklable
    (a module-level function or a ``functools.partial`` of one) to run in other processes.
    ``executor``: None runs an embedded ``ProcessPoolExecutor`` (``max_workers``, default the
    CPU count) and shuts it down; ``"serial"`` runs in this process; any other
    `concurrent.futures.Executor` is used as given and left running, e.g. a dask cluster's
    ``distributed.Client(...).get_executor()``. A design that raises stops the study with its
    error. ``progress``: a progress bar on stderr (None = only on a terminal).
    """
    from tqdm.auto import tqdm

    if not callable(function):
        raise ParameterError(f"parameter_study: function must be callable, got {function!r}")
    if (isinstance(designs, (Mapping, str, bytes)) or not isinstance(designs, Iterable)
            or not all(isinstance(d, Mapping) for d in designs)):
        raise ParameterError("parameter_study: designs must be a sequence of keyword dicts, e.g. "
                             "flexmb.study.grid(...)")
    designs = [dict(d) for d in designs]
    if not designs:
        raise ParameterError("parameter_study: designs is empty")
    bar = dict(total=len(designs), desc="designs", unit="design", leave=False,
               disable=None if progress is None else not progress)
    if isinstance(executor, str) and executor == "serial":
        results = [function(**d) for d in tqdm(designs, **bar)]
    elif executor is None:
        workers = max_workers or os.cpu_count() or 1
        with ProcessPoolExecutor(max_workers=min(workers, len(designs)), initializer=_one_blas_thread) as pool:
            results = [f.result() for f in tqdm([pool.submit(function, **d) for d in designs], **bar)]
    elif isinstance(executor, Executor):
        results = [f.result() for f in tqdm([executor.submit(function, **d) for d in designs], **bar)]
    else:
        raise ParameterError(f"parameter_study: executor must be None, 'serial' or a concurrent.futures.Executor, "
                             f"got {executor!r}")
    rows = [dict(r) if isinstance(r, Mapping) else {"value": r} for r in results]
    names = list(dict.fromkeys(k for d in designs for k in d)) + list(dict.fromkeys(k for r in rows for k in r))
    clash = set(designs[0]) & set(rows[0])
    if clash:
        raise ParameterError(f"parameter_study: outputs {sorted(clash)} have the names of inputs")
    merged = [{**d, **r} for d, r in zip(designs, rows)]
    return Table({n: [row.get(n, np.nan) for row in merged] for n in names})


def _one_blas_thread() -> None:
    """Process-pool initialiser: one BLAS thread per worker (the workers already fill the cores;
    flexmb.linear.single_threaded)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
