"""Rotation maps (flexmb.rotations): properties that hold for every rotation vector."""

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from flexmb.rotations import cross, expm_so3, logm_so3, skew, unskew
from tolerances import EXACT

vec3 = arrays(np.float64, 3, elements=st.floats(-3.0, 3.0))


@given(vec3)
@example(np.array([1e-9, 0.0, 0.0]))  # small angle: no series branch, no cancellation
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


def test_cross_broadcasts_as_numpy_cross():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    np.testing.assert_allclose(cross(a, b), np.cross(a, b), **EXACT)
    np.testing.assert_allclose(cross(a[0], b), np.cross(a[0], b), **EXACT)
    np.testing.assert_allclose(cross(a[:, None], b[None]), np.cross(a[:, None], b[None]), **EXACT)


def test_exp_and_log_keep_full_precision_at_small_angles():
    """Series: exp(w) = I + K + K^2/2 + O(t^3); at t = 1e-6 the remainder is below 1e-18, so the
    matrix agrees to 2 ulp of 1 and its skew part, which carries w, to relative roundoff."""
    w = np.array([3e-7, -8e-7, 5e-7])
    K = skew(w)
    R = expm_so3(w)
    np.testing.assert_allclose(R, np.eye(3) + K + K @ K / 2, rtol=0, atol=2.3e-16)
    np.testing.assert_allclose(unskew(R), w, rtol=1e-12, atol=0)  # sin(t)/t = 1 - 2e-13
    np.testing.assert_allclose(logm_so3(R), w, rtol=1e-12, atol=0)


def test_log_near_pi_takes_the_axis_from_the_symmetric_part():
    """Closed form: exp(t n) for |t| just below pi; sin t -> 0 there, so the axial vector alone
    cannot give the angle's scale."""
    n = np.array([2.0, -1.0, 2.0]) / 3.0
    for t in (np.pi - 1e-4, np.pi - 1e-7):
        np.testing.assert_allclose(logm_so3(expm_so3(t * n)), t * n, rtol=0, atol=1e-8)
