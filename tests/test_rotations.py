"""Rotation maps (flexmb.rotations): properties that hold for every rotation vector."""

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from flexmb.rotations import expm_so3, logm_so3, skew, unskew
from tolerances import EXACT

vec3 = arrays(np.float64, 3, elements=st.floats(-3.0, 3.0))


@given(vec3)
@example(np.array([1e-9, 0.0, 0.0]))  # Taylor branch
@example(np.array([0.0, 0.0, np.pi - 1e-7]))  # near pi
def test_exp_is_a_proper_rotation(w):
    R = expm_so3(w)
    np.testing.assert_allclose(R @ R.T, np.eye(3), **EXACT)
    assert abs(np.linalg.det(R) - 1.0) < 1e-12


@given(vec3.filter(lambda w: np.linalg.norm(w) < np.pi - 1e-3))
@example(np.array([1e-9, -2e-9, 0.0]))
def test_log_inverts_exp_inside_the_principal_ball(w):
    np.testing.assert_allclose(logm_so3(expm_so3(w)), w, rtol=1e-9, atol=1e-12)


@given(vec3, vec3)
def test_skew_is_the_cross_product(a, b):
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), **EXACT)
    np.testing.assert_allclose(unskew(skew(a)), a, **EXACT)


def test_exp_of_rotation_about_z_is_the_planar_rotation():
    """Closed form: exp(theta e_z) = [[c, -s, 0], [s, c, 0], [0, 0, 1]]."""
    t = 0.7
    c, s = np.cos(t), np.sin(t)
    np.testing.assert_allclose(expm_so3([0, 0, t]), [[c, -s, 0], [s, c, 0], [0, 0, 1]], **EXACT)
