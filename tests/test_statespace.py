"""State-space models at a deformed configuration (issue 30 item 5): static gain = `flexmb.compliance`
and poles = `flexmb.modes` (times i 2 pi), both to 1e-9, on a cross-flexure pivot carrying a block."""

import numpy as np
import pytest

import flexmb
from flexmb.errors import ModelError, ParameterError


def pivot_with_block(dim: int, moment: float = 1.5):
    """A Table 1 cross flexure (5 el./leaf) whose upper block is a 0.2 kg steel block (60 x 20 x
    20 mm, inertia of a cuboid about its centre, centre 15 mm above B), loaded by a moment about the
    axis and a side force: the configuration is turned and bent (no paper holds it)."""
    m = flexmb.Mechanism(dim=dim)
    joint = flexmb.CrossFlexure(elements_per_leaf=5)
    B = joint.interface_b(dim)
    mass, (a, b, c) = 0.2, (0.06, 0.02, 0.02)
    Jz = mass * (a**2 + b**2) / 12
    inertia = Jz if dim == 2 else np.diag([mass * (b**2 + c**2) / 12, mass * (a**2 + c**2) / 12, Jz])
    m.add_link("A", fixed=True)
    m.add_link("B", position=B, mass=mass, inertia=inertia, center=np.eye(dim)[1] * 0.015)
    m.add_joint("A", "B", joint, name="pivot")
    m.add_point("B", "tip", B + np.eye(dim)[0] * 0.03)
    m.apply_moment("B", moment if dim == 2 else (0.0, 0.0, moment))
    m.apply_force("B", 0.5 * np.eye(dim)[0])
    return m


@pytest.fixture(scope="module", params=[2, 3])
def solved(request):
    sol = flexmb.solve(pivot_with_block(request.param))
    assert sol.converged and abs(sol.rotation_vector("B")[-1]) > 0.05  # a deformed configuration
    return sol


def comps(dim):
    return ("x", "y", "rotation") if dim == 2 else ("x", "y", "z", "rx", "ry", "rz")


def test_static_gain_equals_the_compliance(solved):
    dim = solved.dim
    cs = comps(dim)
    for point in (None, "tip"):
        extra = () if point is None else (point,)
        ins = [("force", "B", c, *extra) for c in cs]
        outs = [("displacement", "B", c, *extra) for c in cs]
        ss = flexmb.state_space(solved, ins, outs, n_modes=4)
        C = flexmb.compliance(solved, "B", point=point)
        np.testing.assert_allclose(ss.static_gain(), C, rtol=1e-9, atol=1e-9 * np.abs(C).max())
        # and at 0 Hz the frequency response is the same
        np.testing.assert_allclose(ss.frequency_response(0.0)[0].real, C, rtol=1e-9, atol=1e-9 * np.abs(C).max())


def test_poles_are_the_modes_times_i_two_pi(solved):
    n = 5
    ss = flexmb.state_space(solved, [("force", "B", "x")], [("displacement", "B", "x")], n_modes=n)
    f = flexmb.modes(solved, n_modes=n).frequencies
    expected = np.sort(np.concatenate([2j * np.pi * f, -2j * np.pi * f]).imag)
    poles = ss.poles()
    np.testing.assert_allclose(poles.real, 0.0, atol=1e-9 * np.abs(poles).max())
    np.testing.assert_allclose(np.sort(poles.imag), expected, rtol=1e-9)
    np.testing.assert_array_equal(ss.frequencies, f)


def test_damped_poles_and_the_gain_do_not_depend_on_the_damping(solved):
    zeta = np.array([0.01, 0.02, 0.05])
    ss = flexmb.state_space(solved, [("force", "B", "x")], [("displacement", "B", "x")], n_modes=3, damping=zeta)
    w = 2 * np.pi * flexmb.modes(solved, n_modes=3).frequencies
    expected = np.concatenate([w * (-zeta + 1j * np.sqrt(1 - zeta**2)), w * (-zeta - 1j * np.sqrt(1 - zeta**2))])
    got = ss.poles()
    np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(expected), rtol=1e-9)
    undamped = flexmb.state_space(solved, [("force", "B", "x")], [("displacement", "B", "x")], n_modes=3)
    np.testing.assert_allclose(ss.static_gain(), undamped.static_gain(), rtol=1e-12)


def test_motion_inputs_and_reaction_outputs_match_finite_differences():
    """A prescribed rotation of the block as the input: the static gains of the reaction moment
    and of the block's x are d(reaction)/d(rotation) and d(x)/d(rotation) of the nonlinear solves
    (central differences, h = 1e-4 rad: truncation ~h^2 = 1e-8 relative; the solves' residual
    floor, ~1e-8 N m of a 28 N force scale, gives ~1e-8 / h = 1e-4 N m on a 14 N m/rad gain, so
    2e-5 relative)."""
    def pivot(rot):
        m = flexmb.models.cross_flexure_pivot(elements_per_leaf=5, dim=2, rotation=rot)
        m.graph.nodes["B"]["link"] = __import__("attrs").evolve(m.link("B"), mass=0.2, inertia=6.7e-5)
        return m

    r0, h = 0.3, 1e-4
    sol = flexmb.solve(pivot(r0))
    ss = flexmb.state_space(sol, [("motion", "B", "rotation")],
                            [("reaction", "B", "rotation"), ("displacement", "B", "x")], n_modes=4, damping=0.02)
    plus, minus = flexmb.solve(pivot(r0 + h), rtol=1e-13), flexmb.solve(pivot(r0 - h), rtol=1e-13)
    dM = (plus.reaction("B")[2] - minus.reaction("B")[2]) / (2 * h)
    dx = (plus.pose("B")[0][0] - minus.pose("B")[0][0]) / (2 * h)
    G = ss.static_gain()
    assert G[0, 0] == pytest.approx(dM, rel=2e-5) and G[1, 0] == pytest.approx(dx, rel=2e-5)
    assert ss.labels[("reaction", "B", "rotation")] == "N m" and ss.labels[("motion", "B", "rotation")] == "rad"


def test_a_point_force_on_a_link_with_a_held_rotation_and_its_reaction():
    """The pivot with B's turn prescribed: a force along y at B's point 30 mm off (its moment lands
    on the held rotation) and a moment on the held rotation itself. The gains to B's rotation
    reaction are d(reaction)/d(load) of the nonlinear solves (central differences, h = 1e-3 N:
    the reaction is linear in a dead load up to the tangent's change, ~1e-9 relative here, and the
    residual floor ~1e-8 N m / h = 1e-5 N m of ~0.03 N m per N)."""
    def pivot(force=0.0, moment=0.0):
        m = flexmb.models.cross_flexure_pivot(elements_per_leaf=5, dim=2, rotation=0.3)
        m.add_point("B", "side", m.link("B").position + (0.03, 0.0))
        if force:
            m.apply_force("B", (0.0, force), point=m.link("B").position + (0.03, 0.0))
        if moment:
            m.apply_moment("B", moment)
        return m

    sol = flexmb.solve(pivot())
    ss = flexmb.state_space(sol, [("force", "B", "y", "side"), ("force", "B", "rotation")],
                            [("reaction", "B", "rotation"), ("displacement", "B", "y")], n_modes=3)
    G = ss.static_gain()
    h = 1e-3
    for j, (kw, key) in enumerate(((dict(force=h), dict(force=-h)), (dict(moment=h), dict(moment=-h)))):
        plus, minus = flexmb.solve(pivot(**kw), rtol=1e-13), flexmb.solve(pivot(**key), rtol=1e-13)
        dM = (plus.reaction("B")[2] - minus.reaction("B")[2]) / (2 * h)
        dy = (plus.pose("B")[0][1] - minus.pose("B")[0][1]) / (2 * h)
        assert G[0, j] == pytest.approx(dM, rel=1e-4, abs=1e-9), j
        assert G[1, j] == pytest.approx(dy, rel=1e-4, abs=1e-12), j
    assert G[0, 1] == pytest.approx(-1.0, abs=1e-12)  # a moment on the held turn: all of it to the support


@pytest.mark.slow  # importing python-control takes ~3 s
def test_python_control_statespace(solved):
    control = pytest.importorskip("control")
    ss = flexmb.state_space(solved, [("force", "B", "x")], [("displacement", "B", "x"), ("displacement", "B", "y")],
                            n_modes=3, damping=0.01)
    sys_ = ss.to_control()
    assert isinstance(sys_, control.StateSpace)
    assert sys_.input_labels == ["force_B_x"] and sys_.output_labels == ["displacement_B_x", "displacement_B_y"]
    np.testing.assert_allclose(np.asarray(sys_.dcgain()).reshape(2, 1), ss.static_gain(), rtol=1e-9)


def test_a_bode_plot_with_unit_labels(solved, tmp_path):
    pytest.importorskip("matplotlib")
    ss = flexmb.state_space(solved, [("force", "B", "x")], [("displacement", "B", "x")], n_modes=3, damping=0.02)
    mag, phase = ss.plot()
    assert "[m/N]" in mag.get_legend().get_texts()[0].get_text() and phase.get_xlabel() == "frequency [Hz]"
    mag.figure.savefig(tmp_path / "bode.png")
    assert (tmp_path / "bode.png").stat().st_size > 5000


def test_bad_specifications_are_refused(solved):
    good_in, good_out = [("force", "B", "x")], [("displacement", "B", "x")]
    with pytest.raises(ModelError, match="no link 'C'"):
        flexmb.state_space(solved, [("force", "C", "x")], good_out)
    with pytest.raises(ParameterError, match="component 'w'"):
        flexmb.state_space(solved, good_in, [("displacement", "B", "w")])
    with pytest.raises(ModelError, match="not a held DOF"):
        flexmb.state_space(solved, [("motion", "B", "x")], good_out)
    with pytest.raises(ModelError, match="the DOF is free"):
        flexmb.state_space(solved, good_in, [("reaction", "B", "x")])
    with pytest.raises(ParameterError, match="damping"):
        flexmb.state_space(solved, good_in, good_out, damping=1.5)
    with pytest.raises(ParameterError, match="must be"):
        flexmb.state_space(solved, [("torque", "B", "x")], good_out)


@pytest.mark.parametrize("dim", [2, 3])
def test_with_hinges_forces_in_displacements_out(dim):
    """A four-bar on a motor, two spring hinges and a leaf (test_files' hinged mechanism, the coupler
    and rocker given mass): on the motions the hinges allow, static gain = compliance and poles =
    modes, to 1e-9; motions and reactions are refused by name."""
    import warnings

    import attrs
    from test_files import hinged_fourbar

    m = hinged_fourbar(dim)
    for name in ("coupler", "rocker"):
        m.graph.nodes[name]["link"] = attrs.evolve(m.link(name), mass=0.05,
                                                   inertia=2e-5 if dim == 2 else 2e-5 * np.eye(3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", flexmb.PlausibilityWarning)  # the leaf bends past its elastic strain
        sol = flexmb.solve(m)
    cs = comps(dim)
    ss = flexmb.state_space(sol, [("force", "coupler", c) for c in cs], [("displacement", "coupler", c) for c in cs],
                            n_modes=2)
    C = flexmb.compliance(sol, "coupler")
    np.testing.assert_allclose(ss.static_gain(), C, rtol=1e-9, atol=1e-9 * np.abs(C).max())
    f = flexmb.modes(sol, n_modes=2).frequencies
    np.testing.assert_allclose(np.sort(ss.poles().imag), np.sort(np.r_[-2 * np.pi * f, 2 * np.pi * f]), rtol=1e-9)
    with pytest.raises(flexmb.UnsupportedStrategyError, match="with hinges the inputs are forces"):
        flexmb.state_space(sol, [("force", "coupler", "x")], [("reaction", "ground", "x")], n_modes=2)
