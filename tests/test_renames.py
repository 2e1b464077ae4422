"""The names renamed in flexmb 0.2 (CHANGELOG.md): each old name still works for one release,
warns (FutureWarning naming the new name) and gives what the new name gives; the new names do
not warn."""

from __future__ import annotations

import functools
import importlib
import pickle
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import models


@pytest.fixture(scope="module")
def pivot():
    """The Table 1 cross-flexure pivot (Wittrick's pivot, Dwarshuis et al. 2020) turned, converged."""
    return flexmb.solve(models.cross_flexure_pivot(), raise_on_failure=True)


def _new_only(call):
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        warnings.simplefilter("error", DeprecationWarning)
        return call()


def _old(call, new_name: str):
    with pytest.warns(FutureWarning, match=re.escape(new_name)) as record:
        out = call()
    assert all(w.filename == __file__ for w in record if issubclass(w.category, FutureWarning)), \
        "the warning points at the caller's line, not inside flexmb"
    return out


def test_modes_count_is_n_modes(pivot):
    new = _new_only(lambda: flexmb.modes(pivot, n_modes=3))
    old = _old(lambda: flexmb.modes(pivot, n=3), "n_modes=")
    np.testing.assert_array_equal(old.frequencies, new.frequencies)
    assert len(new.frequencies) == 3


def test_buckling_count_is_n_buckling(pivot):
    new = _new_only(lambda: flexmb.buckling(pivot, n_buckling=2))
    old = _old(lambda: flexmb.buckling(pivot, n=2), "n_buckling=")
    np.testing.assert_array_equal(old, new)


def test_state_space_count_is_n_modes(pivot):
    io = ([("force", "B", "rz")], [("displacement", "B", "rz")])
    new = _new_only(lambda: flexmb.state_space(pivot, *io, n_modes=2))
    old = _old(lambda: flexmb.state_space(pivot, *io, n=2), "n_modes=")
    np.testing.assert_array_equal(old.A, new.A)
    assert new.A.shape == (4, 4)


def test_old_and_new_count_together_are_refused(pivot):
    with pytest.raises(flexmb.ParameterError, match="give n_modes= only"):
        flexmb.modes(pivot, n=3, n_modes=4)


def test_held_fixed_is_the_old_none(pivot):
    """``held="fixed"`` holds the fixed links only (the turn is free: its mode is the first)."""
    new = _new_only(lambda: flexmb.modes(pivot, n_modes=2, held="fixed"))
    old = _old(lambda: flexmb.modes(pivot, n_modes=2, held="none"), "held='fixed'")
    np.testing.assert_array_equal(old.frequencies, new.frequencies)
    held = _new_only(lambda: flexmb.modes(pivot, n_modes=2)).frequencies
    assert new.frequencies[0] < held[0]  # the released turn is the softest motion
    C_new = _new_only(lambda: flexmb.compliance(pivot, "B", held="fixed"))
    C_old = _old(lambda: flexmb.compliance(pivot, "B", held="none"), "held='fixed'")
    np.testing.assert_array_equal(C_old, C_new)
    with pytest.raises(flexmb.ParameterError, match="'prescribed', 'fixed', 'floating'"):
        flexmb.modes(pivot, held="nothing")


def test_equilibrium_path_is_the_old_path():
    from flexmb.path import EquilibriumPath

    assert _new_only(lambda: flexmb.EquilibriumPath) is EquilibriumPath
    assert _old(lambda: flexmb.Path, "flexmb.path.EquilibriumPath") is EquilibriumPath
    assert _old(lambda: importlib.import_module("flexmb.path").Path, "EquilibriumPath") is EquilibriumPath
    assert "Path" not in flexmb.__all__ and "EquilibriumPath" in flexmb.__all__


def test_joint_characteristics_is_the_old_analysis():
    from flexmb import joint_characteristics as new

    module = importlib.import_module("flexmb.analysis")
    for old_name, new_name in (("joint_stiffness", "joint_stiffness"), ("support_ratios", "support_ratios"),
                               ("joint_properties", "joint_characteristics")):
        assert _old(lambda name=old_name: getattr(module, name), f"flexmb.joint_characteristics.{new_name}") \
            is getattr(new, new_name)
    assert _old(lambda: new.joint_properties, "joint_characteristics") is new.joint_characteristics
    with pytest.raises(AttributeError):
        module.no_such_name  # noqa: B018
    # a study's design function pickles under its new name (process pools)
    design = functools.partial(new.joint_characteristics, "cross_flexure", rotation=0.1)
    assert pickle.loads(pickle.dumps(design)).func is new.joint_characteristics


def test_from_import_of_an_old_name_warns():
    with pytest.warns(FutureWarning, match="flexmb.joint_characteristics.support_ratios"):
        from flexmb.analysis import support_ratios  # noqa: F401
    with pytest.warns(FutureWarning, match="flexmb.sections.section_values"):
        from flexmb.sections import properties  # noqa: F401


def test_ksd_reduced_model_is_the_old_ksd_properties():
    from flexmb.ksd import reduced_model, reduced_model_jit

    old = importlib.import_module("flexmb.ksd.properties")
    assert _old(lambda: old.reduced_tangent, "flexmb.ksd.reduced_model.reduced_tangent") \
        is reduced_model.reduced_tangent
    old_jit = importlib.import_module("flexmb.ksd.properties_jit")
    assert _old(lambda: old_jit.joint_maps, "flexmb.ksd.reduced_model_jit.joint_maps") is reduced_model_jit.joint_maps


def test_section_values_is_the_old_sections_properties():
    from flexmb import sections

    secs = [sections.rectangle(1e-3, 2e-3, E=2e11, nu=0.3), sections.rectangle(2e-3, 2e-3, E=7e10, nu=0.33)]
    new = _new_only(lambda: sections.section_values(secs, ("E", "A")))
    old = _old(lambda: sections.properties, "flexmb.sections.section_values")(secs, ("E", "A"))
    np.testing.assert_array_equal(old, new)
    np.testing.assert_allclose(new, [[2e11, 7e10], [2e-6, 4e-6]], rtol=1e-15)  # E as given, A = b h


def test_the_changelog_names_every_rename():
    text = (Path(__file__).resolve().parents[1] / "CHANGELOG.md").read_text(encoding="utf-8")
    for old, new in [("flexmb.Path", "flexmb.EquilibriumPath"), ("modes(solution, n=6)", "modes(solution, n_modes=6)"),
                     ("buckling(solution, n=1)", "buckling(solution, n_buckling=1)"),
                     ("state_space(..., n=6)", "state_space(..., n_modes=6)"), ('held="none"', 'held="fixed"'),
                     ("flexmb.analysis", "flexmb.joint_characteristics"),
                     ("flexmb.analysis.joint_properties", "flexmb.joint_characteristics.joint_characteristics"),
                     ("flexmb.ksd.properties", "flexmb.ksd.reduced_model"),
                     ("flexmb.ksd.properties_jit", "flexmb.ksd.reduced_model_jit"),
                     ("flexmb.sections.properties(sections, names)", "flexmb.sections.section_values(sections, names)")]:
        assert f"{old}`" in text and f"{new}`" in text, (old, new)  # the end of a `code` span
