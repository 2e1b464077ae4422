"""Convergence in any consistent unit system and at any mesh size (issue 19 item 2).

The conventional method's default convergence test is relative: the free residual, moments over
the model's length, over the problem's force scale (largest element end force or applied load;
`StaticProblem.scaled_residual`) below ``rtol = 1e-9``, or a Newton correction below 1e-13
(translations over the model length, rotations in rad): the round-off floor. An absolute ``tol``
[N, N m] stays available.
"""

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

import flexmb

#: (length unit in m, force unit in N) of SI, mm-N-MPa and um-uN-MPa
UNITS = {"SI": (1.0, 1.0), "mm-N-MPa": (1e-3, 1.0), "um-uN-MPa": (1e-6, 1e-6)}


def cross_flexure_in(units: str, rotation: float = 0.6) -> flexmb.Mechanism:
    """The Table 1 cross flexure (3 el./leaf, 3D) turned ``rotation`` rad, in ``units``."""
    length, force = UNITS[units]
    stress = force / length**2
    return flexmb.models.cross_flexure_pivot(
        elements_per_leaf=3, dim=3, rotation=rotation, length=0.1 / length, thickness=1e-3 / length,
        width_inner=0.04 / length, width_outer=0.02 / length, E=200e9 / stress, G=76.9e9 / stress)


def test_one_mechanism_gives_the_same_answer_in_three_unit_systems():
    ref = flexmb.solve(cross_flexure_in("SI"))
    assert ref.converged
    for units, (length, force) in UNITS.items():
        sol = flexmb.solve(cross_flexure_in(units))
        assert sol.converged, units
        assert sol.iterations == ref.iterations, units
        # reaction on B: forces [force unit], moments [force unit x length unit]
        np.testing.assert_allclose(sol.reaction("B")[5] * force * length, ref.reaction("B")[5], rtol=1e-9)
        x = sol.node_positions() * length
        np.testing.assert_allclose(x, ref.node_positions(), rtol=0, atol=1e-9 * np.abs(x).max())


def test_the_absolute_tolerance_stays_available():
    sol = flexmb.solve(cross_flexure_in("SI"), tol=5e-7)
    assert sol.converged and sol.tolerance == 5e-7 and sol.residual_history[-1] < 5e-7
    # in um-uN-MPa the moments are 1e12 times larger numbers: 5e-7 is below their round-off
    assert not flexmb.solve(cross_flexure_in("um-uN-MPa"), tol=5e-7).converged


def test_a_fine_cantilever_under_a_small_load_converges_at_once():
    # 200 elements under 1 N: the absolute 5e-7 N is below this model's round-off floor (the
    # step was halved to 3e-5 in 361 iterations before); relative: one step
    m = flexmb.models.cantilever(elements=200, dim=2)
    m.apply_force("tip", (0.0, -1.0))
    sol = flexmb.solve(m)
    assert sol.converged and sol.iterations <= 5
    EI = 200e9 * 0.02 * 1e-3**3 / 12
    assert -sol.pose("tip")[0][1] == pytest.approx(0.1**3 / (3 * EI), rel=1e-3)  # Euler-Bernoulli tip, small load


def elastica_tip(alpha: float) -> tuple[float, float, float]:
    """Inextensible cantilever under a dead transverse end load, ``alpha = F L^2 / EI``
    (Bisshopp & Drucker 1945; Howell, Compliant Mechanisms, 2001, Sec. 5.2): tip angle theta0
    from ``sqrt(alpha) = K(k) - F(phi1, k)``, ``k^2 = (1 + sin theta0) / 2``,
    ``phi1 = asin(1 / (sqrt(2) k))``; x / L = sqrt(2 sin(theta0) / alpha), deflection / L =
    1 - 2 (E(k) - E(phi1, k)) / sqrt(alpha). Returns (x / L, deflection / L, theta0)."""
    def parts(t0):
        m = (1 + np.sin(t0)) / 2
        phi1 = np.arcsin(1 / np.sqrt(2 * m))
        return m, phi1, ellipk(m) - ellipkinc(phi1, m)

    t0 = brentq(lambda t: parts(t)[2] - np.sqrt(alpha), 1e-12, np.pi / 2 - 1e-15, xtol=1e-15)
    m, phi1, _ = parts(t0)
    return np.sqrt(2 * np.sin(t0) / alpha), 1 - 2 * (ellipe(m) - ellipeinc(phi1, m)) / np.sqrt(alpha), t0


@pytest.mark.slow  # fast-set budget: >= 0.9 s measured under load
def test_a_10000_element_cantilever_matches_the_elastica():
    # a 0.1 mm leaf (L/t = 1000) at alpha = F L^2 / EI = 5: 48 degrees at the tip. Its axial and
    # shear compliance, which the elastica lacks, moves the tip by ~alpha t^2 / (12 L^2) = 4e-7 L;
    # the discretisation error is far below (1000 elements: within 1e-7 L of 10 000)
    L, t, E = 0.1, 1e-4, 200e9
    EI = E * 0.02 * t**3 / 12
    m = flexmb.models.cantilever(elements=10_000, dim=2, thickness=t)
    m.apply_force("tip", (0.0, -5.0 * EI / L**2))
    sol = flexmb.solve(m)
    assert sol.converged
    x_ref, v_ref, theta_ref = elastica_tip(5.0)
    x, y = sol.pose("tip")[0]
    assert x / L == pytest.approx(x_ref, abs=2e-6)
    assert -y / L == pytest.approx(v_ref, abs=2e-6)
    assert -sol.rotation_vector("tip")[0] == pytest.approx(theta_ref, abs=2e-6)
