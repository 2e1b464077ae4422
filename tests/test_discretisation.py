"""Accuracy you can see (issue 22, item 8): `flexmb.discretisation_error` estimates the mesh
error of any quantity by Richardson extrapolation from refined meshes, and the shipped joints'
default meshes give their parasitic quantities within 1 % of the converged mesh.

The converged-mesh references are Richardson extrapolations from three fine meshes (named in
each test) with the observed order, computed here: no paper has these cases.
"""

import math

import attrs

import numpy as np
import pytest

import flexmb
from flexmb.discretisation import refined, richardson

from dummy_plugins import Good


# -- the cases: mechanisms built as a user would --------------------------------------------

def parallel_guide(elements=None, *, length=0.1, thickness=1e-3, width=0.02, spacing=0.04, stroke=0.01, E=200e9,
                   G=76.9e9):
    """Two leaf springs along x, ``spacing`` apart, from the base to a stage pushed ``stroke``
    along y (SI by default); ``elements`` None: the joint's default mesh."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("base", fixed=True)
    m.add_link("stage", position=(length, 0.5 * spacing))
    mesh = {} if elements is None else {"elements": elements}
    for name, y in (("lower", 0.0), ("upper", spacing)):
        m.add_joint("base", "stage", flexmb.LeafSpring(length=length, thickness=thickness, width=width, E=E, G=G,
                                                         **mesh), name=name, origin=(0.0, y))
    m.prescribe("stage", y=stroke)
    return m


def guide(sol):
    """The parallel guide's parasitic drop [length] and support stiffness along the leaves."""
    return {"drop": sol.displacement("stage")[0], "support": 1.0 / flexmb.compliance(sol, "stage")[0, 0]}


def pivot(joint, rotation, dim=3):
    """Link A fixed, B at the joint's node B turned by ``rotation`` about z, the rest of B free."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim))
    m.add_joint("A", "B", joint, name="joint")
    m.prescribe("B", rotation=rotation if dim == 2 else (0.0, 0.0, rotation))
    return m


def pivot_parasitics(centre):
    """Centre shift [m] (B's displacement less a rigid turn about ``centre``, the undeformed
    pivot axis) and the support stiffness of B in x and y [N/m]."""
    def parasitics(sol):
        x0 = sol.compiled.problem.model.x0[sol.compiled.link_node["B"]]
        pos, R = sol.pose("B")
        dim = len(pos)
        R = np.array([[math.cos(R), -math.sin(R)], [math.sin(R), math.cos(R)]]) if dim == 2 else R
        C = flexmb.compliance(sol, "B")
        return {"shift": float(np.linalg.norm(pos - (centre + R @ (x0 - centre)))),
                "k_x": 1.0 / C[0, 0], "k_y": 1.0 / C[1, 1]}
    return parasitics


def reference(build, quantity, meshes):
    """{name: converged-mesh value} by Richardson (observed order) from the three ``meshes``."""
    rows = [quantity(flexmb.solve(build(n), raise_on_failure=True)) for n in meshes]
    names = list(rows[0])
    ref, order = richardson(np.array([[r[k] for k in names] for r in rows]))
    assert np.all(order >= 1.5), f"meshes {meshes} not in the asymptotic range: order {order}"
    return dict(zip(names, ref))


# -- the estimate ---------------------------------------------------------------------------

def test_richardson_is_exact_for_a_pure_power_of_h():
    """q(h) = 3 + 0.5 h^2 on h = 1, 1/2, 1/4: order 2 and the limit 3 exactly; on a pair with
    the order given, the same; differences of changing sign: no order, the finest value."""
    h = np.array([1.0, 0.5, 0.25])
    ref, p = richardson(3.0 + 0.5 * h**2)
    assert p == pytest.approx(2.0, abs=1e-12) and ref == pytest.approx(3.0, abs=1e-12)
    ref, p = richardson(3.0 + 0.5 * h[1:] ** 2, order=2.0)
    assert ref == pytest.approx(3.0, abs=1e-12)
    ref, p = richardson([1.0, 2.0, 1.5])
    assert np.isnan(p) and ref == 1.5


def test_estimate_brackets_the_converged_drop_of_a_mm_scale_guide():
    """A parallel guide in mm, N, MPa (two 20 mm steel leaves 0.1 mm thick, 8 mm apart, stage
    pushed 1.5 mm) on 4 elements per leaf: the estimate from 4/8/16 elements recovers the
    converged-mesh reference (Richardson of 32/64/128 elements) to within 5 % of the error it
    estimates, the error itself being several percent. Observed orders: 2 (drop) and ~3.9
    (support stiffness, an h^4 term still dominant on these meshes; 3.0 from 32/64/128)."""
    mm = dict(length=20.0, thickness=0.1, width=5.0, spacing=8.0, stroke=1.5, E=200e3, G=76.9e3)
    truth = reference(lambda n: parallel_guide(n, **mm), guide, (32, 64, 128))
    est = flexmb.discretisation_error(parallel_guide(4, **mm), guide)
    assert est.names == ("drop", "support") and list(est.elements) == [8, 16, 32]
    for name in est.names:
        q = est[name]
        true_error = q["value"] - truth[name]
        assert abs(true_error) > 0.01 * abs(truth[name])  # the coarse mesh is off by over 1 %
        assert abs(q["reference"] - truth[name]) < 0.05 * abs(true_error), (name, q, truth[name])
        assert q["error"] == pytest.approx(true_error, rel=0.05)
        assert q["order"] >= 1.5
    assert np.all(est.asymptotic) and np.all(est.times > 0)
    assert est.table()["quantity"].tolist() == ["drop", "support"]


def test_estimate_of_flexmb_properties_by_name():
    """The columns of `flexmb.properties` as quantities: the first frequency of a parallel guide
    with a 50 g stage (3 levels of a 2-element mesh)."""
    m2 = flexmb.Mechanism(dim=2)
    m2.add_link("base", fixed=True)
    m2.add_link("stage", position=(0.1, 0.02), mass=0.05, inertia=1e-6)
    for name, y in (("lower", 0.0), ("upper", 0.04)):
        m2.add_joint("base", "stage", flexmb.LeafSpring(elements=2), name=name, origin=(0.0, y))
    m2.prescribe("stage", y=0.005)
    est = flexmb.discretisation_error(m2, ("modes", "stress"), property_options={"n_modes": 1}, levels=2)
    assert est.names[0] == "f1" and "von_mises" in est.names
    assert est["f1"]["values"][0] > est["f1"]["values"][-1] > 0  # a coarse mesh is too stiff
    direct = flexmb.discretisation_error(m2, lambda s: {"f1": flexmb.modes(s, n_modes=1).frequencies[0],
                                                        "von_mises": s.stresses().summary()["von_mises"]}, levels=2)
    for name in ("f1", "von_mises"):  # the same numbers as the functions the columns come from
        np.testing.assert_allclose(est[name]["values"], direct[name]["values"], rtol=1e-12)
        assert est[name]["order"] == 2.0  # a Richardson pair assumes the beam element's order


def test_refined_doubles_every_flexure_and_keeps_the_mechanism():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.1, 0.0))
    m.add_link("C", position=(0.1, 0.0))
    m.add_joint("A", "B", flexmb.LeafSpring(elements=3), name="leaf")
    m.add_joint("B", "C", "hinge", k=1.0, name="pin")
    r = refined(m, 4)
    assert r.joints["leaf"].elements == 12 and r.joints["pin"] == m.joints["pin"]
    assert m.joints["leaf"].elements == 3  # the user's mechanism is not changed


def test_refusals_name_what_is_missing():
    m = pivot(Good(), 0.1, dim=2)
    with pytest.raises(flexmb.UnsupportedStrategyError, match="mesh_parameter"):
        flexmb.discretisation_error(m, lambda s: s.reaction("B"))
    leaf = parallel_guide(2)
    with pytest.raises(flexmb.UnsupportedStrategyError, match="no mesh"):
        flexmb.discretisation_error(leaf, guide, method="newton")
    with pytest.raises(flexmb.ParameterError, match="levels"):
        flexmb.discretisation_error(leaf, guide, levels=1)
    with pytest.raises(flexmb.ParameterError, match="quantity"):
        flexmb.discretisation_error(leaf, "frequency")


# -- the defaults ---------------------------------------------------------------------------

def test_leaf_spring_default_gives_the_guides_parasitics_within_1_percent():
    """The SI parallel guide (0.1 m leaves, 1 mm thick, 40 mm apart, 10 mm stroke) on
    `LeafSpring`'s default mesh: drop and support stiffness within 1 % of the converged mesh
    (Richardson of 16/32/64 elements). The former default, 4 elements, was 5.0 % and 7.4 % off."""
    truth = reference(parallel_guide, guide, (16, 32, 64))
    got = guide(flexmb.solve(parallel_guide()))
    for name in truth:
        assert got[name] == pytest.approx(truth[name], rel=0.01), name
    old = guide(flexmb.solve(parallel_guide(4)))
    assert old["drop"] != pytest.approx(truth["drop"], rel=0.04)


@pytest.mark.parametrize("dim", [2, 3])
def test_cross_flexure_default_gives_the_centre_shift_within_1_percent(dim):
    """The Table 1 cross flexure turned 20 deg on its default mesh: centre shift and support
    stiffness within 1 % of the converged mesh (Richardson of 16/32/64 el./leaf). The former
    default, 3 el./leaf, gave the shift 5.6 % high."""
    centre = 0.5 * flexmb.CrossFlexure().interface_b(dim)  # the leaves cross half-way up
    q = pivot_parasitics(centre)
    rot = math.radians(20.0)
    truth = reference(lambda n: pivot(flexmb.CrossFlexure(elements_per_leaf=n), rot, dim), q, (16, 32, 64))
    got = q(flexmb.solve(pivot(flexmb.CrossFlexure(), rot, dim)))
    for name in truth:
        assert got[name] == pytest.approx(truth[name], rel=0.01), name


def test_three_x_infinity_default_gives_its_parasitics_within_1_percent():
    """three_x_infinity turned 45 deg (its range) on its default mesh: the drift of node B off
    the axis and the support stiffness of B in x and along the axis within 1 % of the converged
    mesh (Richardson of 8/16/32 el./leaf). The former default, 3 el./leaf: drift +5.6 %."""
    def q(sol):
        C = flexmb.compliance(sol, "B")
        return {"drift": float(np.linalg.norm(sol.displacement("B"))), "k_x": 1.0 / C[0, 0], "k_z": 1.0 / C[2, 2]}

    rot = math.radians(45.0)
    truth = reference(lambda n: pivot(flexmb.ThreeXInfinity(elements_per_leaf=n), rot), q, (8, 16, 32))
    got = q(flexmb.solve(pivot(flexmb.ThreeXInfinity(), rot)))
    for name in truth:
        assert got[name] == pytest.approx(truth[name], rel=0.01), name


def test_curved_beam_default_gives_its_parasitics_within_1_percent():
    """A 90 deg steel arc (radius 30 mm, 10 x 0.5 mm) whose end is turned 10 deg on the default
    16 elements: the end's drift and support stiffness within 1 % of the converged mesh
    (Richardson of 64/128/256 elements)."""
    def arc(n=None):
        return flexmb.CurvedBeam(radius=0.03, angle=math.pi / 2, E=200e9, width=0.01, height=0.5e-3,
                                 **({} if n is None else {"elements": n}))

    def q(sol):
        C = flexmb.compliance(sol, "B")
        return {"drift": float(np.linalg.norm(sol.displacement("B"))), "k_x": 1.0 / C[0, 0], "k_y": 1.0 / C[1, 1]}

    rot = math.radians(10.0)
    truth = reference(lambda n: pivot(arc(n), rot, 2), q, (64, 128, 256))
    got = q(flexmb.solve(pivot(arc(), rot, 2)))
    for name in truth:
        assert got[name] == pytest.approx(truth[name], rel=0.01), name


def test_a_refinement_that_does_not_converge_keeps_the_meshes_that_did(monkeypatch):
    """The finest solve failing (here made to fail) leaves a Richardson pair of the two meshes
    that converged, with a ConvergenceWarning; the first refinement failing raises."""
    import flexmb.discretisation as disc

    real = disc.solve

    def failing_above(limit):
        def solve(m, method, **options):
            sol = real(m, method, **options)
            n = sum(j.elements for j in m.joints.values())
            return attrs.evolve(sol, converged=False, message="made to fail") if n > limit else sol
        return solve

    m = parallel_guide(4)
    full = flexmb.discretisation_error(m, guide)
    monkeypatch.setattr(disc, "solve", failing_above(16))
    with pytest.warns(flexmb.ConvergenceWarning, match="refined by 4 did not converge.*2 meshes"):
        pair = flexmb.discretisation_error(m, guide)
    np.testing.assert_array_equal(pair.values, full.values[:2])
    assert np.all(pair.order == 2.0)
    monkeypatch.setattr(disc, "solve", failing_above(8))
    with pytest.raises(flexmb.ConvergenceError, match="refined by 2 did not converge"):
        flexmb.discretisation_error(m, guide)
