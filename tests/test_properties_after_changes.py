"""What a user reads of a solution (modes, their shapes, compliance) stays the answer of that
solution: after the mechanism is changed and solved again, after pickling, whatever was solved
before on the same mechanism. Reference: the same numbers from a never-solved deep copy."""

import pickle

import numpy as np
import pytest

import flexmb
from flexmb.models import manipulator


def test_modes_and_solutions_pickle_after_a_conventional_solve_of_the_same_mechanism():
    """The manipulator (Dwarshuis et al. 2020, Sec. 4.4, joint case at 20 deg) solved with the
    conventional method (its tangent factorised by qdldl, whose factorisation does not pickle),
    then with KSD-reduced (sharing the compiled model): both solutions and their `Modes` pickle,
    the copies giving the same frequencies, shapes and compliance as the originals."""
    m = manipulator("joint", np.radians(20))
    for method in ("conventional", "ksd-reduced"):
        sol = flexmb.solve(m, method=method, raise_on_failure=True)
        result = flexmb.modes(sol, n=4)
        copied = pickle.loads(pickle.dumps(result))
        np.testing.assert_array_equal(copied.frequencies, result.frequencies)
        np.testing.assert_array_equal(copied.shapes, result.shapes)
        again = pickle.loads(pickle.dumps(sol))
        np.testing.assert_allclose(flexmb.compliance(again, "link3"), flexmb.compliance(sol, "link3"), rtol=1e-12)
        np.testing.assert_allclose(flexmb.modes(again, n=4).frequencies, result.frequencies, rtol=1e-9)


def test_compliance_with_a_free_rigid_body_motion_is_refused_on_the_sparse_path_too():
    """``held="floating"`` holds nothing, not even the ground: the manipulator (Sec. 4.4, 20 deg)
    can move as a rigid body, its tangent is singular and no compliance exists. The KSD-reduced
    tangent (dense, LAPACK's condition estimate) refuses it; the conventional solution's 384
    free DOFs go to the sparse solver, whose answer had a backward error of 1e-16 (the
    normwise test cannot see a singular K) but solved K x = e to a relative residual of 23: it
    returned 2.8e7 (compiled kernels) or 2.4e9 (numpy) m/N as compliance. Both now raise
    `ModelError`; held="none" (the ground held, the joints' turns free: closed form, the
    joints' rotational stiffness) still answers, the same with both kernels to 1e-6."""
    m = manipulator("joint", np.radians(20))
    for method in ("ksd-reduced", "conventional"):
        sol = flexmb.solve(m, method=method, raise_on_failure=True)
        with pytest.raises(flexmb.ModelError, match="singular"):
            flexmb.compliance(sol, "link3", held="floating")
        assert np.isfinite(flexmb.compliance(sol, "link3", held="none")).all()
