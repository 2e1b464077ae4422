"""The joint conformance suite (`flexmb.testing`) over every joint registered in the
``flexmb.joints`` entry-point group, and proof that it rejects broken joints (mutants)."""

import numpy as np
import pytest

import flexmb
from flexmb import registry, testing


def _conformance(cls):
    return type(f"Conformance_{cls.kind}", (testing.JointConformance,), {"joint_class": cls})()


CHECKS = [name for name in dir(testing.JointConformance) if name.startswith("test_")]
#: every joint the kit runs over: flexmb's own (also when the package's entry points are not
#: installed, e.g. tests run from a plain checkout) and whatever the entry points add
JOINTS = {**registry._shipped(), **flexmb.available_joints()}


def test_the_kit_has_joints_and_checks_to_run():
    """An empty parametrisation would skip every conformance case silently: fail instead."""
    assert set(registry._shipped()) <= set(JOINTS) and CHECKS


@pytest.mark.slow
@pytest.mark.parametrize("check", CHECKS)
@pytest.mark.parametrize("kind", sorted(JOINTS))
def test_registered_joint_conforms(kind, check):
    getattr(_conformance(JOINTS[kind]), check)()


# -- mutants: the suite must reject a broken element/joint -----------------------------------

def _mutate(monkeypatch, module, change):
    # the mutant is a Python-level element: run the numpy kernels, which call it (the compiled
    # model assembly, flexmb.fe.model_jit, inlines the element and would bypass the mutation)
    monkeypatch.setattr(flexmb.jit, "_enabled", False)  # as flexmb.jit.use("numpy"); restored after the test
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


@pytest.mark.slow  # 2.0 s CPU: two 3D cross flexures, each checked sound and mutated
def test_suite_rejects_a_frame_dependent_wrench(monkeypatch):
    """A mutant element that adds a force along the global x axis proportional to its elongation
    (a term written in global instead of co-rotated axes): not frame invariant.

    Why 3 el./leaf: the mutant's force is 1e3 N/m x one element's elongation, and the elements'
    elongations shrink with the mesh, so the term vanishes with refinement (measured at the kit's
    load, 3D cross flexure moved to (0.2, -0.1, 0.3) and turned (0.3, 1.0, -0.4)): spurious force
    1.1e-5 / 6.6e-6 / 3.3e-6 / 1.7e-6 N and reaction error 2.9e-7 / 1.7e-7 / 8.4e-8 / 4.2e-8 of the
    wrench scale (reactions ~0.4 N, 2.7 N m) at 3 / 5 / 10 / 20 el./leaf; a change to the answer of
    1e-6 of the joint's forces, below the kit's solve tolerance (1e-7). The kit's allowance is 1e-7
    plus 10x the residual's roundoff floor, which grows with the elements' stiffness: 1.8e-7 /
    2.3e-7 / 3.6e-7 / 6.3e-7 (the sound element's error: 1.2e-9 at 3, 2.7e-9 at 10 el./leaf). At
    10 el./leaf (the former default, asked for by name since the default became 24) the kit rejects
    the same term 10x stronger (1e4 N/m: 8.4e-7)."""
    from flexmb.fe import beam3d

    def global_term(scale):
        def change(F, K, e, sig, args):
            F = F.copy()
            F[:, 0] += scale * e[:, 0]
            F[:, 6] -= scale * e[:, 0]
            return F, K, e, sig
        return change

    place = (np.array([0.2, -0.1, 0.3]), np.array([0.3, 1.0, -0.4]))
    coarse, default = flexmb.joint("cross_flexure", elements_per_leaf=3), flexmb.joint("cross_flexure", elements_per_leaf=10)
    for joint in (coarse, default):
        testing.check_frame_invariance(joint, 3, *place)
    for joint, scale in ((coarse, 1e3), (default, 1e4)):
        with monkeypatch.context() as patch:
            _mutate(patch, beam3d, global_term(scale))
            with pytest.raises(AssertionError, match="frame invariant"):
                testing.check_frame_invariance(joint, 3, *place)


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


@pytest.mark.slow
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
    monkeypatch.setattr(flexmb.jit, "_enabled", False)  # the mutant is in the numpy path (the compiled one equals it)
    with pytest.raises(AssertionError, match="ksd-reduced: positions not frame invariant"):
        testing.check_strategy_frame_invariance(cross, 3, *where)


# -- scale free: the kit at mm and um scale, in SI, mm-N-MPa and um-uN-MPa (issue 19 item 3) --
#
# Every class below runs all eight checks on joints drawn at that scale. Moduli in MPa are
# N/mm^2 = uN/um^2, so the same numbers serve mm-N-MPa and um-uN-MPa; steel: E = 200 GPa,
# G = 76.9 GPa; silicon <110>: E = 169 GPa, G = 66 GPa (Poisson's ratio 0.28).

STEEL_MPA = {"E": 200e3, "G": 76.9e3}
SILICON_MPA = {"E": 169e3, "G": 66e3}
#: The leaf classes' mesh: the kit's checks are invariants of any mesh (frame invariance, work =
#: energy, reciprocity ...); 8 elements instead of the default 24 keeps these three classes at a
#: third of their time in the fast set (test_registered_joint_conforms checks the default mesh).
LEAF_MESH = {"elements": 8}


@pytest.mark.slow  # the fast set keeps the micrometre class: the same checks, the smallest numbers
class TestLeafSpringAt4mmInSI(testing.JointConformance):
    """The shipped leaf spring at 2-8 mm in SI units (main's kit, which placed it up to 1 m away
    with absolute tolerances, gave NaN or failed 2-3 of the 8 checks at 4 mm)."""

    joint_class = flexmb.LeafSpring
    parameter_ranges = {"length": (2e-3, 8e-3), "width": (0.5e-3, 2e-3), "thickness": (2e-5, 1e-4)}
    joint_parameters = LEAF_MESH


@pytest.mark.slow  # as TestLeafSpringAt4mmInSI
class TestLeafSpringInMillimetres(testing.JointConformance):
    joint_class = flexmb.LeafSpring
    parameter_ranges = {"length": (2.0, 8.0), "width": (0.5, 2.0), "thickness": (0.02, 0.1)}
    joint_parameters = {**STEEL_MPA, **LEAF_MESH}


class TestLeafSpringInMicrometres(testing.JointConformance):
    joint_class = flexmb.LeafSpring
    parameter_ranges = {"length": (200.0, 800.0), "width": (20.0, 100.0), "thickness": (2.0, 10.0)}
    joint_parameters = {**SILICON_MPA, **LEAF_MESH}


@pytest.mark.slow
class TestCrossFlexureInMillimetres(testing.JointConformance):
    joint_class = flexmb.CrossFlexure
    parameter_ranges = {"length": (5.0, 20.0), "angle": (0.4, 1.2), "thickness": (0.05, 0.2)}
    joint_parameters = {**STEEL_MPA, "width_inner": 4.0, "width_outer": 2.0}


@pytest.mark.slow
class TestCrossFlexureInMicrometres(testing.JointConformance):
    """A MEMS cross-axis pivot: silicon leaves of 200-800 um, 5-20 um thick."""

    joint_class = flexmb.CrossFlexure
    parameter_ranges = {"length": (200.0, 800.0), "angle": (0.4, 1.2), "thickness": (5.0, 20.0)}
    joint_parameters = {**SILICON_MPA, "width_inner": 50.0, "width_outer": 25.0}


class TestCurvedBeamInMicrometres(testing.JointConformance):
    """The gripper's curved beams (Cammarata et al. 2022) are this size: radius 0.5-2.5 mm in um."""

    joint_class = flexmb.CurvedBeam
    parameter_ranges = {"radius": (500.0, 2500.0), "angle": (0.5, 3.0), "E": (1e3, 2e5), "width": (20.0, 200.0),
                        "height": (5.0, 50.0)}


def _plugin():
    from dummy_plugins import Good

    return Good


class TestPluginJointInMillimetres(testing.JointConformance):
    """A third-party joint (`tests/dummy_plugins.Good`, one Euler-Bernoulli element) in mm-N-MPa."""

    joint_class = _plugin()
    parameter_ranges = {"length": (2.0, 8.0), "width": (0.5, 2.0), "thickness": (0.02, 0.1)}
    joint_parameters = STEEL_MPA


class TestPluginJointInMicrometres(testing.JointConformance):
    joint_class = _plugin()
    parameter_ranges = {"length": (200.0, 800.0), "width": (20.0, 100.0), "thickness": (2.0, 10.0)}
    joint_parameters = SILICON_MPA


def test_the_force_scale_follows_the_joint_not_the_unit_system():
    """One leaf in SI, mm-N-MPa and um-uN-MPa: the kit's force scale is the same force in each
    (N, N, uN). Reference: the clamped leaf's tip force that deflects it by its length, 3 EI / L^2
    (Euler-Bernoulli; Timoshenko shear adds < 0.1 % at L/t = 80)."""
    si = flexmb.LeafSpring(length=4e-3, width=1e-3, thickness=5e-5, E=200e9, G=76.9e9)
    mm = flexmb.LeafSpring(length=4.0, width=1.0, thickness=0.05, **STEEL_MPA)
    um = flexmb.LeafSpring(length=4000.0, width=1000.0, thickness=50.0, **STEEL_MPA)
    EI = 200e9 * 1e-3 * 5e-5**3 / 12
    for dim in (2, 3):
        f_si, f_mm, f_um = (testing.force_scale(j, dim) for j in (si, mm, um))
        assert f_si == pytest.approx(3 * EI / 4e-3**2, rel=2e-3)  # N
        assert f_mm == pytest.approx(f_si, rel=1e-9)  # N
        assert f_um == pytest.approx(f_si * 1e6, rel=1e-9)  # uN


def test_a_plugin_author_can_set_placements_and_solver_options():
    """The hooks: ``placement_range`` scales the drawn origins by the joint's size and
    ``solver_options`` reaches every solve."""
    seen = []

    class Hooked(testing.JointConformance):
        joint_class = flexmb.LeafSpring
        parameter_ranges = {"length": (4.0, 4.0), "width": (1.0, 1.0), "thickness": (0.05, 0.05)}
        joint_parameters = STEEL_MPA
        placement_range = 3.0

        def solver_options(self, joint, dim):
            return {"tol": 1e-9 * testing.force_scale(joint, dim), "max_iter": 30}

    def body(j, dim, pl, mo, **options):
        seen.append((np.abs(pl[0]).max(), options))

    Hooked()._run(body)
    assert seen and all(reach <= 3.0 * 4.0 for reach, _ in seen)
    assert max(reach for reach, _ in seen) > 4.0  # beyond one joint size: the range is used
    assert all(o["max_iter"] == 30 and o["tol"] > 0 for _, o in seen)


@pytest.mark.parametrize("dim", [2, pytest.param(3, marks=pytest.mark.slow)])  # 3D: 2.2 s CPU
def test_every_check_passes_on_a_4_um_leaf_in_si_placed_far_away(dim):
    """The extreme of both: a 4 um leaf in metres (forces ~1e-7 N, moments ~1e-13 N m) and a 4 mm
    leaf placed 0.7 m (175 sizes) from the origin, each through the eight checks directly."""
    rot = 0.5 if dim == 2 else np.array([0.3, -0.5, 1.0])
    for L, origin in ((4e-6, np.full(dim, 2.8e-6)), (4e-3, np.full(dim, 0.7))):
        j = flexmb.LeafSpring(length=L, width=L / 4, thickness=L / 80)
        testing.check_rest(j, dim)
        testing.check_tangent(j, dim, origin, rot, motion=0.3)
        testing.check_rigid_motion(j, dim, origin, rot)
        testing.check_frame_invariance(j, dim, origin, rot, motion=0.2)
        if dim == 2:
            assert testing.check_strategy_frame_invariance(j, dim, origin, rot, motion=0.2) == ["newton"]
        else:  # nothing to check: the closed form is planar, and a leaf spring has no database
            with pytest.raises(testing.CheckSkipped, match="newton solves 2D mechanisms only.*offers no database"):
                testing.check_strategy_frame_invariance(j, dim, origin, rot, motion=0.2)
        testing.check_reciprocity(j, dim, rot)
        testing.check_energy(j, dim, rot)
        testing.check_strategies(j, dim, motion=0.2)
