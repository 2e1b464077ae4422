"""Properties of KSD-reduced solutions (issue 22 item 6): `flexmb.compliance` from the reduced
mechanism's tangent (each joint's Craig-Bampton EOB stiffness at its near configuration), with the
full model's compliance at the conventional solution as the peer."""

import numpy as np
import pytest

import flexmb
from flexmb.ksd.properties import link_poses, near, reduced_tangent
from flexmb.models import cross_flexure_pivot, fourbar, manipulator
from tolerances import FD_TANGENT


def _pair(m, link, **kw):
    """Compliance of ``link`` from KSD-reduced and from the conventional solution (the peer)."""
    red = flexmb.compliance(flexmb.solve(m, method="ksd-reduced"), link, **kw)
    full = flexmb.compliance(flexmb.solve(m, method="conventional"), link, **kw)
    return red, full


def _relative(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def test_reduced_tangent_is_the_derivative_of_the_reduced_equilibrium():
    """The tangent `compliance` inverts is the Jacobian of KSD step 3's residual at the solution
    (central finite differences of `ReducedMechanism.equilibrium` in spins, deformed state:
    the manipulator's joint case at 30 deg)."""
    sol = flexmb.solve(manipulator("joint", np.radians(30.0)), method="ksd-reduced")
    K, red = reduced_tangent(sol)
    _, (_, Kj, Fh, p_hat, R_hat, _) = near(sol)
    poses = link_poses(red, sol.state)
    n, h = 6 * red.n_links, 1e-6
    fd = np.zeros((n, n))
    for k in range(n):
        dz = np.zeros(n)
        dz[k] = h
        rp = red.equilibrium(poses.moved(dz), Kj, Fh, p_hat, R_hat, tangent=False)[0]
        rm = red.equilibrium(poses.moved(-dz), Kj, Fh, p_hat, R_hat, tangent=False)[0]
        fd[:, k] = (rp - rm) / (2 * h)
    fd = fd[np.ix_(red.emb_dofs, red.emb_dofs)]
    assert np.abs(K - fd).max() <= FD_TANGENT * np.abs(fd).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_at_rest_the_reduced_compliance_is_the_full_models(dim):
    """Undeformed, the EOB is the joint's exact linear model (Craig-Bampton condensation of the
    material stiffness is exact statically, Craig & Bampton 1968): the reduced compliance equals
    the full model's to roundoff (measured 4e-12), with the intended rotation free (a planar
    and a spatial cross flexure, not in the paper)."""
    red, full = _pair(cross_flexure_pivot(5, dim=dim), "B", held="none")
    assert _relative(red, full) < 1e-9


def test_fourbar_compliance_over_its_stroke():
    """Four-bar (Dwarshuis et al. 2020, Fig. 9; 5 el./leaf) at actuations d = 0.05-0.3 m, the
    peer the conventional solution: measured largest diagonal error of the top link's compliance
    0.28 % at 0.05 m, 0.95 % at 0.1 m, 7.3 % at 0.3 m (54 deg flexure rotation: the EOB's
    material stiffness at the near configuration lacks the leaves' geometric stiffening)."""
    for d, bound in ((0.05, 0.004), (0.1, 0.012), (0.3, 0.08)):
        red, full = _pair(fourbar(5, displacement=d), "top")
        free = np.diag(full) > 0
        err = np.abs(np.diag(red)[free] / np.diag(full)[free] - 1.0).max()
        assert err < bound, (d, err)


def test_manipulator_compliance_over_the_range_of_motion():
    """Manipulator (Dwarshuis et al. 2020, Sec. 4.4), joint case at -45, -20, 20, 45 deg: the end
    link's translational compliance (its orientation prescribed, so held; its position free)
    within 1 % of the full model's (measured over the 19 positions: at most 0.72 % at -45 deg,
    median 0.16 %), in global and in link axes; the held rotations' rows are zero."""
    for deg in (-45.0, -20.0, 20.0, 45.0):
        m = manipulator("joint", np.radians(deg))
        for axes in ("global", "link"):
            red, full = _pair(m, "link3", axes=axes)
            assert _relative(red[:3, :3], full[:3, :3]) < 0.01, (deg, axes)
            assert not red[3:].any() and not red[:, 3:].any()


def test_intended_compliance_of_a_turned_pivot_with_its_rotation_released():
    """A planar cross flexure (5 el./leaf) turned 0.3 rad, released (``held="none"``): KSD-reduced
    gives the rotation compliance 1.46 % too large (measured; peer: the conventional solution) -
    the tangent of the reduced model is the EOB's material stiffness, without the leaves' stress
    stiffening. The documented size of the approximation, checked so a change shows."""
    red, full = _pair(cross_flexure_pivot(5, dim=2, rotation=0.3), "B", held="none")
    assert 0.010 < red[2, 2] / full[2, 2] - 1.0 < 0.020


def test_unconverged_and_unsupported():
    """An unconverged KSD-reduced solution has no compliance (`ConvergenceError`); buckling is not
    available for KSD-reduced (`UnsupportedStrategyError` naming it)."""
    with pytest.warns(flexmb.ConvergenceWarning):
        sol = flexmb.solve(fourbar(5, displacement=0.1), method="ksd-reduced", max_iter=1)
    assert not sol.converged
    with pytest.raises(flexmb.ConvergenceError, match="compliance of an unconverged"):
        flexmb.compliance(sol, "top")
    with pytest.raises(flexmb.UnsupportedStrategyError, match="buckling need the full FE equilibrium"):
        flexmb.buckling(flexmb.solve(fourbar(5, displacement=0.1), method="ksd-reduced"))
