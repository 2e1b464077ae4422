"""The compiled KSD-reduced path (steps 1-4 in numba kernels, flexmb.ksd.reduced_jit) as a user
meets it, against the numpy path (the reference): what a solve reports, what survives a change
between solves, and what it refuses. Cases no paper contains: motions far beyond a table's
grid, many kinematic iterations, a misspelt database folder.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb
from flexmb import jit
from flexmb.ksd.kinematics import solve_kinematics
from flexmb.ksd.reduced import ReducedMechanism

pytestmark = pytest.mark.skipif(not jit._AVAILABLE, reason="numba not installed (the numpy path is the only one)")


def test_step_1_reports_every_iteration_however_many(kernels):
    # KSD step 1 (Dwarshuis et al. 2020 Sec. 2.2) of the 2D cross-flexure pivot turned 300 rad
    # (beyond any trained range: step 1 alone, which follows the rotation in quarter turns) with
    # two Newton iterations allowed per step: 191 iterations, more than the 64 x max_iter = 128
    # residuals the compiled kernel's history held. Reference: the numpy loop's history, which
    # keeps them all; info["history"] has one residual per counted iteration on both paths.
    red = ReducedMechanism(flexmb.models.cross_flexure_pivot(2, dim=2, rotation=300.0).compile())
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        out[path] = solve_kinematics(red, max_iter=2)[3]
    ref, got = out["numpy"], out["numba"]
    assert ref["iterations"] > 128 and len(ref["history"]) == ref["iterations"]
    assert got["iterations"] == ref["iterations"] and len(got["history"]) == got["iterations"]
    np.testing.assert_allclose(got["history"], ref["history"], rtol=1e-9, atol=1e-14)


@pytest.mark.parametrize("path", ["numpy", "numba"])
def test_a_table_that_does_not_fit_the_joints_mesh_is_refused(kernels, tmp_path, path):
    # a database file whose EOB table (flexmb.database.eob_format) declares one internal node
    # fewer than the joint's mesh has (P0's last row dropped, its samples and checksums made
    # consistent, as a buggy or foreign trainer might write it). The tabulated quantities' sizes
    # follow from the mesh (Eqs. 2.4-2.6: K_T nd x nd, recovery n_i nd x (nd + 1), P0 n_i x dim);
    # numpy broadcast the short P0 onto every internal node and the compiled lookup read past
    # the samples' rows: converged=True with internal nodes 46 % off. Must be refused, naming
    # the table's layout and the mesh's.
    import attrs

    from flexmb.database import store
    from flexmb.database.eob_format import EOBTable, plain_parameters
    from flexmb.ksd.eob_table import tabulate
    from flexmb.ksd.reduced import template

    kernels(path)
    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=0.5)
    m.apply_force("B", [0.5, -0.3])
    joint = next(iter(m.joints.values()))
    source = store.locate(joint, 2)
    tpl = template(joint, 2)
    table = tabulate(tpl, plain_parameters(joint.describe()), step_deg=5.0, degree=3)
    *head, (name, rows, cols) = table.layout
    assert name == "P0" and rows == tpl.n_nodes - 2 > 0
    short = EOBTable(table.parameters, table.theta, table.degree, (*head, (name, rows - 1, cols)),
                     np.ascontiguousarray(table.values[:, :-cols]))
    store.save(attrs.evolve(store.load(source), eob_table=short), tmp_path / source.name)
    with pytest.raises(flexmb.DatabaseError, match=r"joint 'cross_flexure'.*EOB table.*P0.*\(1, 2\).*\(2, 2\)"):
        flexmb.solve(m, method="ksd-reduced", database=tmp_path)
    assert flexmb.solve(m, method="ksd-reduced").converged  # the shipped data (no table) still serve


@pytest.mark.parametrize("excess", [2e-9, 1e-6])
def test_a_rotation_just_beyond_the_range_is_refused_saying_by_how_much(kernels, excess):
    # three_x_infinity's shipped database and EOB table span +-45 deg (Dwarshuis et al. 2020
    # Sec. 4.4); step 1's roundoff is allowed 1e-9 rad (flexmb.ksd.eob_table.SLACK). Just beyond,
    # the refusal printed "turns it to 45.00 deg, outside its trained range [-45.0, 45.0] deg":
    # it must say how far outside, in rad
    joint = flexmb.ThreeXInfinity(elements_per_leaf=3)
    for sign in (1.0, -1.0):
        m = flexmb.testing.joint_mechanism(joint, 3, motion=sign * (np.radians(45.0) + excess))
        with pytest.raises(flexmb.DatabaseError, match=r"45.00 deg, (\S+) rad outside its trained range") as err:
            flexmb.solve(m, method="ksd-reduced")
        stated = float(err.value.args[0].split(" deg, ")[1].split(" rad")[0])
        assert stated == pytest.approx(excess, rel=0.05)  # two digits, of step 1's converged angle
    m = flexmb.testing.joint_mechanism(joint, 3, motion=np.radians(45.0) + 5e-10)  # within the slack: solved
    sol = flexmb.solve(m, method="ksd-reduced")
    assert sol.converged and sol.stages["eob"]["tabulated"] == 1


def test_a_database_folder_that_does_not_exist_is_refused(tmp_path):
    # database=FOLDER is searched before the user folder and the shipped data
    # (flexmb.database.store.search_path): a misspelt folder was passed over silently and the
    # shipped data solved instead of the user's (own range, own EOB table)
    m = flexmb.models.cross_flexure_pivot(2, dim=2, rotation=0.3)
    missing = tmp_path / "my_databse"
    for method in ("ksd-reduced", "ksd-full"):
        with pytest.raises(flexmb.ParameterError, match=r"database=.*my_databse.* is not a folder"):
            flexmb.solve(m, method=method, database=missing)
    assert flexmb.solve(m, method="ksd-reduced", database=tmp_path).converged  # an empty folder: searched, passed


@pytest.mark.parametrize("path", ["numpy", "numba"])
def test_a_failed_solve_says_why_a_tolerance_below_roundoff(kernels, path):
    # the manipulator's location case at 40 deg (Dwarshuis et al. 2020 Sec. 4.4; not a figure's
    # value) converges with the defaults. A kinematic_tol below the constraints' roundoff
    # (~1e-15, lengths over D0 and rad) stopped step 1 with "the database constraints cannot
    # reach it"; a tol below step 3's roundoff (~5e-12 N) with "a singular or diverging reduced
    # tangent". Each message must name the residual reached and the tolerance instead
    kernels(path)
    m = flexmb.models.manipulator("location", np.radians(40.0))
    assert flexmb.solve(m, method="ksd-reduced").converged
    with pytest.warns(flexmb.ConvergenceWarning):
        sol = flexmb.solve(m, method="ksd-reduced", kinematic_tol=1e-17)
    assert not sol.converged and "roundoff, above kinematic_tol 1e-17" in sol.message
    assert "cannot reach" not in sol.message
    with pytest.warns(flexmb.ConvergenceWarning):
        sol = flexmb.solve(m, method="ksd-reduced", tol=1e-14)
    assert not sol.converged and "in max_iter=20 iterations" in sol.message and "tol 1e-14" in sol.message
    assert "singular or diverging" not in sol.message
    history = sol.stages["reduced"]["history"]
    assert len(history) == 20 and max(history[4:]) < 1e-9  # stalled at roundoff after the fourth


def _arrays(sol):
    """Every array a KSD-reduced Solution hands out, stages included (step 2's kept lookup)."""
    _, eobs, K, Fh = sol.stages["eob"]["near"]
    kin = sol.stages["kinematics"]
    return [sol.state.positions, sol.state.rotations, sol.residual, sol.residual_history, kin["theta"], kin["p_hat"],
            K, Fh] + [a for group in eobs for a in group]


def test_consecutive_compiled_solves_share_no_arrays(kernels):
    # the compiled path keeps its set-up (frames, kernels' inputs, the table's spline) with the
    # compiled mechanism; what a solve returns must be its own: the manipulator's location case
    # (Sec. 4.4) at -40 deg solved twice, the first solution's arrays overwritten, a third solve
    # equal to the second to the last bit
    kernels("numba")
    m = flexmb.models.manipulator("location", np.radians(-40.0))
    first, second = (flexmb.solve(m, method="ksd-reduced") for _ in range(2))
    for a, b in zip(_arrays(first), _arrays(second)):
        assert not np.shares_memory(a, b)
    for a in _arrays(first):
        if a.flags.writeable:  # the residual and its history are read-only
            a[...] = 0.0
    third = flexmb.solve(m, method="ksd-reduced")
    for a, b in zip(_arrays(second), _arrays(third)):
        assert np.array_equal(a, b)


def test_threads_solving_on_the_compiled_path_agree_with_serial_solves(kernels):
    # four threads, two on one mechanism object, solving the manipulator (both cases, Sec. 4.4)
    # and a planar four-bar (Sec. 4.3) on the compiled path: every solve equals the serial one
    # to the last bit
    import threading

    kernels("numba")
    mechanisms = [flexmb.models.manipulator("joint", np.radians(30.0)), flexmb.models.manipulator("location", -0.6),
                  flexmb.models.fourbar(2, displacement=0.1, moment=0.5, dim=2)]
    reference = [flexmb.solve(m, method="ksd-reduced").node_positions() for m in mechanisms]
    wrong = []

    def run(k):
        for _ in range(15):
            sol = flexmb.solve(mechanisms[k], method="ksd-reduced")
            if not (sol.converged and np.array_equal(sol.node_positions(), reference[k])):
                wrong.append(k)

    threads = [threading.Thread(target=run, args=(k,)) for k in (0, 1, 2, 0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == []
