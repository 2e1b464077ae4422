import os
import tempfile

import pytest
from hypothesis import HealthCheck, settings

# "ci": few, reproducible examples so the suite stays fast; "thorough": on demand,
# HYPOTHESIS_PROFILE=thorough python -m pytest
settings.register_profile("ci", max_examples=25, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=25, deadline=None)
settings.register_profile("thorough", max_examples=500, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# issue 31: the compiled kernels' cache in a folder of the system's temporary directory (kept between runs),
# never the user's cache folder (numba reads NUMBA_CACHE_DIR when first imported, after this)
os.environ.setdefault("NUMBA_CACHE_DIR", os.path.join(tempfile.gettempdir(), "flexmb-tests-numba-cache"))


def pytest_report_header(config):
    """Which kernels the run uses (CI runs the suite with both: .ci/run)."""
    from flexmb import jit

    return f"flexmb kernels: {'compiled (numba)' if jit.enabled() else 'numpy'} (FLEXMB_KERNELS to choose)"


@pytest.fixture
def kernels():
    """`flexmb.jit.use`, to switch between the compiled and numpy kernels in a test; the choice
    the run started with is restored after it."""
    from flexmb import jit

    previous = jit.enabled()
    yield jit.use
    jit.use("auto" if previous else "numpy")
