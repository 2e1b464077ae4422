"""Mass matrices and vibration modes (`flexmb.fe.mass`, `flexmb.modes`): closed forms, convergence
rates, invariants, conventions and bad input. Each reference value names its source."""

import math

import attrs
import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

import flexmb
from flexmb.fe.mass import local_mass, mass_matrix
from flexmb.modal import stiffness_and_mass
from flexmb.rotations import expm_so3, skew

STEEL = dict(E=200e9, G=76.9e9)
RHO = 7800.0
#: Euler-Bernoulli cantilever: roots of cos(bL) cosh(bL) = -1 (Blevins 1979, Table 8-1; Rao,
#: Vibration of Continuous Systems, Table 11.3), to 9 digits.
BETA_L = np.array([1.87510407, 4.69409113, 7.85475744])


def _leaf_mechanism(dim, elements, section=None, length=1.0, width=0.01, thickness=1e-4, density=RHO,
                    tip_mass=0.0, tip_inertia=None, Q=None, origin=None):
    """Link "g" fixed at ``origin``, a leaf spring to link "tip" along Q's x axis."""
    Q = np.eye(dim) if Q is None else Q
    origin = np.zeros(dim) if origin is None else np.asarray(origin, float)
    m = flexmb.Mechanism(dim=dim)
    m.add_link("g", position=origin, fixed=True)
    m.add_link("tip", position=origin + Q[:, 0] * length, mass=tip_mass, inertia=tip_inertia)
    sizes = dict(width=width, thickness=thickness) if section is None else {}  # else the section's
    leaf = flexmb.joint("leaf_spring", length=length, elements=elements, density=density, section=section,
                        **sizes, **STEEL)
    rot = None if Q is None else (math.atan2(Q[1, 0], Q[0, 0]) if dim == 2 else Q)
    m.add_joint("g", "tip", leaf, name="leaf", origin=origin, rotation=rot)
    return m


def _euler_bernoulli(width, thickness):
    s = flexmb.rectangle(width, thickness, density=RHO, **STEEL)
    return attrs.evolve(s, ky=np.inf, kz=np.inf)  # no shear deformation


def _dominant(modes):
    """Index of the dominant DOF kind of every mode: 0 axial x, 1 in-plane y, 2 out-of-plane z, 3 twist."""
    energy = (modes.shapes ** 2).sum(axis=1)
    return np.argmax(energy[:, :4], axis=1)


# -- element mass matrices ------------------------------------------------------------------
def test_element_mass_is_przemieniecki_euler_bernoulli_with_rotary_inertia():
    """phi = 0: Przemieniecki (1968), Eqs. 11.29-11.31 (Cook et al. 2002, Eq. 11.3-5 + rotary part):
    rho A L/420 [156, 22L, 54, -13L; ...] + rho I/(30 L) [36, 3L, -36, 3L; ...]."""
    L, rho, A, Iy, Iz = 0.7, 3.0, 2.0, 0.8, 0.5
    s = flexmb.Section(E=1.0, G=1.0, A=A, Iy=Iy, Iz=Iz, It=1.0, ky=np.inf, kz=np.inf, density=rho)

    def bending(I):
        return rho * A * L / 420 * np.array([[156, 22 * L, 54, -13 * L], [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                                             [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L**2, -22 * L, 4 * L**2]]) \
            + rho * I / (30 * L) * np.array([[36, 3 * L, -36, 3 * L], [3 * L, 4 * L**2, -3 * L, -L**2],
                                            [-36, -3 * L, 36, -3 * L], [3 * L, -L**2, -3 * L, 4 * L**2]])

    bar = rho * A * L / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])
    M2 = local_mass([s], np.array([L]), 2)[0]
    np.testing.assert_allclose(M2[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])], bending(Iz), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(M2[np.ix_([0, 3], [0, 3])], bar, rtol=1e-13)
    M3 = local_mass([s], np.array([L]), 3)[0]
    np.testing.assert_allclose(M3[np.ix_([1, 5, 7, 11], [1, 5, 7, 11])], bending(Iz), rtol=1e-13, atol=1e-15)
    flip = np.diag([1.0, -1.0, 1.0, -1.0])  # theta_y = -dw/dx
    np.testing.assert_allclose(M3[np.ix_([2, 4, 8, 10], [2, 4, 8, 10])], flip @ bending(Iy) @ flip, rtol=1e-13,
                               atol=1e-15)
    np.testing.assert_allclose(M3[np.ix_([3, 9], [3, 9])], rho * (Iy + Iz) * L / 6 * np.array([[2, 1], [1, 2]]),
                               rtol=1e-13)
    assert np.allclose(M3, M3.T, rtol=0, atol=1e-15)


def test_element_mass_with_shear_is_przemieniecki_timoshenko():
    """phi > 0: Przemieniecki (1968), Sec. 11.5 (Timoshenko beam with rotary inertia; the same
    matrices as Friedman & Kosmatka 1993, Eq. 19), written out here independently."""
    L, rho, A, I, phi = 0.3, 2.0, 1.5, 0.2, 0.37
    E = 1.0
    G = 12 * E * I / (phi * A * L**2)  # k = 1
    s = flexmb.Section(E=E, G=G, A=A, Iy=I, Iz=I, It=1.0, ky=1.0, kz=1.0, density=rho)
    c = 1.0 / (1 + phi) ** 2
    a = 13 / 35 + 7 * phi / 10 + phi**2 / 3
    b = (11 / 210 + 11 * phi / 120 + phi**2 / 24) * L
    cc = 9 / 70 + 3 * phi / 10 + phi**2 / 6
    d = (13 / 420 + 3 * phi / 40 + phi**2 / 24) * L
    e = (1 / 105 + phi / 60 + phi**2 / 120) * L**2
    f = (1 / 140 + phi / 60 + phi**2 / 120) * L**2
    Mt = rho * A * L * c * np.array([[a, b, cc, -d], [b, e, d, -f], [cc, d, a, -b], [-d, -f, -b, e]])
    g = (1 / 10 - phi / 2) * L
    h = (2 / 15 + phi / 6 + phi**2 / 3) * L**2
    k = (-1 / 30 - phi / 6 + phi**2 / 6) * L**2
    Mr = rho * I / L * c * np.array([[6 / 5, g, -6 / 5, g], [g, h, -g, k], [-6 / 5, -g, 6 / 5, -g], [g, k, -g, h]])
    M2 = local_mass([s], np.array([L]), 2)[0]
    np.testing.assert_allclose(M2[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])], Mt + Mr, rtol=1e-12, atol=1e-15)


# -- cantilever closed forms and convergence rates -----------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_cantilever_bending_frequencies_converge_at_fourth_order(dim):
    """f_n = (beta_n L)^2/(2 pi) sqrt(EI/(rho A L^4)), beta_n L = 1.8751, 4.6941, 7.8548 (Euler-
    Bernoulli; Blevins 1979 Table 8-1). Cubic Hermite (consistent-mass) elements: eigenvalue error
    O(h^4) from above (Strang & Fix 1973, Sec. 6.3). L/t = 1e4 so rotary inertia (~1e-9) is below
    the errors measured; observed orders at 8 -> 16 elements: 4.03, 3.97, 3.94."""
    w, t, L = 0.01, 1e-4, 1.0
    s = _euler_bernoulli(w, t)
    exact = BETA_L**2 / (2 * np.pi) * np.sqrt(s.E * s.Iz / (RHO * s.A * L**4))
    errors = []
    for n_el in (4, 8, 16):
        md = flexmb.modes(flexmb.solve(_leaf_mechanism(dim, n_el, section=s)), n_modes=8, held="fixed")
        f = md.frequencies if dim == 2 else md.frequencies[_dominant(md) == 1]
        errors.append(f[:3] / exact - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)  # Rayleigh-Ritz: from above
    assert np.all(errors[-1] < [2e-7, 1e-5, 1e-4])
    order = np.log2(errors[1] / errors[2])
    assert np.all((order > 3.8) & (order < 4.2)), order


def test_cantilever_torsion_and_axial_frequencies_converge_at_second_order():
    """Torsion f_n = (2n-1)/(4L) sqrt(G I_t/(rho I_p)), I_p = Iy + Iz; axial f_n = (2n-1)/(4L)
    sqrt(E/rho) (Rao, Vibration of Continuous Systems, Eqs. 9.64 and 8.92, fixed-free). Linear
    interpolation with consistent mass: O(h^2) from above. Observed 2.00 and 2.00 (8 -> 16)."""
    w, t, L = 0.01, 0.004, 0.05  # a stubby bar: torsion and axial modes among the lowest
    s = flexmb.rectangle(w, t, density=RHO, **STEEL)
    f_tor = np.array([1, 3]) / (4 * L) * np.sqrt(s.G * s.It / (RHO * (s.Iy + s.Iz)))
    f_ax = np.array([1, 3]) / (4 * L) * np.sqrt(s.E / RHO)
    err_t, err_a = [], []
    for n_el in (8, 16):
        md = flexmb.modes(flexmb.solve(_leaf_mechanism(3, n_el, section=s, length=L)), n_modes=40, held="fixed")
        kind = _dominant(md)
        err_t.append(md.frequencies[kind == 3][:2] / f_tor - 1)
        err_a.append(md.frequencies[kind == 0][:2] / f_ax - 1)
    for err in (np.array(err_t), np.array(err_a)):
        assert np.all(err > 0)
        order = np.log2(err[0] / err[1])
        assert np.all((order > 1.9) & (order < 2.1)), order
        assert np.all(err[-1] < 2e-2)


def _timoshenko_cantilever(s, L, guesses):
    """Exact natural frequencies [Hz] of a Timoshenko cantilever (Timoshenko 1921; the clamped-
    free frequency equation of Han, Benaroya & Wei 2000, J. Sound Vib. 225, Sec. 5), here from
    the ODE itself: ``rho A w_tt = kGA (w' - psi)'``, ``rho I psi_tt = EI psi'' + kGA (w' - psi)``,
    w = psi = 0 at x = 0, psi' = w' - psi = 0 at x = L; the transfer matrix over L is a matrix
    exponential (constant coefficients), the root of the 2x2 end determinant by brentq."""
    E, G, A, I, k, rho = s.E, s.G, s.A, s.Iz, s.ky, s.density

    def det(f):
        w2 = (2 * np.pi * f) ** 2
        # y = [w, w', psi, psi']
        Amat = np.array([[0, 1, 0, 0],
                         [-rho * A * w2 / (k * G * A), 0, 0, 1],
                         [0, 0, 0, 1],
                         [0, -k * G * A / (E * I), -(rho * I * w2 - k * G * A) / (E * I), 0]])
        Y = sla.expm(Amat * L)[:, [1, 3]]  # free initial values w'(0), psi'(0)
        ends = np.array([Y[3], Y[1] - Y[2]])  # psi'(L), w'(L) - psi(L)
        return np.linalg.det(ends)

    return np.array([brentq(det, 0.97 * g, 1.03 * g, xtol=1e-12, rtol=1e-13) for g in guesses])


def test_thick_cantilever_gets_the_timoshenko_correction():
    """L/h = 5: shear and rotary inertia lower the first three frequencies by 1.5-17 % from Euler-
    Bernoulli; Timoshenko elements with the Timoshenko-consistent mass converge to the exact
    Timoshenko solution (`_timoshenko_cantilever`) at second order (measured 2.006, 2.002, 2.000
    from 16 to 32 elements; errors at 32: 4.8e-6, 1.3e-4, 7.4e-4; the shear-dominated short
    elements lose the fourth order of the slender beam)."""
    L, w, h = 0.05, 0.002, 0.01  # bending in the plane of h: the 2D model
    s = flexmb.rectangle(w, h, density=RHO, **STEEL)
    errors = []
    for n_el in (16, 32):
        md = flexmb.modes(flexmb.solve(_leaf_mechanism(2, n_el, section=s, length=L)), n_modes=6, held="fixed")
        bend = md.frequencies[np.argmax((md.shapes ** 2).sum(axis=1)[:, :2], axis=1) == 1][:3]
        exact = _timoshenko_cantilever(s, L, bend)
        errors.append(bend / exact - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)
    assert np.all(errors[1] < [1e-5, 3e-4, 1.5e-3]), errors
    order = np.log2(errors[0] / errors[1])
    assert np.all((order > 1.9) & (order < 2.1)), order
    eb = BETA_L**2 / (2 * np.pi) * np.sqrt(s.E * s.Iz / (RHO * s.A * L**4))
    assert np.all(exact / eb - 1 < [-0.01, -0.08, -0.15])  # the correction is large here


# -- rigid bodies -------------------------------------------------------------------------
def _parallel_guide(scale=1.0, force_unit=1.0, mass_unit=1.0, mass=0.5, inertia=2e-4, density=0.0, elements=1):
    """Stage "s" (mass, inertia about its centre) on two parallel leaves (one element each) from
    ground "g", leaves along y at x = +-a; lengths in units of ``scale`` m, forces of
    ``force_unit`` N, masses of ``mass_unit`` kg (e.g. mm, mN, kg: 1e-3, 1e-3, 1)."""
    L, w, t, a = 0.05 / scale, 0.01 / scale, 2e-4 / scale, 0.02 / scale
    E, G = 200e9 * scale**2 / force_unit, 76.9e9 * scale**2 / force_unit
    m = flexmb.Mechanism(dim=2)
    m.add_link("g", fixed=True)
    m.add_link("s", position=(0.0, L), mass=mass / mass_unit, inertia=inertia / mass_unit / scale**2)
    for x in (-a, a):
        leaf = flexmb.LeafSpring(length=L, width=w, thickness=t, E=E, G=G,
                                 density=density * scale**3 / mass_unit, elements=elements)
        m.add_joint("g", "s", leaf, origin=(x, 0.0), rotation=np.pi / 2)
    return m, leaf


def test_rigid_body_on_massless_springs():
    """A 0.5 kg stage on two massless leaves (one element each: no internal node), each held DOF
    set leaving single-DOF oscillators, f = sqrt(k/m)/(2 pi) with closed-form stiffnesses (one
    Timoshenko element is exact for them): stage rotation held: x, fixed-guided k = 2 * 12 EI /
    (L^3 (1 + phi)); x held: y, axial k = 2 EA/L (J = 1e-4 kg m^2, the rotation higher), or the
    rotation about the stage's centre, k = 2 (EA a^2 + EI (4 + phi)/(1 + phi)) / L (J = 4e-4,
    lower; y and rotation uncouple by symmetry)."""
    for J in (1e-4, 4e-4):
        mech, leaf = _parallel_guide(inertia=J)
        sol = flexmb.solve(mech)
        s, L, a = leaf.cross_section(), leaf.length, 0.02
        phi = 12 * s.E * s.Iz / (s.ky * s.G * s.A * L**2)
        k_x = 2 * 12 * s.E * s.Iz / (L**3 * (1 + phi))
        k_y = 2 * s.E * s.A / L
        k_rot = 2 * (s.E * s.A * a**2 + s.E * s.Iz * (4 + phi) / (1 + phi)) / L
        md = flexmb.modes(sol, n_modes=1, held=[("s", "rotation")])
        np.testing.assert_allclose(md.frequencies, np.sqrt(k_x / 0.5) / (2 * np.pi), rtol=1e-10)
        assert md.link_shapes["s"][0] == pytest.approx([1 / np.sqrt(0.5), 0.0, 0.0], abs=1e-9)  # m phi^2 = 1
        md = flexmb.modes(sol, n_modes=1, held=[("s", "x")])
        expected = np.sqrt(k_y / 0.5) if J == 1e-4 else np.sqrt(k_rot / J)
        np.testing.assert_allclose(md.frequencies, expected / (2 * np.pi), rtol=1e-10)


def test_parallel_guide_in_mm_mN_kg_units_gives_the_same_frequencies():
    """A case no paper contains: the guide with steel leaves (density 7800 kg/m^3, 4 elements per
    leaf) in mm, mN and kg (consistent: 1 mN = 1 kg mm/s^2; E in mN/mm^2 = kPa, density in
    kg/mm^3) has the same frequencies [Hz] as in SI."""
    si = flexmb.modes(flexmb.solve(_parallel_guide(density=RHO, elements=4)[0]), n_modes=6, held="fixed")
    mm = flexmb.modes(flexmb.solve(_parallel_guide(scale=1e-3, force_unit=1e-3, density=RHO, elements=4)[0]),
                      n_modes=6, held="fixed")
    np.testing.assert_allclose(mm.frequencies, si.frequencies, rtol=1e-9)
    # shapes normalised by phi^T M phi = 1 with M in kg: the translations' numbers (per unit of
    # the modal coordinate, kg^1/2 times the length unit) do not depend on the length unit
    np.testing.assert_allclose(np.abs(mm.link_shapes["s"][:, :2]), np.abs(si.link_shapes["s"][:, :2]), rtol=1e-6,
                               atol=1e-9 * np.abs(si.link_shapes["s"][:, :2]).max())


def _pivot(rotation_deg, elements=5, mass=1.0, J=1e-3, density=RHO, Q=None, origin=None):
    """Dwarshuis et al. (2020) Table 1 cross flexure, block B of ``mass`` [kg] and inertia J I
    [kg m^2] about its centre (= interface node B), A fixed, B turned about the joint's z."""
    Q = np.eye(3) if Q is None else Q
    origin = np.zeros(3) if origin is None else origin
    joint = flexmb.CrossFlexure(elements_per_leaf=elements, density=density)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", position=origin, fixed=True)
    m.add_link("B", position=origin + Q @ joint.interface_b(3), mass=mass, inertia=Q @ (J * np.eye(3)) @ Q.T)
    m.add_joint("A", "B", joint, name="pivot", origin=origin, rotation=Q)
    m.prescribe("B", rotation=np.radians(rotation_deg) * Q[:, 2])
    return m


def test_total_mass_and_inertia_equal_the_sum_of_the_parts():
    """The consistent mass reproduces rigid-body kinetic energy exactly: for a rigid velocity
    (v, omega) of every node, 1/2 u^T M u gives the total mass and the inertia tensor about the
    origin, which must equal the sum of the leaves (boxes L x w x t: m (a^2 + b^2)/12 about
    their centres) and the links (J + m (|c|^2 I - c c^T), parallel axes) exactly."""
    joint = flexmb.CrossFlexure(elements_per_leaf=4, density=RHO, gap=1e-3)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True, mass=0.3, inertia=np.diag([1e-4, 2e-4, 2.5e-4]), center=(0.01, -0.02, 0.0))
    JB = np.array([[2e-3, 1e-4, 0.0], [1e-4, 1e-3, 0.0], [0.0, 0.0, 2.5e-3]])
    cB = np.array([0.0, 0.03, 0.01])
    m.add_link("B", position=joint.interface_b(3), mass=1.2, inertia=JB, center=cB)
    m.add_joint("A", "B", joint, name="pivot", origin=(0.0, 0.0, 0.0))
    compiled = m.compile()
    model = compiled.problem.model
    M = mass_matrix(model, model.initial_state(), model.rigid_masses).toarray()
    V = _rigid_velocities(model)
    MR = V.T @ M @ V
    total = 0.0
    inertia = np.zeros((3, 3))
    centre_sum = np.zeros(3)

    def add(mass, J, c):
        nonlocal total, inertia, centre_sum
        total += mass
        centre_sum += mass * c
        inertia += J + mass * (c @ c * np.eye(3) - np.outer(c, c))

    add(0.3, np.diag([1e-4, 2e-4, 2.5e-4]), np.array([0.01, -0.02, 0.0]))
    add(1.2, JB, joint.interface_b(3) + cB)
    for start, end, width in joint.leaves(3):
        ex = (end - start) / np.linalg.norm(end - start)
        ez = np.array([0.0, 0.0, 1.0])  # width
        ey = np.cross(ez, ex)  # thickness
        mass = RHO * joint.length * width * joint.thickness
        R = np.stack([ex, ey, ez], axis=1)
        Jloc = mass / 12 * np.diag([width**2 + joint.thickness**2, joint.length**2 + width**2,
                                    joint.length**2 + joint.thickness**2])
        add(mass, R @ Jloc @ R.T, 0.5 * (start + end))
    np.testing.assert_allclose(MR[:3, :3], total * np.eye(3), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(MR[3:, 3:], inertia, rtol=1e-12, atol=1e-12 * np.abs(inertia).max())
    # first moment: m c x
    np.testing.assert_allclose(MR[:3, 3:], -skew(centre_sum), rtol=1e-12, atol=1e-15)


# -- invariants -----------------------------------------------------------------------------
def test_mass_symmetric_positive_definite_and_rayleigh_quotients():
    """M is symmetric positive definite on the free DOFs; K phi = lambda M phi, and each mode's
    Rayleigh quotient phi^T K phi / phi^T M phi equals omega^2 (symmetric and non-symmetric cases)."""
    sol = flexmb.solve(_pivot(60.0, elements=3))
    K, M = stiffness_and_mass(sol)
    for held in ("prescribed", [("B", "rz")], "fixed"):
        md = flexmb.modes(sol, n_modes=6, held=held)
        free = np.setdiff1d(np.arange(K.shape[0]), md.held)
        Kf, Mf = K.toarray()[np.ix_(free, free)], M.toarray()[np.ix_(free, free)]
        assert np.array_equal(Mf, Mf.T)
        assert np.linalg.eigvalsh(Mf).min() > 0
        phi = md.shapes.reshape(6, -1)[:, free].T
        pMp = phi.T @ Mf @ phi
        # mass-normalised; M-orthogonal when symmetric (a non-symmetric K's right vectors are not)
        np.testing.assert_allclose(pMp if md.symmetric else np.diag(pMp), np.eye(6) if md.symmetric else 1.0,
                                   atol=1e-9)
        omega2 = np.einsum("ik,ik->k", phi, Kf @ phi)
        np.testing.assert_allclose(omega2, (2 * np.pi * md.frequencies) ** 2, rtol=1e-8)
        res = Kf @ phi - Mf @ phi * omega2
        assert np.abs(res).max() < 1e-8 * np.abs(Kf @ phi).max()


def test_frequencies_unchanged_by_a_rigid_move_of_the_whole_mechanism():
    """Frame indifference: the pivot turned by 40 deg about a skew axis and shifted gives the same
    frequencies at 45 deg, B's rotation about the joint axis held or not."""
    Q = expm_so3(np.radians(40.0) * np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5]))
    origin = np.array([0.3, -0.1, 0.2])
    ref = flexmb.solve(_pivot(45.0, elements=3))
    moved = flexmb.solve(_pivot(45.0, elements=3, Q=Q, origin=origin))
    for held in ("prescribed", "fixed"):
        a, b = flexmb.modes(ref, n_modes=6, held=held), flexmb.modes(moved, n_modes=6, held=held)
        np.testing.assert_allclose(b.frequencies, a.frequencies, rtol=1e-7)
        # B's shapes turn with the mechanism
        for k in range(6):
            sa, sb = a.link_shapes["B"][k], b.link_shapes["B"][k]
            np.testing.assert_allclose(np.abs(sb[:3]), np.abs(Q @ sa[:3]), atol=1e-6 * np.abs(a.shapes[k]).max())


def test_releasing_everything_gives_the_rigid_body_zero_modes():
    """held="floating" (nothing held, the unsupported mechanism): exactly 6 zero modes in 3D and 3
    in 2D (rigid-body motions: no strain, no load), the next frequency clearly positive."""
    for dim, zeros in ((2, 3), (3, 6)):
        sol = flexmb.solve(_leaf_mechanism(dim, 4, length=0.1, thickness=1e-3, tip_mass=0.1,
                                           tip_inertia=1e-5 if dim == 2 else 1e-5 * np.eye(3)))
        md = flexmb.modes(sol, n_modes=zeros + 1, held="floating")
        assert np.all(np.abs(md.frequencies[:zeros]) < 1e-4 * md.frequencies[zeros]), md.frequencies
        assert md.frequencies[zeros] > 1.0


def test_modes_of_ksd_full_equal_conventional():
    """KSD-full reaches the same equilibrium as the conventional method (to its tolerance), so
    the same modes (Dwarshuis et al. 2020, step 5 is the full model)."""
    m = _pivot(30.0, elements=3)
    a = flexmb.modes(flexmb.solve(m, method="conventional"), n_modes=6)
    b = flexmb.modes(flexmb.solve(m, method="ksd-full"), n_modes=6)
    np.testing.assert_allclose(b.frequencies, a.frequencies, rtol=1e-6)
    # KSD-reduced (issue 22 item 6, tests/test_ksd_properties.py): the reduced mechanism's modes,
    # measured within 0.27 % of these six (the joint's Craig-Bampton mass, 6 fixed-interface modes)
    c = flexmb.modes(flexmb.solve(m, method="ksd-reduced"), n_modes=6)
    np.testing.assert_allclose(c.frequencies, a.frequencies, rtol=5e-3)


# -- conventions ----------------------------------------------------------------------------
def test_a_dead_moment_leaves_half_its_skew_matrix_in_the_tangent():
    """Spin coordinates: at a link held by a dead moment m (here B's reaction at 75 deg, kept
    when its rotation is released), the tangent's rotation block has the skew part -1/2 skew(m)
    (the internal moments balance m there); `modes` then solves the non-symmetric problem, and
    dropping the skew part (symmetrising) moves the first parasitic mode, by 0.05-1 %."""
    sol = flexmb.solve(_pivot(75.0, elements=3))
    K, M = stiffness_and_mass(sol)
    b = sol.compiled.link_node["B"] * 6 + np.arange(3, 6)
    Kr = K.toarray()[np.ix_(b, b)]
    m = sol.reaction("B")[3:]
    assert np.linalg.norm(m) > 1.0  # the moment that holds 75 deg [N m]
    np.testing.assert_allclose(0.5 * (Kr - Kr.T), -0.5 * skew(m), atol=1e-9 * np.linalg.norm(m))
    md = flexmb.modes(sol, n_modes=2, held=[("B", "rz")])
    assert not md.symmetric
    free = np.setdiff1d(np.arange(K.shape[0]), md.held)
    Kf, Mf = K.toarray()[np.ix_(free, free)], M.toarray()[np.ix_(free, free)]
    sym = np.sqrt(sla.eigh(0.5 * (Kf + Kf.T), Mf, eigvals_only=True, subset_by_index=[0, 0])) / (2 * np.pi)
    shift = sym[0] / md.frequencies[0] - 1
    assert 5e-4 < abs(shift) < 1e-2, shift
    # with everything prescribed held, no free rotation carries a dead moment: symmetric
    assert flexmb.modes(sol, n_modes=2).symmetric


def test_mass_is_taken_at_the_deformed_configuration():
    """A massless-tip cantilever curled by an end moment M = pi EI/L into a half circle of radius
    L/pi: its rigid-rotation inertia about the clamp, from the consistent mass at that state,
    tends to the arc's rho A int |x|^2 ds + rho I_z L = rho A L^3 (2/pi^2) + rho Iz L
    (closed form of the semicircle from its end); the cubic elements' geometry converges at fourth
    order (measured 1.0e-4 and 6.2e-6 at 8 and 16 elements: 4.007)."""
    L, w, t = 1.0, 0.01, 1e-3
    s = _euler_bernoulli(w, t)
    errors = []
    for n in (8, 16):
        mech = _leaf_mechanism(2, n, section=s, length=L)
        mech.apply_moment("tip", np.pi * s.E * s.Iz / L)
        sol = flexmb.solve(mech)
        model = sol.compiled.problem.model
        M = mass_matrix(model, sol.state).toarray()
        x = sol.state.positions
        u = np.zeros(model.n_dofs)
        u[model.node_dofs[:, 0]], u[model.node_dofs[:, 1]], u[model.node_dofs[:, 2]] = -x[:, 1], x[:, 0], 1.0
        exact = RHO * s.A * L**3 * 2 / np.pi**2 + RHO * s.Iz * L
        errors.append(u @ M @ u / exact - 1)
    straight = RHO * s.A * L**3 / 3 / exact - 1  # what the undeformed mass would give: +64 %
    assert straight > 0.6
    assert abs(errors[1]) < 1e-5
    assert 3.8 < np.log2(abs(errors[0] / errors[1])) < 4.2, errors


# -- the case: physics only ---------------------------------------------------------
def test_cross_flexure_intended_mode_matches_the_condensed_pivot():
    """Table 1 cross flexure, B of 1 kg and 1e-3 kg m^2: with B's prescribed rotation released
    (its moment kept as a dead load) the lowest mode is the intended one; its frequency equals
    that of B's rigid-body mass on B's condensed 6x6 stiffness (the solve's tangent, internal
    nodes eliminated statically) within the leaves' own inertia: 2 % at 7800 kg/m^3 (measured
    0.6-0.9 %, always below: the leaves add inertia), 1e-4 at 7.8 kg/m^3."""
    for deg in (0.0, 60.0):
        for density, tol in ((RHO, 2e-2), (RHO / 1000, 1e-4)):
            sol = flexmb.solve(_pivot(deg, elements=5, density=density))
            K, M = stiffness_and_mass(sol)
            K = K.toarray()
            node = sol.compiled.link_node["B"]
            model = sol.compiled.problem.model
            B = model.node_dofs[node]
            inner = model.node_dofs[np.concatenate(list(sol.compiled.joint_nodes.values()))].ravel()
            KB = K[np.ix_(B, B)] - K[np.ix_(B, inner)] @ np.linalg.solve(K[np.ix_(inner, inner)], K[np.ix_(inner, B)])
            MB = np.diag([1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3])
            lam = np.sort(sla.eigvals(KB, MB).real)
            f_cond = np.sqrt(lam[0]) / (2 * np.pi)
            md = flexmb.modes(sol, n_modes=1, held="fixed")
            assert md.frequencies[0] < f_cond
            assert md.frequencies[0] == pytest.approx(f_cond, rel=tol)
            assert abs(md.link_shapes["B"][0, 5]) > 0.5 * np.abs(md.link_shapes["B"][0]).max()  # turns about z


# -- bad input -------------------------------------------------------------------------------
@pytest.mark.parametrize("density", [-1.0, float("nan"), float("inf"), "steel"])
def test_bad_density_is_refused(density):
    with pytest.raises(flexmb.ParameterError, match="density"):
        flexmb.rectangle(0.01, 1e-3, 200e9, 76.9e9, density=density)
    with pytest.raises(flexmb.ParameterError, match="density"):
        flexmb.Section(E=1.0, G=1.0, A=1.0, Iy=1.0, Iz=1.0, It=1.0, density=density)
    for kind in ("cross_flexure", "leaf_spring", "three_x_infinity"):
        with pytest.raises(flexmb.ParameterError, match="density"):
            flexmb.joint(kind, density=density)
    with pytest.raises(flexmb.ParameterError, match="density"):
        flexmb.CurvedBeam(radius=0.05, angle=1.0, E=200e9, width=0.01, height=1e-3, density=density)


@pytest.mark.parametrize("inertia, match", [
    (np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "not symmetric"),
    (np.diag([1.0, 1.0, -0.5]), "positive semi-definite"),
    (np.diag([1.0, 1.0, 3.0]), "triangle inequality"),
    (np.eye(2), r"\(3, 3\)"),
    (np.diag([1.0, np.nan, 1.0]), "finite"),
])
def test_bad_inertia_is_refused_naming_the_link(inertia, match):
    m = flexmb.Mechanism(dim=3)
    with pytest.raises(flexmb.ParameterError, match=f"link 'B'.*{match}"):
        m.add_link("B", mass=1.0, inertia=inertia)
    with pytest.raises(flexmb.ParameterError, match="link 'B'.*mass"):
        m.add_link("B", mass=-1.0)
    with pytest.raises(flexmb.ParameterError, match="link 'B'.*center"):
        m.add_link("B", mass=1.0, center=(0.0, np.nan, 0.0))
    assert "B" not in m.links


def test_modes_refuse_bad_requests():
    sol = flexmb.solve(_leaf_mechanism(2, 2, length=0.1, thickness=1e-3))  # 2 free nodes: 6 DOFs
    with pytest.raises(flexmb.ParameterError, match=r"n_modes=7 must be an integer in \[1, 6\]"):
        flexmb.modes(sol, n_modes=7)  # all 6 free DOFs' modes can be asked for (was [1, 5])
    with pytest.raises(flexmb.ParameterError, match="held"):
        flexmb.modes(sol, held="everything")
    with pytest.raises(flexmb.ParameterError, match="component 'rz'"):
        flexmb.modes(sol, held=[("tip", "rz")])  # a 2D link has "rotation"
    with pytest.raises(flexmb.ModelError, match="no link 'nope'"):
        flexmb.modes(sol, held=["nope"])
    with pytest.raises(flexmb.ParameterError, match="neither a link name nor"):
        flexmb.modes(sol, held=[("tip", "x", "y")])
    with pytest.raises(flexmb.ParameterError, match="buckling: held"):
        flexmb.buckling(sol, held="all")
    mech = _leaf_mechanism(2, 8, length=0.1, thickness=1e-3)
    mech.apply_moment("tip", 2 * np.pi * 200e9 * 0.01 * 1e-9 / 12 / 0.1)  # a full circle
    from flexmb.solvers.conventional import Conventional
    unconverged = Conventional(max_iter=1, min_step=0.5).solve(mech.compile())
    assert not unconverged.converged
    with pytest.raises(flexmb.ConvergenceError, match="unconverged"):
        flexmb.modes(unconverged)


def test_a_free_direction_without_mass_is_named():
    """Massless leaves (one element, no internal node) and a massless tip: the tip's DOFs are
    free but carry no mass; the error names the link and the components."""
    sol = flexmb.solve(_leaf_mechanism(3, 1, length=0.1, thickness=1e-3, density=0.0))
    with pytest.raises(flexmb.ModelError, match=r"no mass: link 'tip' x, link 'tip' y"):
        flexmb.modes(sol, n_modes=2, held="fixed")
    sol = flexmb.solve(_leaf_mechanism(3, 1, length=0.1, thickness=1e-3, density=0.0, tip_mass=1.0))
    with pytest.raises(flexmb.ModelError, match=r"link 'tip' rx"):  # mass, but no inertia
        flexmb.modes(sol, n_modes=2, held="fixed")


def test_held_rotation_components_are_global_spins():
    """In 3D a held rotation component is a zero spin about that global axis: holding rx, ry, rz
    is holding "rotation"; the held components of every shape are exactly zero, the others not."""
    sol = flexmb.solve(_pivot(30.0, elements=3))
    a = flexmb.modes(sol, n_modes=4, held=[("B", "rx"), ("B", "ry"), ("B", "rz")])
    b = flexmb.modes(sol, n_modes=4, held=[("B", "rotation")])
    np.testing.assert_array_equal(a.held, b.held)
    np.testing.assert_allclose(a.frequencies, b.frequencies, rtol=1e-12)
    c = flexmb.modes(sol, n_modes=4, held=[("B", "rz")])
    assert np.all(c.link_shapes["B"][:, 5] == 0.0)
    assert np.abs(c.link_shapes["B"][:, 3:5]).max() > 1.0


@pytest.mark.slow
def test_sparse_shift_invert_equals_dense(monkeypatch):
    """Above `DENSE_BELOW` (`DENSE_BELOW_NONSYMMETRIC`) free DOFs `modes` uses eigsh (symmetric)
    or eigs (a dead moment on a free rotation): the same frequencies as the dense solver, shapes
    equal up to sign."""
    import flexmb.modal as modal

    cases = [(flexmb.solve(_leaf_mechanism(3, 80, length=0.1, thickness=1e-3)), "fixed", True),
             (flexmb.solve(_pivot(75.0, elements=8)), [("B", "rz")], False)]
    for sol, held, symmetric in cases:
        sparse = flexmb.modes(sol, n_modes=6, held=held)
        assert sparse.solver == "sparse" and sparse.symmetric == symmetric
        monkeypatch.setattr(modal, "DENSE_BELOW", 10**6)
        monkeypatch.setattr(modal, "DENSE_BELOW_NONSYMMETRIC", 10**6)
        dense = flexmb.modes(sol, n_modes=6, held=held)
        monkeypatch.undo()
        assert dense.solver == "dense"
        np.testing.assert_allclose(sparse.frequencies, dense.frequencies, rtol=1e-9)
        np.testing.assert_allclose(np.abs(sparse.shapes), np.abs(dense.shapes), atol=1e-6 * np.abs(dense.shapes).max())


def _rigid_velocities(model):
    """(N ndof, 6) nodal velocities of the rigid motions: unit translations, unit spins about the
    global axes through the origin."""
    V = np.zeros((model.n_dofs, 6))
    for i in range(3):
        V[model.node_dofs[:, i], i] = 1.0
        V[model.node_dofs[:, :3].ravel(), 3 + i] = np.cross(np.eye(3)[i], model.x0).ravel()
        V[model.node_dofs[:, 3 + i], 3 + i] = 1.0
    return V


def test_intermediate_bodies_carry_the_leaves_mass_exactly():
    """three_x_infinity (3 stages): the leaf ends clamped in the rigid intermediate bodies reach
    the bodies' FE nodes through the rigid lever, so the joint's rigid-body mass and inertia are
    those of its 9 leaves as boxes, exactly (links massless)."""
    joint = flexmb.ThreeXInfinity(elements_per_leaf=2, density=RHO)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3))
    m.add_joint("A", "B", joint, name="hinge")
    model = m.compile().problem.model
    V = _rigid_velocities(model)
    MR = V.T @ mass_matrix(model, model.initial_state()).toarray() @ V
    mesh = joint.mesh(3)
    total, inertia = 0.0, np.zeros((3, 3))
    n = joint.elements_per_leaf
    for leaf in range(9):
        el = mesh.elements[leaf * n:(leaf + 1) * n]
        a, b = mesh.points[el[0, 0]], mesh.points[el[-1, 1]]
        width = mesh.sections[leaf * n].zmax * 2
        ex = (b - a) / joint.length
        ez = np.array([0.0, 0.0, 1.0])
        R = np.stack([ex, np.cross(ez, ex), ez], axis=1)
        mass = RHO * joint.length * width * joint.thickness
        J = mass / 12 * np.diag([width**2 + joint.thickness**2, joint.length**2 + width**2,
                                 joint.length**2 + joint.thickness**2])
        c = 0.5 * (a + b)
        total += mass
        inertia += R @ J @ R.T + mass * (c @ c * np.eye(3) - np.outer(c, c))
    np.testing.assert_allclose(MR[:3, :3], total * np.eye(3), rtol=1e-13)
    np.testing.assert_allclose(MR[3:, 3:], inertia, rtol=1e-12, atol=1e-12 * np.abs(inertia).max())


def test_cross_flexure_leaves_vibrate_clamped_clamped_at_zero_degrees():
    """At 0 deg with B's rotation held, modes 2-4 are the three leaves' own in-plane bending with
    the 1 kg block nearly still: the clamped-clamped Euler-Bernoulli frequency (beta L = 4.7300,
    Blevins 1979 Table 8-1) f = 22.373/(2 pi) sqrt(E t^2/(12 rho L^4)) = 520.5 Hz; 5 el./leaf
    give 520.2-520.3 Hz (shear, rotary inertia and the mesh: -0.05 %)."""
    md = flexmb.modes(flexmb.solve(_pivot(0.0, elements=5)), n_modes=4, held=[("B", "rz")])
    f_cc = 4.73004074**2 / (2 * np.pi) * np.sqrt(200e9 * 1e-3**2 / (12 * RHO * 0.1**4))
    np.testing.assert_allclose(md.frequencies[1:4], f_cc, rtol=2e-3)
    assert np.abs(md.link_shapes["B"][1:4, :3]).max() < 0.02 * np.abs(md.shapes[1:4]).max()


def test_dead_forces_keep_the_tangent_symmetric_dead_moments_do_not():
    """A force at an offset point is conservative (its load stiffness cancels the internal
    moments' skew part): symmetric. An applied dead moment m on a free link leaves -1/2 skew(m)
    (3D spin coordinates): non-symmetric. In 2D both are conservative."""
    for dim in (2, 3):
        m = _leaf_mechanism(dim, 4, length=0.1, width=0.02, thickness=1e-3, tip_mass=0.1,
                            tip_inertia=1e-5 if dim == 2 else 1e-5 * np.eye(3))
        m.apply_force("tip", (0.0, 20.0, 5.0)[:dim], point=(0.12, 0.01, 0.02)[:dim])
        assert flexmb.modes(flexmb.solve(m), n_modes=2).symmetric
        moment = 3.0 if dim == 2 else np.array([0.5, -1.0, 3.0])
        m.apply_moment("tip", moment)
        sol = flexmb.solve(m)
        assert flexmb.modes(sol, n_modes=2).symmetric == (dim == 2)
        if dim == 3:
            K = stiffness_and_mass(sol)[0].toarray()
            r = sol.compiled.problem.model.node_dofs[sol.compiled.link_node["tip"]][3:]
            Kr = K[np.ix_(r, r)]
            np.testing.assert_allclose(0.5 * (Kr - Kr.T), -0.5 * skew(moment), atol=1e-6)


@pytest.mark.parametrize("call", [lambda m, s: flexmb.modes(m), lambda m, s: flexmb.buckling(m),
                                  lambda m, s: flexmb.compliance(m, "tip"), lambda m, s: flexmb.buckling(s, base=m)])
def test_linearising_a_mechanism_instead_of_a_solution_is_a_parameter_error(call):
    """A Mechanism passed where a Solution belongs (modes(m) for modes(flexmb.solve(m))) is
    named, not an AttributeError from inside."""
    m = flexmb.models.cantilever(dim=2)
    s = flexmb.solve(m)
    with pytest.raises(flexmb.errors.ParameterError, match="needs a Solution"):
        call(m, s)


def _pendulum(dim, k=5.0, mass=0.2, J=1e-4, r=0.05):
    """A link of ``mass`` [kg] and centroidal inertia ``J`` [kg m^2], its centre ``r`` [m] from a
    hinge with a spring ``k`` [N m/rad] to the ground: one free motion."""
    z = [0.0] * (dim - 2)
    m = flexmb.Mechanism(dim=dim)
    m.add_link("g", position=[0.0, 0.0] + z, fixed=True)
    m.add_link("arm", position=[r, 0.0] + z, mass=mass, inertia=J if dim == 2 else np.diag([J, J, J]))
    m.add_joint("g", "arm", flexmb.Hinge(k=k), name="pivot", origin=[0.0, 0.0] + z)
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_a_one_dof_mechanism_has_its_one_mode(dim):
    # f = sqrt(k / (J + m r^2)) / (2 pi): a compound pendulum on a torsion spring (closed form,
    # parallel-axis theorem); the valid n is [1, 1] (before: "n must be in [1, 0]")
    sol = flexmb.solve(_pendulum(dim))
    md = flexmb.modes(sol, n_modes=1)
    assert md.frequencies == pytest.approx([np.sqrt(5.0 / (1e-4 + 0.2 * 0.05**2)) / (2 * np.pi)], rel=1e-10)
    with pytest.raises(flexmb.ParameterError, match=r"n_modes=2 must be an integer in \[1, 1\]"):
        flexmb.modes(sol, n_modes=2)


@pytest.mark.parametrize("n", [0, -1, 1.0, True, "3"])
def test_modes_refuse_a_count_that_is_not_a_positive_integer(n):
    sol = flexmb.solve(_pendulum(2))
    with pytest.raises(flexmb.ParameterError, match=r"modes: n_modes=.* must be an integer"):
        flexmb.modes(sol, n_modes=n)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_mechanism_without_a_free_motion_has_no_modes_and_says_so(dim):
    m = _pendulum(dim)
    m.prescribe("arm", rotation=0.3 if dim == 2 else [0.0, 0.0, 0.3])  # held by default: nothing moves
    sol = flexmb.solve(m)
    with pytest.raises(flexmb.ModelError, match="no free motion.*held"):
        flexmb.modes(sol, n_modes=1)
    # released, the arm swings again about the turned pivot (the spring's moment k theta is a
    # follower of the arm: the frequency is unchanged by the turn). 3D: the hinge's axis rows,
    # dropped at build as dependent on the prescribed orientation, keep the released arm on its
    # axis (without them it tilted freely: -0.00015 Hz)
    md = flexmb.modes(sol, n_modes=1, held="fixed")
    assert md.frequencies == pytest.approx([np.sqrt(5.0 / (1e-4 + 0.2 * 0.05**2)) / (2 * np.pi)], rel=1e-9)


def test_every_mode_of_a_small_model_can_be_asked_for():
    # a leaf of 2 elements: 6 free DOFs, 6 modes (dense), the same lowest ones as n=3 (sparse path
    # not taken below DENSE_BELOW); n = 7 is out of [1, 6]
    sol = flexmb.solve(_leaf_mechanism(2, 2, length=0.1, thickness=1e-3))
    all_ = flexmb.modes(sol, n_modes=6)
    assert len(all_.frequencies) == 6 and np.all(np.diff(all_.frequencies) > 0)
    assert flexmb.modes(sol, n_modes=3).frequencies == pytest.approx(all_.frequencies[:3], rel=1e-10)
    with pytest.raises(flexmb.ParameterError, match=r"n_modes=7 must be an integer in \[1, 6\]"):
        flexmb.modes(sol, n_modes=7)


@pytest.mark.parametrize("make", [lambda **kw: flexmb.rectangle(0.01, 1e-4, **STEEL, **kw),
                                  lambda **kw: flexmb.circle(1e-3, **STEEL, **kw)])
def test_section_builders_default_to_the_joints_steel_and_massless_leaves_are_named(make):
    # issue 22: the shipped joints default to steel, 7800 kg/m^3; a leaf given section=rectangle()
    # or circle() weighs the same by default (circle and rectangle defaulted to 0: massless)
    assert make().density == flexmb.LeafSpring().density == 7800.0
    sol = flexmb.solve(_leaf_mechanism(3, 4, length=0.1, section=make()))
    md = flexmb.modes(sol, n_modes=1)
    s = make()  # the closed form: a clamped-free beam's first bending frequency (BETA_L above)
    f1 = BETA_L[0] ** 2 / (2 * np.pi * 0.1**2) * np.sqrt(s.E * min(s.Iy, s.Iz) / (7800.0 * s.A))
    assert md.frequencies[0] == pytest.approx(f1, rel=2e-2)  # 4 Timoshenko elements
    # massless leaves (density=0) and a massless tip: the free directions without mass (the tip's
    # 6, 3 internal nodes' 18) are counted and named
    sol = flexmb.solve(_leaf_mechanism(3, 4, length=0.1, section=make(density=0.0)))
    with pytest.raises(flexmb.ModelError, match=r"24 free direction\(s\) carry no mass: link 'tip' x.*sections\) density"):
        flexmb.modes(sol, n_modes=1)


def test_a_density_in_kg_per_m3_with_lengths_in_mm_warns_at_the_modes():
    # a careless user: the leaf in N, mm, MPa but the density left at the joints' SI default 7800
    # (kg/m^3; in these units 7.8e-9 t/mm^3): f1 came out 0.00026 Hz without a word. The wave
    # speed sqrt(E / density) over the joint's length is unit-free (1/s): ~1e5 for this leaf in
    # any consistent units, 0.1 here; engineering materials (c = 30 ... 13 000 m/s) in joints of
    # 1 um ... 10 m stay within [3, 1.3e10]
    def leaf(density):
        m = flexmb.Mechanism(dim=2)
        m.add_link("g", fixed=True)
        m.add_link("tip", position=(50.0, 0.0))
        m.add_joint("g", "tip", flexmb.LeafSpring(length=50.0, width=10.0, thickness=0.5, E=2e5, G=7.7e4,
                                                  density=density, elements=4))
        return flexmb.solve(m)

    with pytest.warns(flexmb.PlausibilityWarning, match=r"density=7800 .*joint 'leaf_spring_0'.*mass per length cubed"):
        wrong = flexmb.modes(leaf(7800.0), n_modes=1)
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        right = flexmb.modes(leaf(7.8e-9), n_modes=1)  # t/mm^3: quiet
        flexmb.modes(flexmb.solve(_leaf_mechanism(2, 4, length=0.05, thickness=5e-4)), n_modes=1)  # SI: quiet
    # the same leaf, the density 1e12 x too large: the frequency 1e6 x too low (f ~ 1/sqrt(rho))
    assert wrong.frequencies[0] == pytest.approx(right.frequencies[0] * np.sqrt(7.8e-9 / 7800.0), rel=1e-9)


@pytest.mark.parametrize("dim", [2, 3])
def test_buckling_counts_the_motions_the_hinges_allow_as_modes_does(dim):
    # the one-DOF pendulum under a dead load along its arm (compression towards the pivot): one
    # multiplier can be asked for, n=2 names [1, 1]; with its turn prescribed nothing can buckle
    m = _pendulum(dim)
    m.apply_force("arm", [-1.0, 0.0] + [0.0] * (dim - 2))
    sol = flexmb.solve(m)
    # the pendulum pushed towards its pivot: k_eff = k - P r = 5 - 0.05 > 0, lam = k / (P r) = 100
    assert flexmb.buckling(sol, n_buckling=1) == pytest.approx([100.0], rel=1e-9)
    with pytest.raises(flexmb.ParameterError, match=r"buckling: n_buckling=2 must be an integer in \[1, 1\]"):
        flexmb.buckling(sol, n_buckling=2)
    m.prescribe("arm", rotation=0.0 if dim == 2 else [0.0, 0.0, 0.0])
    with pytest.raises(flexmb.ModelError, match="buckling: no free motion"):
        flexmb.buckling(flexmb.solve(m), n_buckling=1)


@pytest.mark.parametrize("dim", [2, 3])
def test_compliance_of_a_released_pendulum_is_its_spring_about_the_pivot(dim):
    # the pendulum's turn prescribed to 0.3 rad and released (held="fixed"): a force at the arm's
    # centre (r = 0.05 from the pivot, at 0.3 rad) turns it by (r x F)/k: C = q q^T / k with
    # q = r (-sin 0.3, cos 0.3) the point's motion per unit turn (closed form); the turn 1/k.
    # 3D: the hinge's axis rows, dropped at build as dependent on the prescribed orientation,
    # hold again (the tangent was singular: ModelError)
    m = _pendulum(dim)
    m.prescribe("arm", rotation=0.3 if dim == 2 else [0.0, 0.0, 0.3])
    C = flexmb.compliance(flexmb.solve(m), "arm", held="fixed")
    q = 0.05 * np.array([-np.sin(0.3), np.cos(0.3)])
    xy = [0, 1]
    np.testing.assert_allclose(C[np.ix_(xy, xy)], np.outer(q, q) / 5.0, rtol=1e-9, atol=1e-15)
    assert C[-1, -1] == pytest.approx(1 / 5.0, rel=1e-9)
    if dim == 3:  # the bearing holds z and the tilts exactly
        np.testing.assert_allclose(C[2:5, 2:5], 0.0, atol=1e-12)


def test_a_leaf_given_a_section_and_another_material_is_refused_naming_both():
    # the section's material applies: density=2700 (aluminium) beside a steel section was silently
    # steel in the modes; a value equal to the section's, or the joint's default, is fine
    steel = flexmb.rectangle(0.01, 1e-4, **STEEL)
    with pytest.raises(flexmb.ParameterError, match=r"density=2700.0 \(section: 7800.0\).*section's material"):
        flexmb.LeafSpring(density=2700.0, section=steel)
    with pytest.raises(flexmb.ParameterError, match=r"E=70000000000.0 \(section: 200000000000.0\)"):
        flexmb.LeafSpring(E=70e9, G=26e9, section=steel)
    flexmb.LeafSpring(section=steel)
    flexmb.LeafSpring(density=7800.0, E=200e9, section=steel)


def test_a_leaf_given_a_section_and_other_sizes_is_refused_naming_both():
    # issue 22: width/thickness beside a section were silently the section's; the same sizes as
    # the section's rectangle (or the defaults) pass, any size beside a circle is refused
    steel = flexmb.rectangle(0.01, 1e-4, **STEEL)
    with pytest.raises(flexmb.ParameterError, match=r"width=0.03 \(section: 0.01\).*section's shape applies"):
        flexmb.LeafSpring(width=0.03, section=steel)
    with pytest.raises(flexmb.ParameterError, match=r"width=0.025 \(section: 0.01\), thickness=0.002 \(section: "):
        flexmb.LeafSpring(width=0.025, thickness=2e-3, section=steel)
    with pytest.raises(flexmb.ParameterError, match=r"thickness=0.0005 \(section: a circle section, A="):
        flexmb.LeafSpring(thickness=5e-4, section=flexmb.circle(1e-3, **STEEL))
    leaf = flexmb.LeafSpring(width=0.01, thickness=1e-4, section=steel)
    assert leaf.cross_section() is steel
    flexmb.LeafSpring(section=steel)
    # the slenderness check reads the section's thickness: a 2 mm bar 1 mm long is refused
    with pytest.raises(flexmb.ParameterError, match=r"thickness=0.002 m \(section\) must be < length=0.001 m"):
        flexmb.LeafSpring(length=1e-3, section=flexmb.rectangle(0.01, 2e-3, **STEEL))


def test_the_density_check_warns_at_every_modes_call_of_a_wrong_model():
    """`flexmb.modes` checks a model's densities once while they fit (`modal._PLAUSIBLE_MASS`),
    but a model that warns warns at every call (the leaf of the previous test, 7800 in N, mm,
    MPa), and its frequencies are the same each time."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("g", fixed=True)
    m.add_link("tip", position=(50.0, 0.0))
    m.add_joint("g", "tip", flexmb.LeafSpring(length=50.0, width=10.0, thickness=0.5, E=2e5, G=7.7e4,
                                              density=7800.0, elements=4))
    sol = flexmb.solve(m)
    f = []
    for _ in range(3):
        with pytest.warns(flexmb.PlausibilityWarning, match=r"density=7800 .*mass per length cubed"):
            f.append(flexmb.modes(sol, n_modes=2).frequencies)
    np.testing.assert_array_equal(f[0], f[2])
    from flexmb import modal

    assert sol.compiled.problem.model not in modal._PLAUSIBLE_MASS
