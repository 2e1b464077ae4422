"""Design gradients (issue 28): adjoint and direct against the Taylor test and central differences
of plain solves, in deformed states (>= 0.3 rad), 2D and 3D; the closed forms; the checker's
mutation tests; bad input."""

from __future__ import annotations

import attrs
import numpy as np
import pytest

import flexmb
from flexmb.design import DesignPoint, evaluate, responses as R
from flexmb.design.check import check_gradient, taylor_test
from flexmb.errors import FlexmbError, ParameterError, TopologyError, UnsupportedStrategyError

from design_cases import PIVOT, PIVOT_BOUNDS, SPATIAL, pivot, spatial

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


def test_ksd_reduced_is_refused_naming_it_and_each_parameter_s_kind():
    with pytest.raises(UnsupportedStrategyError, match="ksd-reduced") as info:
        evaluate(_pivot(2), PIVOT, R.reaction("B", "rotation"), bounds=PIVOT_BOUNDS, method="ksd-reduced")
    text = str(info.value)
    for name, kind in (("t", "joint dimension or material"), ("E", "joint dimension or material"),
                       ("x", "placement"), ("m", "mass"), ("F", "load")):
        assert f"'{name}' ({kind})" in text, text


def test_the_closed_form_strategy_is_refused_naming_it():
    with pytest.raises(UnsupportedStrategyError, match="'newton'.*'t'"):
        evaluate(lambda q: _cantilever(q, 2), {"L": 0.1, "t": 1e-3}, R.displacement("B", "y"), method="newton")


def test_reaction_at_a_free_dof_is_refused():
    with pytest.raises(FlexmbError, match="free DOF"):
        evaluate(_pivot(2), PIVOT, R.reaction("B", "x"))
