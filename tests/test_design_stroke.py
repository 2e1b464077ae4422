"""Responses over the range of motion (issue 28 item 4): a stroke solved as one continuation,
aggregated (KS max / min, mean, total, at) with exact gradients in deformed states, 2D and 3D.

Checks: the Taylor test (remainder rate 2 over four halvings, Farrell et al. 2013, as
`flexmb.testing.taylor_test`) and central differences of plain solves of the whole stroke, on
the aggregate itself; the KS aggregate's bounds (Kreisselmeier & Steinhauser 1979: max <= KS <=
max + s ln(N) / rho); the continuation equals N solves from the undeformed state.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import flexmb
from flexmb import responses as R
from flexmb.design.derived import reciprocal, support_stiffness
from flexmb.design.stroke import (Aggregate, Stroke, StrokePoint, at, evaluate_stroke, ks_max, ks_min, mean,
                                  solve_configuration, total)
from flexmb.errors import ConvergenceError, ModelError, ParameterError
from flexmb.studies.optimization import stage_build

from design_cases import PIVOT, PIVOT_BOUNDS, pivot

RATE = 0.1  # Taylor rate 2 +- 0.1 (the tolerance)
AGREEMENT = 1e-6  # central differences, scaled per parameter as flexmb.testing.check_gradient


def _taylor_and_central(build, p, aggregates, stroke, bounds=None, h0=1e-2, **options):
    """Per aggregate: the Taylor rates along a random direction and the scaled error against central
    differences of plain stroke solves (relative step 1e-4 of each parameter's scale)."""
    sp = StrokePoint(build, p, aggregates, stroke, bounds=bounds, **options)
    v0, _ = sp.values()
    J = sp.jacobian()
    scales = np.array([q.step / 1e-5 for q in sp.point.design.parameters])
    rng = np.random.default_rng(1)
    dp = scales * rng.uniform(0.5, 1.0, len(scales)) * rng.choice([-1.0, 1.0], len(scales))

    def values(q):
        return StrokePoint(build, q, aggregates, stroke, bounds=bounds, **options).values()[0]

    eps = h0 / 2.0 ** np.arange(5)
    rem = np.array([np.abs(values({k: p[k] + e * d for k, d in zip(sp.names, dp)}) - v0 - e * (J @ dp))
                    for e in eps])  # (5, R)
    with np.errstate(divide="ignore", invalid="ignore"):  # a constant response: 0 / 0
        rates = np.log(rem[:-1] / rem[1:]) / np.log(2.0)
    cd = np.zeros_like(J)
    for k, (name, s) in enumerate(zip(sp.names, scales)):
        h = 1e-4 * s
        cd[:, k] = (values({**p, name: p[name] + h}) - values({**p, name: p[name] - h})) / (2 * h)
    size = np.maximum(np.max(np.abs(J * scales), axis=1), np.max(np.abs(cd * scales), axis=1))
    errors = np.abs(J - cd) * scales / np.maximum(size, 1e-300)[:, None]
    return rates, errors, sp


PIVOT_STROKE = Stroke(np.linspace(0.3, 0.6, 3), motion=("B", "rotation"))


@pytest.mark.slow  # fast-set budget: >= 0.9 s measured under load
def test_aggregates_over_a_2d_stroke_pass_the_taylor_test_and_central_differences():
    aggs = [ks_max(R.reaction("B", "rotation")), ks_min(R.frequency(1, held=[("B", "rotation")])),
            mean(R.displacement("B", "x")), total(R.stress(scale=1e9)), at(R.rotation("B", "rotation"), 1)]
    build = functools.partial(pivot, dim=2)
    rates, errors, sp = _taylor_and_central(build, dict(PIVOT), aggs, PIVOT_STROKE, PIVOT_BOUNDS)
    for a, r, e in zip(aggs, rates.T, errors):
        if a.kind == "at":  # a prescribed rotation: constant (its gradient exactly zero)
            assert np.all(np.abs(sp.jacobian()[-1]) == 0.0)
            continue
        assert np.all(np.abs(r - 2.0) <= RATE), (a.name, r)
        assert np.all(e <= AGREEMENT), (a.name, e)


@pytest.mark.slow  # fast-set budget: >= 0.9 s measured under load
def test_aggregates_over_a_3d_stroke_of_rotation_vectors():
    """3D: the pivot turned about z through 0.3 .. 0.5 rad, prescribed as rotation vectors (N, 3);
    support stiffness at an offset point, the actuation moment and the first parasitic frequency."""
    stroke = Stroke([(0.0, 0.0, 0.3), (0.0, 0.0, 0.4), (0.0, 0.0, 0.5)], motion=("B", "rotation"))
    aggs = [ks_min(support_stiffness("B", "y")), ks_max(R.reaction("B", "rz")),
            ks_min(R.frequency(1, held=[("B", "rz")]))]
    build = functools.partial(pivot, dim=3)
    p = {k: PIVOT[k] for k in ("L", "t", "m", "F")}
    rates, errors, _ = _taylor_and_central(lambda q: build({**PIVOT, **q}), p, aggs, stroke)
    assert np.all(np.abs(rates - 2.0) <= RATE), rates
    assert np.all(errors <= AGREEMENT), errors


def test_the_continuation_gives_the_cold_solves_answers_with_fewer_iterations():
    build = functools.partial(pivot, dim=2)
    sp = StrokePoint(build, dict(PIVOT), [ks_max(R.reaction("B", "rotation"))], PIVOT_STROKE, bounds=PIVOT_BOUNDS)
    warm = sp.configuration_values()[:, 0]
    cold, cold_iterations = [], 0
    for i in range(len(PIVOT_STROKE)):
        mech = sp.point.mechanism(PIVOT_STROKE.configure_at(i))
        sol = flexmb.solve(mech)
        cold.append(R.reaction("B", "rotation").value(sol))
        cold_iterations += sol.iterations
    np.testing.assert_allclose(warm, cold, rtol=1e-8)
    assert sp.solves == 3 and sp.iterations < cold_iterations


def test_ks_aggregate_bounds_and_its_gradient_in_the_values():
    x = np.array([1.0, 3.0, 2.5, -0.5])
    for rho in (10.0, 100.0):
        hi, w_hi, exact_hi = ks_max(R.mass(), rho=rho).combine(x)
        lo, w_lo, exact_lo = ks_min(R.mass(), rho=rho).combine(x)
        s = np.mean(np.abs(x))
        assert exact_hi <= hi <= exact_hi + s * np.log(len(x)) / rho
        assert exact_lo - s * np.log(len(x)) / rho <= lo <= exact_lo
        for agg, w in ((ks_max(R.mass(), rho=rho), w_hi), (ks_min(R.mass(), rho=rho), w_lo)):
            cd = [(agg.combine(x + 1e-6 * e)[0] - agg.combine(x - 1e-6 * e)[0]) / 2e-6 for e in np.eye(len(x))]
            np.testing.assert_allclose(w, cd, rtol=1e-7, atol=1e-9)
    assert mean(R.mass()).combine(x)[0] == pytest.approx(1.5) and total(R.mass()).combine(x)[0] == 6.0
    assert at(R.mass(), -1).combine(x)[0] == -0.5


# -- beyond the papers: a double-parallelogram stage in mm, N, MPa over +-5 mm ---------------------------
stage = stage_build  # the study's builder (flexmb.studies.optimization): the same stage, written once


STAGE = dict(t=0.5, L=60.0, d=40.0)


@pytest.mark.slow  # fast-set budget: >= 0.9 s measured under load
def test_support_stiffness_of_a_stage_over_its_stroke_in_mm_n_mpa():
    """The minimum support stiffness [N/mm] over +-5 mm (its drop with the stroke, Awtar et al. 2007's
    effect) with the peak stroke force and stress, each aggregate's gradient checked."""
    # not through x = 0: the undeformed state has no stress, where von Mises has a kink (|sigma|)
    stroke = Stroke([-5.0, -3.0, -1.0, 1.0, 3.0, 5.0], motion=("stage", "x"))
    aggs = [ks_min(support_stiffness("stage", "y", point="tool")), ks_max(R.reaction("stage", "x")),
            ks_max(R.stress(scale=500.0))]
    rates, errors, sp = _taylor_and_central(stage, dict(STAGE), aggs, stroke)
    assert np.all(np.abs(rates - 2.0) <= RATE), rates
    assert np.all(errors <= AGREEMENT), errors
    k = sp.configuration_values()[:, 0]
    assert min(k[2], k[3]) > 5 * max(k[0], k[5])  # falls with |x| (the tool point beside the centre: not symmetric)
    ev = sp.evaluation()
    assert ev.exact[0] == pytest.approx(min(k)) and ev.exact[0] - ev.values[0] <= np.mean(k) * np.log(6) / 100


def test_a_stroke_of_actuation_force_levels():
    """Load levels: the pivot's B turned by an actuation force (no prescribed rotation)."""
    def build(p):
        m = flexmb.Mechanism(dim=2)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(0.0, p["L"] * np.sin(np.pi / 4)))
        m.add_joint("A", "B", "cross_flexure", length=p["L"], thickness=p["t"], elements_per_leaf=4)
        m.set_actuation("B", (-1.0, 0.0), point=(0.0, 0.1))
        return m

    stroke = Stroke([30.0, 60.0, 90.0])  # [N] at 0.1 m
    aggs = [ks_max(R.rotation("B", "rotation")), mean(R.displacement("B", "y"))]
    rates, errors, sp = _taylor_and_central(build, {"L": 0.1, "t": 1e-3}, aggs, stroke)
    assert sp.configuration_values()[-1, 0] > 0.3
    assert np.all(np.abs(rates - 2.0) <= RATE), rates
    assert np.all(errors <= AGREEMENT), errors


@pytest.mark.slow
def test_a_stroke_on_a_process_pool_gives_the_serial_numbers():
    stroke = Stroke(np.linspace(-5.0, 5.0, 4), motion=("stage", "x"))  # not through the unstressed x = 0
    aggs = [ks_min(support_stiffness("stage", "y", point="tool")), ks_max(R.stress(scale=500.0))]
    serial = evaluate_stroke(stage, dict(STAGE), aggs, stroke)
    pooled = evaluate_stroke(stage, dict(STAGE), aggs, stroke, executor="process", chunks=2)
    np.testing.assert_allclose(pooled.values, serial.values, rtol=1e-8)
    np.testing.assert_allclose(pooled.jacobian, serial.jacobian, rtol=1e-6)
    assert pooled.solutions is None and pooled.solves == 4


def test_bad_strokes_and_aggregates_are_refused_naming_them():
    with pytest.raises(ParameterError, match="aggregate"):
        StrokePoint(stage, dict(STAGE), [R.reaction("stage", "x")], Stroke([0.0, 1.0], motion=("stage", "x")))
    with pytest.raises(ParameterError, match="finite"):
        Stroke([0.0, np.nan], motion=("stage", "x"))
    with pytest.raises(ParameterError, match="motion"):
        Stroke([0.0, 1.0], motion=("stage",))
    with pytest.raises(ParameterError, match="rho"):
        ks_max(R.mass(), rho=-1.0)
    with pytest.raises(ParameterError, match="index"):
        at(R.mass(), 5).combine(np.zeros(3))
    with pytest.raises(ParameterError, match="kind"):
        Aggregate(R.mass(), "median")
    with pytest.raises(ParameterError, match="not a response"):
        reciprocal(3.0)
    with pytest.raises(ModelError, match="actuation"):
        StrokePoint(stage, dict(STAGE), [mean(R.mass())], Stroke([1.0, 2.0])).values()


def test_a_configuration_that_fails_names_its_stroke_value():
    sp = StrokePoint(stage, dict(STAGE), [mean(R.reaction("stage", "x"))],
                     Stroke([0.0, 5.0, 80.0], motion=("stage", "x")), max_iter=4, min_step=0.1)
    with pytest.raises(ConvergenceError, match=r"stroke value 80.0 \(configuration 2\)"):
        sp.values()
    assert sp.solves >= 2


def test_solve_configuration_returns_the_clean_problem_of_the_configuration():
    point = StrokePoint(stage, dict(STAGE), [mean(R.mass())]).point
    strategy = flexmb.solvers.make_strategy("conventional", {})
    first = solve_configuration(point, Stroke([2.0], motion=("stage", "x")).configure_at(0), strategy)
    second = solve_configuration(point, Stroke([3.0], motion=("stage", "x")).configure_at(0), strategy, first)
    assert second.converged and np.max(second.compiled.problem.values) == 3.0
    assert np.abs(second.residual[second.compiled.problem.free]).max() < 1e-6


def test_several_responses_in_one_aggregate_and_the_configurations_it_needs():
    """The smallest of two support stiffnesses over the stroke (one KS over 2 x N values), with a
    fixed scale: the gradient from the configurations whose KS weight counts (here one) equals the
    one from every configuration's gradient, and passes the Taylor test and central differences."""
    stroke = Stroke([-5.0, -2.0, 2.0, 5.0], motion=("stage", "x"))
    agg = ks_min([support_stiffness("stage", "y", point="tool"), support_stiffness("stage", "rotation")], scale=1e3)
    rates, errors, sp = _taylor_and_central(stage, dict(STAGE), [agg, at(R.reaction("stage", "x"), 1)], stroke)
    assert np.all(np.abs(rates - 2.0) <= RATE), rates
    assert np.all(errors <= AGREEMENT), errors
    sparse = StrokePoint(stage, dict(STAGE), [agg, at(R.reaction("stage", "x"), 1)], stroke)
    J = sparse.jacobian()
    assert len(sparse._rows) < 4 * 2  # not every (configuration, response) was differentiated
    full = StrokePoint(stage, dict(STAGE), [agg, at(R.reaction("stage", "x"), 1)], stroke)
    full.configuration_jacobians()
    np.testing.assert_allclose(J, full.jacobian(), rtol=1e-7, atol=0)  # adjoint vs direct solves: round-off
    assert agg.name.startswith("ks_min([1/compliance(stage, y, y), 1/compliance(stage, rotation, rotation)]")


def test_a_stroke_on_any_executor_gives_the_serial_numbers():
    """Any concurrent.futures.Executor (here threads; a dask client's get_executor() the same way)."""
    from concurrent.futures import ThreadPoolExecutor

    stroke = Stroke([-5.0, -2.0, 2.0, 5.0], motion=("stage", "x"))
    aggs = [ks_min(support_stiffness("stage", "y", point="tool")), ks_max(R.reaction("stage", "x"))]
    serial = evaluate_stroke(stage, dict(STAGE), aggs, stroke)
    with ThreadPoolExecutor(2) as pool:
        spread = evaluate_stroke(stage, dict(STAGE), aggs, stroke, executor=pool, chunks=2)
    np.testing.assert_allclose(spread.values, serial.values, rtol=1e-8)
    np.testing.assert_allclose(spread.jacobian, serial.jacobian, rtol=1e-6)
    assert spread.solves == 4 and spread.solutions is None
