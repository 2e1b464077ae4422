"""Interleaved timing of solves for the case studies (speed-up ratios measured in one run)."""

from __future__ import annotations

import gc
import time

import numpy as np

from ..errors import ParameterError
from ..solvers import solve


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def interleaved(mechanism, methods, repeats: int, consecutive: int = 1, clock: str = "wall") -> tuple[dict, dict]:
    """Solve ``mechanism`` with every method ``repeats`` times, the methods interleaved so that
    drifts of the machine hit all alike, garbage collection paused during each solve (as timeit).
    Call after a warm-up solve. Returns the last solution and the median time [s] per method on ``clock``.

    ``consecutive=1``: one solve per method and round after a full collection, so every solve
    starts with the caches left by another method (a single solve). ``consecutive=k > 1``: k
    solves in a row per method and round, timing all but the first (the steady state of a
    sweep or optimisation loop that solves one method repeatedly).

    ``clock="wall"``: what a user waits; ``"cpu"``: the process's CPU time, which does not count the
    waits for a core on a busy machine. With `flexmb demo` on a 2-core host with the other core busy, medians of 5 wall
    times of one solve differed threefold by position (a lost time slice)."""
    if clock not in CLOCKS:
        raise ParameterError(f"clock={clock!r}; valid: {', '.join(CLOCKS)}")
    now = CLOCKS[clock]
    times = {m: [] for m in methods}
    sols = {}
    for _ in range(repeats):
        for method in methods:
            gc.collect()
            for k in range(consecutive):
                gc.disable()
                try:
                    t = now()
                    sols[method] = solve(mechanism, method=method, raise_on_failure=True)
                    elapsed = now() - t
                finally:
                    gc.enable()
                if consecutive == 1 or k > 0:
                    times[method].append(elapsed)
    return sols, {m: float(np.median(t)) for m, t in times.items()}
