"""The requested motion, not another one (issue 19 item 6): a prescribed rotation is never wrapped
modulo 2 pi (KSD) nor turned the short way round (warm-started 3D sweeps)."""

import numpy as np
import pytest

import flexmb


@pytest.mark.parametrize("rotation", [45.0, 2 * np.pi + 0.3, -2 * np.pi + 0.3])
@pytest.mark.parametrize("method", ["ksd-full", "ksd-reduced"])
def test_ksd_refuses_a_rotation_beyond_its_range_however_many_turns(rotation, method):
    # 45 rad (degrees typed as radians) once converged to 16.18 N m: 45 mod 2 pi = 1.02 rad is in range
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=rotation)
    with pytest.raises(flexmb.DatabaseError, match="outside its trained range") as exc:
        flexmb.solve(m, method=method)
    # the rotation asked for, not the angle where step 1 stopped (2 pi + 0.3: 270 deg, 72 % of the way)
    assert f"{rotation:.4g}" in str(exc.value)


def test_ksd_still_solves_in_range():
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.3)
    ksd, conv = flexmb.solve(m, method="ksd-full"), flexmb.solve(m)
    assert ksd.converged and ksd.reaction("B")[-1] == pytest.approx(conv.reaction("B")[-1], rel=1e-8)


def test_a_3d_sweep_turns_the_requested_way_beyond_pi():
    # pure bending of a straight cantilever (EI = 1 per unit length here): the tip moment is
    # EI theta / L for any theta (a circular arc; closed form), so +13.33 N m at 4 rad, whatever
    # the previous sweep value; the short way round (4 - 2 pi = -2.28 rad) gave -7.61 N m
    m = flexmb.models.cantilever(dim=3, elements=16)
    m.prescribe("tip", rotation=(0.0, 0.0, 0.0))
    swept = flexmb.sweep(m, [[0, 0, 0.1], [0, 0, 4.0]], motion=("tip", "rotation"))
    m2 = flexmb.models.cantilever(dim=3, elements=16)
    m2.prescribe("tip", rotation=(0.0, 0.0, 4.0))
    cold = flexmb.solve(m2)
    assert swept[1].converged and cold.converged
    assert cold.reaction("tip")[5] == pytest.approx(13.3333333, rel=1e-6)
    assert swept[1].reaction("tip")[5] == pytest.approx(cold.reaction("tip")[5], rel=1e-9)
    np.testing.assert_allclose(swept[1].rotation_vector("tip"), cold.rotation_vector("tip"), atol=1e-9)

