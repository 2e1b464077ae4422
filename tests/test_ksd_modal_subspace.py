"""KSD-reduced free vibration from the joints' tabulated span of fixed-interface modes
(`flexmb.ksd.joint_mass.condensed_subspace`): the same frequencies as the Ritz eigenproblems
solved per configuration, and a kept span that does not depend on roundoff (the tie rule)."""

import functools
import weakref

import numpy as np
import pytest

import flexmb
import flexmb.modal as modal
from flexmb.ksd import reduced_model
from flexmb.ksd import joint_mass as jm
from flexmb.ksd.joint_mass import joint_mass
from flexmb.models import cross_flexure_pivot, fourbar, manipulator


def _frequencies(sol, n, table, **kw):
    """`flexmb.modes` of a KSD-reduced solution with the joints' span tabulated (``table``) or
    their Ritz eigenproblems solved at the configuration (the reference path)."""
    original = reduced_model.reduced_modal_model  # what the KSD-reduced linearisation calls
    reduced_model.reduced_modal_model = functools.partial(original, table=table)
    try:
        reduced_model._NEAR.pop(sol, None)
        return flexmb.modes(sol, n_modes=n, **kw).frequencies
    finally:
        reduced_model.reduced_modal_model = original


def _pivot_with_stage(deg, mass):
    """A 3D Table 1 cross flexure (5 el./leaf, steel) carrying a massive stage B (``mass`` kg, a
    5 cm aluminium-like cube's inertia scaled), B turned ``deg`` about the joint axis: not in
    the paper."""
    joint = flexmb.CrossFlexure(elements_per_leaf=5)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3), mass=mass, inertia=mass * 0.05 ** 2 / 6 * np.eye(3))
    m.add_joint("A", "B", joint, name="pivot")
    m.prescribe("B", rotation=(0.0, 0.0, np.radians(deg)))
    return m


@pytest.mark.slow
def test_tabulated_span_gives_the_per_configuration_frequencies():
    """The manipulator (Dwarshuis et al. 2020, Sec. 4.4, joint case) at 10 rotations between the
    table's grid points (four within 1 deg of 0, where its joints' 6th and 7th fixed-interface
    eigenvalues come within 0.085 % of each other): f1-f6 from the splined span equal the
    per-configuration eigensolve's to 1e-7 relative (measured 5.8e-11), and the four-bar's
    (Fig. 9, 5 el./leaf) at 5 strokes (measured 2.5e-13)."""
    rng = np.random.default_rng(11)
    for deg in np.r_[rng.uniform(-45, 45, 6), rng.uniform(-1, 1, 4)]:
        sol = flexmb.solve(manipulator("joint", np.radians(deg)), method="ksd-reduced", raise_on_failure=True)
        np.testing.assert_allclose(_frequencies(sol, 6, True), _frequencies(sol, 6, False), rtol=1e-7)
    for d in rng.uniform(0.0, 0.3, 5):
        sol = flexmb.solve(fourbar(5, displacement=d), method="ksd-reduced", raise_on_failure=True)
        np.testing.assert_allclose(_frequencies(sol, 6, True), _frequencies(sol, 6, False), rtol=1e-7)


def test_the_kept_span_keeps_whole_ties_at_the_cut():
    """The four-bar's cross flexures have three interior chains whose fixed-interface
    eigenvalues tie at the joint's middle rotation (the 5th-7th of the pooled spectrum): all
    three are kept (7 coordinates for n_fixed = 6), so the frequencies are a smooth function of
    the solution. Unturned against a stroke of 1e-10 m: measured 5e-10 relative; choosing 6 of
    the 7 per configuration (before) moved them 1.7e-5."""
    sol = flexmb.solve(fourbar(5), method="ksd-reduced", raise_on_failure=True)
    red, _ = reduced_model.near(sol)
    tpl, _, idx = red.groups[0]
    joint = {k: j for k, j, *_ in sol.compiled.joints}[red.joint_names[idx[0]]]
    counts = joint_mass(tpl, joint).cut(6)
    assert [c.tolist() for c in counts] == [[3, 2, 2]]
    f0 = flexmb.modes(sol, n_modes=6).frequencies
    for d in (1e-10, -1e-10):
        f = flexmb.modes(flexmb.solve(fourbar(5, displacement=d), method="ksd-reduced"), n_modes=6).frequencies
        np.testing.assert_allclose(f, f0, rtol=1e-8)


@pytest.mark.parametrize("deg", [-41.3, 23.7])
def test_modes_of_a_turned_pivot_with_a_massive_stage(deg):
    """A 3D cross-flexure pivot with a 2 kg stage, turned between the table's grid points (not
    in the paper): KSD-reduced f1-f3 within 1 % of the conventional solution's (measured +0.49,
    +0.53, -0.24 % at -41.3 deg; +0.18, +0.17, -0.09 % at 23.7 deg), the splined span's equal
    to the per-configuration eigensolve's to 1e-7 (measured 2e-14), and the recovered
    mass-normalised shapes on every node equal to the conventional ones (up to sign) within 2 %
    of their largest entry (measured 0.11-0.96 %)."""
    m = _pivot_with_stage(deg, 2.0)
    full, red = flexmb.solve(m), flexmb.solve(m, method="ksd-reduced", raise_on_failure=True)
    a, b = flexmb.modes(full, n_modes=3), flexmb.modes(red, n_modes=3)
    np.testing.assert_allclose(b.frequencies, a.frequencies, rtol=0.01)
    np.testing.assert_allclose(_frequencies(red, 3, True), _frequencies(red, 3, False), rtol=1e-7)
    for u, v in zip(a.shapes.reshape(3, -1), b.shapes.reshape(3, -1)):
        assert min(np.abs(u - v).max(), np.abs(u + v).max()) <= 0.02 * np.abs(u).max()


def test_a_crossing_at_the_cut_is_detected_from_the_samples():
    """A chain whose kept mode (one of a 2D Ritz space) swaps between two samples, as a true
    eigenvalue crossing at the cut makes it (constructed: the kept vector e1 below 0 deg, e2
    above, the two eigenvalues meeting there): the neighbouring spans' overlap is 0 and the
    gap 1 at the crossing, so `span_check` refuses the table; a smoothly turning span (1 deg
    per sample) passes with overlap cos(1 deg)."""
    theta = np.radians(np.linspace(-2.0, 2.0, 9))
    lam1, lam2 = 1.0 + theta, 1.0 - theta  # cross at 0: the lower one is kept
    gap = np.maximum(lam1, lam2) / np.minimum(lam1, lam2)
    kept = np.where((lam1 <= lam2)[:, None, None], [[1.0], [0.0]], [[0.0], [1.0]])
    sv = np.abs(kept[:, 0])  # against the middle sample's e1 (theta = 0 keeps e1)
    margins = jm.span_margins([(theta, [(gap, sv, kept)])], theta[1] - theta[0])
    assert margins["neighbour"][0] == pytest.approx(0.0, abs=1e-12)
    assert margins["gap"][0] == pytest.approx(1.0)
    assert "neighbouring samples' span overlap 0 < 0.9" in jm.span_check(margins)
    turning = np.stack([np.cos(theta), np.sin(theta)], axis=1)[:, :, None]
    smooth = jm.span_margins([(theta, [(np.full(9, 2.0), np.cos(theta)[:, None], turning)])], theta[1] - theta[0])
    assert smooth["neighbour"][0] == pytest.approx(np.cos(theta[1] - theta[0]))
    assert jm.span_check(smooth) == ""


@pytest.mark.slow
def test_a_refused_table_falls_back_to_the_per_configuration_eigensolve(monkeypatch):
    """With the neighbour threshold raised above the manipulator's measured overlap (0.982, at
    its avoided crossing at 0 deg) its joint's table is refused, the reason recorded, and
    `condensed_subspace` gives exactly the Ritz eigenproblems solved per configuration."""
    sol = flexmb.solve(manipulator("joint", np.radians(10.0)), method="ksd-reduced", raise_on_failure=True)
    red, _ = reduced_model.near(sol)
    tpl, _, idx = red.groups[0]
    joint = {k: j for k, j, *_ in sol.compiled.joints}[red.joint_names[idx[0]]]
    monkeypatch.setattr(jm, "_JOINT_MASS", weakref.WeakKeyDictionary())
    monkeypatch.setattr(jm, "NEIGHBOUR_MIN", 0.99)
    theta = np.radians([-30.0, 0.3, 12.0])
    got = jm.condensed_subspace(tpl, joint, theta, 6)
    data = jm.joint_mass(tpl, joint)
    assert data.table(6) is None
    assert "neighbouring samples' span overlap 0.98" in data.refused[6]
    assert 0.98 < data.margins[6]["neighbour"][0] < 0.99
    want = jm.condensed_subspace(tpl, joint, theta, 6, table=False)
    for a, b in zip(got[:3] + got[3], want[:3] + want[3]):
        np.testing.assert_array_equal(a, b)


def test_a_planar_cross_flexure_turned_where_the_alignment_degenerates():
    """A planar cross flexure pivot (5 el./leaf, not in the paper) turned 62.6 deg: its joint
    template's kept span (two chains, 3 + 3 modes) turns through a direction orthogonal to the
    middle rotation's (alignment singular value 1.7e-4 at 62.75 deg: the aligned basis flips
    there), so `span_check` refuses the table. Splined across the flip the frequencies were
    wrong (f3 -2.55 % against the conventional solution instead of +0.42 %, 3 % off the Ritz
    eigensolve); now `flexmb.modes` equals the per-configuration eigensolve and f1-f3 are within
    1.5 % of the conventional ones (measured +1.02, +1.26, +0.42 %)."""
    m = cross_flexure_pivot(5, dim=2, rotation=np.radians(62.6))
    red = flexmb.solve(m, method="ksd-reduced", raise_on_failure=True)
    f = flexmb.modes(red, n_modes=6).frequencies
    np.testing.assert_allclose(f, _frequencies(red, 6, False), rtol=1e-12)
    np.testing.assert_allclose(f[:3], flexmb.modes(flexmb.solve(m), n_modes=3).frequencies, rtol=0.015)
    r, _ = reduced_model.near(red)
    tpl, _, idx = r.groups[0]
    data = joint_mass(tpl, {k: j for k, j, *_ in red.compiled.joints}[r.joint_names[idx[0]]])
    assert data.table(6) is None and "alignment's smallest singular value" in data.refused[6]


def test_the_interior_recovery_is_read_only_when_the_shapes_are():
    """`condensed_subspace(..., recovery=False)` defers the joints' interior transformation
    (``X``, fixed-interface shapes): called, it gives bit for bit what ``recovery=True`` gives,
    and a KSD-reduced `Modes` builds its shapes per node on first access (once, read-only): the
    links' rows equal to ``link_shapes`` (and a pickled copy's), the joints' internal nodes moving (recovered; their
    agreement with the full model: `test_modes_of_a_turned_pivot_with_a_massive_stage`)."""
    sol = flexmb.solve(manipulator("joint", np.radians(-17.0)), method="ksd-reduced", raise_on_failure=True)
    red, _ = reduced_model.near(sol)
    tpl, _, idx = red.groups[0]
    joint = {k: j for k, j, *_ in sol.compiled.joints}[red.joint_names[idx[0]]]
    theta = np.radians([-17.0, 3.3, 40.1])
    eager = jm.condensed_subspace(tpl, joint, theta, 6)
    lazy = jm.condensed_subspace(tpl, joint, theta, 6, recovery=False)
    for a, b in zip(eager[:3] + eager[3], lazy[:3] + lazy[3]()):
        np.testing.assert_array_equal(a, b)
    result = flexmb.modes(sol, n_modes=4)
    assert callable(result._shapes)
    import pickle

    copy = pickle.loads(pickle.dumps(result))  # pickled with its shapes built
    np.testing.assert_array_equal(copy.shapes, result.shapes)
    np.testing.assert_array_equal(copy.frequencies, result.frequencies)
    shapes = result.shapes
    assert not shapes.flags.writeable and result.shapes is shapes
    for link, node in sol.compiled.link_node.items():
        np.testing.assert_array_equal(shapes[:, node], result.link_shapes[link])
    assert shapes.shape == (4, sol.compiled.problem.model.n_nodes, 6)
    internal = np.concatenate([np.asarray(n) for n in sol.compiled.joint_nodes.values()])
    internal = internal[internal >= len(sol.compiled.link_node)]
    assert (np.abs(shapes[:, internal]).max(axis=(1, 2)) > 0.1 * np.abs(shapes).max(axis=(1, 2))).all()


@pytest.mark.parametrize("deg", [-33.0, 12.5])
def test_a_heavy_stage_pivot_through_the_fast_paths_equals_the_reference_paths(deg, monkeypatch, kernels):
    """The 3D cross-flexure pivot carrying a 2 kg stage (not in the paper), turned between the
    tables' grid points, loaded by a dead force on the stage: KSD-reduced ``modes`` from the
    tabulated span (interior recovery deferred) equal the Ritz eigenproblems per configuration
    to 1e-10; the compliance's solve by LAPACK directly (the linearisation's kept factorisation) equals
    `scipy.linalg.solve`'s bit for bit; the
    stresses with the compiled EOB axial forces equal the numpy path's to 1e-12."""
    import scipy.linalg as sla

    from flexmb.fe.stress import element_stresses

    m = _pivot_with_stage(deg, 2.0)
    m.apply_force("B", [3.0, -2.0, 1.0])
    sol = flexmb.solve(m, method="ksd-reduced", raise_on_failure=True)
    np.testing.assert_allclose(_frequencies(sol, 6, True), _frequencies(sol, 6, False), rtol=1e-10)
    lin = sol.linearisation(owner="compliance")
    rhs = np.eye(len(lin.free))[:, :3]
    np.testing.assert_array_equal(lin.solve(rhs), sla.solve(lin.K, rhs))  # the kept factorisation's first solve
    at, N = reduced_model.eob_axial_forces(sol)
    kernels("numpy")
    at0, N0 = reduced_model.eob_axial_forces(sol)
    model, joints = sol.compiled.problem.model, sol.compiled.joint_elements
    vm, vm0 = (element_stresses(model, sol.state, joints, axial=(a, n)).von_mises for a, n in ((at, N), (at0, N0)))
    np.testing.assert_allclose(vm, vm0, rtol=1e-12)


def test_deferred_vectors_equal_the_eager_solve(monkeypatch):
    """A KSD-reduced `flexmb.modes` solves the eigenvalues alone (LAPACK ``dsygvx`` without
    vectors) and the vectors when ``shapes`` or ``link_shapes`` is first read: the frequencies
    equal the eager solve's (vectors with the values) to 1e-12 relative, the shapes and link
    shapes bit for bit (the same call solves them)."""
    sol = flexmb.solve(manipulator("joint", np.radians(28.0)), method="ksd-reduced", raise_on_failure=True)
    lazy = flexmb.modes(sol, n_modes=6)
    assert callable(lazy._link_shapes) and callable(lazy._shapes)
    monkeypatch.setattr(modal, "_dense_eigenvalues", lambda K, M, n: None)
    eager = flexmb.modes(sol, n_modes=6)
    assert not callable(eager._link_shapes)
    np.testing.assert_allclose(lazy.frequencies, eager.frequencies, rtol=1e-12)
    np.testing.assert_array_equal(lazy.shapes, eager.shapes)
    for link, rows in eager.link_shapes.items():
        np.testing.assert_array_equal(lazy.link_shapes[link], rows)


def test_joints_whose_chains_keep_no_fixed_interface_mode_give_modes():
    """The four-bar (Sec. 4.3, d = 0.3 m) meshed with one element per leaf: its cross flexures'
    chains keep no fixed-interface mode, whose empty tables failed to spline (ValueError on a
    zero-size maximum). Now its KSD-reduced modes come out and match the conventional model's
    first four to 0.1 % (measured 0.03 %: 221.48 / 221.42 Hz, 471.77 / 471.68 Hz)."""
    m = fourbar(1, displacement=0.3)
    red = flexmb.modes(flexmb.solve(m, method="ksd-reduced", raise_on_failure=True), n_modes=4).frequencies
    full = flexmb.modes(flexmb.solve(m, raise_on_failure=True), n_modes=4).frequencies
    np.testing.assert_allclose(red, full, rtol=1e-3)
