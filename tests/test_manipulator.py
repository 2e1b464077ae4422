"""The spatial three-link manipulator (issue 5; Dwarshuis et al. 2020, Sec. 4.4, Figs. 13 and 15).

CI uses three positions where the full benchmark (benchmarks/bench_manipulator.py) runs 19."""

import numpy as np
import pytest

import flexmb
from flexmb.studies import manipulator as mc
from flexmb.errors import DatabaseError, FlexmbError, ParameterError
from flexmb.models import manipulator, manipulator_rotations

ROTATIONS = (-45.0, 20.0, 45.0)


def _solve_all(case, deg):
    m = manipulator(case, np.radians(deg))
    return {k: flexmb.solve(m, method=k) for k in mc.METHODS}


def test_joint_case_turns_every_joint_by_the_rotation():
    """Prescribed link orientations are the chains Rz(r), Rz(r) Ry(r), Rz(r) Ry(2 r) (Fig. 13:
    joint 1 about global z, joints 2 and 3 initially about global y), reached with untilted joints."""
    r = np.radians(30.0)
    sol = flexmb.solve(manipulator("joint", r))
    assert sol.converged
    for link, R in zip(mc.LINKS, manipulator_rotations(r)):
        np.testing.assert_allclose(sol.pose(link)[1], R, atol=1e-12)
    F = np.array([sol.reaction(k)[:3] for k in mc.LINKS])
    assert np.abs(F).max() < 1e-6  # the positions are free: moments only


@pytest.mark.parametrize("case", ["joint", "location"])
@pytest.mark.parametrize("deg", ROTATIONS)
def test_ksd_full_converges_to_the_conventional_solution(case, deg):
    sols = _solve_all(case, deg)
    ref, full = sols["conventional"], sols["ksd-full"]
    assert ref.converged and full.converged
    assert full.residual_history[-1] < 5e-7
    x = ref.node_positions()
    np.testing.assert_allclose(full.node_positions(), x, rtol=0, atol=1e-8 * np.abs(x).max())
    # KSD-reduced, against the same converged full model (Sec. 4.4: joint case essentially exact,
    # location case below 2 % in force and 0.3 % in displacement)
    err = mc.errors(case, sols["ksd-reduced"], ref)
    if case == "joint":
        assert err["reaction"] < 1e-6 and err["displacement"] < 1e-8
    else:
        assert err["reaction"] < 0.02 and err["displacement"] < 0.003


def test_location_case_reaches_the_joint_case_end_point():
    """Sec. 4.4: the location case goes through the end points of the joint case; the joint
    case's equilibrium keeps the trained kinematics to 2 um (its downstream joint moments tilt
    joints 1 and 2 slightly)."""
    r = np.radians(-30.0)
    joint = flexmb.solve(manipulator("joint", r), method="ksd-reduced")
    loc = flexmb.solve(manipulator("location", r), method="ksd-reduced")
    assert np.linalg.norm(loc.pose("link3")[0] - joint.pose("link3")[0]) < 2e-6
    assert np.abs(mc.joint_moments(joint)).min() > 0.1  # N m: the joints are actuated


def test_out_of_range_targets_are_refused_naming_the_joint_and_range():
    with pytest.raises(ParameterError, match=r"outside the range of the three_x_infinity joints, \+-45 deg"):
        manipulator("joint", np.radians(50.0))
    with pytest.raises(ParameterError, match="case='elbow'; valid: joint, location"):
        manipulator("elbow", 0.1)
    # a mechanism turning a joint beyond the trained range: KSD refuses, naming joint and range
    m = manipulator("joint", np.radians(40.0))
    m.prescribe("link3", rotation=[(0.0, 0.0, np.radians(40.0)), (0.0, np.radians(130.0), 0.0)])
    with pytest.raises(DatabaseError, match=r"joint 'joint3' \(three_x_infinity\).*outside its trained range "
                                            r"\[-45.0, 45.0\] deg"):
        flexmb.solve(m, method="ksd-reduced")


def test_kinematically_indeterminate_manipulator_names_the_free_motion():
    m = manipulator("location", 0.3)
    m.prescribe("link3", z=None)
    with pytest.raises(FlexmbError, match="free"):
        flexmb.solve(m, method="ksd-reduced")
