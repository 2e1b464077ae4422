"""Curved-beam joint (Cammarata et al. 2022, Eq. 2): closed-form compliance vs limits and flexmb's FE arc."""

import numpy as np
import pytest

import flexmb


def _beam(angle_deg=300.0, elements=16, **kw):
    # Table 1 of the paper in mm: r_f = 0.2, b = 0.025, h = 0.005; E = 100 GPa = 1e11 uN/mm^2
    return flexmb.CurvedBeam(radius=0.2, angle=np.radians(angle_deg), E=1e11, width=0.025, height=0.005,
                             elements=elements, **kw)


def test_eq2_tends_to_the_straight_cantilever():
    """r_f -> inf with r_f theta_f = L: C_f -> [[0, 0, 0], [0, L^3/3, L^2/2], [0, L^2/2, L]] / EI
    (Euler-Bernoulli cantilever; x is the end tangent, along which a bending-only arc is rigid).
    The largest correction is C_13 = r^2 (theta - sin theta) ~ L^3 theta / 6: 1.7e-4 L^3/EI at
    theta = 1e-3."""
    L = 1.0
    j = flexmb.CurvedBeam(radius=1e3, angle=L / 1e3, E=1.0, width=1.0, height=0.5)
    EI = j.bending_stiffness
    expected = np.array([[0, 0, 0], [0, L**3 / 3, L**2 / 2], [0, L**2 / 2, L]]) / EI
    np.testing.assert_allclose(j.compliance(), expected, rtol=0, atol=2e-4 * L**3 / EI)


@pytest.mark.parametrize("angle_deg", [30.0, 180.0, 250.0, 330.0])
def test_eq2_is_symmetric_positive_definite(angle_deg):
    C = _beam(angle_deg).compliance()
    np.testing.assert_array_equal(C, C.T)
    assert np.all(np.linalg.eigvalsh(C) > 0)


@pytest.mark.parametrize("angle_deg", [60.0, 250.0, 300.0, 330.0])
def test_eq2_equals_the_small_load_compliance_of_the_fe_arc(angle_deg):
    """Independent check of Eq. (2): flexmb's arc of straight co-rotational elements, clamped at B,
    loaded at A. Its linear compliance (inverse tangent at rest), Richardson-extrapolated from 128
    and 256 elements (chord error ~1/n^2), equals Eq. (2) mapped to global axes (x = end tangent
    -> +x, y = outward radius -> -y at node A) up to the axial and shear compliance Eq. (2)
    neglects, ~(h/r_f)^2 / 12 = 5e-5 of the bending terms."""

    def fe_compliance(n):
        beam = _beam(angle_deg, elements=n)
        m = flexmb.Mechanism(dim=2)
        m.add_link("A")
        m.add_link("B", position=beam.interface_b(2), fixed=True)
        m.add_joint("A", "B", beam)
        p = m.compile().problem
        K = p.evaluate(p.model.initial_state(), 0.0)[1].toarray()
        link_a = np.searchsorted(p.free, [0, 1, 2])  # link A's DOFs are 0, 1, 2 and free
        return np.linalg.inv(K)[np.ix_(link_a, link_a)]

    fe = (4 * fe_compliance(256) - fe_compliance(128)) / 3
    T = np.diag([1.0, -1.0, 1.0])
    closed_form = T @ _beam(angle_deg).compliance() @ T.T
    np.testing.assert_allclose(fe, closed_form, rtol=0, atol=2e-4 * np.abs(closed_form).max())


def test_curved_beam_is_planar_only():
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B")
    with pytest.raises(flexmb.UnsupportedStrategyError, match="curved_beam.*dim"):
        m.add_joint("A", "B", _beam())


@pytest.mark.parametrize("params, name", [
    (dict(angle=0.0), "angle"), (dict(angle=2 * np.pi), "angle"), (dict(angle=7.0), "angle"),
    (dict(radius=0.0), "radius"), (dict(radius=-1.0), "radius"), (dict(width=0.0), "width"),
    (dict(height=-0.005), "height"), (dict(E=float("nan")), "E"),
])
def test_bad_curved_beam_parameters_name_the_parameter(params, name):
    base = dict(radius=0.2, angle=np.radians(300), E=1e11, width=0.025, height=0.005)
    with pytest.raises(flexmb.ParameterError, match=name):
        flexmb.CurvedBeam(**{**base, **params})


def test_large_rotation_of_the_fe_arc_converges():
    """The FE arc is fully non-linear: a 30-degree end rotation under a pure moment converges."""
    beam = _beam(300.0, elements=24)
    m = flexmb.Mechanism(dim=2)
    m.add_link("A")
    m.add_link("B", position=beam.interface_b(2), fixed=True)
    m.add_joint("A", "B", beam)
    m.apply_moment("A", np.radians(30) / beam.compliance()[2, 2])
    sol = flexmb.solve(m, tol=1e-6 * beam.bending_stiffness)
    assert sol.converged, sol.message
    # a pure moment bends every element uniformly: end rotation = M x (sum of chord lengths) / EI,
    # the arc's r theta (C33) shortened to the polygon's 2 r n sin(theta / 2n) (0.2 % here)
    n, t = 24, beam.angle
    expected = np.radians(30) * 2 * n * np.sin(t / (2 * n)) / t
    assert abs(sol.pose("A")[1] - expected) < 1e-6


def test_through_places_the_arc_on_its_hinge_centre_and_attachment_points():
    """Table 1 hinge a: centre (0.5, 0), attachments on body 1 (0.6848, 0.0765) and body 2
    (G2 + s_2a = (0.6587, -0.1218)): radius 0.2 mm, 300 degrees counter-clockwise."""
    beam, placement = flexmb.CurvedBeam.through((0.5, 0.0), (0.6848, 0.0765), (0.6587, -0.1218),
                                                E=1e11, width=0.025, height=0.005)
    assert abs(beam.radius - 0.2) < 1e-4 and abs(np.degrees(beam.angle) - 300.0) < 0.1
    m = flexmb.Mechanism(dim=2)
    m.add_link("one", fixed=True)
    m.add_link("two", position=(1.5, 0.2))
    m.add_joint("one", "two", beam, **placement)
    x = m.compile().problem.model.point_x0
    np.testing.assert_allclose(np.linalg.norm(x[2:] - [0.5, 0.0], axis=1), beam.radius, rtol=1e-12)
    np.testing.assert_allclose(x[-1], [0.6587, -0.1218], atol=2e-4)  # ends where Table 1 says


def test_through_reports_inconsistent_attachment_points_and_by_how_much():
    with pytest.raises(flexmb.ParameterError, match=r"inconsistent with one radius by \+0.05"):
        flexmb.CurvedBeam.through((0.0, 0.0), (0.2, 0.0), (0.0, 0.25), E=1e11, width=0.025, height=0.005)


def test_gripper_geometry_matches_table_1_and_rests_in_equilibrium():
    m = flexmb.models.gripper()
    assert sorted(m.joints) == ["a", "b", "c", "d"]
    angles = [np.degrees(m.joints[h].angle) for h in "abcd"]
    np.testing.assert_allclose(angles, [300, 320, 330, 250], atol=0.5)  # Table 1
    sol = flexmb.solve(m)
    assert sol.converged and sol.iterations <= 1
    np.testing.assert_allclose(sol.point("body3", "end_effector"), [1.8 - 1.3571, 1.5 + 1.6991], atol=1e-12)


def test_gripper_fe_closing_force_scales_with_youngs_modulus():
    """Rigid bodies + elastic beams of one material: the equilibrium depends on F / E only, so the
    closing force (end-effector x = 0) of nylon is exactly 3.84/100 of silicon's (Sec. 5.1 moduli)."""
    from scipy.optimize import brentq

    def closing(material, hi):
        def x(F):
            return flexmb.solve(flexmb.models.gripper(material, force=F, elements=8),
                                raise_on_failure=True).point("body3", "end_effector")[0]
        return brentq(x, 0.0, hi, xtol=1e-9 * hi)

    si = closing("silicon", 200.0)
    ny = closing("nylon", 200.0 * 0.0384)
    assert 60.0 < si < 80.0  # measured: 71.96 uN at 8 elements/beam, 69.85 uN extrapolated
    assert abs(ny / si - 0.0384) < 1e-6


@pytest.mark.parametrize("angle", [1e-3, 3e-2, 0.3, 0.4999, 0.5001])
def test_eq2_is_evaluated_without_cancellation_at_small_angles(angle):
    """6t + sin2t - 8 sin t = t^5/5 - t^7/42 + t^9/720 - ... (Taylor): evaluated directly it
    cancels to zero below ~1e-4 rad (review), so flexmb sums the series below 0.5 rad. Reference:
    the three-term series below 0.05 rad (truncation < 1e-12 relative), the direct formula above
    (cancellation error 40 eps / t^4 < 1e-9 relative)."""
    j = flexmb.CurvedBeam(radius=1.0, angle=angle, E=12.0, width=1.0, height=0.1)
    C00 = j.compliance()[0, 0] * j.bending_stiffness * 4
    t = angle
    reference = t**5 / 5 - t**7 / 42 + t**9 / 720 if t < 0.05 else 6 * t + np.sin(2 * t) - 8 * np.sin(t)
    assert C00 == pytest.approx(reference, rel=1e-9)
    assert np.all(np.linalg.eigvalsh(j.compliance()) > 0)


def test_too_small_an_angle_for_the_bending_only_closed_form_is_a_parameter_error():
    j = flexmb.CurvedBeam(radius=1.0, angle=1e-4, E=12.0, width=1.0, height=0.1)
    with pytest.raises(flexmb.ParameterError, match="angle.*too small"):
        j.stiffness()
