"""The compiled KSD-reduced path (steps 1-4 in numba kernels, flexmb.ksd.reduced_jit) as a user
meets it, against the numpy path (the reference): what a solve reports, what survives a change
between solves, and what it refuses. Cases no paper contains: motions far beyond a table's
grid, many kinematic iterations, a misspelt database folder.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb
from flexmb import jit
from flexmb.ksd.kinematics import solve_kinematics
from flexmb.ksd.reduced import ReducedMechanism

pytestmark = pytest.mark.skipif(not jit._AVAILABLE, reason="numba not installed (the numpy path is the only one)")


@pytest.fixture
def kernels():
    previous = jit.enabled()
    yield jit.use
    jit.use("auto" if previous else "numpy")


def test_step_1_reports_every_iteration_however_many(kernels):
    # KSD step 1 (Dwarshuis et al. 2020 Sec. 2.2) of the 2D cross-flexure pivot turned 300 rad
    # (beyond any trained range: step 1 alone, which follows the rotation in quarter turns) with
    # two Newton iterations allowed per step: 191 iterations, more than the 64 x max_iter = 128
    # residuals the compiled kernel's history held. Reference: the numpy loop's history, which
    # keeps them all; info["history"] has one residual per counted iteration on both paths.
    red = ReducedMechanism(flexmb.models.cross_flexure_pivot(2, dim=2, rotation=300.0).compile())
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        out[path] = solve_kinematics(red, max_iter=2)[3]
    ref, got = out["numpy"], out["numba"]
    assert ref["iterations"] > 128 and len(ref["history"]) == ref["iterations"]
    assert got["iterations"] == ref["iterations"] and len(got["history"]) == got["iterations"]
    np.testing.assert_allclose(got["history"], ref["history"], rtol=1e-9, atol=1e-14)
