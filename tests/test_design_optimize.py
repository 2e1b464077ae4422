"""The optimisation driver (issue 28 item 5): `flexmb.optimize` over scipy (SLSQP, trust-constr,
COBYLA), IPOPT and MMA, with its cache, history, failure handling, Ctrl-C and refusals."""

from __future__ import annotations

import os
import signal
import sys

import numpy as np
import pytest

import flexmb
from flexmb import responses as R
from flexmb.design.derived import support_stiffness
from flexmb.design.optimize import Constraint, _Problem, optimize
from flexmb.design.stroke import Stroke, ks_max, ks_min
from flexmb.errors import MissingExtraError, ParameterError, UnsupportedStrategyError

from test_design_stroke import STAGE, stage

STROKE = Stroke([-5.0, 5.0], motion=("stage", "x"))  # [mm]
BOUNDS = {"t": (0.2, 1.0), "L": (30.0, 100.0), "d": (20.0, 60.0)}


def stage_problem(**kw):
    """Maximise the stage's minimum support stiffness [N/mm] at the tool point over +-5 mm with the
    stroke force <= 5 N (a stroke-stiffness ceiling of 1 N/mm) and the stress <= 300 MPa."""
    args = dict(objective=ks_min(support_stiffness("stage", "y", point="tool")), maximize=True,
                constraints=[Constraint(ks_max(R.reaction("stage", "x")), upper=5.0),
                             Constraint(ks_max(R.stress(scale=500.0)), upper=300.0)], stroke=STROKE)
    args.update(kw)
    return optimize(stage, dict(STAGE), BOUNDS, **args)


def test_slsqp_with_design_gradients_reaches_the_derivative_free_optimum_with_fewer_solves():
    """SLSQP (adjoint) and COBYLA (plain solves) from the same start under the same constraints: the
    same optimum within 0.5 %; the stroke force constraint active (t^3 / L^3 at its ceiling)."""
    grad = stage_problem(optimizer="slsqp")
    free = stage_problem(optimizer="cobyla", max_iter=200)
    assert grad.success and grad.feasible and free.feasible
    assert grad.objective >= free.objective * (1 - 5e-3)
    assert grad.constraints["ks_max(reaction(stage, x), rho=100) <= 5"] == pytest.approx(5.0, rel=1e-4)
    assert grad.solves < free.solves
    assert len(grad.solutions) == len(STROKE) and all(s.converged for s in grad.solutions)
    h = grad.history
    assert h.n_rows == grad.evaluations and np.all(np.diff(h["solves"]) >= 0) and np.all(h["error"] == "")
    assert {"t", "L", "d", "objective", "objective_exact", "gradient_norm", "time", "newton_iterations"} <= set(h)
    assert np.nanmax(h["objective"][h["feasible"]]) == pytest.approx(grad.objective)


def test_one_design_evaluated_for_objective_constraints_and_gradients_is_solved_once():
    from flexmb.design.parameters import as_design
    from flexmb.design.stroke import as_aggregates

    design = as_design(stage, dict(STAGE))
    aggs = as_aggregates([ks_min(support_stiffness("stage", "y", point="tool")), ks_max(R.reaction("stage", "x"))],
                         len(STROKE))
    lower, upper = np.array([0.2, 30.0, 20.0]), np.array([1.0, 100.0, 60.0])
    prob = _Problem(design, lower, upper, aggs, -1.0, [(1, "<=", 5.0, "force")], STROKE, "adjoint", {}, None)
    x = np.array([0.4, 0.5, 0.5])
    prob.f(x), prob.c(x), prob.df(x), prob.dc(x), prob.f(x.copy()), prob.dc(x)
    assert prob.solves == len(STROKE) and len(prob.rows) == 1


def test_central_differences_reach_the_same_optimum_with_many_more_solves():
    grad = stage_problem(optimizer="slsqp")
    central = stage_problem(optimizer="slsqp", gradient="central")
    assert central.objective == pytest.approx(grad.objective, rel=1e-4)
    assert central.solves > 3 * grad.solves


@pytest.mark.slow
@pytest.mark.parametrize("optimizer", ["trust-constr", "mma", "ipopt"])
def test_other_optimizers_reach_the_optimum(optimizer):
    pytest.importorskip({"mma": "nlopt", "ipopt": "cyipopt"}.get(optimizer, "scipy"))
    reference = stage_problem(optimizer="slsqp")
    result = stage_problem(optimizer=optimizer)
    assert result.feasible and result.objective >= reference.objective * (1 - 5e-3)


class Failing:
    """The stage, refused by its clamp (a `ParameterError`) for leaves thicker than 0.79 mm (SLSQP's
    first step goes to 0.80 mm; the optimum is 0.781 mm)."""

    def __init__(self):
        self.calls = 0

    def __call__(self, p):
        self.calls += 1
        if p["t"] > 0.79:
            raise ParameterError(f"clamp: leaves of {p['t']} mm do not fit")
        return stage(p)


def test_a_failing_design_is_recorded_and_never_ends_the_run():
    build = Failing()
    result = optimize(build, dict(STAGE), BOUNDS, objective=ks_min(support_stiffness("stage", "y", point="tool")),
                      maximize=True, constraints=[Constraint(ks_max(R.reaction("stage", "x")), upper=5.0)],
                      stroke=STROKE)
    h = result.history
    failed = np.flatnonzero(h["error"] != "")
    assert len(failed) >= 1 and all("clamp" in e for e in h["error"][failed])
    assert np.all(np.isnan(h["objective"][failed])) and not np.any(h["feasible"][failed])
    first = failed[0]
    assert np.all(np.isfinite(h["objective"][:first])) and np.all(h["error"][:first] == "")  # nothing lost before it
    assert result.feasible and result.p["t"] <= 0.79
    assert result.objective >= stage_problem(optimizer="slsqp", constraints=[
        Constraint(ks_max(R.reaction("stage", "x")), upper=5.0)]).objective * (1 - 5e-3)


def test_a_design_that_does_not_converge_is_penalised(monkeypatch):
    """A real non-converged solve (one Newton iteration per step, no step halving) for short leaves."""
    from flexmb.design import stroke as stroke_module

    real = stroke_module.solve_configuration

    def solve(point, configure, strategy, previous=None):
        if point.design.values["L"] < 45.0:
            strategy = flexmb.solvers.make_strategy("conventional", {"max_iter": 1, "min_step": 1.0})
        return real(point, configure, strategy, previous)

    monkeypatch.setattr(stroke_module, "solve_configuration", solve)
    result = optimize(stage, {**STAGE, "L": 50.0}, BOUNDS, objective=ks_max(R.reaction("stage", "x")),
                      maximize=True, stroke=STROKE, max_iter=30)  # the stroke force grows as L falls
    h = result.history
    failed = h["error"] != ""
    assert np.any(failed) and all("ConvergenceError" in e for e in h["error"][failed])
    assert np.all(h["L"][failed] < 45.0) and result.p["L"] >= 45.0


def test_ctrl_c_returns_the_best_design_so_far_with_its_history():
    """A real SIGINT sent to this process from inside the 20th build (the start takes 8: two
    configurations and two builds per parameter for the gradients). Python's own Ctrl-C handler is
    installed for the test: a shell starts background jobs with SIGINT ignored."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    calls = []

    def build(p):
        calls.append(dict(p))
        if len(calls) == 20:
            os.kill(os.getpid(), signal.SIGINT)
        return stage(p)

    try:
        result = optimize(build, dict(STAGE), BOUNDS, objective=ks_min(support_stiffness("stage", "y", point="tool")),
                          maximize=True, constraints=[Constraint(ks_max(R.reaction("stage", "x")), upper=5.0)],
                          stroke=STROKE)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert result.interrupted and not result.success and "interrupted" in result.message
    h = result.history
    assert h.n_rows >= 2 and len(calls) == 20
    row = int(np.nanargmin(np.abs(h["objective"] - result.objective)))  # the best design is one of the history's
    assert h["objective"][row] == result.objective and h["t"][row] == result.p["t"]
    if np.any(h["feasible"]):
        assert result.feasible and result.objective == np.max(h["objective"][h["feasible"]])
    else:  # the start breaks the force ceiling: the least violation so far
        margin = h["margin ks_max(reaction(stage, x), rho=100) <= 5"]
        assert not result.feasible and margin[row] == np.nanmax(margin)


def test_the_progress_bar_shows_iterations(capsys):
    stage_problem(progress=True, max_iter=3)
    err = capsys.readouterr().err
    assert "optimize (slsqp)" in err and "it" in err


def test_bad_input_is_refused_naming_it(monkeypatch):
    obj = ks_min(support_stiffness("stage", "y", point="tool"))
    with pytest.raises(ParameterError, match="unknown design parameter.*'w'"):
        optimize(stage, dict(STAGE), {**BOUNDS, "w": (1.0, 2.0)}, objective=obj, stroke=STROKE)
    with pytest.raises(ParameterError, match="'t'.*finite"):
        optimize(stage, {**STAGE, "t": float("nan")}, BOUNDS, objective=obj, stroke=STROKE)
    with pytest.raises(ParameterError, match="'d'.*finite bounds"):
        optimize(stage, dict(STAGE), {"t": (0.2, 1.0), "L": (30.0, 100.0)}, objective=obj, stroke=STROKE)
    with pytest.raises(ParameterError, match="optimizer='bfgs'"):
        optimize(stage, dict(STAGE), BOUNDS, objective=obj, stroke=STROKE, optimizer="bfgs")
    with pytest.raises(ParameterError, match="not a response"):
        optimize(stage, dict(STAGE), BOUNDS, objective=ks_min(3.0), stroke=STROKE)
    with pytest.raises(ParameterError, match="'nelder-mead' takes bounds only"):
        optimize(stage, dict(STAGE), BOUNDS, objective=obj, stroke=STROKE, optimizer="nelder-mead",
                 constraints=[Constraint(ks_max(R.reaction("stage", "x")), upper=5.0)])
    with pytest.raises(ParameterError, match="derivative-free"):
        optimize(stage, dict(STAGE), BOUNDS, objective=obj, stroke=STROKE, optimizer="cobyla", gradient="adjoint")
    with pytest.raises(ParameterError, match="aggregate"):
        optimize(stage, dict(STAGE), BOUNDS, objective=R.reaction("stage", "x"), stroke=STROKE)
    with pytest.raises(UnsupportedStrategyError, match="'newton'"):
        optimize(stage, dict(STAGE), BOUNDS, objective=obj, stroke=STROKE, method="newton")
    monkeypatch.setitem(sys.modules, "nlopt", None)  # the extra not installed
    with pytest.raises(MissingExtraError, match="nlopt"):
        optimize(stage, dict(STAGE), BOUNDS, objective=obj, stroke=STROKE, optimizer="mma")
    monkeypatch.setitem(sys.modules, "cyipopt", None)
    with pytest.raises(MissingExtraError, match="ipopt"):
        optimize(stage, dict(STAGE), BOUNDS, objective=obj, stroke=STROKE, optimizer="ipopt")


def test_a_single_configuration_optimisation_without_a_stroke():
    """No stroke: plain responses at the design's own configuration (the pivot turned 0.4 rad)."""
    from design_cases import pivot

    def build(p):
        return pivot({"L": p["L"], "a": np.pi / 4, "t": p["t"], "E": 200e9, "m": 1.0, "x": 0.0, "F": 0.0})

    result = optimize(build, {"L": 0.1, "t": 1e-3}, {"L": (0.05, 0.15), "t": (5e-4, 1.5e-3)},
                      objective=R.frequency(1, held=[("B", "rotation")]), maximize=True,
                      constraints=[Constraint(R.reaction("B", "rotation"), upper=2.0)])
    assert result.feasible and result.constraints["reaction(B, rotation) <= 2"] == pytest.approx(2.0, rel=1e-4)
    assert len(result.solutions) == 1


def test_an_optimisation_with_its_configurations_on_an_executor_keeps_the_best_designs_solutions():
    from concurrent.futures import ThreadPoolExecutor

    serial = stage_problem(optimizer="slsqp")
    with ThreadPoolExecutor(2) as pool:
        spread = stage_problem(optimizer="slsqp", executor=pool, chunks=2)
    assert spread.objective == pytest.approx(serial.objective, rel=1e-6)
    assert len(spread.solutions) == len(STROKE) and all(s.converged for s in spread.solutions)
