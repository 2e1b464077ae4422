"""KSD-reduced design gradients (issue 28): with respect to loads on the reduced mechanism's
equilibrium, checked against KSD-reduced re-solves; other parameters and responses refused by name."""

from __future__ import annotations

import pytest

import flexmb
from flexmb.design import evaluate
from flexmb.design import responses as R
from flexmb.design.check import check_gradient
from flexmb.errors import UnsupportedStrategyError

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
