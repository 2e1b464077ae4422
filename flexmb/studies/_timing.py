"""Interleaved timing of solves for the case studies (speed-up ratios measured in one run)."""

from __future__ import annotations

import gc
import time

import numpy as np

from ..solvers import solve


def interleaved(mechanism, methods, repeats: int, consecutive: int = 1) -> tuple[dict, dict]:
    """Solve ``mechanism`` with every method ``repeats`` times, the methods interleaved so that
    drifts of the machine hit all alike, garbage collection paused during each solve (as timeit).
    Call after a warm-up solve. Returns the last solution and the median wall time [s] per method.

    ``consecutive=1``: one solve per method and round after a full collection, so every solve
    starts with the caches left by another method (a single solve). ``consecutive=k > 1``: k
    solves in a row per method and round, timing all but the first (the steady state of a
    sweep or optimisation loop that solves one method repeatedly)."""
    times = {m: [] for m in methods}
    sols = {}
    for _ in range(repeats):
        for method in methods:
            gc.collect()
            for k in range(consecutive):
                gc.disable()
                try:
                    t = time.perf_counter()
                    sols[method] = solve(mechanism, method=method, raise_on_failure=True)
                    elapsed = time.perf_counter() - t
                finally:
                    gc.enable()
                if consecutive == 1 or k > 0:
                    times[method].append(elapsed)
    return sols, {m: float(np.median(t)) for m, t in times.items()}
