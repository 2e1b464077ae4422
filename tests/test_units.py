"""Declared unit systems (issue 30 item 2): one user mechanism in SI, mm-N-MPa and um-uN-MPa with a
named material gives the same physical answers; numbers that cannot be in the declared units warn."""

import math
import warnings

import numpy as np
import pytest

import flexmb
from flexmb import units
from flexmb.errors import ModelError, ParameterError, PlausibilityWarning

SYSTEMS = ("SI", "mm-N-MPa", "um-uN-MPa")


def guided_stage(system: str) -> flexmb.Mechanism:
    """A user's planar stage (no paper has it): a block on two spring-steel leaves 40 mm x 8 mm x
    0.3 mm, 30 mm apart, pushed sideways 2 mm and loaded along the leaves by 5 N, with a 20 g
    block (inertia 2e-6 kg m^2). Numbers given in SI and converted to ``system``."""
    u = units.SYSTEMS[system]
    L = lambda x: u.from_si("length", x)  # noqa: E731
    m = flexmb.Mechanism(dim=2, units=system)
    m.add_link("ground", fixed=True)
    m.add_link("block", position=(0.0, L(0.04)), mass=u.from_si("mass", 0.02), inertia=u.from_si("inertia", 2e-6))
    for x in (-0.015, 0.015):
        m.add_joint("ground", "block", "leaf_spring", origin=(L(x), 0.0), rotation=math.pi / 2, length=L(0.04),
                    width=L(0.008), thickness=L(3e-4), elements=6, material="spring_steel")
    m.prescribe("block", x=L(0.002), rotation=0.0)
    m.apply_force("block", (0.0, u.from_si("force", -5.0)))
    return m


def physical(system: str) -> dict:
    """The stage's answers in SI: block position [m], reaction [N, N m], first frequencies [Hz],
    compliance of the block (along y [m/N]), peak stress [Pa]."""
    u = units.SYSTEMS[system]
    sol = flexmb.solve(guided_stage(system))
    assert sol.converged
    md = flexmb.modes(sol, n_modes=2, held="fixed")
    C = flexmb.compliance(sol, "block", held="fixed")
    return {"position": u.to_si("length", sol.pose("block")[0]),
            "force": u.to_si("force", sol.reaction("block")[:2]),
            "moment": u.to_si("moment", sol.reaction("block")[2]),
            "frequencies": u.to_si("frequency", md.frequencies),
            "compliance_y": u.to_si("compliance", C[1, 1]),
            "stress": u.to_si("stress", sol.peak_stress().max())}


def test_the_same_mechanism_in_three_unit_systems_gives_the_same_physical_answers():
    ref = physical("SI")
    assert 0.0 < ref["compliance_y"] and ref["frequencies"][0] > 1.0
    for system in SYSTEMS[1:]:
        got = physical(system)
        for key, value in ref.items():
            np.testing.assert_allclose(got[key], value, rtol=1e-9, atol=1e-9 * np.abs(value).max(), err_msg=key)


def test_a_named_material_resolves_in_the_mechanism_units():
    m = guided_stage("mm-N-MPa")
    joint = next(iter(m.joints.values()))
    assert joint.material == flexmb.material("spring_steel", "mm-N-MPa")
    assert joint.E == pytest.approx(196.5e3) and joint.density == pytest.approx(7.85e-9)


def test_a_material_in_other_units_is_refused_naming_the_joint():
    m = flexmb.Mechanism(dim=2, units="mm-N-MPa")
    m.add_link("A", fixed=True)
    m.add_link("B", position=(50.0, 0.0))
    with pytest.raises(ModelError, match=r"joint 'leaf_spring_0': the default steel is in SI numbers .*mm-N-MPa"):
        m.add_joint("A", "B", "leaf_spring", length=50.0, width=10.0, thickness=0.5)
    with pytest.raises(ModelError, match="'peek' is in SI numbers"):
        m.add_joint("A", "B", flexmb.LeafSpring(length=50.0, width=10.0, thickness=0.5, material="peek"))
    m.add_joint("A", "B", "leaf_spring", length=50.0, width=10.0, thickness=0.5, material="peek")  # resolved in mm


def test_mm_geometry_with_an_si_modulus_warns():
    m = flexmb.Mechanism(dim=2)  # undeclared: SI assumed
    m.add_link("A", fixed=True)
    m.add_link("B", position=(50.0, 0.0))
    with pytest.warns(PlausibilityWarning, match="SI modulus .Pa. with lengths in mm"):
        m.add_joint("A", "B", "leaf_spring", length=50.0, width=10.0, thickness=0.5)
    # declared units: every number is checked in them
    d = flexmb.Mechanism(dim=2, units="mm-N-MPa")
    d.add_link("A", fixed=True)
    d.add_link("B", position=(50.0, 0.0))
    with pytest.warns(PlausibilityWarning, match=r"E=2e\+11 MPa = 2e\+17 Pa"):
        d.add_joint("A", "B", "leaf_spring", length=50.0, width=10.0, thickness=0.5, E=2e11, G=7.7e10)
    with pytest.warns(PlausibilityWarning, match="density=7800 t/mm"):
        d.add_joint("A", "B", "leaf_spring", length=50.0, width=10.0, thickness=0.5, E=2e5, G=7.7e4, density=7800.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d.add_joint("A", "B", "leaf_spring", length=50.0, width=10.0, thickness=0.5, E=2e5, G=7.7e4, density=7.8e-9)


@pytest.mark.parametrize("call", ["prescribe", "add_joint", "hinge", "sweep", "prescribe_3d"])
def test_an_angle_above_two_pi_warns_wherever_radians_are_meant(call):
    m = flexmb.models.cantilever(elements=2)
    with pytest.warns(PlausibilityWarning, match="rad is 4.77 turns; angles are in radians"):
        if call == "prescribe":
            m.prescribe("tip", rotation=30.0)
        elif call == "add_joint":
            m.add_link("C", position=(0.2, 0.0))
            m.add_joint("tip", "C", "leaf_spring", rotation=30.0)
        elif call == "hinge":
            m.add_link("C", position=(0.2, 0.0))
            m.add_joint("tip", "C", "hinge", angle=30.0)
        elif call == "sweep":
            m.prescribe("tip", rotation=0.0)
            flexmb.sweep(m, [0.1, 30.0], motion=("tip", "rotation"), max_iter=2, progress=False)
        else:
            flexmb.models.cross_flexure_pivot(elements_per_leaf=1).prescribe("B", rotation=(0.0, 0.0, 30.0))


def test_unit_systems_are_consistent_and_labelled():
    for u in units.SYSTEMS.values():
        # mass = force time^2 / length; stress = force / length^2
        assert u.scale("mass") == pytest.approx(u.force / u.length)
        assert u.scale("density") == pytest.approx(u.scale("mass") / u.length**3)
        for q in units.QUANTITIES:
            assert u.label(q) and "?" not in u.label(q)
    assert units.label("mm-N-MPa", "mass") == "t" and units.label("um-uN-MPa", "mass") == "kg"
    assert units.label("mm-uN-Pa", "mass") == "g" and units.label(None, "stiffness") == "N/m"
    assert flexmb.models.gripper().units.name == "mm-uN-Pa"
    with pytest.raises(ParameterError, match="units='inch'"):
        flexmb.Mechanism(units="inch")


def test_figure_axes_carry_the_declared_length_unit():
    pytest.importorskip("matplotlib")
    from flexmb import plot

    ax = plot.plot_mechanism(flexmb.models.gripper())  # mm-uN-Pa
    assert ax.get_xlabel() == "x [mm]"
    m = guided_stage("um-uN-MPa")
    assert plot.plot_mechanism(flexmb.solve(m)).get_ylabel() == "y [um]"
    assert plot.plot_mechanism(flexmb.models.cantilever()).get_xlabel() == "x [m]"  # undeclared: SI
    assert units.column_unit("block.Fx", "mm-N-MPa") == "N" and units.column_unit("block.Mz", "mm-N-MPa") == "N mm"
    assert units.column_unit("C.B.x.rotation", None) == "m/(N m)" and units.column_unit("f2") == "Hz"


def test_the_mm_check_knows_the_units_and_every_shipped_flexure():
    """Undeclared: a cross flexure and a curved beam in mm with SI moduli warn when placed; a
    mm-uN-Pa arc (the gripper's system: E = 1e11 is the pascal there) of 5 mm radius does not."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, 70.0))
    with pytest.warns(PlausibilityWarning, match="SI modulus"):
        m.add_joint("A", "B", "cross_flexure", length=100.0, thickness=1.0, width_inner=40.0, width_outer=20.0)
    with pytest.warns(PlausibilityWarning, match="SI modulus"):
        m.add_joint("A", "B", "curved_beam", radius=30.0, angle=1.0, width=5.0, height=0.5, E=2e11)
    g = flexmb.Mechanism(dim=2, units="mm-uN-Pa")
    g.add_link("A", fixed=True)
    g.add_link("B", position=(5.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g.add_joint("A", "B", "curved_beam", radius=5.0, angle=1.0, width=0.5, height=0.05, E=1e11, density=2.3e-3)
