"""The ``three_x_infinity`` joint (issue 5; Dwarshuis et al. 2020, Sec. 4.4 and Fig. 1)."""

import numpy as np
import pytest

import flexmb
from flexmb import database as db
from flexmb.joint_characteristics import support_ratios
from flexmb.rotations import logm_so3
from flexmb.testing import joint_mechanism

J = flexmb.ThreeXInfinity(elements_per_leaf=3)  # the mesh of the shipped database and of docs/manipulator.md's numbers
DEG45 = np.radians(45.0)


def test_geometry_three_stages_on_one_axis():
    """27 flexible elements (Sec. 4.4: about 30) and two rigid intermediate bodies; every leaf
    crosses the z axis at its midpoint, so all stages turn about one axis."""
    mesh = J.mesh(3)
    assert J.flexible_elements == len(mesh.elements) == 27
    assert sorted(set(mesh.body.tolist())) == [-1, 0, 1]
    ends = mesh.points[mesh.elements]
    n = J.elements_per_leaf
    starts, stops = ends[::n, 0], ends[n - 1::n, 1]
    np.testing.assert_allclose((0.5 * (starts + stops))[:, :2], 0.0, atol=1e-15)
    np.testing.assert_allclose(J.interface_b(3), [0.0, 0.0, 2 * J.pitch])


def test_rotational_stiffness_at_rest_is_the_series_of_the_stages():
    """Linear cross-spring pivot, leaves crossing at their midpoints: K = E I / L per stage with
    I = (w1 + 2 w2) t^3 / 12 (the small-angle limit of Eq. 4.3, see the cross-flexure demo);
    three equal stages in series: K / 3 = 0.3375 N m/rad."""
    I = (J.width_inner + 2 * J.width_outer) * J.thickness**3 / 12
    assert support_ratios(J, 0.0)["k_rotation"] == pytest.approx(J.E * I / J.length / J.stages, rel=1e-9)


@pytest.mark.parametrize("deg", [-45.0, 45.0])
def test_reaches_45_degrees_below_600_mpa_with_equal_stages(deg):
    """+-45 deg (Sec. 4.4, Fig. 1: 90 deg range); peak normal stress 445 MPa < 600 MPa; equal
    stages in series under a pure moment share the rotation equally (1/3, 2/3 at the bodies)."""
    sol = flexmb.solve(joint_mechanism(J, 3, motion=np.radians(deg)))
    assert sol.converged, sol.message
    assert sol.peak_stress().max() == pytest.approx(445e6, rel=0.01)
    bodies = logm_so3(sol.state.rotations[sol.compiled.joint_nodes["joint"][:2]])
    np.testing.assert_allclose(np.degrees(bodies[:, 2]), [deg / 3, 2 * deg / 3], atol=1e-6)
    np.testing.assert_allclose(bodies[:, :2], 0.0, atol=1e-12)


@pytest.mark.parametrize("deg", [-45.0, -30.0, 0.0, 15.0, 30.0, 45.0])
def test_support_stiffness_stays_100_times_the_rotational_stiffness(deg):
    """Every unintended direction at least 100x as stiff as the rotation (translations as
    k D0^2 [N m], tilts [N m/rad]); the weakest is the tilt about y at +45 deg (104x) and about x
    at -45 deg (mirror image)."""
    r = support_ratios(J, np.radians(deg))
    assert min(r[k] for k in ("x", "y", "z", "tilt_x", "tilt_y")) >= 100.0


def test_database_follows_sec_4_4():
    """19 intended rotations from -45 to 45 deg; constraints, element and node rotations as
    fourth-order polynomials; the rigid bodies' orientations are in the node data."""
    data = db.shipped(J, 3)
    np.testing.assert_allclose(np.degrees(data.samples), np.arange(-45, 46, 5))
    assert len(data.samples) == 19
    assert data.function("x/D0").powers.max() == data.elements.powers.max() == 4
    assert data.elements.coefficients.shape[0] == 3 * 27
    assert data.elements.max_residual < 1e-6 and data.function("x/D0").max_residual < 1e-4


@pytest.mark.parametrize("deg, force", [(30.0, None), (45.0, None), (-40.0, (5.0, 2.0, -3.0))])
def test_ksd_full_converges_to_the_conventional_solution(deg, force):
    m = joint_mechanism(J, 3, motion=np.radians(deg), force=force)
    ref = flexmb.solve(m, method="conventional")
    ksd = flexmb.solve(m, method="ksd-full")
    assert ref.converged and ksd.converged
    assert ksd.residual_history[-1] < 5e-7
    np.testing.assert_allclose(ksd.node_positions(), ref.node_positions(), rtol=0,
                               atol=1e-8 * np.abs(ref.node_positions()).max())


def test_ksd_reduced_is_exact_without_unintended_load_and_close_with_it():
    """Pure intended rotation: no unintended motion, the EOB is the trained configuration (fit
    residuals 1e-7 rad). With a 5 N side load at -40 deg: B within 0.5 um (0.001 % of D0)."""
    for force, tol in ((None, 1e-9), ((5.0, 2.0, -3.0), 1e-6)):
        m = joint_mechanism(J, 3, motion=np.radians(-40.0), force=force)
        ref = flexmb.solve(m)
        red = flexmb.solve(m, method="ksd-reduced")
        assert red.converged
        assert np.abs(red.pose("B")[0] - ref.pose("B")[0]).max() < tol
