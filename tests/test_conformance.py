"""The joint conformance suite (`flexmb.testing`) over every joint registered in the
``flexmb.joints`` entry-point group, and proof that it rejects broken joints (mutants)."""

import numpy as np
import pytest

import flexmb
from flexmb import testing


def _conformance(cls):
    return type(f"Conformance_{cls.kind}", (testing.JointConformance,), {"joint_class": cls})()


CHECKS = [name for name in dir(testing.JointConformance) if name.startswith("test_")]


@pytest.mark.parametrize("check", CHECKS)
@pytest.mark.parametrize("kind", sorted(flexmb.available_joints()))
def test_registered_joint_conforms(kind, check):
    getattr(_conformance(flexmb.available_joints()[kind]), check)()


# -- mutants: the suite must reject a broken element/joint -----------------------------------

def _mutate(monkeypatch, module, change):
    original = module.internal_force_and_tangent

    def mutant(*args, **kwargs):
        F, K, e, sig = original(*args, **kwargs)
        return change(F, K, e, sig, args)

    monkeypatch.setattr(module, "internal_force_and_tangent", mutant)


def test_suite_rejects_a_tangent_with_one_wrong_sign(monkeypatch):
    """One off-diagonal coupling of the planar element tangent (axial force vs end rotation)
    flipped: the residual is unchanged, so only the finite-difference check can see it."""
    from flexmb.fe import beam2d

    def flip(F, K, e, sig, args):
        if K is not None:
            K = K.copy()
            K[:, 0, 2] *= -1.0
        return F, K, e, sig

    leaf = flexmb.joint("leaf_spring")
    testing.check_tangent(leaf, 2, (0.1, 0.2), 0.3, motion=0.3)  # the healthy element passes
    _mutate(monkeypatch, beam2d, flip)
    with pytest.raises(AssertionError, match="central differences|did not converge"):
        testing.check_tangent(leaf, 2, (0.1, 0.2), 0.3, motion=0.3)


def test_suite_rejects_a_frame_dependent_wrench(monkeypatch):
    """A mutant element that adds a force along the global x axis proportional to its elongation
    (a term written in global instead of co-rotated axes): not frame invariant."""
    from flexmb.fe import beam3d

    def global_term(F, K, e, sig, args):
        F = F.copy()
        F[:, 0] += 1e3 * e[:, 0]
        F[:, 6] -= 1e3 * e[:, 0]
        return F, K, e, sig

    cross = flexmb.joint("cross_flexure")
    testing.check_frame_invariance(cross, 3, np.array([0.2, -0.1, 0.3]), np.array([0.3, 1.0, -0.4]))
    _mutate(monkeypatch, beam3d, global_term)
    with pytest.raises(AssertionError, match="frame invariant"):
        testing.check_frame_invariance(cross, 3, np.array([0.2, -0.1, 0.3]), np.array([0.3, 1.0, -0.4]))


def test_suite_rejects_an_asymmetric_joint_stiffness(monkeypatch):
    """A joint whose element stiffness matrix is not symmetric (a coupling entered on one side
    only) fails the symmetric-tangent-at-rest check."""
    from flexmb.fe import beam2d

    def one_sided(F, K, e, sig, args):
        if K is not None:
            K = K.copy()
            K[:, 1, 4] += 0.01 * np.abs(K[:, 1, 1])
        return F, K, e, sig

    leaf = flexmb.joint("leaf_spring")
    testing.check_rest(leaf, 2)
    _mutate(monkeypatch, beam2d, one_sided)
    with pytest.raises(AssertionError, match="not symmetric"):
        testing.check_rest(leaf, 2)


def test_suite_rejects_a_ksd_wrench_left_in_the_joint_frame(monkeypatch):
    """A mutant reduced mechanism that forgets to turn each joint's condensed wrench from the
    joint frame to global axes (F = I in step 3): right when the joint frame is the global one,
    wrong anywhere else, so KSD is not frame invariant and the strategy check rejects it."""
    from flexmb.ksd.geometry import JointFrames

    cross = flexmb.joint("cross_flexure")
    where = (np.array([0.2, -0.1, 0.3]), np.array([0.3, 1.0, -0.4]))
    assert testing.check_strategy_frame_invariance(cross, 3, *where) == ["ksd-reduced", "ksd-full"]
    original = JointFrames.relative

    def joint_frame_wrench(self, poses):
        p, Rrel, geo = original(self, poses)
        return p, Rrel, {**geo, "F": np.broadcast_to(np.eye(3), geo["F"].shape)}

    monkeypatch.setattr(JointFrames, "relative", joint_frame_wrench)
    with pytest.raises(AssertionError, match="ksd-reduced: positions not frame invariant"):
        testing.check_strategy_frame_invariance(cross, 3, *where)
