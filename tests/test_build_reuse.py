"""What a design loop's builds reuse (`flexmb.models`, `flexmb.compiled`): the same numbers as a
fresh build, and a changed design never served a kept one."""

from __future__ import annotations

import math

import numpy as np
import pytest

import flexmb
from flexmb import models
from flexmb.compiled import compiled_for
from flexmb.ksd.kinematics import solve_kinematics
from flexmb.ksd.reduced import reduced_mechanism


def _joint_case_kinematics_end(rotation, geometry=None, **joint_params) -> np.ndarray:
    """The location case's end point as it was computed before it was kept: a KSD kinematics
    solve of the joint case on the design's own geometry."""
    m = models.manipulator("joint", rotation, geometry=geometry, **joint_params)
    compiled = compiled_for(m)
    return solve_kinematics(reduced_mechanism(compiled))[0].x[compiled.link_node["link3"]]


def _motion(m) -> np.ndarray:
    """The prescribed motion of the end point [m]."""
    p = m.prescribed("link3")
    return np.array([p["x"], p["y"], p["z"]])


def _end(m) -> np.ndarray:
    return m.links["link3"].position + _motion(m)


#: The paper's joint scaled by 0.8 (its trained kinematics scale with it): another joint, the same data.
SMALLER = {k: 0.8 * getattr(flexmb.ThreeXInfinity(), k)
           for k in ("length", "thickness", "width_inner", "width_outer", "gap", "stage_gap")}


def _placement(seed: int) -> dict:
    rng = np.random.default_rng(seed)
    g0 = models.MANIPULATOR
    g = {k: g0[k] * (1.0 + rng.uniform(-0.3, 0.3)) for k in ("post", "arm2", "arm3")}
    g.update({k: g0[k] + rng.uniform(-0.3, 0.3) for k in ("angle2", "angle3")})
    return g


def test_location_end_point_on_the_paper_geometry_is_the_kinematics_solve_bit_for_bit():
    """Dwarshuis et al. (2020) Sec. 4.4: the location case's end point is where the joint case's
    KSD kinematics puts it; kept per rotation and joint, the same bits as solving it again."""
    models._JOINT_CASE.clear()
    for deg in (-45.0, 30.0, 30.0):
        r = math.radians(deg)
        m = models.manipulator("location", r)
        np.testing.assert_array_equal(_motion(m), _joint_case_kinematics_end(r) - m.links["link3"].position)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_other_placements_chain_the_joints_motions_exactly(seed):
    """Not in the paper: joints placed elsewhere (+-30 % lengths, +-17 deg arm angles). The joints'
    relative motions kept from the paper's geometry, chained through the new one, give the end
    point of a kinematics solve on the new geometry to round-off (its tolerance is 1e-10)."""
    g = _placement(seed)
    for deg in (-40.0, 25.0):
        r = math.radians(deg)
        models.manipulator("location", r)  # the paper's geometry first: its motions kept
        end = _end(models.manipulator("location", r, geometry=g))
        np.testing.assert_allclose(end, _joint_case_kinematics_end(r, g), rtol=0, atol=1e-14)


def test_another_joint_is_not_served_the_kept_motions():
    """Another joint is another key: its own kinematics (a thicker leaf: the same trained data, its
    own entry), and a joint no database holds (0.8 times the size, another mesh) takes rigid-link
    kinematics about the joints' axes, as before the motions were kept."""
    r = math.radians(35.0)
    g = _placement(4)
    models._JOINT_CASE.clear()
    models.manipulator("location", r, geometry=g)
    end = _end(models.manipulator("location", r, geometry=g, thickness=0.5e-3))
    assert len(models._JOINT_CASE) == 2
    np.testing.assert_allclose(end, _joint_case_kinematics_end(r, g, thickness=0.5e-3), rtol=0, atol=1e-14)
    for params in (SMALLER, {"elements": 4}):
        m = models.manipulator("location", r, geometry=g, **params)
        D0 = float(m.joints["joint1"].interface_b(3)[2])
        a2, a3 = models._frames(D0, models._manipulator_geometry(g))[1][1:]
        X3 = m.links["link3"].position
        np.testing.assert_array_equal(_motion(m), models._end_point(models.manipulator_rotations(r), (a2, a3), X3) - X3)
    assert len(models._JOINT_CASE) == 2


def test_kept_motions_are_bounded():
    models._JOINT_CASE.clear()
    for k in range(models.JOINT_CASE_KEPT + 3):
        models.manipulator("location", 0.001 * k)
    assert len(models._JOINT_CASE) == models.JOINT_CASE_KEPT


def test_a_placement_loop_solves_as_fresh_builds_did():
    """A design loop over placements (KSD-reduced): each design's answer equal to its own build
    solved alone with a cleared cache (the end point only moves at round-off)."""
    r = math.radians(30.0)
    g = _placement(5)
    models._JOINT_CASE.clear()
    alone = flexmb.solve(models.manipulator("location", r, geometry=g), method="ksd-reduced")
    models.manipulator("location", r)
    looped = flexmb.solve(models.manipulator("location", r, geometry=g), method="ksd-reduced")
    np.testing.assert_allclose(looped.node_positions(), alone.node_positions(), rtol=0, atol=1e-13)
    np.testing.assert_allclose(looped.reaction("link3"), alone.reaction("link3"), rtol=1e-10)


def _stage(spacing_mm: float = 30.0, push_mm: float = 2.0, thickness_mm: float = 0.3, leaves: int = 2):
    """A user's planar stage in mm-N-MPa (no paper has it): a block on ``leaves`` spring-steel
    leaves 40 x 8 x ``thickness_mm`` mm, ``spacing_mm`` apart, pushed sideways ``push_mm``, 5 N
    along the leaves."""
    m = flexmb.Mechanism(dim=2, units="mm-N-MPa")
    m.add_link("ground", fixed=True)
    m.add_link("block", position=(0.0, 40.0))
    for x in np.linspace(-0.5 * spacing_mm, 0.5 * spacing_mm, leaves):
        m.add_joint("ground", "block", "leaf_spring", origin=(x, 0.0), rotation=math.pi / 2, length=40.0,
                    width=8.0, thickness=thickness_mm, elements=6, material="spring_steel")
    m.prescribe("block", x=push_mm, rotation=0.0)
    m.apply_force("block", (0.0, -5.0))
    return m


def _lever(x: float = 0.005, arm: float = 0.12, turn: float = 0.3, thickness: float = 1e-3):
    """A user's lever (no paper has it): an arm on one cross flexure (Table 1's 100 mm leaves, the
    trained design) placed at ``x`` [m], its reference point ``arm`` above, turned ``turn`` [rad]
    and loaded by 5 N downwards."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("arm", position=(x, arm))
    m.add_joint("ground", "arm", "cross_flexure", origin=(x, 0.0), elements_per_leaf=3, thickness=thickness)
    m.prescribe("arm", rotation=turn)
    m.apply_force("arm", (0.0, -5.0))
    return m


def _no_reuse(fn):
    kept = flexmb.compiled.STRUCTURES_KEPT
    try:
        flexmb.compiled.STRUCTURES_KEPT = 0
        flexmb.compiled._LOCAL.structures = {}
        return fn()
    finally:
        flexmb.compiled.STRUCTURES_KEPT = kept


def _same(a, b) -> None:
    assert a.converged and b.converged and a.iterations == b.iterations
    assert np.array_equal(a.node_positions(), b.node_positions()) and np.array_equal(a.residual, b.residual)


def _derived(red) -> dict:
    """What a KSD set-up derived on its first solve and `rebind` may keep."""
    start = red._kinematic_start
    arrays = {f"jit {k}": a for k, a in red._kinematics_jit.items()}
    return {"rest x": start[0].x, "rest R": start[0].R, "jac0": start[1], "rows": start[2], "theta0": start[3],
            "turn rate": np.array(start[4]), **arrays}


@pytest.mark.parametrize("other", [{}, {"turn": -0.2}, {"x": 0.02, "arm": 0.15}],
                         ids=["same design", "another turn", "other placements"])
def test_a_rebound_ksd_set_up_derives_what_a_new_one_derives(other):
    """A user's lever: a set-up rebound from a solved design (`ReducedMechanism.rebind`: the
    kinematic start kept where the geometry's numbers are equal, the compiled arrays moved to the
    new frames) holds the values a new set-up derives, bit for bit, and solves the same."""
    from flexmb.ksd.kinematics import _kinematics_call
    from flexmb.ksd.reduced import ReducedMechanism, reduced_mechanism

    first = _lever()
    flexmb.solve(first, method="ksd-reduced")
    red = reduced_mechanism(compiled_for(first))
    new = _lever(**other).compile()
    rebound, built = red.rebind(new), ReducedMechanism(new)
    assert rebound is not None
    for r in (rebound, built):
        _kinematics_call(r)
    kept = rebound._kinematic_start[1] is red._kinematic_start[1]
    assert kept == ("x" not in other)  # the start at rest is kept only for the same geometry
    a, b = _derived(rebound), _derived(built)
    for name in a:
        assert np.array_equal(a[name], b[name]), name
    sa = flexmb.solve(_lever(**other), method="ksd-reduced")
    sb = _no_reuse(lambda: flexmb.solve(_lever(**other), method="ksd-reduced"))
    _same(sa, sb)
    assert sa.stages["setup"]["files"] == sb.stages["setup"]["files"]


def test_another_topology_or_joint_is_not_rebound():
    """A second joint (another topology) or another joint value: no rebind, a set-up of its own."""
    from flexmb.ksd.reduced import ReducedMechanism

    red = ReducedMechanism(_lever().compile())
    assert red.rebind(_lever(thickness=0.8e-3).compile()) is None
    two = _lever()
    two.add_link("tip", position=(0.005, 0.3))
    two.add_joint("arm", "tip", "cross_flexure", origin=(0.005, 0.18), elements_per_leaf=3)
    assert red.rebind(two.compile()) is None


@pytest.mark.filterwarnings("ignore::flexmb.DiscretisationWarning")  # a coarse mesh on purpose
@pytest.mark.parametrize("other", [{"spacing_mm": 34.0}, {"thickness_mm": 0.35}, {"leaves": 3}],
                         ids=["other placements", "thicker leaves", "a third leaf"])
def test_a_user_stage_in_mm_reuses_its_structure_only_when_it_is_the_same(other):
    """A user's stage in mm-N-MPa, conventional: a design loop's next build shares the pattern and
    the solver's analysis when the topology is the same, gets its own when a leaf is added, and
    gives the answers of a solve without reuse, bit for bit."""
    flexmb.solve(_stage())
    c1 = compiled_for(_stage())
    flexmb.solve(_stage())
    nxt = _stage(**other)
    c2 = compiled_for(nxt)
    shared = vars(c2.problem).get("_pattern") is vars(c1.problem).get("_pattern")
    assert shared == ("leaves" not in other)
    _same(flexmb.solve(_stage(**other)), _no_reuse(lambda: flexmb.solve(_stage(**other))))
