"""Co-rotational beam elements (Appendix A): tangent, energy, rigid-body and objectivity checks."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from flexmb.fe import beam2d, beam3d
from flexmb.rotations import expm_so3
from flexmb.sections import section_values, rectangle
from tolerances import FD_TANGENT

SECTION = rectangle(0.02, 1e-3, 200e9, 76.9e9)  # a Table 1 outer leaf
L0 = 0.05


def _config3d(seed, n=3, pos=0.01, rot=0.3):
    """Random deformed configurations of n elements (positions ~ pos [m], rotations ~ rot [rad])."""
    rng = np.random.default_rng(seed)
    Q = expm_so3(rng.normal(size=(n, 3)))  # random undeformed element orientations
    ny0, nz0 = Q[:, :, 1], Q[:, :, 2]
    xp = rng.normal(scale=0.1, size=(n, 3))
    xq = xp + L0 * Q[:, :, 0] + rng.normal(scale=pos, size=(n, 3))
    Rp = expm_so3(rng.normal(scale=rot, size=(n, 3))) @ np.eye(3)
    Rq = expm_so3(rng.normal(scale=rot, size=(n, 3)))
    S = beam3d.local_stiffness([SECTION] * n, np.full(n, L0))
    return xp, xq, Rp, Rq, ny0, nz0, np.full(n, L0), S


def _perturb3d(cfg, dq):
    xp, xq, Rp, Rq, *rest = cfg
    return (xp + dq[:, 0:3], xq + dq[:, 6:9], expm_so3(dq[:, 3:6]) @ Rp, expm_so3(dq[:, 9:12]) @ Rq, *rest)


@given(st.integers(0, 2**32 - 1))
def test_3d_tangent_matches_central_differences_in_deformed_configurations(seed):
    cfg = _config3d(seed)
    F, K, _, _ = beam3d.internal_force_and_tangent(*cfg)
    h = 1e-7
    Kfd = np.empty_like(K)
    for j in range(12):
        dq = np.zeros((3, 12))
        dq[:, j] = h
        Kfd[:, :, j] = (beam3d.internal_force(*_perturb3d(cfg, dq)) - beam3d.internal_force(*_perturb3d(cfg, -dq))) / (2 * h)
    assert np.abs(K - Kfd).max() <= FD_TANGENT * np.abs(K).max()


@given(st.integers(0, 2**32 - 1))
def test_3d_force_is_the_gradient_of_the_strain_energy(seed):
    """F = D^T S e (Eq. A.18) is dU/dq for U = e^T S e / 2."""
    cfg = _config3d(seed)
    F = beam3d.internal_force(*cfg)

    def energy(dq):
        _, _, e, s = beam3d.internal_force_and_tangent(*_perturb3d(cfg, dq), tangent=False)
        return 0.5 * np.einsum("ei,ei->e", e, s)

    h = 1e-7
    Ffd = np.stack([(energy(h * np.eye(12)[j] * np.ones((3, 1))) - energy(-h * np.eye(12)[j] * np.ones((3, 1)))) / (2 * h)
                    for j in range(12)], axis=1)
    assert np.abs(F - Ffd).max() <= FD_TANGENT * np.abs(F).max()


@given(st.integers(0, 2**32 - 1))
def test_3d_rigid_body_motion_gives_zero_internal_force(seed):
    rng = np.random.default_rng(seed)
    xp, xq, _, _, ny0, nz0, L, S = _config3d(seed, pos=0.0)
    Q = expm_so3(rng.normal(size=3))
    t = rng.normal(size=3)
    Rs = np.tile(Q, (3, 1, 1))
    F = beam3d.internal_force(xp @ Q.T + t, xq @ Q.T + t, Rs, Rs, ny0, nz0, L, S)
    # scale: axial stiffness EA/L0 times the roundoff of coordinates of size ~1
    assert np.abs(F).max() < 1e-15 * SECTION.E * SECTION.A / L0 * 10


@given(st.integers(0, 2**32 - 1))
def test_3d_objectivity_a_superposed_rotation_rotates_the_forces(seed):
    """x -> Q x, R -> Q R on a deformed state (same undeformed reference): F -> Q F."""
    cfg = _config3d(seed)
    Q = expm_so3(np.random.default_rng(seed + 1).normal(size=3))
    xp, xq, Rp, Rq, ny0, nz0, L, S = cfg
    F = beam3d.internal_force(*cfg).reshape(3, 4, 3)
    Fr = beam3d.internal_force(xp @ Q.T, xq @ Q.T, Q @ Rp, Q @ Rq, ny0, nz0, L, S).reshape(3, 4, 3)
    np.testing.assert_allclose(Fr, F @ Q.T, rtol=0, atol=1e-9 * np.abs(F).max())


@given(st.integers(0, 2**32 - 1))
def test_3d_internal_forces_are_self_equilibrated(seed):
    xp, xq, *_ = cfg = _config3d(seed)
    F = beam3d.internal_force(*cfg)
    fp, mp, fq, mq = F[:, 0:3], F[:, 3:6], F[:, 6:9], F[:, 9:12]
    scale = np.abs(F).max()
    np.testing.assert_allclose(fp + fq, 0, atol=1e-10 * scale)
    np.testing.assert_allclose(mp + mq + np.cross(xp, fp) + np.cross(xq, fq), 0, atol=1e-10 * scale)


def test_3d_tangent_is_symmetric_at_rest():
    cfg = _config3d(7, pos=0.0, rot=0.0)
    K = beam3d.internal_force_and_tangent(*cfg)[1]
    np.testing.assert_allclose(K, np.swapaxes(K, 1, 2), rtol=0, atol=1e-12 * np.abs(K).max())


def test_3d_small_displacement_stiffness_is_the_timoshenko_beam_matrix():
    """Closed form: the tip stiffness of a clamped Timoshenko beam, v = F L^3/(3EI) + F L/(k G A)."""
    L = np.array([L0])
    S = beam3d.local_stiffness([SECTION], L)
    I3 = np.eye(3)[None]
    K = beam3d.internal_force_and_tangent(np.zeros((1, 3)), np.array([[L0, 0, 0]]), I3, I3,
                                          np.array([[0, 1.0, 0]]), np.array([[0, 0, 1.0]]), L, S)[1][0]
    tip = np.linalg.inv(K[6:, 6:])  # node p clamped
    s = SECTION
    np.testing.assert_allclose(tip[1, 1], L0**3 / (3 * s.E * s.Iz) + L0 / (s.ky * s.G * s.A), rtol=1e-12)
    np.testing.assert_allclose(tip[2, 2], L0**3 / (3 * s.E * s.Iy) + L0 / (s.kz * s.G * s.A), rtol=1e-12)
    np.testing.assert_allclose(tip[0, 0], L0 / (s.E * s.A), rtol=1e-12)
    np.testing.assert_allclose(tip[3, 3], L0 / (s.G * s.It), rtol=1e-12)


def _second_difference(value, perturb, n_dofs, h1=1e-6, h2=1e-5):
    """(E, n, n): central differences of the central-difference gradient of ``value(cfg)`` (E,),
    ``perturb(cfg, dq)`` moving a configuration by increments ``dq`` (E, n) (spins for rotations)."""
    def gradient(cfg):
        return np.stack([(value(perturb(cfg, h1 * np.eye(n_dofs)[j] * np.ones((3, 1))))
                          - value(perturb(cfg, -h1 * np.eye(n_dofs)[j] * np.ones((3, 1))))) / (2 * h1)
                         for j in range(n_dofs)], axis=1)
    return lambda cfg: np.stack([(gradient(perturb(cfg, h2 * np.eye(n_dofs)[j] * np.ones((3, 1))))
                                  - gradient(perturb(cfg, -h2 * np.eye(n_dofs)[j] * np.ones((3, 1))))) / (2 * h2)
                                 for j in range(n_dofs)], axis=2)


@pytest.mark.parametrize("seed", range(3))
def test_3d_geometric_stiffness_of_given_stresses_is_the_second_derivative_of_the_deformations(seed):
    """``geometric_stress``: K with stresses sigma + w in its geometric part is the element tangent
    plus sum_i w_i d2 e_i / dq2 (Appendix A: K = D^T S D + sum_i sigma_i dD_i/dq), the second
    derivative taken by central differences of w . e along the spin update."""
    cfg = _config3d(seed)
    w = np.random.default_rng(seed + 100).normal(scale=1e3, size=(3, 6))
    K = beam3d.internal_force_and_tangent(*cfg)[1]
    Kw = beam3d.internal_force_and_tangent(*cfg, geometric_stress=lambda sigma: sigma + w)[1]
    Kfd = _second_difference(lambda c: np.einsum("ei,ei->e", beam3d.deformations(*c[:7]), w), _perturb3d, 12)(cfg)
    assert np.abs(Kw - K - Kfd).max() <= FD_TANGENT * np.abs(Kfd).max()
    np.testing.assert_array_equal(beam3d.internal_force_and_tangent(*cfg, geometric_stress=lambda sigma: sigma)[1], K)


def _config2d(seed, n=3):
    rng = np.random.default_rng(seed)
    a0 = rng.uniform(-np.pi, np.pi, n)
    xp = rng.normal(scale=0.1, size=(n, 2))
    xq = xp + L0 * np.stack([np.cos(a0), np.sin(a0)], 1) + rng.normal(scale=0.01, size=(n, 2))
    # node rotations up to +-2 rad: beyond the 3D element's arcsine domain, fine for the angle form
    return xp, xq, rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), a0, np.full(n, L0), beam2d.local_stiffness([SECTION] * n, np.full(n, L0))


@given(st.integers(0, 2**32 - 1))
def test_2d_tangent_matches_central_differences_in_deformed_configurations(seed):
    xp, xq, tp, tq, a0, L, S = _config2d(seed)
    F, K, _, _ = beam2d.internal_force_and_tangent(xp, xq, tp, tq, a0, L, S)

    def force(dq):
        return beam2d.internal_force_and_tangent(xp + dq[:, 0:2], xq + dq[:, 3:5], tp + dq[:, 2], tq + dq[:, 5], a0, L, S,
                                                 tangent=False)[0]

    h = 1e-7
    Kfd = np.stack([(force(h * np.eye(6)[j] * np.ones((3, 1))) - force(-h * np.eye(6)[j] * np.ones((3, 1)))) / (2 * h)
                    for j in range(6)], axis=2)
    assert np.abs(K - Kfd).max() <= FD_TANGENT * np.abs(K).max()
    np.testing.assert_allclose(K, np.swapaxes(K, 1, 2), rtol=0, atol=1e-12 * np.abs(K).max())


@pytest.mark.parametrize("seed", range(3))
def test_2d_geometric_stiffness_of_given_stresses_is_the_second_derivative_of_the_deformations(seed):
    """As the 3D test: K with sigma + w in its geometric part = K + sum_i w_i d2 e_i / dq2."""
    xp, xq, tp, tq, a0, L, S = _config2d(seed)
    w = np.random.default_rng(seed + 100).normal(scale=1e3, size=(3, 3))

    def perturb(c, dq):
        return (c[0] + dq[:, 0:2], c[1] + dq[:, 3:5], c[2] + dq[:, 2], c[3] + dq[:, 5])

    def work(c):
        e = beam2d.internal_force_and_tangent(*c, a0, L, S, tangent=False)[2]
        return np.einsum("ei,ei->e", e, w)

    K = beam2d.internal_force_and_tangent(xp, xq, tp, tq, a0, L, S)[1]
    Kw = beam2d.internal_force_and_tangent(xp, xq, tp, tq, a0, L, S, geometric_stress=lambda sigma: sigma + w)[1]
    Kfd = _second_difference(work, perturb, 6)((xp, xq, tp, tq))
    assert np.abs(Kw - K - Kfd).max() <= FD_TANGENT * np.abs(Kfd).max()


@pytest.mark.parametrize("seed", range(5))
def test_2d_element_is_the_planar_restriction_of_the_3d_element(seed):
    """Same section, same in-plane motion: the 3D element's in-plane forces equal the 2D ones."""
    xp, xq, tp, tq, a0, L, S2 = _config2d(seed)
    tp, tq = tp * 0.4, tq * 0.4  # stay inside the 3D arcsine domain
    F2 = beam2d.internal_force_and_tangent(xp, xq, tp, tq, a0, L, S2, tangent=False)[0]
    n = len(L)
    z = np.zeros((n, 1))
    Rz = lambda t: expm_so3(np.stack([0 * t, 0 * t, t], 1))  # noqa: E731
    ny0 = np.stack([-np.sin(a0), np.cos(a0), 0 * a0], 1)
    S3 = beam3d.local_stiffness([SECTION] * n, L)
    F3 = beam3d.internal_force(np.hstack([xp, z]), np.hstack([xq, z]), Rz(tp), Rz(tq), ny0,
                               np.tile([0, 0, 1.0], (n, 1)), L, S3)
    np.testing.assert_allclose(F3[:, [0, 1, 5, 6, 7, 11]], F2, rtol=1e-9, atol=1e-9 * np.abs(F2).max())
    np.testing.assert_allclose(F3[:, [2, 3, 4, 8, 9, 10]], 0, atol=1e-9 * np.abs(F2).max())


def test_section_properties_follow_the_element_order():
    """Each distinct section is read once; the table has one column per element, in order."""
    other = rectangle(0.01, 2e-3, 70e9, 26e9)
    E, A, Iz = section_values([SECTION, other, SECTION, other, other], ("E", "A", "Iz"))
    np.testing.assert_array_equal(E, [200e9, 70e9, 200e9, 70e9, 70e9])
    np.testing.assert_array_equal(A, [SECTION.A, other.A, SECTION.A, other.A, other.A])
    np.testing.assert_array_equal(Iz, [SECTION.Iz, other.Iz, SECTION.Iz, other.Iz, other.Iz])
    assert section_values([], ("E",)).shape == (1, 0)
