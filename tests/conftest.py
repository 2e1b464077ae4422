import gc
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# "ci": few, reproducible examples so the suite stays fast; "thorough": on demand,
# HYPOTHESIS_PROFILE=thorough python -m pytest
settings.register_profile("ci", max_examples=25, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=25, deadline=None)
settings.register_profile("thorough", max_examples=500, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


# -- the sealed suite (issue 32) ---------------------------------------------------------------
# A user's trained joint data in ~/.local/share/flexmb/database (where `flexmb train` writes by
# default) took precedence over the shipped data in the suite's KSD solves and failed 6 tests on
# one machine. The suite therefore runs with its home, data, cache and config folders, the joint
# database folder and numba's cache in temporary folders: it reads none of the user's files and
# writes none (an unwritable home is fine). Set here, when pytest imports this file, before any
# test module imports flexmb: numba picks a kernel's cache folder when the kernel is decorated,
# at import. numba's cache goes to one folder per user under the system's temporary folder, kept
# between runs (compiling every kernel again costs ~40 s of CPU per run; numba keys its cache on
# the source file's path and time stamp, so checkouts do not mix; issue 31 had set it so too, when
# not set); everything else is new per run.
_RUN = Path(tempfile.mkdtemp(prefix="flexmb-tests-"))
_UID = os.getuid() if hasattr(os, "getuid") else "user"


def _kept(name: str) -> Path | None:
    """A folder of the suite's kept between runs in the temporary folder, or None when another
    user owns that folder (a shared /tmp)."""
    kept = Path(tempfile.gettempdir()) / f"flexmb-tests-{_UID}" / name
    try:
        kept.mkdir(parents=True, exist_ok=True)
        if not hasattr(os, "getuid") or kept.parent.stat().st_uid == os.getuid():
            return kept
    except OSError:
        pass
    return None


def _numba_cache() -> Path:
    """numba's cache for the suite: kept between runs (`_kept`), else a new one for this run."""
    return _kept("numba") or _RUN / "numba"


# Bytecode: with PYTHONDONTWRITEBYTECODE set (a checkout kept free of __pycache__ folders), every
# run compiled flexmb's ~130 modules and pytest rewrote the ~100 test modules' asserts again: 3.4 s
# of the fast set's 6.6 s collection CPU (issue 27). The suite writes them under the kept temporary
# folder instead (sys.pycache_prefix: the checkout stays clean; Python checks each against its
# source's time stamp and size, pytest's rewritten ones too); from here on, so this file, pytest
# and the installed packages are as before. FLEXMB_TESTS_NO_BYTECODE=1: write none.
_BYTECODE = None
if sys.dont_write_bytecode and os.environ.get("FLEXMB_TESTS_NO_BYTECODE") != "1":
    _BYTECODE = _kept("pycache")
    if _BYTECODE is not None:
        sys.pycache_prefix, sys.dont_write_bytecode = str(_BYTECODE), False


SEALED = {
    "HOME": _RUN / "home",
    "USERPROFILE": _RUN / "home",  # Windows' Path.home()
    "LOCALAPPDATA": _RUN / "home" / "AppData" / "Local",
    "XDG_DATA_HOME": _RUN / "data",
    "XDG_CACHE_HOME": _RUN / "cache",
    "XDG_CONFIG_HOME": _RUN / "config",
    "MPLCONFIGDIR": _RUN / "config" / "matplotlib",
    "FLEXMB_DATABASE": _RUN / "data" / "flexmb" / "database",
    "NUMBA_CACHE_DIR": _numba_cache(),
}
#: the variables as the run found them (for tests that need the user's, e.g. to show what is sealed)
UNSEALED = {k: os.environ.get(k) for k in SEALED}
if os.environ.get("FLEXMB_TESTS_UNSEALED") != "1":  # the proof's control run (tests/test_sealed.py) only
    for _key, _path in SEALED.items():
        if _key not in ("FLEXMB_DATABASE", "MPLCONFIGDIR"):  # folders created by whoever writes them
            _path.mkdir(parents=True, exist_ok=True)
        os.environ[_key] = str(_path)


@pytest.fixture(autouse=True, scope="session")
def sealed_environment():
    """The suite's home, data, cache and config folders, joint database folder and numba cache
    (`SEALED`), kept for the whole session: a test that changes one of them (monkeypatch) gets it
    back after; the run's folders are removed at the end. Yields `SEALED`."""
    if os.environ.get("FLEXMB_TESTS_UNSEALED") == "1":
        yield {}
        return
    with pytest.MonkeyPatch.context() as mp:
        for key, path in SEALED.items():
            mp.setenv(key, str(path))
        numba = __import__("sys").modules.get("numba")
        if numba is not None:  # numba reads NUMBA_CACHE_DIR when imported: imported after the lines above
            mp.setattr(numba.config, "CACHE_DIR", str(SEALED["NUMBA_CACHE_DIR"]))
        yield dict(SEALED)
    shutil.rmtree(_RUN, ignore_errors=True)


def pytest_report_header(config):
    """Which kernels the run uses (CI runs the suite with both: .ci/run), and where the suite's
    home and data folders are (sealed from the user's)."""
    from flexmb import jit

    sealed = "not sealed (FLEXMB_TESTS_UNSEALED=1)" if os.environ.get("FLEXMB_TESTS_UNSEALED") == "1" else \
        f"sealed in {_RUN} (numba cache {SEALED['NUMBA_CACHE_DIR']})"
    lines = [f"flexmb kernels: {'compiled (numba)' if jit.enabled() else 'numpy'} (FLEXMB_KERNELS to choose)",
             f"flexmb home and data folders: {sealed}"]
    if _BYTECODE is not None:
        lines.append(f"bytecode (PYTHONDONTWRITEBYTECODE is set): kept in {_BYTECODE}")
    return lines


def pytest_collection_finish(session):
    """The cyclic garbage collector's first threshold at 7000 allocations (Python's default 700)
    once the tests are collected: the suite's caches, compiled models and solutions keep ~200 000
    objects alive, which every full collection walks. Measured on the fast set (issue 27): the
    collector's CPU time 3.6 s -> 2.1 s (collections 3959/354/17 -> 1163/105/10 by generation).
    The tests see the same collector (a test that needs garbage gone calls gc.collect(), as
    tests/test_ksd.py does)."""
    gc.set_threshold(7000, *gc.get_threshold()[1:])


@pytest.fixture
def kernels():
    """`flexmb.jit.use`, to switch between the compiled and numpy kernels in a test; the choice
    the run started with is restored after it."""
    from flexmb import jit

    previous = jit.enabled()
    yield jit.use
    jit.use("auto" if previous else "numpy")
