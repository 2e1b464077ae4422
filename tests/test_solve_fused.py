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


@pytest.fixture
def kernels():
    previous = jit.enabled()
    yield jit.use
    jit.use("auto" if previous else "numpy")


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
    # peak normal stresses and both argmaxes in one call; it must warn exactly as the numpy path
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
    kernel, args, _ = _plan(model, tab)
    sigma = np.empty(len(tab.E))
    st = sol.state
    ks, ky, strain, over = kernel(np.ascontiguousarray(st.positions), np.ascontiguousarray(st.rotations), *args, sigma)
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
