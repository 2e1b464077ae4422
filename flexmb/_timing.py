"""Wall time per phase of a solve [s]: `Stopwatch`, instead of hand-written ``perf_counter`` pairs."""

from __future__ import annotations

import time

__all__ = ["Stopwatch"]


class _Phase:
    """``with watch.adding(key):`` adds the block's wall time to ``times[key]`` (also when it raises)."""

    __slots__ = ("times", "key", "t0")

    def __init__(self, times: dict, key: str):
        self.times, self.key = times, key

    def __enter__(self):
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> bool:
        self.times[self.key] = self.times.get(self.key, 0.0) + (time.perf_counter() - self.t0)
        return False


class Stopwatch:
    """Times the phases of a run into the dict ``times`` [s] (a `flexmb.Solution`'s ``wall_time``).

    ``lap(key)`` stores under ``key`` the time since the previous lap (or the start);
    ``adding(key)`` is a context manager adding its block's time to ``times[key]`` (phases that
    recur: assembly and linear solves per iteration); ``total(key="total")`` stores the time since
    the start. Each returns or stores seconds from `time.perf_counter`."""

    __slots__ = ("times", "start", "last")

    def __init__(self, times: dict | None = None):
        self.times = {} if times is None else times
        self.start = self.last = time.perf_counter()

    def lap(self, key: str) -> float:
        """Store the time since the last lap under ``key``; returns it."""
        now = time.perf_counter()
        dt = self.times[key] = now - self.last
        self.last = now
        return dt

    def adding(self, key: str) -> _Phase:
        """A context manager adding its block's time to ``times[key]``."""
        return _Phase(self.times, key)

    def total(self, key: str = "total") -> float:
        """Store the time since the start under ``key``; returns it."""
        dt = self.times[key] = time.perf_counter() - self.start
        return dt
