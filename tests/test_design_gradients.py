"""Design gradients (issue 28): adjoint and direct against the Taylor test and central differences
of plain solves, in deformed states (>= 0.3 rad), 2D and 3D; the closed forms; the checker's
mutation tests; bad input."""

from __future__ import annotations

import attrs
import numpy as np
import pytest
from design_cases import PIVOT, PIVOT_BOUNDS, SPATIAL, pivot, spatial

import flexmb
from flexmb.design import DesignPoint, evaluate
from flexmb.design import responses as R
from flexmb.design.check import check_gradient, taylor_test
from flexmb.errors import FlexmbError, ParameterError, TopologyError, UnsupportedStrategyError

TIGHT = dict(rtol=1e-12)  # solves converged far below the Taylor remainders


def _pivot(dim):
    return lambda p: pivot(p, dim)


def test_reaction_of_the_ground_passes_taylor_and_central_differences():
    c = check_gradient(_pivot(2), PIVOT, R.reaction("A", "rotation"), bounds=PIVOT_BOUNDS, **TIGHT)
    assert c.ok, str(c)


@pytest.mark.parametrize("response", [R.reaction("C", "rx"), R.reaction("C", "rz"), R.displacement("B", "z"),
                                      R.position("B", "y", point="tip"), R.rotation("B", "ry"),
                                      R.displacement("C", "y")])
def test_spatial_gradients_pass_taylor_and_central_differences(response):
    c = check_gradient(spatial, SPATIAL, response, **TIGHT)
    assert c.ok, str(c)


def test_spatial_tangent_is_not_symmetric_and_adjoint_equals_direct():
    # the dead moment and the loads at offsets make K_ff non-symmetric: the adjoint must solve with
    # K_ff^T (a symmetrised solve would differ); adjoint and direct agree to round-off
    point = DesignPoint(spatial, SPATIAL)
    resp = [R.displacement("B", "z"), R.reaction("C", "ry")]
    adj = point.evaluate(resp, mode="adjoint", **TIGHT)
    dirc = point.evaluate(resp, mode="direct", **TIGHT)
    from flexmb.design.adjoint import Sensitivity

    sens = Sensitivity(adj.solution, point.rates(adj.solution.compiled))
    np.testing.assert_allclose(adj.jacobian, dirc.jacobian, rtol=1e-9, atol=1e-12 * np.abs(adj.jacobian).max())
    # the symmetrised tangent's "adjoint" gives another gradient
    K = sens.K[sens.free][:, sens.free].toarray()
    dJ_du, dJ_dN = resp[0].partials(sens)
    lam = np.linalg.solve(0.5 * (K + K.T), dJ_du[sens.free])
    wrong = dJ_dN + dJ_du[sens.prescribed] @ sens.prescribed_rates - lam @ sens._b
    assert np.abs(wrong - adj.jacobian[0]).max() > 1e-4 * np.abs(adj.jacobian[0]).max()


def test_mass_gradient_is_exact():
    # the beams' density A L0 and the links' masses: d m / d t = rho w L per leaf, d m / d m_B = 1
    ev = evaluate(spatial, SPATIAL, R.mass(), **TIGHT)
    rho, L, t = 7800.0, SPATIAL["L"], SPATIAL["t"]
    expected = rho * L * t * (SPATIAL["w"] + 0.01) + SPATIAL["m"]
    assert ev.values[0] == pytest.approx(expected, rel=1e-12)
    g = ev.gradient(0)
    assert g["t"] == pytest.approx(rho * L * (SPATIAL["w"] + 0.01), rel=1e-9)
    assert g["w"] == pytest.approx(rho * L * t, rel=1e-9)
    assert g["L"] == pytest.approx(rho * t * (SPATIAL["w"] + 0.01), rel=1e-9)
    assert g["m"] == pytest.approx(1.0, rel=1e-9)
    assert g["E"] == 0.0 and g["F"] == 0.0


def _cantilever(p, dim):
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(p["L"], 0.0, 0.0)[:dim])
    m.add_joint("A", "B", "leaf_spring", length=p["L"], thickness=p["t"], width=0.02, elements=8)
    m.apply_force("B", (0.0, 1e-3, 0.0)[:dim])
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_slender_cantilever_tip_deflection_closed_forms(dim):
    # Euler-Bernoulli cantilever under an end load, delta = F L^3 / (3 E I), I = w t^3 / 12
    # (Gere & Goodno, Mechanics of Materials, Table G-1 case 4): d ln delta / d ln t = -3 and
    # d ln delta / d ln L = 3. flexmb's beams are Timoshenko's: delta = F L^3/(3EI) + F L/(k G A)
    # (Timoshenko & Gere 1972, Sec. 5.?): the shear part shifts the slopes by ~1.5e-4 at L/t = 100,
    # checked exactly too. The load (1 mN, delta/L = 1e-5) keeps the geometry linear.
    p = {"L": 0.1, "t": 1e-3}
    ev = evaluate(lambda q: _cantilever(q, dim), p, R.displacement("B", "y"), **TIGHT)
    g, d = ev.gradient(0), ev.values[0]
    assert g["t"] * p["t"] / d == pytest.approx(-3.0, abs=1e-3)
    assert g["L"] * p["L"] / d == pytest.approx(3.0, abs=1e-3)
    s = flexmb.rectangle(0.02, 1e-3, 200e9, 76.9e9)
    bend, shear = 1e-3 * 0.1**3 / (3 * s.E * s.Iz), 1e-3 * 0.1 / (s.ky * s.G * s.A)
    assert d == pytest.approx(bend + shear, rel=1e-8)
    assert g["t"] * p["t"] / d == pytest.approx((-3 * bend - shear) / (bend + shear), abs=1e-7)
    assert g["L"] * p["L"] / d == pytest.approx((3 * bend + shear) / (bend + shear), abs=1e-7)


@pytest.mark.parametrize("method", ["conventional", "ksd-full"])
def test_ksd_full_shares_the_conventional_gradient(method):
    # KSD-full converges to the conventional equations from its KSD start: the same gradient. The
    # database is keyed on the leaf angle and states the joint's length, so the Taylor test moves
    # the other parameters only (re-solving at another length needs another database).
    p = {k: v for k, v in PIVOT.items()}
    direction = {"t": 1e-3, "E": 200e9, "x": 0.002, "F": 3.0}
    resp = R.reaction("B", "rz")
    tight = {"conventional": TIGHT, "ksd-full": dict(tol=1e-8)}  # KSD-full: absolute [N, N m], round-off ~4e-9
    t = taylor_test(_pivot(3), p, resp, direction=direction, bounds=PIVOT_BOUNDS, method=method, **tight[method])
    assert t.ok, str(t)
    ev = {m: evaluate(_pivot(3), p, resp, bounds=PIVOT_BOUNDS, method=m, **tight[m]) for m in tight}
    np.testing.assert_allclose(ev["ksd-full"].jacobian, ev["conventional"].jacobian, rtol=1e-7)


# -- the checker can fail ------------------------------------------------------------------------
@attrs.frozen
class _Mutant:
    """A response whose gradient is wrong: sign flipped, or one of its terms dropped."""

    inner: object
    mutation: str

    @property
    def name(self):
        return f"mutant({self.inner.name})"

    def value(self, solution):
        return self.inner.value(solution)

    def gradient(self, sens, method="auto"):
        dJ_du, dJ_dN = self.inner.partials(sens)
        if self.mutation == "sign":
            return -sens.gradient(dJ_du, dJ_dN, method)
        if self.mutation == "direct term":  # the reaction's own dependence on the model numbers
            return sens.gradient(dJ_du, 0.0 * dJ_dN, method)
        # the prescribed DOFs' motion with the parameters (x0 and the prescribed values)
        lam = sens.solve(dJ_du[sens.free], transpose=True)
        return dJ_dN - lam @ (sens.residual_rates[sens.free])


@pytest.mark.parametrize("mutation", ["sign", "direct term", "prescribed motion"])
def test_checker_catches_a_wrong_gradient(mutation):
    resp = _Mutant(R.reaction("C", "rz"), mutation)
    c = check_gradient(spatial, SPATIAL, resp, **TIGHT)
    assert not c.ok
    assert not c.taylor.ok
    assert max(c.errors.values()) > 1e-3
    assert "FAILED" in str(c)


def test_central_differences_catch_an_error_the_taylor_test_cannot_see():
    """A gradient 1e-4 off (relative) still gives Taylor rates of 2 over 1e-2 ... 6e-4 (its
    linear remainder is below the quadratic one); the differences at either of their two steps
    (flexmb.design.check.CHECK_STEPS) see it, so the check fails and names the error."""
    resp = R.displacement("B", "z")
    exact = check_gradient(spatial, SPATIAL, resp, **TIGHT)
    assert exact.ok, str(exact)
    off = {k: g * (1.0 + 1e-4) for k, g in exact.gradient.items()}
    c = check_gradient(spatial, SPATIAL, resp, gradient=off, **TIGHT)
    assert c.taylor.ok and not c.ok
    assert 5e-5 < max(c.errors.values()) < 2e-4


def test_taylor_rate_of_a_wrong_gradient_is_one():
    resp = _Mutant(R.displacement("B", "z"), "sign")
    t = taylor_test(spatial, SPATIAL, resp, **TIGHT)
    assert abs(t.rate - 1.0) < 0.1 and not t.ok


# -- bad input -------------------------------------------------------------------------------------
def test_topology_change_is_refused_naming_the_parameter():
    def build(p):
        m = flexmb.Mechanism(dim=2)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(p["L"], 0.0))
        m.add_joint("A", "B", "leaf_spring", length=p["L"], elements=int(p["L"] / 0.01))
        m.apply_force("B", (0.0, 1.0))
        return m

    with pytest.raises(TopologyError, match="'L'"):
        evaluate(build, {"L": 0.1}, R.displacement("B", "y"))


def test_unknown_non_finite_and_ignored_parameters_are_refused():
    with pytest.raises(ParameterError, match="'t'"):
        evaluate(_pivot(2), {**PIVOT, "t": np.nan}, R.mass())
    with pytest.raises(ParameterError, match="'q'"):
        DesignPoint(_pivot(2), PIVOT).design.at({"q": 1.0})
    with pytest.raises(ParameterError, match="'unused'"):
        evaluate(_pivot(2), {**PIVOT, "unused": 1.0}, R.mass())


def test_ksd_reduced_refuses_joints_and_masses_naming_each_parameter_s_kind():
    # KSD-reduced's gradients follow placements, loads and prescribed motion (tests/test_design_reduced.py)
    with pytest.raises(UnsupportedStrategyError, match="ksd-reduced") as info:
        evaluate(_pivot(2), PIVOT, R.reaction("B", "rotation"), bounds=PIVOT_BOUNDS, method="ksd-reduced")
    text = str(info.value)
    for name, kind in (("t", "joint dimension or material"), ("E", "joint dimension or material"), ("m", "mass")):
        assert f"'{name}' ({kind})" in text, text
    assert "'F'" not in text and "'x'" not in text


def test_the_closed_form_strategy_is_refused_naming_it():
    with pytest.raises(UnsupportedStrategyError, match="'newton'.*'t'"):
        evaluate(lambda q: _cantilever(q, 2), {"L": 0.1, "t": 1e-3}, R.displacement("B", "y"), method="newton")


def test_reaction_at_a_free_dof_is_refused():
    with pytest.raises(FlexmbError, match="free DOF"):
        evaluate(_pivot(2), PIVOT, R.reaction("B", "x"))


def test_a_configuration_shares_the_design_rates_and_gives_the_same_gradient():
    # one DesignPoint, configurations changed by configure(mechanism) (a stroke): the same values and
    # gradients as designs built in that configuration, the builds' rates computed once
    calls = []

    def counted(p):
        calls.append(1)
        return pivot(p, 2)

    point = DesignPoint(counted, PIVOT, PIVOT_BOUNDS)
    resp = [R.reaction("B", "rotation"), R.displacement("B", "x"), R.frequency(1)]
    for turn in (0.1, 0.3):
        before = len(calls)
        ev = point.evaluate(resp, configure=lambda m, turn=turn: m.prescribe("B", rotation=turn), **TIGHT)
        builds = len(calls) - before

        def turned(p, turn=turn):
            m = pivot(p, 2)
            m.prescribe("B", rotation=turn)
            return m

        ref = evaluate(turned, PIVOT, resp, bounds=PIVOT_BOUNDS, **TIGHT)
        np.testing.assert_allclose(ev.values, ref.values, rtol=1e-12)
        np.testing.assert_allclose(ev.jacobian, ref.jacobian, rtol=1e-8, atol=1e-12 * np.abs(ref.jacobian).max())
    # the second configuration: its solve's build only (its configured compile copies the design's kept
    # build, DesignPoint._configured), not 2 per parameter again
    assert builds == 1


def test_ideal_hinges_are_refused_by_name():
    def build(p):
        m = flexmb.Mechanism(dim=2)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(0.1, 0.0))
        m.add_link("C", position=(0.2, 0.0))
        m.add_joint("A", "B", "leaf_spring", length=p["L"], elements=4)
        m.add_joint("B", "C", flexmb.Hinge(k=1.0), name="pin", origin=(0.1, 0.0))
        m.apply_force("C", (0.0, 1.0))
        return m

    with pytest.raises(UnsupportedStrategyError, match="'?pin'?"):
        evaluate(build, {"L": 0.1}, R.displacement("C", "y"))


def test_warm_started_sweep_solutions_give_the_fresh_gradient():
    # a stroke solved warm-started (flexmb.sweep: the problem holds increments of the prescribed
    # values) gives the same gradients as fresh solves, with configure= and for the design's own
    # configuration (whose prescribed rotation vector depends on the parameter 'ry')
    point = DesignPoint(spatial, SPATIAL)
    resp = [R.reaction("C", "rz"), R.displacement("B", "z"), R.frequency(1)]
    turns = [(0.1, SPATIAL["ry"], 0.2), (0.1, SPATIAL["ry"], 0.4)]
    sw = flexmb.sweep(point.mechanism(), np.array(turns), motion=("C", "rotation"), **TIGHT)
    for w, sol in zip(turns, sw):
        cfg = lambda m, w=w: m.prescribe("C", rotation=w)
        warm, fresh = point.evaluate(resp, configure=cfg, solution=sol), point.evaluate(resp, configure=cfg, **TIGHT)
        np.testing.assert_allclose(warm.jacobian, fresh.jacobian, rtol=1e-8, atol=1e-9 * np.abs(fresh.jacobian).max())
    own = point.evaluate(resp, solution=sw[-1])  # turns[-1] is the design's own configuration
    fresh = point.evaluate(resp, **TIGHT)
    assert abs(fresh.gradient(0)["ry"]) > 1e-3 * np.abs(fresh.jacobian[0]).max()
    np.testing.assert_allclose(own.jacobian, fresh.jacobian, rtol=1e-8, atol=1e-9 * np.abs(fresh.jacobian).max())


def test_a_solution_of_another_design_is_refused():
    other = flexmb.solve(pivot({**PIVOT, "t": 1.1e-3}, 2))
    with pytest.raises(ParameterError, match="not one of the design"):
        DesignPoint(_pivot(2), PIVOT, PIVOT_BOUNDS).evaluate(R.reaction("B", "rotation"), solution=other)


def test_a_user_gradient_is_checked_and_a_wrong_one_fails():
    # flexmb.testing.check_gradient on a gradient given by its user (a plugin author's own)
    right = evaluate(spatial, SPATIAL, R.displacement("B", "z"), **TIGHT).gradient(0)
    assert check_gradient(spatial, SPATIAL, R.displacement("B", "z"), gradient=right, **TIGHT).ok
    wrong = {**right, "t": 1.01 * right["t"]}  # one component 1 % off
    c = check_gradient(spatial, SPATIAL, R.displacement("B", "z"), gradient=lambda p: wrong, **TIGHT)
    assert not c.ok and c.errors["t"] > 1e-4 and max(v for k, v in c.errors.items() if k != "t") < 1e-6


def test_configurations_that_add_loads_do_not_accumulate():
    # configure may add a load (not only replace values): each configuration starts from the builds
    point = DesignPoint(_pivot(2), PIVOT, PIVOT_BOUNDS)
    jac = [point.evaluate(R.displacement("B", "x"), configure=lambda m, f=force: m.apply_force("B", (f, 0.0)),
                          **TIGHT).jacobian for force in (1.0, 2.0, 1.0)]
    np.testing.assert_allclose(jac[2], jac[0], rtol=1e-10)
    assert np.abs(jac[1] - jac[0]).max() > 1e-6 * np.abs(jac[0]).max()


def _chained(p):
    """A leaf turned by a chain of two rotations (a manipulator's prescribed joint angles)."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.1, 0.0, 0.0))
    m.add_joint("A", "B", "leaf_spring", length=0.1, thickness=p["t"], elements=6)
    m.prescribe("B", rotation=[(0.0, 0.0, p["a"]), (0.1, 0.0, 0.0)])
    return m


@pytest.mark.parametrize("response", [R.reaction("B", "rz"), R.displacement("B", "y"), R.reaction("A", "rx")])
def test_a_prescribed_chain_of_rotations_and_its_angles(response):
    # R = exp(w_1) exp(w_2) with w_1 = (0, 0, a): the spin sum_i P_(i-1) J_l(w_i) w_i'
    c = check_gradient(_chained, {"t": 1e-3, "a": 0.35}, response, **TIGHT)
    assert c.ok, str(c)


def test_a_build_with_a_kink_at_the_design_is_refused_by_name():
    # thickness = max(t, 1 mm) at t = 1 mm: the model's stiffness has slope 3 S/t above and 0 below
    def build(p):
        m = _cantilever({"L": 0.1, "t": max(p["t"], 1e-3)}, 2)
        m.apply_force("B", (0.0, p["F"]))
        return m

    with pytest.raises(ParameterError, match="'t'.*not smooth"):
        evaluate(build, {"t": 1e-3, "F": 1e-3}, R.displacement("B", "y"))
    evaluate(build, {"t": 1.2e-3, "F": 1e-3}, R.displacement("B", "y"))  # away from the kink: fine


def _manipulator(p):
    """The spatial manipulator of Dwarshuis et al. (2020) Sec. 4.4 (three 3x-infinity joints, its
    links' orientations prescribed as chains of the joints' turns, 0.35 rad) with its arms' lengths
    as placements of joints 3 and the end point, and a dead load on the end link."""
    m = flexmb.models.manipulator("joint", rotation=0.35, geometry={"arm2": p["arm2"], "arm3": p["arm3"]})
    m.apply_force("link3", (0.0, 0.0, p["Fz"]))
    return m


@pytest.mark.slow  # ~2.5 s
@pytest.mark.parametrize("response", [R.reaction("link2", "ry"), R.displacement("link3", "z")])
def test_the_manipulator_s_placements(response):
    c = check_gradient(_manipulator, {"arm2": 0.3, "arm3": 0.25, "Fz": -20.0}, response, rtol=1e-11)
    assert c.ok, str(c)
    assert abs(c.taylor.rate - 2.0) <= 0.1
