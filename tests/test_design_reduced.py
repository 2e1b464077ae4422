"""KSD-reduced design gradients: with respect to loads, placements and prescribed motion on the
reduced mechanism's equilibrium (through KSD steps 1-3), checked against KSD-reduced re-solves
(Taylor rate 2, central differences); joints, masses and the EOB-model responses refused by name."""

from __future__ import annotations

import numpy as np
import pytest

import flexmb
from flexmb.design import evaluate
from flexmb.design import reduced
from flexmb.design import responses as R
from flexmb.design.check import check_gradient
from flexmb.design.derived import support_stiffness
from flexmb.errors import UnsupportedStrategyError
from flexmb.joints.three_x_infinity import ThreeXInfinity
from flexmb.ksd import reduced_model
from flexmb.rotations import expm_so3
from flexmb.studies.optimization import manipulator, manipulator_build, manipulator_configure

OPTIONS = dict(method="ksd-reduced", tol=1e-9)  # absolute [N, N m]; step 3 stalls near 1e-10
P = {"M": 5.0, "Fx": 0.0, "Fy": -200.0}


def fourbar(p, dim=2, t=1e-3):
    """The four-bar of Dwarshuis et al. (2020) Sec. 4.3 pushed 0.2 m (its flexures turned ~36 deg),
    with a moment and a dead force at an offset point of the top link as design loads."""
    m = flexmb.models.fourbar(3, displacement=0.2, moment=p["M"], dim=dim, thickness=t)
    m.apply_force("top", (p["Fx"], p["Fy"], 0.0)[:dim], point=(0.1, 0.5, 0.0)[:dim])
    return m


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("response", ["rotation", "displacement", "reaction", "left"])
def test_ksd_reduced_load_gradients(dim, response):
    rz = "rotation" if dim == 2 else "rz"
    resp = {"rotation": R.rotation("top", rz), "displacement": R.displacement("top", "y"),
            "reaction": R.reaction("top", "x"), "left": R.rotation("left", rz)}[response]
    c = check_gradient(lambda q: fourbar(q, dim), P, resp, **OPTIONS)
    assert c.ok, str(c)
    assert abs(c.taylor.rate - 2.0) <= 0.1  # the loads act nonlinearly: the rate is measured, not round-off


def test_ksd_reduced_refuses_a_joint_dimension_naming_it():
    with pytest.raises(UnsupportedStrategyError, match=r"'t' \(joint dimension or material\).*ksd-full"):
        evaluate(lambda q: fourbar(q, 2, t=q["t"]), {**P, "t": 1e-3}, R.rotation("top", "rotation"), **OPTIONS)


def test_ksd_reduced_refuses_the_linearisation_responses_naming_them():
    with pytest.raises(UnsupportedStrategyError, match=r"frequency\(1\).*'ksd-reduced'"):
        evaluate(lambda q: fourbar(q, 2), P, R.frequency(1), **OPTIONS)


# -- placements ------------------------------------------------------------------------------------
TIGHT = dict(method="ksd-reduced", tol=1e-10, kinematic_tol=1e-13)  # the re-solves' noise below 1e-6 of a rate
JOINT = ThreeXInfinity(elements_per_leaf=3)  # the shipped database with its tabulated condensation
TURN = 0.35  # [rad] both joints of the arm, all three of the manipulator


def arm(p):
    """A user-built two-joint arm (no paper's): two 3x-infinity joints with parallel axes (global z),
    the elbow placed at ``L1`` along x and ``h`` above the shoulder's B node and rolled by ``roll``
    about its axis, the forearm's end ``L2`` beyond it at 0.8 rad; the end's x, y prescribed where
    rigid links put it with both joints turned `TURN`, a dead force ``Fz`` beside it."""
    D0 = JOINT.interface_b(3)[2]
    a2 = np.array([p["L1"], 0.0, D0 + p["h"]])
    end = a2 + np.array([0.0, 0.0, D0]) + p["L2"] * np.array([np.cos(0.8), np.sin(0.8), 0.0])
    m = flexmb.Mechanism(dim=3)
    m.add_link("ground", fixed=True)
    m.add_link("upper", position=(0.0, 0.0, D0))
    m.add_link("fore", position=end)
    m.add_joint("ground", "upper", JOINT, name="shoulder")
    m.add_joint("upper", "fore", JOINT, name="elbow", origin=a2, rotation=(0.0, 0.0, p["roll"]))
    Rz = expm_so3(np.array([0.0, 0.0, TURN]))
    d = Rz @ a2 + Rz @ Rz @ (end - a2) - end  # complex-safe: the placements' complex step passes
    m.prescribe("fore", x=d[0], y=d[1])
    m.apply_force("fore", (0.0, 0.0, p["Fz"]), point=end + np.array([0.0, 0.05, 0.0]))
    return m


ARM = {"L1": 0.3, "L2": 0.25, "h": 0.02, "roll": 0.1, "Fz": -5.0}
MANIPULATOR = {k: manipulator().p0[k] for k in ("post", "arm2", "angle3", "roll2", "shift3")}


def _manipulator(q):
    return manipulator_build({**manipulator().p0, **q})


def _turned(mechanism):
    manipulator_configure(mechanism, TURN)


def _checked(build, p, response, **options):
    c = check_gradient(build, p, response, **TIGHT, **options)
    assert c.ok, str(c)
    assert abs(c.taylor.rate - 2.0) <= 0.1, str(c)
    return c


@pytest.mark.parametrize("response", [R.reaction("fore", "x"), R.rotation("fore", "rz"), R.displacement("fore", "z"),
                                      R.position("upper", "y"), support_stiffness("fore", "rx"),
                                      R.compliance("upper", "z", "rx")])
def test_ksd_reduced_placements_of_a_two_joint_arm(response):
    # both joints turned 0.35 rad; the placements move step 1's kinematics (the joints' angles and
    # near positions), step 2's tabulated condensation and step 3's frames
    _checked(arm, ARM, response)


@pytest.mark.slow  # ~12 s: five placements of the manipulator, four responses
@pytest.mark.parametrize("response", [R.reaction("link3", "x"), R.rotation("link3", "rz"),
                                      R.displacement("link1", "x", point="axis2"), support_stiffness("link3", "ry"),
                                      R.compliance("link3", "rx", "rz", axes="link")])
def test_ksd_reduced_placements_of_the_manipulator(response):
    # the optimisation's placements (post, arm, elevation, roll, shift) with the end point prescribed
    # where the joints turned 0.35 rad put it (configure: the prescribed values follow the placements)
    _checked(_manipulator, MANIPULATOR, response, configure=_turned)


def _mutant_caught(monkeypatch, response, where, replacement):
    right = evaluate(arm, ARM, response, **TIGHT).gradient(0)
    monkeypatch.setattr(where[0], where[1], replacement)
    c = check_gradient(arm, ARM, response, **TIGHT)
    assert not c.ok and c.taylor.rate < 1.5, str(c)
    return right, c


def test_dropped_near_configuration_terms_are_caught(monkeypatch):
    # step 2's rates (the condensation follows the joints' angles) dropped: the checker fails
    _mutant_caught(monkeypatch, R.reaction("fore", "x"), (reduced, "_condensation_rates"), lambda *a: None)


def test_dropped_kinematics_rates_are_caught(monkeypatch):
    # step 1's rates dropped (the near configuration held at the design's): the checker fails
    def frozen(red, poses, rel, pres):
        return np.zeros((len(red.joint_names), rel.shape[-1])), np.zeros((len(red.joint_names), 3, rel.shape[-1]))

    _mutant_caught(monkeypatch, R.rotation("fore", "rz"), (reduced, "kinematics_rates"), frozen)


def test_a_compliance_without_the_state_s_part_is_caught(monkeypatch):
    # the tangent's rate along the parameters only (dK/dp without dK/dz z'): the checker fails
    original = reduced.ReducedSensitivity._complex
    _mutant_caught(monkeypatch, support_stiffness("fore", "rx"), (reduced.ReducedSensitivity, "_complex"),
                   lambda self, state=None: original(self))


@pytest.mark.parametrize("dim", [2, 3])
def test_the_complex_step3_is_the_reduced_equilibrium(dim):
    # flexmb.ksd.reduced_model.step3 (complex arithmetic) against ReducedMechanism.equilibrium at a
    # loaded four-bar's solution (dead force at an offset point: the load's tangent term)
    sol = flexmb.solve(fourbar(P, dim), **OPTIONS)
    red, (_, K, Fh, p_hat, R_hat, _) = reduced_model.near(sol)
    r, T = (a[0] for a in reduced_model.step3(red, {k: v[None] for k, v in reduced_model.step3_inputs(sol).items()}))
    r0, T0 = red.equilibrium(reduced_model.link_poses(red, sol.state), K, Fh, p_hat, R_hat, tangent=True)
    np.testing.assert_allclose(r.real, r0, rtol=0, atol=1e-12 * np.abs(r0).max())
    np.testing.assert_allclose(T.real, T0, rtol=0, atol=1e-13 * np.abs(T0).max())
    assert not r.imag.any() and not T.imag.any()


def test_ksd_reduced_refuses_placements_of_joints_without_a_table_naming_them():
    # the 2D cross flexure's condensation is evaluated directly (no tabulated condensation): its rate
    # with the joints' angles is not differentiated
    def build(q):
        return flexmb.models.fourbar(3, displacement=0.2, dim=2, width=q["W"])

    with pytest.raises(UnsupportedStrategyError, match="'bottom_left'.*evaluated directly.*ksd-full"):
        evaluate(build, {"W": 0.4}, R.reaction("top", "x"), **OPTIONS)


def test_the_manipulator_s_configure_carries_the_complex_step():
    # manipulator_configure computes the prescribed end point without float(): no parameter's
    # boundary rates fall back to central differences of the build (two real builds each)
    from flexmb.design.evaluate import DesignPoint

    point = DesignPoint(_manipulator, MANIPULATOR)
    rates = point.rates(None)
    fallen, fallback = [], rates.fallback
    rates.fallback = lambda k: fallen.append(k) or fallback(k)
    ev = point.evaluate(R.reaction("link3", "x"), configure=_turned, **TIGHT)
    assert fallen == [] and np.all(np.isfinite(ev.jacobian))
    assert all(method == "complex step" for method, _ in rates.methods)


@pytest.fixture(scope="module")
def tabulated_2d(tmp_path_factory):
    """A database folder holding the 2D cross flexure's shipped data with its EOB condensation
    tabulated (`flexmb.database.training.with_eob_table`, as `flexmb train --eob-table` adds it; the
    shipped 2D file has none), under the key-only name `locate` finds first."""
    from flexmb.database.store import locate, save, shipped
    from flexmb.database.training import with_eob_table
    from flexmb.joints.cross_flexure import CrossFlexure

    folder = tmp_path_factory.mktemp("tabulated")
    joint = CrossFlexure(elements_per_leaf=3)
    save(with_eob_table(joint, shipped(joint, 2)), folder / locate(joint, 2).name)
    return folder


def placed_fourbar(p):
    """The four-bar of `fourbar` (2D, pushed 0.2 m: flexures turned 0.56 rad) with its width and
    height (the joints' and links' placements) as design parameters besides the loads."""
    m = flexmb.models.fourbar(3, displacement=0.2, moment=p["M"], dim=2, width=p["W"], height=p["H"])
    m.apply_force("top", (0.0, p["Fy"]), point=(0.1, 0.5))
    return m


@pytest.mark.parametrize("response", [R.rotation("top", "rotation"), R.reaction("top", "x"),
                                      R.displacement("top", "y"), R.position("left", "x"),
                                      R.compliance("top", "y", "y")])
def test_ksd_reduced_placements_of_the_2d_fourbar_with_a_trained_table(tabulated_2d, response):
    # step 3 stalls near 1e-10 here: its tol 1e-9 (the re-solves' noise stays below 1e-7 of a rate)
    c = check_gradient(placed_fourbar, {"M": 5.0, "Fy": -200.0, "W": 0.4, "H": 0.3}, response,
                       **{**TIGHT, "tol": 1e-9}, database=tabulated_2d)
    assert c.ok, str(c)
    assert abs(c.taylor.rate - 2.0) <= 0.1, str(c)
