"""Every response x every parameter kind (issue 28's first must-show line): a joint dimension
(L, a, t), a material constant (E), a placement (x), a mass (m) and a load (F), on a cross-flexure
pivot turned 0.4 rad with a dead load at an offset point, in 2D and 3D, conventional and KSD-full:
the Taylor test (rates 2 +- 0.1 over four halvings) and central differences of plain solves (1e-6,
scaled per parameter)."""

from __future__ import annotations

import pytest
from design_cases import PIVOT, PIVOT_BOUNDS, pivot

from flexmb.design import responses as R
from flexmb.design.check import check_gradient

RESPONSES = {
    "reaction": lambda rz: R.reaction("B", rz),
    "displacement": lambda rz: R.displacement("B", "x"),
    "frequency": lambda rz: R.frequency(1),
    "buckling": lambda rz: R.buckling(1),
    "compliance": lambda rz: R.compliance("B", "x", "x"),
    "stress": lambda rz: R.stress(scale=300e6),
    "mass": lambda rz: R.mass(),
}
# KSD-full's joint database is keyed on the leaf angle and states the joint's length: re-solving
# at another L or a needs another database, so its check holds them (the gradient is the same
# equations' as conventional's, tests/test_design_gradients.py)
KSD_FIXED = ("L", "a")


@pytest.mark.slow  # 21 cases, ~10 s: the must-show matrix; tests/test_design_gradients.py keeps fast ones
@pytest.mark.parametrize("case", ["2d-conventional", "3d-conventional", "3d-ksd-full"])
@pytest.mark.parametrize("response", list(RESPONSES))
def test_every_response_and_parameter_kind(case, response):
    dim = int(case[0])
    method = case[3:]
    resp = RESPONSES[response]("rotation" if dim == 2 else "rz")
    if method == "ksd-full":
        fixed = {k: PIVOT[k] for k in KSD_FIXED}
        p = {k: v for k, v in PIVOT.items() if k not in KSD_FIXED}
        build = lambda q: pivot({**fixed, **q}, dim)
        options = dict(method=method, tol=1e-8)  # absolute [N, N m]: KSD-full's round-off ~4e-9
    else:
        p, build, options = PIVOT, (lambda q: pivot(q, dim)), dict(rtol=1e-12)
    c = check_gradient(build, p, resp, bounds=PIVOT_BOUNDS, **options)
    assert c.ok, str(c)
