"""`flexmb.Material` (issue 27 item 4) and the named materials (issue 30 item 2)."""

import attrs
import numpy as np
import pytest

import flexmb
from flexmb import materials
from flexmb.errors import ParameterError
from flexmb.joints import CrossFlexure, CurvedBeam, LeafSpring, ThreeXInfinity


def test_a_material_takes_g_or_poissons_ratio_and_checks_once():
    m = flexmb.Material(200e9, nu=0.3, density=7800.0, yield_stress=1e9)
    assert m.G == 200e9 / 2.6 and m.nu == pytest.approx(0.3, rel=1e-15)
    assert flexmb.Material(200e9, 76.9e9) == flexmb.Material(200e9, 76.9e9, name="x")  # names are not numbers
    for kwargs, match in (({"E": -1.0, "G": 1.0}, "E=-1"), ({"E": 1.0, "G": 0.1}, "Poisson's ratio"),
                          ({"E": 1.0, "nu": 0.7}, "nu=0.7"), ({"E": 1.0, "G": 0.4, "nu": 0.2}, "G or nu"),
                          ({"E": 1.0, "G": 0.4, "density": -1}, "density"), ({"E": 1.0}, "G or Poisson"),
                          ({"E": 1.0, "G": 0.4, "yield_stress": 0.0}, "yield_stress"),
                          ({"E": float("nan"), "G": 0.4}, "finite")):
        with pytest.raises(ParameterError, match=match):
            flexmb.Material(**kwargs)


def test_named_materials_resolve_in_every_system_with_their_sources():
    for name, data in materials.CATALOGUE.items():
        assert "source" in data and len(data["source"]) > 40, name
        si = flexmb.material(name)
        assert si.units == "SI" and si.name == name
        assert 1e9 < si.E < 3e11 and 1000 < si.density < 9000 and si.yield_stress > 0
        assert -1 < si.nu < 0.5
        mm = flexmb.material(name, "mm-N-MPa")
        assert mm.E == pytest.approx(si.E * 1e-6, rel=1e-15)  # MPa
        assert mm.density == pytest.approx(si.density * 1e-12, rel=1e-15)  # t/mm^3
        um = flexmb.material(name, "um-uN-MPa")
        assert um.E == pytest.approx(si.E * 1e-6, rel=1e-15)  # MPa again
        assert um.density == pytest.approx(si.density * 1e-18, rel=1e-15)  # kg/um^3
    assert flexmb.material("steel") == flexmb.material("structural_steel")
    with pytest.raises(ParameterError, match="named materials: structural_steel"):
        flexmb.material("unobtainium")
    with pytest.raises(ParameterError, match="units="):
        flexmb.material("peek", "furlongs")


@pytest.mark.parametrize("cls, required", [(CrossFlexure, {}), (LeafSpring, {}), (ThreeXInfinity, {}),
                                           (CurvedBeam, {"radius": 0.03, "angle": 1.0, "width": 5e-3,
                                                         "height": 4e-4})])
def test_every_joint_takes_one_material_and_its_old_keywords(cls, required):
    E, nu, rho, ys = 70e9, 0.33, 2700.0, 3e8
    by_keywords = cls(**required, E=E, nu=nu, density=rho, yield_stress=ys)
    by_material = cls(**required, material=flexmb.Material(E, nu=nu, density=rho, yield_stress=ys))
    assert by_keywords == by_material and hash(by_keywords) == hash(by_material)
    assert (by_keywords.E, by_keywords.density, by_keywords.yield_stress) == (E, rho, ys)
    assert by_keywords.G == E / (2 * (1 + nu)) and by_keywords.nu is None  # stored as G, as before
    # the mesh's sections carry the material
    sec = by_material.mesh(2 if 2 in cls.dims else 3).sections[0]
    assert (sec.E, sec.G, sec.density, sec.yield_stress) == (E, by_keywords.G, rho, ys)
    # keywords beside a material replace its values (attrs.evolve relies on it)
    stiffer = attrs.evolve(by_material, E=1.1 * E)
    assert stiffer.E == 1.1 * E and stiffer.G == by_material.G and stiffer.density == rho
    shape = {"length": by_material.length * 1.01} if hasattr(by_material, "length") else {"angle": 1.1}
    assert attrs.evolve(by_material, **shape).material == by_material.material
    # a named material
    assert cls(**required, material="peek").material == flexmb.material("peek")
    # a bad value is refused by the material's check, naming the joint
    with pytest.raises(ParameterError, match=f"{cls.kind}: density=-1"):
        cls(**required, E=E, density=-1)
    with pytest.raises(ParameterError, match=f"{cls.kind}: material="):
        cls(**required, material=3.0)


def test_the_shipped_defaults_are_unchanged():
    assert CrossFlexure().material == flexmb.Material(200e9, 76.9e9, density=7800.0)
    assert LeafSpring().describe()["E"] == 200e9 and LeafSpring().describe()["nu"] is None
    assert CrossFlexure(E=70e9).G == 76.9e9  # keywords alone complete the default material, as the fields did
    cb = CurvedBeam(radius=0.2, angle=1.0, E=100e9, width=0.025, height=0.005)
    assert cb.G == 100e9 / 2.6 and cb.density == 7800.0
    with pytest.raises(ParameterError, match="curved_beam: give Young's modulus E or a material"):
        CurvedBeam(radius=0.2, angle=1.0, width=0.025, height=0.005)


def test_a_gpa_modulus_with_lengths_in_m_warns_when_the_joint_is_made():
    # the mm-with-SI-modulus check needs the units: it runs in Mechanism.add_joint (tests/test_units.py)
    with pytest.warns(flexmb.PlausibilityWarning, match="GPa with lengths in m"):
        LeafSpring(E=200.0, G=77.0)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LeafSpring(length=50.0, width=10.0, thickness=0.5, material=flexmb.material("spring_steel", "mm-N-MPa"))
        LeafSpring(length=0.05, width=0.01, thickness=5e-4, material="spring_steel")
    np.testing.assert_equal(LeafSpring(material="spring_steel").E, 196.5e9)
