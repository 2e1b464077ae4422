"""What a user reads of a solution (modes, their shapes, compliance) stays the answer of that
solution: after the mechanism is changed and solved again, after pickling, whatever was solved
before on the same mechanism. Reference: the same numbers from a never-solved deep copy."""

import os
import pickle

import numpy as np
import pytest

import flexmb
from flexmb.models import manipulator


@pytest.mark.slow
def test_modes_and_solutions_pickle_after_a_conventional_solve_of_the_same_mechanism():
    """The manipulator (Dwarshuis et al. 2020, Sec. 4.4, joint case at 20 deg) solved with the
    conventional method (its tangent factorised by qdldl, whose factorisation does not pickle),
    then with KSD-reduced (sharing the compiled model): both solutions and their `Modes` pickle,
    the copies giving the same frequencies, shapes and compliance as the originals."""
    m = manipulator("joint", np.radians(20))
    for method in ("conventional", "ksd-reduced"):
        sol = flexmb.solve(m, method=method, raise_on_failure=True)
        result = flexmb.modes(sol, n_modes=4)
        copied = pickle.loads(pickle.dumps(result))
        np.testing.assert_array_equal(copied.frequencies, result.frequencies)
        np.testing.assert_array_equal(copied.shapes, result.shapes)
        again = pickle.loads(pickle.dumps(sol))
        np.testing.assert_allclose(flexmb.compliance(again, "link3"), flexmb.compliance(sol, "link3"), rtol=1e-12)
        np.testing.assert_allclose(flexmb.modes(again, n_modes=4).frequencies, result.frequencies, rtol=1e-9)


def test_compliance_with_a_free_rigid_body_motion_is_refused_on_the_sparse_path_too():
    """``held="floating"`` holds nothing, not even the ground: the manipulator (Sec. 4.4, 20 deg)
    can move as a rigid body, its tangent is singular and no compliance exists. The KSD-reduced
    tangent (dense, LAPACK's condition estimate) refuses it; the conventional solution's 384
    free DOFs go to the sparse solver, whose answer had a backward error of 1e-16 (the
    normwise test cannot see a singular K) but solved K x = e to a relative residual of 23: it
    returned 2.8e7 (compiled kernels) or 2.4e9 (numpy) m/N as compliance. Both now raise
    `ModelError`; held="fixed" (the ground held, the joints' turns free: closed form, the
    joints' rotational stiffness) still answers, the same with both kernels to 1e-6."""
    m = manipulator("joint", np.radians(20))
    for method in ("ksd-reduced", "conventional"):
        sol = flexmb.solve(m, method=method, raise_on_failure=True)
        with pytest.raises(flexmb.ModelError, match="singular"):
            flexmb.compliance(sol, "link3", held="floating")
        assert np.isfinite(flexmb.compliance(sol, "link3", held="fixed")).all()


def test_a_replaced_os_environ_names_the_user_folder_the_next_solve_reads(tmp_path):
    """``unittest.mock.patch("os.environ", {...})`` replaces the environment mapping (it does
    not edit the old one) with ``FLEXMB_DATABASE`` naming a folder holding the joint's file (a
    copy of the shipped one, bit for bit: the same fits, another file). The kept KSD set-up of a
    mechanism solved before must notice it, as `flexmb.database.store.locate` does, and read
    the file there: the set-up check read the variables from the old mapping's storage, kept the
    shipped file and its set-up. 2D Table 1 cross-flexure pivot (2 el./leaf) at 12 deg."""
    import shutil
    from unittest import mock

    from flexmb.database import store
    from flexmb.models import cross_flexure_pivot

    m = cross_flexure_pivot(2, dim=2, rotation=np.radians(12))
    first = flexmb.solve(m, method="ksd-reduced", raise_on_failure=True)
    source = store.locate(next(iter(m.joints.values())), 2)
    shutil.copy(source, tmp_path / source.name)
    with mock.patch("os.environ", dict(os.environ, FLEXMB_DATABASE=str(tmp_path))):
        assert store.locate(next(iter(m.joints.values())), 2) == tmp_path / source.name
        sol = flexmb.solve(m, method="ksd-reduced", raise_on_failure=True)
        red = sol.stages["eob"]["near"][0]
        assert red._templates[0][2][1] == os.path.join(str(tmp_path), source.name)
        np.testing.assert_array_equal(sol.node_positions(), first.node_positions())  # the same fits
    again = flexmb.solve(m, method="ksd-reduced", raise_on_failure=True)  # the environment back
    assert again.stages["eob"]["near"][0]._templates[0][2][1] == os.fspath(source)


def test_sparse_buckling_and_modes_repeat_exactly():
    """ARPACK starts from a fixed vector (`flexmb.modal.start_vector`): repeated `buckling` and
    `modes` of one solution on the sparse path give the same numbers. Reference: the first call.
    (With ARPACK's random start the conventional manipulator's first multiplier with
    held="fixed" scattered 415.27-415.36 between calls: four multipliers within 2e-5 of each other,
    split into complex pairs by the dead moments' non-symmetric tangent part.)"""
    import flexmb.modal as modal

    sol = flexmb.solve(manipulator("joint", np.radians(30)))
    assert sol.compiled.problem.model.n_dofs - 12 > modal.DENSE_BELOW  # the sparse (ARPACK) path, two links fixed at most
    first = flexmb.buckling(sol, n_buckling=2, held="fixed")
    f = flexmb.modes(sol, n_modes=6, held="fixed").frequencies
    for _ in range(2):
        np.testing.assert_array_equal(flexmb.buckling(sol, n_buckling=2, held="fixed"), first)
        np.testing.assert_array_equal(flexmb.modes(sol, n_modes=6, held="fixed").frequencies, f)
