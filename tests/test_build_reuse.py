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
