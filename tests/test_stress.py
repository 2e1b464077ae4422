"""Stresses a designer can sign off (`Solution.stresses`, `flexmb.fe.stress`): section forces
against statics, Saint-Venant torsion of rectangles against Timoshenko & Goodier's table, circles
(wire flexures), the perimeter sampling's error, stress-concentration and safety factors."""

import numpy as np
import pytest

import flexmb
import flexmb.fe.stress as fs
from flexmb.fe.stress import _rectangle_torsion, perimeter_peaks, section_resultants
from flexmb.sections import circle, rectangle, torsion_constant_rectangle

STEEL = dict(E=200e9, G=76.9e9)


def _cantilever(dim=3, force=None, moment=None, section=None, length=0.1, width=0.01, thickness=1e-3, elements=4,
                rotation=None):
    """Leaf "leaf" from the fixed link "g" to "tip" along x (or turned by ``rotation``), loaded at the tip."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("g", fixed=True)
    R = np.eye(dim) if rotation is None else flexmb.rotations.expm_so3(np.asarray(rotation))
    m.add_link("tip", position=length * R[:, 0])
    sizes = dict(width=width, thickness=thickness) if section is None else {}  # else the section's
    m.add_joint("g", "tip", flexmb.joint("leaf_spring", length=length, elements=elements, section=section, **sizes,
                                         **STEEL), name="leaf",
                rotation=rotation)
    if force is not None:
        m.apply_force("tip", R @ np.asarray(force, dtype=float))
    if moment is not None:
        m.apply_moment("tip", R @ np.asarray(moment, dtype=float) if dim == 3 else moment)
    sol = flexmb.solve(m)
    assert sol.converged
    return sol


@pytest.mark.parametrize("ratio, k", [(1.0, 0.675), (1.5, 0.848), (2.0, 0.930), (3.0, 0.985), (10.0, 1.000)])
def test_rectangle_torsion_peak_is_timoshenko_goodier(ratio, k):
    """tau_max = k G theta (2a) at the middle of the long sides of a 2a x 2b rectangle
    (Timoshenko & Goodier 1970, Sec. 109, table of k for b/a; three digits)."""
    tp, tq = _rectangle_torsion(np.array([1.0]), np.array([0.0]), 1.0, ratio)
    assert tq[0] / 2.0 == pytest.approx(k, abs=6e-4)
    assert tp[0] == pytest.approx(0.0, abs=1e-12)


def test_rectangle_torsion_field_carries_the_torque_and_is_symmetric():
    """The shear field's moment about the axis, integrated over the section (Gauss 80 x 80),
    is G theta I_t with the series torsion constant of `torsion_constant_rectangle` (an
    independent sum); a square's short and long sides carry the same peak; a thin strip's
    short-side peak tends to 8 G_Catalan / pi^2 = 0.7425 of the long side's (T & G Sec. 109)."""
    a, b = 0.5, 1.0
    x, w = np.polynomial.legendre.leggauss(80)
    P, Q = np.meshgrid(a * x, b * x, indexing="ij")
    tp, tq = _rectangle_torsion(P.ravel(), Q.ravel(), a, b)
    torque = np.sum(np.outer(w, w).ravel() * a * b * (P.ravel() * tq - Q.ravel() * tp))
    assert torque == pytest.approx(torsion_constant_rectangle(2 * a, 2 * b), rel=1e-5)
    tp, tq = _rectangle_torsion(np.array([1.0, 0.0]), np.array([0.0, 1.0]), 1.0, 1.0)
    assert abs(tp[1]) == pytest.approx(tq[0], rel=1e-6)
    tp, tq = _rectangle_torsion(np.array([1.0, 0.0]), np.array([0.0, 50.0]), 1.0, 50.0)
    assert abs(tp[1]) / tq[0] == pytest.approx(8 * 0.915965594177219 / np.pi**2, rel=1e-5)


def test_cantilever_section_forces_follow_statics():
    """A tip force P along y, then z, then a tip torque T on a 3D cantilever (loads at 1e-6 of
    yield: linear): at the root N = 0, Vy = P, Mz = P L (Vz = P, My = -P L for a force along z:
    dMz/dx = -Vy, dMy/dx = Vz), at the last element's outer end Mz = P L/4 of 4 elements; the
    torque is T everywhere. Beam theory sign conventions (sigma_x = N/A + My z/Iy - Mz y/Iz)."""
    P, T, L = 1e-4, 2e-5, 0.1  # tip rotation 3e-3 rad: the lever arms change by ~1e-6
    # N: the solve's residual tolerance (5e-7 N) leaves ~1e-8 N of axial force
    r = section_resultants(*_model(_cantilever(force=(0, P, 0))))
    np.testing.assert_allclose(r[0, 0], [0, P, 0, 0, 0, P * L], rtol=2e-6, atol=1e-7)
    assert r[0, 1, 5] == pytest.approx(0.75 * P * L, rel=2e-6)
    r = section_resultants(*_model(_cantilever(force=(0, 0, P))))
    np.testing.assert_allclose(r[0, 0], [0, 0, P, 0, -P * L, 0], rtol=2e-6, atol=1e-7)
    r = section_resultants(*_model(_cantilever(moment=(T, 0, 0))))
    np.testing.assert_allclose(r[:, :, 3], T, rtol=1e-9)
    np.testing.assert_allclose(np.delete(r, 3, axis=2), 0.0, atol=1e-9 * T)


def _model(sol):
    return sol.compiled.problem.model, sol.state


@pytest.mark.parametrize("dim", [2, 3])
def test_bending_and_transverse_shear_of_a_leaf(dim):
    """Tip force P across the leaf (w = 10 mm, t = 1 mm, L = 100 mm): peak normal stress at the
    root 6 P L/(w t^2), peak shear 3P/(2A) at the neutral axis (Jourawski), von Mises the normal
    one (the two peak at different fibres); in 2D and 3D alike, and equal to `peak_stress`."""
    P, L, w, t = 1e-3, 0.1, 0.01, 1e-3
    sol = _cantilever(dim, force=(0, P, 0)[:dim] if dim == 3 else (0, P))
    s = sol.stresses()
    assert s.normal.max() == pytest.approx(6 * P * L / (w * t**2), rel=1e-6)
    assert s.shear.max() == pytest.approx(1.5 * P / (w * t), rel=1e-6)
    assert s.von_mises.max() == pytest.approx(s.normal.max(), rel=1e-9)
    np.testing.assert_allclose(s.normal, sol.peak_stress(), rtol=1e-9)


@pytest.mark.slow
def test_torsion_of_a_leaf_in_another_frame():
    """Tip torque T on a 20 x 1 mm leaf turned arbitrarily in space: the peak shear k t T / I_t
    (T & G table, b/a = 20: k = 1.000 to 4 digits), von Mises sqrt(3) times it, no normal
    stress; the leaf's stiff direction along local y instead (thickness along z) gives the same."""
    T = 1e-3
    sol = _cantilever(moment=(T, 0, 0), width=0.02, rotation=(0.3, -1.1, 0.7))
    s = sol.stresses()
    It = torsion_constant_rectangle(0.02, 1e-3)
    tp, tq = _rectangle_torsion(np.array([5e-4]), np.array([0.0]), 5e-4, 0.01)
    assert s.shear.max() == pytest.approx(tq[0] * T / It, rel=1e-6)
    assert tq[0] / 1e-3 == pytest.approx(1.0, abs=1e-4)
    assert s.von_mises.max() == pytest.approx(np.sqrt(3) * s.shear.max(), rel=1e-9)
    assert s.normal.max() < 1e-6 * s.shear.max()
    turned = flexmb.Section(E=2e11, G=7.69e10, A=2e-5, Iy=1e-3 * 0.02**3 / 12, Iz=0.02 * 1e-9 / 12, It=It,
                            ymax=0.01, zmax=5e-4, shape="rectangle")
    peaks = perimeter_peaks(turned, np.array([[[0, 0, 0, T, 0, 0]]]))
    assert peaks[1][0] == pytest.approx(s.shear.max(), rel=1e-9)


def test_wire_flexure_bending_and_torsion_combine_as_in_a_shaft():
    """A circular wire (d = 1 mm) bent about a diagonal and twisted: peak normal M r/I (the
    rectangle formula |My| + |Mz| would be sqrt(2) too high), torsion T r/J, von Mises
    (r/I) sqrt(M^2 + 3/4 T^2) (the distortion-energy shaft formula 32/(pi d^3) sqrt(M^2 + 3/4 T^2),
    Budynas & Nisbett, Shigley's Mechanical Engineering Design, Ch. 7; sampled rim: <= 3e-4 low), transverse shear 4V/(3A) at the neutral axis.
    `peak_stress` of a circle uses the resultant moment too."""
    d = 1e-3
    s = circle(d, **STEEL)
    r = d / 2
    assert (s.A, s.Iy, s.It) == (pytest.approx(np.pi * r**2), pytest.approx(np.pi * r**4 / 4),
                                 pytest.approx(np.pi * r**4 / 2))
    M, T = 1e-3, 7e-4
    res = np.array([[[0, 0, 0, T, M / np.sqrt(2), M / np.sqrt(2)]]])
    normal, shear, vm = perimeter_peaks(s, res)
    assert normal[0] == pytest.approx(M * r / s.Iy, rel=3e-4)
    assert shear[0] == pytest.approx(T * r / s.It, rel=1e-12)
    assert vm[0] == pytest.approx(r / s.Iy * np.sqrt(M**2 + 0.75 * T**2), rel=3e-4)
    assert perimeter_peaks(s, np.array([[[0, 2e-3, 0, 0, 0, 0]]]))[1][0] == pytest.approx(4 * 2e-3 / (3 * s.A))
    P, L = 1e-4, 0.05
    sol = _cantilever(force=(0, P / np.sqrt(2), P / np.sqrt(2)), section=s, length=L)
    assert sol.peak_stress().max() == pytest.approx(P * L * r / s.Iy, rel=1e-6)
    assert sol.stresses().normal.max() == pytest.approx(P * L * r / s.Iy, rel=3e-4)


@pytest.mark.parametrize("shape", ["rectangle", "square", "circle"])
def test_perimeter_search_error_is_small(shape, monkeypatch):
    """The searched peaks (`PERIMETER_POINTS` = 2048, `COARSE_STEP` = 16) against 16 times as many
    points, for 400 random combinations of all six section forces at both ends: never high, at
    most 2e-5 low (measured 8.3e-6 on the 20 x 1 rectangle, 8.7e-6 on the 1 x 2, 1.2e-6 on the
    circle; with 512 points a coarse search on the wide rectangle picked the wrong peak, 1.4 %)."""
    sec = {"rectangle": rectangle(0.02, 1e-3, **STEEL), "square": rectangle(1e-3, 2e-3, **STEEL),
           "circle": circle(1e-3, **STEEL)}[shape]
    rng = np.random.default_rng(1)
    scale = np.array([sec.A, sec.A, sec.A, sec.It / sec.ymax, sec.Iy / sec.zmax, sec.Iz / sec.ymax])
    res = rng.standard_normal((400, 2, 6)) * scale * 1e8 * rng.uniform(0, 1, (400, 2, 6)) ** 3
    coarse = perimeter_peaks(sec, res)
    monkeypatch.setattr(fs, "PERIMETER_POINTS", 16 * fs.PERIMETER_POINTS)
    monkeypatch.setattr(fs, "COARSE_STEP", 16 * fs.COARSE_STEP)
    fs._points.cache_clear()
    fine = perimeter_peaks(sec, res)
    fs._points.cache_clear()
    for c, f in zip(coarse, fine):
        assert np.all(c <= f * (1 + 1e-12))
        assert np.all(c >= f * (1 - 2e-5))


def test_concentration_and_safety_factors_per_joint():
    """A notch factor on one joint multiplies its elements' stresses only; the safety factor is
    limit / von Mises per element, its minimum per joint and for the mechanism."""
    sol = _two_leaves()
    plain = sol.stresses()
    s = sol.stresses(concentration={"left": 1.8}, limit=250e6)
    left, right = sol.compiled.joint_elements["left"], sol.compiled.joint_elements["right"]
    np.testing.assert_allclose(s.von_mises[left], 1.8 * plain.von_mises[left], rtol=1e-14)
    np.testing.assert_array_equal(s.von_mises[right], plain.von_mises[right])
    np.testing.assert_allclose(s.safety, 250e6 / s.von_mises, rtol=1e-14)
    assert s.joint("left")["safety"] == pytest.approx(250e6 / s.von_mises[left].max())
    assert s.summary()["safety"] == pytest.approx(s.safety.min())
    assert s.summary()["von_mises"] == pytest.approx(max(s.joint("left")["von_mises"], s.joint("right")["von_mises"]))
    np.testing.assert_allclose(sol.stresses(concentration=2.0).normal, 2 * plain.normal, rtol=1e-14)


def _two_leaves():
    """A parallel guide built as a user would: two 50 mm leaves 20 mm apart, stage pushed
    sideways 2 mm."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("base", fixed=True)
    m.add_link("stage", position=(0.05, 0.01))
    for name, y in (("left", 0.0), ("right", 0.02)):
        m.add_joint("base", "stage", flexmb.joint("leaf_spring", length=0.05, width=0.01, thickness=0.3e-3,
                                                  elements=6, **STEEL), name=name, origin=(0.0, y))
    m.prescribe("stage", y=0.012)
    sol = flexmb.solve(m)
    assert sol.converged
    return sol


def test_safety_from_the_joints_yield_stress():
    """Without ``limit`` the safety factors come from the sections' ``yield_stress`` (a joint's
    ``yield_stress``); a joint without one has NaN safety, ignored in the minima; ``limit``
    overrides it for all."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("base", fixed=True)
    m.add_link("stage", position=(0.05, 0.01))
    for name, y, ys in (("left", 0.0, 900e6), ("right", 0.02, None)):
        m.add_joint("base", "stage", flexmb.joint("leaf_spring", length=0.05, width=0.01, thickness=0.3e-3,
                                                  elements=6, yield_stress=ys, **STEEL), name=name, origin=(0.0, y))
    m.prescribe("stage", y=0.012)
    sol = flexmb.solve(m)
    s = sol.stresses()
    left, right = sol.compiled.joint_elements["left"], sol.compiled.joint_elements["right"]
    np.testing.assert_allclose(s.safety[left], 900e6 / s.von_mises[left], rtol=1e-14)
    assert np.all(np.isnan(s.safety[right]))
    assert s.summary()["safety"] == s.joint("left")["safety"] == pytest.approx(900e6 / s.von_mises[left].max())
    assert np.isnan(s.joint("right")["safety"])
    np.testing.assert_allclose(sol.stresses(limit=500e6).safety, 500e6 / s.von_mises, rtol=1e-14)
    assert _two_leaves().stresses().safety is None  # no yield stress anywhere


def test_stresses_refuse_bad_input():
    sol = _two_leaves()
    with pytest.raises(flexmb.ParameterError, match="concentration.*>= 1"):
        sol.stresses(concentration={"left": 0.5})
    with pytest.raises(flexmb.ModelError, match="no joint 'middle'"):
        sol.stresses(concentration={"middle": 1.5})
    with pytest.raises(flexmb.ParameterError, match="limit"):
        sol.stresses(limit=-1.0)
    with pytest.raises(flexmb.ParameterError, match="limit='1e9'"):  # text is not a number (was read as one)
        sol.stresses(limit="1e9")
    with pytest.raises(flexmb.ParameterError, match="concentration='2'"):
        sol.stresses(concentration="2")
    with pytest.raises(flexmb.ModelError, match="no joint named 'middle'"):
        sol.stresses().joint("middle")
    bare = flexmb.Section(E=2e11, G=7.69e10, A=1e-6, Iy=1e-13, Iz=1e-13, It=1e-13, ymax=5e-4, zmax=5e-4)
    with pytest.raises(flexmb.ModelError, match="shape"):
        _cantilever(section=bare).stresses()
    with pytest.raises(flexmb.ParameterError, match="shape"):
        flexmb.Section(E=2e11, G=7.69e10, A=1e-6, Iy=1e-13, Iz=1e-13, It=1e-13, ymax=5e-4, zmax=5e-4, shape="oval")
    with pytest.raises(flexmb.ParameterError, match="diameter"):
        circle(-1.0, **STEEL)


def _per_element(sol, axial=None):
    """The reference: every element's perimeter search alone, with its own section object."""
    model = sol.compiled.problem.model
    res = section_resultants(model, sol.state, axial)
    peaks = [perimeter_peaks(s, res[i:i + 1]) for i, s in enumerate(model.elements.sections)]
    return [np.concatenate([p[k] for p in peaks]) for k in range(3)]


def _wire_cross():
    """A wire cross flexure built as a user would (no paper has one): two 40 mm steel wires of
    1 mm diameter crossing at 90 deg, of two steels differing in density only (two `circle`
    sections, alike for the stress search), in 3D, the upper
    block turned 0.1 rad about z and pushed along z (torsion and bending about both axes)."""
    L, c = 0.04, 0.04 / np.sqrt(2.0)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.5 * c, c, 0.0))
    for name, x, angle, rho in (("rising", 0.0, np.pi / 4, 7800.0), ("falling", c, 3 * np.pi / 4, 7900.0)):
        m.add_joint("A", "B", flexmb.joint("leaf_spring", length=L, elements=5,
                                           section=circle(1e-3, density=rho, **STEEL)),
                    name=name, origin=(x, 0.0, 0.0), rotation=(0.0, 0.0, angle))
    m.prescribe("B", z=2e-4, rotation=(0.0, 0.0, 0.1))
    sol = flexmb.solve(m)
    assert sol.converged
    return sol


@pytest.mark.parametrize("case", ["manipulator", "manipulator ksd-reduced", "wire cross"])
def test_equal_sections_share_one_perimeter_search(case):
    """Elements whose sections are equal in what the search reads share one search
    (`fe.stress.section_table`, 9 groups -> 2 on the manipulator): the same stresses as each
    element searched alone (to 1e-14 of the peak: the same arithmetic)."""
    if case == "wire cross":
        sol = _wire_cross()
        assert len({id(s) for s in sol.compiled.problem.model.elements.sections}) == 2
        assert len(fs.section_table(sol.compiled.problem.model.elements).stress_groups) == 1
    else:
        m = flexmb.models.manipulator("joint", np.radians(45))
        sol = flexmb.solve(m, method="ksd-reduced" if "ksd" in case else "conventional", raise_on_failure=True)
    s = sol.stresses()
    ref = _per_element(sol, sol._element_axial_forces() if "ksd" in case else None)
    for got, want in zip((s.normal, s.shear, s.von_mises), ref):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * want.max())
    assert s.shear.max() > 0


def test_a_plugin_section_with_the_planar_beam_data_only():
    """A plugin section object carrying only what a planar beam reads (E, G, A, Iz, ky): its
    table has no Iy, no mass and no fibres (NaN, 0, `has_y` False), so the peak stress is refused
    by name (the plausibility check then skips it) rather than failing on a missing attribute."""
    import attrs

    from flexmb.errors import ModelError
    from flexmb.fe.model import BeamElements

    @attrs.frozen
    class Plain:
        E: float = 200e9
        G: float = 77e9
        A: float = 1e-5
        Iz: float = 1e-12
        ky: float = 5.0 / 6.0

    el = BeamElements(ends=np.array([[0, 1], [1, 2]]), L0=np.array([0.1, 0.1]), S=np.zeros((2, 3, 3)),
                      sections=(Plain(), Plain()), owner=np.array([0, 0]))
    table = fs.section_table(el)
    assert np.all(np.isnan(table.Iy)) and np.all(table.density == 0.0) and not table.has_y
    np.testing.assert_array_equal(table.length, [0.2, 0.2])  # one joint of two 0.1 m elements
    assert fs.section_table(el) is table  # kept with the batch

    class Model:
        dim, elements = 2, el

    with pytest.raises(ModelError, match="extreme-fibre distances"):
        fs.peak_normal_stress(Model(), None)


@pytest.mark.skipif(not flexmb.jit._AVAILABLE, reason="numba not installed")
@pytest.mark.parametrize("shape", ["rectangle", "square", "circle", "planar"])
def test_compiled_perimeter_search_equals_the_numpy_one(shape):
    """The compiled perimeter search (`flexmb.fe.stress_jit`) does the numpy path's arithmetic in
    its order: the same peaks to the last bit, on random section forces over nine decades at
    both ends (3D: all six; planar: N, Vy, Mz) and an axial force NaN (NaN normal and von Mises
    stress there, as numpy; the shear does not read it)."""
    sec = {"rectangle": rectangle(0.02, 1e-3, **STEEL), "square": rectangle(1e-3, 2e-3, **STEEL),
           "circle": circle(1e-3, **STEEL), "planar": rectangle(5e-3, 0.5e-3, **STEEL)}[shape]
    rng = np.random.default_rng(7)
    k = 3 if shape == "planar" else 6
    res = rng.standard_normal((300, 2, k)) * 10.0 ** rng.uniform(-6, 3, (300, 2, k))
    res[17, 1, 0] = np.nan
    previous = flexmb.jit.use("numpy")
    try:
        want = perimeter_peaks(sec, res)
        flexmb.jit.use("numba")
        got = perimeter_peaks(sec, res)
    finally:
        flexmb.jit.use("numba" if previous else "numpy")
    assert np.isnan(got[0][17]) and np.isnan(got[2][17]) and np.isfinite(got[1][17])
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_stresses_of_a_user_built_mechanism_in_mm_n_tonne_units():
    """A cross flexure built as a user would, once in m, N, Pa and once in mm, N, MPa (two 40 mm
    leaves crossing, the stage turned 0.2 rad): the peak stresses in MPa equal
    the SI ones / 1e6 (consistent units), with the compiled perimeter search and the numpy one."""
    def pivot(mm):
        u, c = (1e3 if mm else 1.0), 0.04 / (2 * np.sqrt(2))
        m = flexmb.Mechanism(dim=2)
        m.add_link("base", fixed=True)
        m.add_link("stage", position=(0.0, 2 * c * u))
        for name, x, angle in (("rising", -c, np.pi / 4), ("falling", c, 3 * np.pi / 4)):
            leaf = flexmb.joint("leaf_spring", length=0.04 * u, width=0.01 * u, thickness=0.3e-3 * u, elements=6,
                                E=200e9 / u**2, G=77e9 / u**2)
            m.add_joint("base", "stage", leaf, name=name, origin=(x * u, 0.0), rotation=angle)
        m.prescribe("stage", rotation=0.2)
        return flexmb.solve(m, raise_on_failure=True)

    si, mm = pivot(False), pivot(True)
    for mode in ("numpy", "auto"):
        previous = flexmb.jit.use(mode)
        try:
            a, b = si.stresses(), mm.stresses()
        finally:
            flexmb.jit.use("numba" if previous else "numpy")
        for k in ("normal", "shear", "von_mises"):
            np.testing.assert_allclose(getattr(b, k), getattr(a, k) / 1e6, rtol=1e-7)
        assert a.von_mises.max() > 1e7


def _wire_stage():
    """A stage on three round steel wires (1 mm) and one flat leaf (10 x 0.5 mm), 30 mm long, built
    as a user would in mm, N, MPa: pushed sideways, twisted and pulled (bending, torsion, shear and
    axial force in every element; two section groups)."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("base", (0.0, 0.0, 0.0), fixed=True)
    m.add_link("stage", (0.0, 0.0, 30.0))
    wire = circle(1.0, E=200000.0, nu=0.3, density=7.8e-9)
    for k, angle in enumerate((0.0, 2 * np.pi / 3, 4 * np.pi / 3)):
        x, y = 12.0 * np.cos(angle), 12.0 * np.sin(angle)
        m.add_joint("base", "stage", flexmb.LeafSpring(length=30.0, elements=5, section=wire), name=f"wire{k}",
                    origin=(x, y, 0.0), rotation=(0.0, -np.pi / 2, 0.0))
    m.add_joint("base", "stage", flexmb.LeafSpring(length=30.0, elements=5, section=rectangle(10.0, 0.5, E=200000.0,
                                                                                              nu=0.3)),
                name="leaf", origin=(0.0, 0.0, 0.0), rotation=(0.0, -np.pi / 2, 0.0))
    m.apply_force("stage", (3.0, 1.0, 20.0))  # N
    m.apply_moment("stage", (0.0, 0.0, 40.0))  # N mm
    return m


@pytest.mark.skipif(not flexmb.jit._AVAILABLE, reason="numba not installed")
def test_one_pass_stresses_equal_the_per_group_search_on_a_wire_stage_in_mm():
    """`Solution.stresses`'s one compiled pass (`stress_jit.element_peaks`) gives the per-group
    compiled search's numbers to the last bit and the numpy path's to the assembly's 1e-12 (its
    generalised stresses: tests/test_kernels.py), on a mechanism no paper has: a stage on three
    round wires and a flat leaf in mm, N, MPa, with the torsion, shear and axial force nonzero."""
    sol = flexmb.solve(_wire_stage(), raise_on_failure=True)
    fast = sol.stresses(concentration={"leaf": 1.4})
    model = sol.compiled.problem.model
    assert fs._plan(fs.section_table(model.elements), len(model.elements.L0)) is not None  # the one pass ran
    assert len(fs.section_table(model.elements).stress_groups) == 2
    res = section_resultants(model, sol.state)
    assert np.all(np.abs(res[:, :, 3]) > 1e-3) and np.all(np.abs(res[:, :, 0]) > 1e-2)  # torsion [N mm], axial [N]
    plans = fs._plan
    try:
        fs._plan = lambda tab, n: None  # the per-group path
        grouped = sol.stresses(concentration={"leaf": 1.4})
    finally:
        fs._plan = plans
    previous = flexmb.jit.use("numpy")
    try:
        slow = sol.stresses(concentration={"leaf": 1.4})
    finally:
        flexmb.jit.use("numba" if previous else "numpy")
    for k in ("normal", "shear", "von_mises"):
        np.testing.assert_array_equal(getattr(fast, k), getattr(grouped, k))
        np.testing.assert_allclose(getattr(fast, k), getattr(slow, k), rtol=1e-12)
    assert 10.0 < fast.von_mises.max() < 2000.0  # MPa: stressed, below steel's yield
    assert fast.joint("leaf")["normal"] > 0 and fast.shear.min() > 0
    again = sol.stresses(concentration={"leaf": 1.4})
    assert again.von_mises is not fast.von_mises and not np.shares_memory(again.von_mises, fast.von_mises)
    np.testing.assert_array_equal(again.von_mises, fast.von_mises)


@pytest.mark.skipif(not flexmb.jit._AVAILABLE, reason="numba not installed")
def test_the_compiled_coarse_argmax_is_numpys():
    """`stress_jit._first_max` (eight running maxima, then the first index reaching the largest)
    is ``np.argmax`` (the first of equal largest values) on random and tied arrays of every length
    up to 40 and the perimeter search's 128 and 129."""
    from flexmb.fe import stress_jit

    rng = np.random.default_rng(3)
    for n in [*range(1, 41), 128, 129]:
        for _ in range(50):
            a = rng.integers(0, 4, n).astype(float) if rng.random() < 0.5 else rng.standard_normal(n)
            assert stress_jit._first_max(a, n) == np.argmax(a)


@pytest.mark.skipif(not flexmb.jit._AVAILABLE, reason="numba not installed")
def test_compiled_search_equals_numpy_where_the_stresses_overflow():
    """Section forces so large that the stresses overflow (inf, and inf - inf = NaN at some points):
    the compiled search, which skips its NaN scan only below such bounds, gives numpy's infinities
    and NaNs (rectangle and circle, 3D)."""
    rng = np.random.default_rng(11)
    res = rng.standard_normal((40, 2, 6)) * 10.0 ** rng.uniform(150, 300, (40, 2, 6))
    res[5] = 1e308  # every component: N/A + My z/Iy - Mz y/Iz = inf - inf at a corner
    for sec in (rectangle(0.02, 1e-3, **STEEL), circle(1e-3, **STEEL)):
        previous = flexmb.jit.use("numpy")
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                want = perimeter_peaks(sec, res)
            flexmb.jit.use("numba")
            got = perimeter_peaks(sec, res)
        finally:
            flexmb.jit.use("numba" if previous else "numpy")
        assert np.isnan(want[0][5]) and np.isnan(want[2][5]) and np.isinf(want[2]).sum() == 39
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
