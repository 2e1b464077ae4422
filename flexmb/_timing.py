"""Interleaved timing of solves for the case studies (speed-up ratios measured in one run)."""

from __future__ import annotations

import gc
import time

import numpy as np

from .solvers import solve


def interleaved(mechanism, methods, repeats: int) -> tuple[dict, dict]:
    """Solve ``mechanism`` with every method ``repeats`` times, the methods interleaved so that
    drifts of the machine hit all alike, garbage collection paused during each solve (as timeit;
    a collection triggered by earlier garbage is not the solver's time). Call after a warm-up
    solve. Returns the last solution and the median wall time [s] per method."""
    times = {m: [] for m in methods}
    sols = {}
    for _ in range(repeats):
        for method in methods:
            gc.collect()
            gc.disable()
            try:
                t = time.perf_counter()
                sols[method] = solve(mechanism, method=method, raise_on_failure=True)
                times[method].append(time.perf_counter() - t)
            finally:
                gc.enable()
    return sols, {m: float(np.median(t)) for m, t in times.items()}
