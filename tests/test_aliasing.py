"""Copy on input, copy on output (issue 20, class 1): an array the user passes to flexmb or gets
back from it stays the user's; changing it later never changes a mechanism, a result or a table."""

import numpy as np
import pytest

import flexmb
from flexmb import models


def test_a_reused_force_array_gives_each_load_its_own_value():
    """The issue's reproducer: three loads written through one array were three loads of -3 N."""
    m = models.cantilever(dim=2)
    b = np.zeros(2)
    for f in (-1.0, -2.0, -3.0):
        b[1] = f
        m.apply_force("tip", b)
    assert [load[2][1] for load in m.loads] == [-1.0, -2.0, -3.0]
    b *= 100
    b[0] = np.nan  # NaN written later cannot bypass the validation
    assert [load[2][1] for load in m.loads] == [-1.0, -2.0, -3.0]


def test_a_changed_force_array_does_not_change_the_next_solve():
    m = models.cantilever(dim=2)
    b = np.array([0.0, -1.0])
    m.apply_force("tip", b)
    before = flexmb.solve(m).reaction("ground")
    b *= 100
    after = flexmb.solve(m).reaction("ground")
    np.testing.assert_array_equal(after, before)  # the same mechanism, bit for bit


def test_link_joint_point_and_prescribed_arrays_are_copies():
    m = flexmb.Mechanism(dim=3)
    pos, org, rot = np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.1])
    m.add_link("A", pos, fixed=True)
    tip = np.array([0.1, 0.0, 0.0])
    m.add_link("B", tip)
    m.add_joint("A", "B", flexmb.LeafSpring(length=0.1, width=0.02, thickness=1e-3, E=2e11, G=7.7e10, elements=2),
                origin=org)
    m.prescribe("B", rotation=rot)
    point = np.array([0.1, 0.01, 0.0])
    m.add_point("B", "P", point)
    for a in (pos, org, rot, tip, point):
        a[0] = np.nan
    assert m.link("A").position.tolist() == [0.0, 0.0, 0.0]
    assert m.link("B").position.tolist() == [0.1, 0.0, 0.0]
    assert m.graph.edges["A", "B", "leaf_spring_0"]["placement"].origin.tolist() == [0.0, 0.0, 0.0]
    assert m.points["P"][1].tolist() == pytest.approx([0.0, 0.01, 0.0])
    got = m.prescribed("B")
    assert got["rotation"].tolist() == [0.0, 0.0, 0.1]
    with pytest.raises(ValueError, match="read-only"):  # the issue: prescribed() returned the live array
        got["rotation"][2] = 5.0
    with pytest.raises(ValueError, match="read-only"):  # nor can a link's arrays be changed in place
        m.link("B").position[0] = 1.0
    assert m.prescribed("B")["rotation"].tolist() == [0.0, 0.0, 0.1]


def test_sweep_values_and_table_columns_are_copies():
    m = models.cross_flexure_pivot(elements_per_leaf=2, dim=2)
    m.prescribe("B", rotation=0.0)
    angles = np.array([0.1, 0.2])
    result = flexmb.sweep(m, angles, motion=("B", "rotation"))
    angles[:] = 7.0  # the issue: SweepResult.values aliased the input
    np.testing.assert_array_equal(result.values, [0.1, 0.2])
    result.values[:] = 9.0
    np.testing.assert_array_equal(result.values, [0.1, 0.2])
    col = np.array([1.0, 2.0])
    table = flexmb.Table({"a": col})
    col[0] = 5.0
    table["a"][1] = 6.0
    np.testing.assert_array_equal(table["a"], [1.0, 2.0])


def test_solution_arrays_cannot_be_changed_through_what_it_returns():
    sol = flexmb.solve(models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.1))
    before = sol.reaction("B").copy(), sol.residual_history.copy(), sol.node_positions().copy()
    sol.reaction("B")[:] = 0.0
    sol.pose("B")[0][:] = 0.0
    sol.displacement("B")[:] = 0.0
    sol.rotation_vector("B")[:] = 0.0
    sol.node_positions()[:] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        sol.residual_history[0] = 0.0
    np.testing.assert_array_equal(sol.reaction("B"), before[0])
    np.testing.assert_array_equal(sol.residual_history, before[1])
    np.testing.assert_array_equal(sol.node_positions(), before[2])


def test_path_arrays_are_copies():
    # Path.stable & co. were plain attributes: writing into one changed the path for everyone after
    m = models.cantilever(dim=2)
    m.apply_force("tip", [0.0, -1.0])
    path = flexmb.trace(m, steps=3, progress=False)
    before = {k: getattr(path, k).copy() for k in ("stable", "load_factor", "negative_eigenvalues", "arc_length")}
    for k, a in before.items():
        got = getattr(path, k)
        got[...] = ~got if got.dtype == bool else 7
        np.testing.assert_array_equal(getattr(path, k), a)
    np.testing.assert_array_equal(path.table()["stable"], before["stable"])


def test_mode_arrays_are_read_only():
    sol = flexmb.solve(models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.1))
    md = flexmb.modes(sol, n_modes=2)
    f = md.frequencies.copy()
    for name in ("frequencies", "eigenvalues", "shapes", "held"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(md, name).flat[0] = 0
    with pytest.raises(ValueError, match="read-only"):
        md.link_shapes["B"][0, 0] = 0.0
    assert md.held.dtype.kind == "i"  # DOF indices stay integers
    np.testing.assert_array_equal(flexmb.modes(sol, n_modes=2).frequencies, f)
