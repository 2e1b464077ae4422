"""The KS aggregate of the von Mises stress (issue 28): its gradient, its bounds, the exact peak beside it."""

from __future__ import annotations

import pytest
from design_cases import PIVOT, PIVOT_BOUNDS, SPATIAL, pivot, spatial

from flexmb.design import evaluate
from flexmb.design import responses as R
from flexmb.design.check import check_gradient
from flexmb.errors import ModelError, ParameterError

TIGHT = dict(rtol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_ks_stress_gradient(dim):
    c = check_gradient(lambda q: pivot(q, dim), PIVOT, R.stress(scale=300e6), bounds=PIVOT_BOUNDS, **TIGHT)
    assert c.ok, str(c)


def test_ks_stress_of_one_joint_in_a_spatial_case():
    c = check_gradient(spatial, SPATIAL, R.stress(scale=300e6, joint="leaf2", rho=100.0), **TIGHT)
    assert c.ok, str(c)


@pytest.mark.parametrize("rho", [20.0, 50.0, 200.0])
def test_ks_bounds_the_peak_from_above_within_its_bound(rho):
    # Kreisselmeier & Steinhauser: max <= KS <= max + s ln(n) / rho; the sampled points include the
    # section's corners, where a leaf bent about its weak axis peaks: the sampled maximum is the
    # exact peak of flexmb.Solution.stresses there
    r = R.stress(scale=300e6, rho=rho)
    ev = evaluate(lambda q: pivot(q, 3), PIVOT, r, bounds=PIVOT_BOUNDS)
    rep = r.report(ev.solution)
    assert rep["sampled_max"] <= rep["ks"] <= rep["sampled_max"] + rep["bound"]
    assert rep["sampled_max"] <= rep["max"] * (1 + 1e-12)
    assert rep["max"] == pytest.approx(rep["sampled_max"], rel=1e-3)
    assert ev.values[0] == pytest.approx(rep["ks"], rel=1e-14)


def test_ks_stress_needs_a_scale_or_yield_stresses():
    with pytest.raises(ParameterError, match="scale"):
        evaluate(lambda q: pivot(q, 2), PIVOT, R.stress(), bounds=PIVOT_BOUNDS)
    with pytest.raises(ModelError, match="'nope'"):
        evaluate(lambda q: pivot(q, 2), PIVOT, R.stress(scale=1e8, joint="nope"), bounds=PIVOT_BOUNDS)
