"""What `flexmb.modes` and `flexmb.compliance` of a KSD-reduced solution share and the small
eigen-solvers they call directly (issue 22: KSD-reduced properties per configuration): the shared
tangent is the one a fresh solution gives and is handed out as a copy; the direct LAPACK calls
return what `numpy.linalg.eigh` / `scipy.linalg.eigh` return."""

import numpy as np
import pytest
import scipy.linalg as sla

import flexmb
from flexmb.ksd.joint_mass import _lowest
from flexmb.ksd.reduced_model import reduced_tangent
from flexmb.modal import _highest_pairs
from flexmb.models import manipulator


def test_compliance_after_modes_is_the_compliance_of_a_fresh_solution():
    """The tangent built for `modes` and kept per solution gives `compliance` the same 6x6 as a
    solution whose compliance is asked first (the manipulator's joint case at -20 deg, a position
    the paper's table has but no other test; the end link at its named-point-free reference)."""
    m = manipulator("joint", np.radians(-20.0))
    first = flexmb.solve(m, method="ksd-reduced")
    flexmb.modes(first, n_modes=6)
    after_modes = flexmb.compliance(first, "link3")
    alone = flexmb.compliance(flexmb.solve(m, method="ksd-reduced"), "link3")
    np.testing.assert_allclose(after_modes, alone, rtol=1e-12, atol=1e-12 * np.abs(alone).max())


def test_the_kept_tangent_is_handed_out_as_a_copy():
    """Writing into the returned tangent changes neither the next call's nor `compliance`."""
    sol = flexmb.solve(manipulator("joint", np.radians(15.0)), method="ksd-reduced")
    before = flexmb.compliance(sol, "link3")
    K, _ = reduced_tangent(sol)
    reference = K.copy()
    K[:] = 0.0
    np.testing.assert_array_equal(reduced_tangent(sol)[0], reference)
    np.testing.assert_array_equal(flexmb.compliance(sol, "link3"), before)


def test_lowest_pairs_are_numpys_lowest_eigenpairs():
    """`_lowest` (LAPACK dsyevr, wanted pairs only) against `numpy.linalg.eigh` on stacked random
    symmetric matrices (2, 3, 20, 20) with a spread spectrum: eigenvalues to 1e-12 relative,
    vectors up to sign (clustered-free spectrum)."""
    rng = np.random.default_rng(7)
    Q = np.linalg.qr(rng.standard_normal((2, 3, 20, 20)))[0]
    lam = np.sort(rng.uniform(1.0, 1e6, (2, 3, 20)), axis=-1)
    S = Q @ (lam[..., None] * np.swapaxes(Q, -1, -2))
    w, V = _lowest(S, 5)
    w0, V0 = np.linalg.eigh(S)
    assert w.shape == (2, 3, 5) and V.shape == (2, 3, 20, 5)
    np.testing.assert_allclose(w, w0[..., :5], rtol=1e-12)
    np.testing.assert_allclose(np.abs(np.einsum("...ik,...ik->...k", V, V0[..., :5])), 1.0, rtol=1e-9)


def test_highest_pairs_are_scipys_subset():
    """`_highest_pairs` (LAPACK dsygvx called directly) returns bit for bit what
    `scipy.linalg.eigh(A, B, subset_by_index=...)` returns (the routine it calls), and raises
    `numpy.linalg.LinAlgError` for an indefinite B as eigh does."""
    rng = np.random.default_rng(3)
    A = rng.standard_normal((12, 12))
    A = A @ A.T
    B = rng.standard_normal((12, 12))
    B = B @ B.T + 12 * np.eye(12)
    mu, vec = _highest_pairs(A, B, 4)
    mu0, vec0 = sla.eigh(A, B, subset_by_index=[8, 11])
    np.testing.assert_array_equal(mu, mu0)
    np.testing.assert_array_equal(vec, vec0)
    with pytest.raises(np.linalg.LinAlgError):
        _highest_pairs(A, -B, 4)
