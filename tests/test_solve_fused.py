"""The fused per-solve paths (issue: a KSD-reduced solve after other work, cold caches) held equal
to the numpy path they replace: the plausibility check's one compiled call
(`flexmb.plausibility_jit`) and KSD-reduced's slimmed compiled stages, on mechanisms no paper
contains (a 2D cross-flexure pivot, a four-bar with two joint values, a rod of circular section)
besides the manipulator (Dwarshuis et al. 2020 Sec. 4.4).
"""

from __future__ import annotations

import warnings

import attrs
import numpy as np
import pytest

import flexmb
from flexmb import jit

pytestmark = pytest.mark.skipif(not jit._AVAILABLE, reason="numba not installed (the numpy path is the only one)")


def _two_kinds(dim):
    """The four-bar with thicker upper flexures: two joint values, two constraint groups."""
    m = flexmb.models.fourbar(2, displacement=0.1, dim=dim)
    thick = attrs.evolve(m.graph.edges["left", "top", "top_left"]["joint"], thickness=1.5e-3)
    for link, name in (("left", "top_left"), ("right", "top_right")):
        m.graph.edges[link, "top", name]["joint"] = thick
    return m


def _rod(dim, force):
    """A cantilevered rod of circular section (1 mm, 50 mm, yield stress 1.5 GPa) pulled and bent at its end."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.05, 0.0, 0.0)[:dim])
    m.add_joint("A", "B", flexmb.LeafSpring(length=0.05, elements=4, section=flexmb.circle(1e-3, 200e9, 76.9e9,
                                                                                    yield_stress=1.5e9)))
    m.apply_force("B", (force, 0.3, 0.2)[:dim])
    return m


def _pivot(deg, dim=2):
    return flexmb.models.cross_flexure_pivot(elements_per_leaf=5, dim=dim, rotation=np.radians(deg))


def _mixed_kinds():
    """A 3D chain of two joint kinds: ground A, a three_x_infinity to link B, a cross-flexure pivot
    to link C; B turned 10 deg and C 25 deg about z (the second joint 15 deg), C pushed."""
    a, c = flexmb.ThreeXInfinity(elements_per_leaf=3), flexmb.CrossFlexure(elements_per_leaf=3)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    b = np.asarray(a.interface_b(3), dtype=float)
    m.add_link("B", position=b)
    m.add_link("C", position=b + np.asarray(c.interface_b(3), dtype=float))
    m.add_joint("A", "B", a, name="three_x")
    m.add_joint("B", "C", c, name="cross", origin=b)
    m.prescribe("B", rotation=[0.0, 0.0, np.radians(10.0)])
    m.prescribe("C", rotation=[0.0, 0.0, np.radians(25.0)])
    m.apply_force("C", [0.5, -0.3, 0.2])
    return m


CHECKED = {  # (mechanism, method, options)
    "pivot 2d 20 deg, ksd-reduced": (lambda: _pivot(20.0), "ksd-reduced", {}),
    # the paper's step control alone wanders to a 6 % peak strain (tests/test_solver.py), beyond STRAIN_LIMIT
    "pivot 2d 55 deg, wandering": (lambda: _pivot(55.0), "conventional", {"max_rotation": None, "step_control": "paper"}),
    "two kinds 2d, ksd-reduced": (lambda: _two_kinds(2), "ksd-reduced", {}),
    "two kinds 3d, ksd-reduced": (lambda: _two_kinds(3), "ksd-reduced", {}),
    "rod 3d, yielding": (lambda: _rod(3, 2e3), "conventional", {}),
    "manipulator joint 45 deg": (lambda: flexmb.models.manipulator("joint", np.radians(45.0)), "ksd-reduced", {}),
}


@pytest.mark.parametrize("case", list(CHECKED))
def test_the_plausibility_check_says_the_same_on_either_path(kernels, case):
    # flexmb.plausibility.check after a solve: the compiled path computes the elements' stresses,
    # peak normal stresses and both argmaxes by compiled kernels; it must warn exactly as the numpy path
    # (flexmb.fe.stress.peak_normal_stress / E, / yield stress) on the same state, and its peak
    # stresses must equal the numpy function's to the last bit (the same kernels in the same order)
    from flexmb.fe.stress import peak_normal_stress, section_table
    from flexmb.plausibility import _plan, check

    build, method, options = CHECKED[case]
    kernels("numba")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = flexmb.solve(build(), method=method, **options)
    assert sol.converged
    said = {}
    for path in ("numpy", "numba"):
        kernels(path)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check(sol)
        said[path] = [str(w.message) for w in caught]
    assert said["numba"] == said["numpy"]
    if case.startswith(("pivot 2d 55", "rod")):
        assert said["numba"], "the case is chosen to warn"
    model = sol.compiled.problem.model
    tab = section_table(model.elements)
    kernel, args = _plan(model, tab)[:2]
    sigma = np.empty(len(tab.E))
    st = sol.state
    ks, ky, strain, over = kernel(model, st, *args, sigma)
    ref = peak_normal_stress(model, st)  # numba on: the compiled assembly's stresses, numpy's formula
    np.testing.assert_array_equal(sigma, ref)
    assert (ks, ky) == (np.argmax(ref / tab.E), np.argmax(ref / tab.yield_stress))
    assert strain == ref[ks] / tab.E[ks] and over == ref[ky] / tab.yield_stress[ky]


def test_a_database_file_put_in_the_user_folder_between_solves_is_used(tmp_path, monkeypatch):
    # the set-up of a KSD solve is kept with the compiled mechanism and checked per solve
    # (ReducedMechanism.current: the folders searched, which file and its state); the check now
    # tests a folder without the file by os.access instead of an lstat raising FileNotFoundError.
    # The user folder (FLEXMB_DATABASE) is searched before the shipped data: a file copied there
    # after a solve must be the one the next solve reads, and one removed again gives the shipped
    # data back; a broken link there is refused, as `template` refuses it. 2D cross-flexure pivot
    # (not a paper case)
    import os
    import shutil

    from flexmb.database import store

    monkeypatch.setenv("FLEXMB_DATABASE", str(tmp_path))
    m = _pivot(10.0)

    def used(sol):
        red = sol.stages["eob"]["near"][0]
        return red, red._templates[0][2][1]

    first_red, first = used(flexmb.solve(m, method="ksd-reduced"))
    assert not first.startswith(str(tmp_path))
    assert used(flexmb.solve(m, method="ksd-reduced"))[0] is first_red  # unchanged: the same set-up
    source = store.locate(next(iter(m.joints.values())), 2)
    shutil.copy(source, tmp_path / source.name)
    red, path = used(flexmb.solve(m, method="ksd-reduced"))
    assert red is not first_red and path == os.path.join(str(tmp_path), source.name)
    (tmp_path / source.name).unlink()
    assert used(flexmb.solve(m, method="ksd-reduced"))[1] == first
    if hasattr(os, "symlink"):
        os.symlink(tmp_path / "nowhere.json", tmp_path / source.name)
        with pytest.raises(flexmb.DatabaseError):
            flexmb.solve(m, method="ksd-reduced")


@pytest.fixture
def tabulated_pivots():
    """The cross-flexure pivots' templates (2D: both thicknesses of the two-kinds four-bar and the
    pivot's; 3D: the mixed chain's) with their condensation tabulated on a coarse grid
    (flexmb.ksd.eob_table.tabulate, degree 5 on 2 deg) attached, so their solves take the
    tabulated path; detached afterwards."""
    from flexmb.ksd.eob_table import Lookup, tabulate
    from flexmb.ksd.reduced import ReducedMechanism

    attached = []
    for m in (_two_kinds(2), _pivot(10.0), _mixed_kinds()):
        for tpl, _, _ in ReducedMechanism(m.compile()).groups:
            if tpl.lookup is None and all(tpl is not t for t, _ in attached):
                attached.append((tpl, tpl.lookup))
                tpl.lookup = Lookup(tpl, tabulate(tpl, {}, step_deg=2.0, degree=5))
    yield
    for tpl, previous in attached:
        tpl.lookup = previous


FUSED = {  # none of them a paper case
    "mixed kinds 3d": _mixed_kinds,
    "pivot 2d": lambda: _pivot(12.0),
    "two kinds 2d": lambda: _two_kinds(2),
    "three_x_infinity 3d at 17 deg, loaded": lambda: flexmb.testing.joint_mechanism(
        flexmb.ThreeXInfinity(elements_per_leaf=3), 3, motion=np.radians(17.0), force=[2.0, -1.0, 0.5]),
}


@pytest.mark.parametrize("case", list(FUSED))
@pytest.mark.slow
def test_the_tabulated_path_equals_the_general_and_the_numpy_path(kernels, tabulated_pivots, case):
    # KSD-reduced (Dwarshuis et al. 2020 Sec. 2, steps 1-4) with every joint tabulated and in range
    # runs the prepared kernels with their outputs allocated inside (flexmb.ksd.reduced.ReducedMechanism.tabulated_plan):
    # the same kernels as the general compiled path, so the same numbers to the last bit; and the
    # numpy path's (step 2 by Lookup.__call__) to 1e-12, as tests/test_kernels.py holds the stages

    m = FUSED[case]()
    kernels("numba")
    fast = flexmb.solve(m, method="ksd-reduced")
    red = fast.stages["eob"]["near"][0]
    assert red.tabulated_plan() is not None and fast.stages["eob"]["tabulated"] == len(red.joint_names)
    red._tabulated = False  # the general compiled path for the same set-up
    general = flexmb.solve(m, method="ksd-reduced")
    del red._tabulated
    kernels("numpy")
    ref = flexmb.solve(m, method="ksd-reduced")
    assert fast.converged and general.converged and ref.converged
    assert fast.iterations == general.iterations == ref.iterations
    for a, b in ((fast.state.positions, general.state.positions), (fast.state.rotations, general.state.rotations),
                 (fast.residual, general.residual), (fast.residual_history, general.residual_history)):
        np.testing.assert_array_equal(a, b)
    for key in ("kinematics", "eob", "reduced"):
        assert fast.stages[key].keys() == general.stages[key].keys()
    np.testing.assert_array_equal(fast.stages["kinematics"]["theta"], general.stages["kinematics"]["theta"])
    assert fast.stages["kinematics"]["history"] == general.stages["kinematics"]["history"]
    assert fast.stages["reduced"]["history"] == general.stages["reduced"]["history"]
    for (_, ea, Ka, Fa), (_, eb, Kb, Fb) in [(fast.stages["eob"]["near"], general.stages["eob"]["near"])]:
        np.testing.assert_array_equal(Ka, Kb)
        np.testing.assert_array_equal(Fa, Fb)
        for ga, gb in zip(ea, eb):
            for a, b in zip(ga, gb):
                np.testing.assert_array_equal(a, b)
    scale = np.abs(ref.state.positions).max()
    assert np.abs(fast.state.positions - ref.state.positions).max() <= 1e-12 * scale
    assert np.abs(fast.state.rotations - ref.state.rotations).max() <= 1e-12
    assert not fast.state.positions.flags.writeable or not np.shares_memory(fast.state.positions, general.state.positions)
