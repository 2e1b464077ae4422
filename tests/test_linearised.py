"""Buckling multipliers and compliance from the linearised problem (`flexmb.buckling`,
`flexmb.compliance`): closed forms, convergence, invariants, bad input."""

import numpy as np
import pytest

import flexmb
from flexmb.linearised import material_tangent
from flexmb.modal import full_tangent

STEEL = dict(E=200e9, G=76.9e9)


def _column(dim, elements, P, guided=False, length=1.0, width=0.01, thickness=1e-3, Q=None):
    """Leaf from fixed "g" along Q's x axis to "tip", compressed by a dead tip force P [N]
    (guided: the tip's rotation held, its translations free)."""
    Q = np.eye(dim) if Q is None else Q
    m = flexmb.Mechanism(dim=dim)
    m.add_link("g", fixed=True)
    m.add_link("tip", position=length * Q[:, 0])
    rot = None if dim == 3 and np.allclose(Q, np.eye(3)) else (np.arctan2(Q[1, 0], Q[0, 0]) if dim == 2 else Q)
    m.add_joint("g", "tip", flexmb.joint("leaf_spring", length=length, width=width, thickness=thickness,
                                         elements=elements, **STEEL), name="leaf", rotation=rot)
    m.apply_force("tip", -P * Q[:, 0])
    if guided:
        m.prescribe("tip", rotation=0.0 if dim == 2 else (0.0, 0.0, 0.0))
    return m


def _euler(s, L, factor):
    """Euler load factor * pi^2 EI/L^2 (weak axis Iz) with the Timoshenko shear correction
    P/(1 + P/(k G A)) (Timoshenko & Gere 1961, Eq. 2-51)."""
    Pe = factor * np.pi**2 * s.E * s.Iz / L**2
    return Pe / (1.0 + Pe / (s.ky * s.G * s.A))


@pytest.mark.parametrize("dim", [2, 3])
def test_euler_buckling_fixed_free_and_fixed_guided(dim):
    """Fixed-free: P_cr = pi^2 EI/(4 L^2); fixed-guided (sway, tip rotation held): pi^2 EI/L^2
    (Timoshenko & Gere 1961, Secs. 2.1 and 2.3). The pre-buckling state is pure compression
    (linear), at 1e-3 of the critical load. The co-rotational element's chord-based geometric
    stiffness converges at second order (measured 1.29e-2, 3.22e-3, 8.03e-4 at 4, 8, 16
    elements fixed-free; 5.2e-2, 1.3e-2, 3.2e-3 guided), from above. The second fixed-free
    multiplier tends to 9 times the first ((3 pi/2)^2 / (pi/2)^2)."""
    s = flexmb.rectangle(0.01, 1e-3, **STEEL)
    for guided, factor in ((False, 0.25), (True, 1.0)):
        P = 1e-3 * _euler(s, 1.0, factor)
        err = []
        for n in (4, 8, 16):
            lam = flexmb.buckling(flexmb.solve(_column(dim, n, P, guided)), n_buckling=2)
            err.append(lam[0] * P / _euler(s, 1.0, factor) - 1)
        if not guided:
            assert lam[1] / lam[0] == pytest.approx(9.0, rel=2e-2)
        err = np.array(err)
        assert np.all(err > 0)
        assert 1.9 < np.log2(err[1] / err[2]) < 2.1
        assert err[-1] < 4e-3


def test_buckling_multiplier_scales_inversely_with_the_load_on_a_linear_path():
    """Stresses proportional to the load: twice the load, half the multiplier; a turned and
    shifted column has the same critical load (frame indifference). At 0.3 of the critical load,
    so the residual tolerance (5e-7 N) is 1e-6 of the load."""
    s = flexmb.rectangle(0.01, 1e-3, **STEEL)
    P = 0.3 * _euler(s, 1.0, 0.25)
    a = flexmb.buckling(flexmb.solve(_column(3, 8, P)), n_buckling=2)
    b = flexmb.buckling(flexmb.solve(_column(3, 8, 2 * P)), n_buckling=2)
    np.testing.assert_allclose(2 * b, a, rtol=1e-6)
    Q = flexmb.rotations.expm_so3(np.array([0.3, -0.5, 0.8]))
    c = flexmb.buckling(flexmb.solve(_column(3, 8, P, Q=Q)), n_buckling=2)
    np.testing.assert_allclose(c, a, rtol=1e-7)


def test_material_tangent_is_the_stress_free_part():
    """K_t - K_m is linear in the load: at twice the (linear-path) load it doubles; without load it
    vanishes."""
    s = flexmb.rectangle(0.01, 1e-3, **STEEL)
    P = 1e-3 * _euler(s, 1.0, 0.25)
    parts = []
    for load in (P, 2 * P):
        sol = flexmb.solve(_column(3, 4, load))
        parts.append((full_tangent(sol) - material_tangent(sol)).toarray())
    np.testing.assert_allclose(parts[1], 2 * parts[0], atol=1e-6 * np.abs(parts[1]).max())
    sol = flexmb.solve(_column(3, 4, 0.0))
    assert np.abs((full_tangent(sol) - material_tangent(sol)).toarray()).max() == 0.0
    assert np.all(np.isinf(flexmb.buckling(sol)))


def test_tip_compliance_is_the_timoshenko_cantilever():
    """Unloaded cantilever: C = diag(L/EA, L^3/(3 EI) + L/(k G A), ...) with the L^2/(2 EI)
    coupling (`LeafSpring.compliance`, closed form; one Timoshenko element is exact), in global
    axes; in 3D also the stiff plane (Iy, kz) and torsion L/(G I_t)."""
    leaf = flexmb.LeafSpring(length=0.1, width=0.02, thickness=1e-3, elements=3, **STEEL)
    s, L = leaf.cross_section(), leaf.length
    C2 = flexmb.compliance(flexmb.solve(_column(2, 3, 0.0, length=L, width=0.02)), "tip")
    np.testing.assert_allclose(C2, leaf.compliance(), rtol=1e-9, atol=1e-20)
    C3 = flexmb.compliance(flexmb.solve(_column(3, 3, 0.0, length=L, width=0.02)), "tip")
    np.testing.assert_allclose(C3[np.ix_([0, 1, 5], [0, 1, 5])], leaf.compliance(), rtol=1e-9, atol=1e-20)
    stiff = np.array([[L**3 / (3 * s.E * s.Iy) + L / (s.kz * s.G * s.A), -L**2 / (2 * s.E * s.Iy)],
                      [-L**2 / (2 * s.E * s.Iy), L / (s.E * s.Iy)]])
    np.testing.assert_allclose(C3[np.ix_([2, 4], [2, 4])], stiff, rtol=1e-9)
    assert C3[3, 3] == pytest.approx(L / (s.G * s.It), rel=1e-9)


def test_compliance_of_an_offset_point_and_in_link_axes():
    """A named point offset from the tip: its compliance column equals the finite-difference
    response of the point to a small dead force there (a loaded, deformed state); in link axes it
    is the global one turned by the link's current rotation."""
    m = _column(3, 4, 0.0, length=0.1, width=0.02)
    m.apply_force("tip", (0.0, 3.0, 1.0))
    m.add_point("tip", "probe", (0.13, 0.02, -0.01))
    sol = flexmb.solve(m)
    C = flexmb.compliance(sol, "tip", "probe")
    np.testing.assert_array_equal(C, flexmb.compliance(sol, "tip", point=(0.13, 0.02, -0.01)))
    h = 1e-3
    for i, direction in enumerate(np.eye(3)):
        resp = []
        for sign in (1, -1):
            mm = _column(3, 4, 0.0, length=0.1, width=0.02)
            mm.apply_force("tip", (0.0, 3.0, 1.0))
            mm.apply_force("tip", sign * h * direction, point=(0.13, 0.02, -0.01))
            mm.add_point("tip", "probe", (0.13, 0.02, -0.01))
            resp.append(flexmb.solve(mm).point("tip", "probe"))
        np.testing.assert_allclose((resp[0] - resp[1]) / (2 * h), C[:3, i], rtol=1e-5, atol=1e-9 * np.abs(C).max())
    R = sol.pose("tip")[1]
    B = np.kron(np.eye(2), R)
    np.testing.assert_allclose(flexmb.compliance(sol, "tip", "probe", axes="link"), B.T @ C @ B, rtol=1e-12)
    # the fixed link does not move
    assert np.all(flexmb.compliance(sol, "g") == 0.0)


def test_linearised_properties_refuse_bad_input():
    sol = flexmb.solve(_column(2, 2, 1.0))
    with pytest.raises(flexmb.ModelError, match="no link named 'nope'"):
        flexmb.compliance(sol, "nope")
    with pytest.raises(flexmb.ParameterError, match="axes='local'"):
        flexmb.compliance(sol, "tip", axes="local")
    with pytest.raises(flexmb.ModelError, match="no point named 'probe'"):
        flexmb.compliance(sol, "tip", "probe")
    with pytest.raises(flexmb.ParameterError, match="point"):
        flexmb.compliance(sol, "tip", point=(1.0, 2.0, 3.0))
    with pytest.raises(flexmb.ParameterError, match=r"n_buckling=7 must be an integer in \[1, 6\]"):
        flexmb.buckling(sol, n_buckling=7)  # every one of the 6 free DOFs' multipliers can be asked for (was [1, 5])
    with pytest.raises(flexmb.UnsupportedStrategyError):
        flexmb.buckling(flexmb.solve(flexmb.models.gripper(), method="newton"))


def test_sparse_buckling_equals_dense(monkeypatch):
    """Above `DENSE_BELOW` free DOFs `buckling` uses Lanczos (``eigsh``, K_m as the metric): the
    same multipliers as the dense solver."""
    import flexmb.linearised as linearised

    s = flexmb.rectangle(0.01, 1e-3, **STEEL)
    sol = flexmb.solve(_column(3, 45, 0.3 * _euler(s, 1.0, 0.25)))
    assert len(sol.compiled.problem.free) >= linearised.DENSE_BELOW
    sparse = flexmb.buckling(sol, n_buckling=3)
    monkeypatch.setattr(linearised, "DENSE_BELOW", 10**6)
    np.testing.assert_allclose(sparse, flexmb.buckling(sol, n_buckling=3), rtol=1e-9)


def test_support_ratios_are_compliance_with_the_intended_rotation_released():
    """`flexmb.joint_characteristics.support_ratios` is `compliance(..., held="fixed")` of node B: its inverse
    equals the FE tangent statically condensed onto B (`joint_stiffness`, an independent
    Schur-complement route), turned into B's frame, to 1e-9 of the diagonal (a cross flexure of
    another size than Table 1's, at 20 deg)."""
    from flexmb.joint_characteristics import joint_stiffness, support_ratios
    from flexmb.ksd.geometry import rz

    J = flexmb.joint("cross_flexure", length=0.04, width_inner=0.012, width_outer=0.006,
                      thickness=0.3e-3, elements_per_leaf=3)
    K, sol = joint_stiffness(J, np.radians(20.0))
    T = np.kron(np.eye(2), rz(np.radians(20.0)))
    C = T.T @ flexmb.compliance(sol, "B", held="fixed") @ T
    np.testing.assert_allclose(np.linalg.inv(C), K, atol=1e-9 * np.abs(np.diag(K)).max())
    r = support_ratios(J, np.radians(20.0))
    assert r["k_rotation"] == pytest.approx(1.0 / C[5, 5], rel=1e-12)
    assert r["tilt_x"] == pytest.approx(1.0 / C[3, 3] / r["k_rotation"], rel=1e-12)
    with pytest.raises(flexmb.ModelError, match="singular"):
        flexmb.compliance(sol, "B", held="floating")


def test_lateral_torsional_buckling_of_a_cantilever_strip():
    """A narrow strip (20:1, L = 100 mm) clamped at one end, a dead centroidal tip load along its
    width (bending about the stiff axis): it buckles sideways and twists at
    P_cr = 4.013 sqrt(E I_weak G J) / L^2 (Timoshenko & Gere 1961, Sec. 6.3, Eq. 6-26 with
    gamma = 4.013 for a load at the centroid; pre-buckling deflection neglected, I_weak/I_strong =
    0.0025 here). Linearised about the state at 1e-3 P_cr: converges from above at second order
    (measured +1.11e-2, +2.65e-3, +5.6e-4 at 8, 16, 32 elements); the Richardson limit is
    within 2e-4 of 4.013 (measured -1.4e-4: 4.013 is itself rounded from 4.0126). The strip
    turned arbitrarily in space gives the same."""
    L, w, t = 0.1, 0.01, 0.5e-3
    s = flexmb.rectangle(w, t, **STEEL)
    P_cr = 4.013 * np.sqrt(s.E * s.Iz * s.G * s.It) / L**2
    Q = flexmb.rotations.expm_so3(np.array([0.4, 1.2, -0.3]))
    err = []
    for n in (8, 16, 32):
        m = _column(3, n, 0.0, length=L, width=w, thickness=t, Q=Q)
        m.apply_force("tip", -1e-3 * P_cr * Q[:, 2])  # along the width (local z)
        err.append(flexmb.buckling(flexmb.solve(m))[0] * 1e-3 - 1.0)
    err = np.array(err)
    assert np.all(err > 0)
    assert 1.9 < np.log2(err[0] / err[1]) < 2.4 and 1.9 < np.log2(err[1] / err[2]) < 2.4
    assert abs(err[2] - (err[1] - err[2]) / 3.0) < 2e-4


def test_buckling_about_a_preloaded_base_state():
    """``base``: the multiplier scales only the load increment from ``base`` to the solution.
    On Euler's fixed-free column (a linear pre-buckling path) the preload P1 = 0.6 P_cr plus
    lam x (1e-3 P_cr) gives the critical load found from the unloaded column to 1e-5; from
    the unloaded state as base, the same as without base to 1e-4 (K_m at the deformed vs the
    undeformed state). A base of another mechanism is refused."""
    s = flexmb.rectangle(0.01, 1e-3, **STEEL)
    Pe = _euler(s, 1.0, 0.25)
    small = flexmb.solve(_column(3, 8, 1e-3 * Pe))
    P_cr = flexmb.buckling(small)[0] * 1e-3 * Pe
    base = flexmb.solve(_column(3, 8, 0.6 * Pe))
    sol = flexmb.solve(_column(3, 8, 0.601 * Pe))
    assert 0.6 * Pe + flexmb.buckling(sol, base=base)[0] * 1e-3 * Pe == pytest.approx(P_cr, rel=1e-5)
    rest = flexmb.solve(_column(3, 8, 0.0))
    assert flexmb.buckling(small, base=rest)[0] == pytest.approx(flexmb.buckling(small)[0], rel=1e-4)
    with pytest.raises(flexmb.ModelError, match="same mechanism"):
        flexmb.buckling(small, base=flexmb.solve(_column(3, 4, 0.0)))


def test_sparse_non_symmetric_buckling_equals_dense(monkeypatch):
    """A dead moment on a free rotation (the Table 1 pivot turned 30 deg, the turn released)
    makes the buckling pencil non-symmetric; forced onto the sparse path (Arnoldi on
    K_m^-1 (-K_s)) it gives the dense multipliers."""
    import flexmb.linearised as linearised

    def pushed(force):
        J = flexmb.CrossFlexure(elements_per_leaf=3)
        m = flexmb.Mechanism(dim=3)
        m.add_link("A", fixed=True)
        m.add_link("B", position=J.interface_b(3))
        m.add_joint("A", "B", J, name="pivot")
        m.prescribe("B", rotation=(0.0, 0.0, np.radians(30.0)))
        m.apply_force("B", (0.0, -force, 0.0))
        return flexmb.solve(m)

    base, sol = pushed(0.0), pushed(1.0)
    dense = flexmb.buckling(sol, n_buckling=2, held="fixed", base=base)
    monkeypatch.setattr(linearised, "DENSE_BELOW", 0)
    np.testing.assert_allclose(flexmb.buckling(sol, n_buckling=2, held="fixed", base=base), dense, rtol=1e-8)


def test_dense_solve_is_scipys_bit_for_bit_with_its_singular_and_ill_conditioned_tests():
    """`flexmb.linearised._solve_dense` (LAPACK dgetrf/dgecon/dgetrs directly) returns exactly
    `scipy.linalg.solve`'s answer for a non-symmetric matrix, raises `LinAlgError` where scipy
    does (an exactly singular one) and warns `LinAlgWarning` where scipy does (rcond below eps,
    here an upper-triangular 5 x 5 with pivots 1-4 and 1e-17: LU leaves it as it is, so its last
    pivot is 1e-17 and never rounds to an exact zero, as a rotated diag(1, 2, 3, 4, 1e-16) did
    with numpy 2.4 / scipy 1.17, where both then raised `LinAlgError` instead)."""
    import warnings

    import scipy.linalg as sla

    from flexmb.linearised import _solve_dense

    rng = np.random.default_rng(3)
    A, b = rng.normal(size=(9, 9)), rng.normal(size=(9, 3))
    np.testing.assert_array_equal(_solve_dense(A, b), sla.solve(A, b))
    S = A.copy()
    S[:, 4] = 0.0  # an exactly zero pivot
    for solver in (sla.solve, _solve_dense):
        with pytest.raises(np.linalg.LinAlgError):
            solver(S, b)
    ill = np.diag([1.0, 2.0, 3.0, 4.0, 1e-17]) + np.triu(rng.normal(size=(5, 5)), 1)
    for solver in (sla.solve, _solve_dense):
        with warnings.catch_warnings():
            warnings.simplefilter("error", sla.LinAlgWarning)
            with pytest.raises(sla.LinAlgWarning):
                solver(ill, b[:5])
    with pytest.raises(sla.LinAlgWarning):  # as compliance calls it: raised, whatever the filters
        _solve_dense(ill, b[:5], ill_conditioned="raise")
    sym = A + A.T  # scipy's own symmetric path
    np.testing.assert_array_equal(_solve_dense(sym, b), sla.solve(sym, b))
