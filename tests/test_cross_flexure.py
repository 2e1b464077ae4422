"""The cross-flexure pivot (Dwarshuis et al. 2020, Sec. 4.1-4.2, Table 1) on the full model."""

import attrs
import numpy as np
import pytest

import flexmb
from flexmb.reference import cross_spring_pivot


def _moment_ratio(n, theta, dim=2, **params):
    """M / (E I theta / L) with I = (w1 + 2 w2) t^3 / 12 (Eq. 4.4), and the solution."""
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=n, dim=dim, rotation=theta, **params)
    sol = flexmb.solve(m)
    assert sol.converged, sol.message
    j = m.joints["cross_flexure"]
    return sol.reaction("B")[-1] / (j.E * j.second_moment * theta / j.length), sol


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n", [1, 3, 5])
def test_small_rotation_stiffness_is_EI_over_L_half_of_eq_4_3(dim, n):
    """Linear beam theory, leaves crossing at their midpoints: rotating a clamped-clamped leaf of
    length L about its midpoint moves its end by theta L/2 across the leaf, so (stiffness matrix
    [12 -6L; -6L 4L^2] EI/L^3) its shear force 12v/L^3 - 6theta/L^2 = 0 and its end moment is
    EI_k theta / L. Summed over the leaves: M = E I theta / L with I of Eq. (4.4), for any number of
    elements (each leaf is then a circular arc, which the co-rotational element represents exactly).
    Eq. (4.3)'s M_lin = 2 E I theta / L is therefore twice the small-angle stiffness: M/M_lin -> 0.5."""
    ratio, _ = _moment_ratio(n, 1e-4, dim)
    assert abs(ratio - 1.0) < 1e-5  # theta = 1e-4: the nonlinear term ~ theta^2/6 (reference) ~ 2e-9


def test_planar_and_spatial_models_agree():
    """The 2D model lumps the two outer leaves into one of width 2 w2: same in-plane stiffness."""
    for theta in np.radians([20.0, 75.0]):
        r2, s2 = _moment_ratio(3, theta, dim=2)
        r3, s3 = _moment_ratio(3, theta, dim=3)
        assert abs(r2 - r3) < 1e-9
        np.testing.assert_allclose(s3.displacement("B")[:2], s2.displacement("B"), atol=1e-12)


def test_spatial_model_has_no_out_of_plane_reaction():
    """Symmetric three-leaf layout (outer leaves at +-z): z force and tilting moments on B vanish."""
    _, sol = _moment_ratio(3, np.radians(60), dim=3)
    R = sol.reaction("B")
    assert np.abs(R[[2, 3, 4]]).max() < 1e-6 * abs(R[5])
    assert np.abs(R[[0, 1]]).max() < sol.tolerance  # free in x and y: the solver's tolerance (rtol x force scale)


@pytest.mark.parametrize("deg", [15, 45, 75])
def test_converges_to_the_inextensible_elastica_reference(deg):
    """The elastica reference (Wittrick 1948 model; flexmb.reference) has no axial or shear
    compliance. The FE moment converges as 1/n^2; Richardson-extrapolated from n = 12 and 24 it is
    within 1e-4 of the reference (t/L = 0.01: axial/shear effects ~ (t/L)^2 = 1e-4; measured
    -0.5e-5, -3.3e-5 and -6.7e-5 at 15, 45 and 75 degrees)."""
    theta = np.radians(deg)
    ref = cross_spring_pivot(theta, length=0.1, angle=np.pi / 4, bending_stiffness=(1.0, 1.0)).moment_ratio
    r6, r12, r24 = (_moment_ratio(n, theta)[0] for n in (6, 12, 24))
    assert abs(r6 - r12) > 3.5 * abs(r12 - r24)  # second order in n (4 for exact 1/n^2)
    extrapolated = (4 * r24 - r12) / 3
    assert abs(extrapolated / ref - 1.0) < 1e-4


def test_moment_grows_monotonically_towards_the_reference_with_elements():
    """Fig. 7(a): more elements per leaf -> lower normalised moment, approaching the reference."""
    theta = np.radians(75)
    ratios = [_moment_ratio(n, theta)[0] for n in range(1, 7)]
    assert all(a > b for a, b in zip(ratios, ratios[1:]))
    ref = cross_spring_pivot(theta, length=0.1, bending_stiffness=(1.0, 1.0)).moment_ratio
    assert ratios[-1] > ref


def test_table_1_defaults():
    """Table 1: L = 0.1 m, alpha = 45 deg, t = 1 mm, w1 = 0.04 m, w2 = 0.02 m, E = 200 GPa, G = 76.9 GPa."""
    j = flexmb.CrossFlexure()
    assert (j.length, j.angle, j.thickness, j.width_inner, j.width_outer, j.E, j.G) == (
        0.1, np.pi / 4, 1e-3, 0.04, 0.02, 200e9, 76.9e9)
    assert j.second_moment == pytest.approx((0.04 + 2 * 0.02) * 1e-9 / 12)  # Eq. (4.4)
    mesh = attrs.evolve(j, elements_per_leaf=3).mesh(3)
    assert len(mesh.elements) == 3 * 3  # three leaves, elements_per_leaf = 3
    assert j.elements_per_leaf == 24  # flexmb's default mesh, not Table 1's: tests/test_accuracy.py
