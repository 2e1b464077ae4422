"""Specification of `flexmb.registry`: joint plugins found through the ``flexmb.joints`` entry points.

The pattern is xarray's ``tests/test_plugins.py``: fabricated
``importlib.metadata.EntryPoint`` objects pointing at `tests.dummy_plugins` are
patched into ``flexmb.registry.entry_points``; the registry's ``lru_cache`` is
cleared (`flexmb.registry.refresh`) before and after, so the real entry points
come back for the other tests. Session registrations (`register_joint`) are
undone after every test.

Where the expectations come from:

* ``cross_flexure`` and ``leaf_spring`` are the entry points that flexmb's own
  ``pyproject.toml`` declares in ``[project.entry-points."flexmb.joints"]``;
* warnings, skipping and duplicates: the registry contract of STYLE.md Sec. 3.5
  ("warns with RuntimeWarning on duplicate names and on load failures, and does
  not crash"; "when a loaded object does not pass isinstance(obj, Joint), skip it
  with a warning"; test: "a broken plugin produces one warning, and a duplicate
  is resolved with a warning") and the `_installed` docstring (the first entry
  point of a name is kept);
* ``clobber``: fsspec's ``register_implementation(..., clobber=...)``, cited by
  STYLE.md Sec. 3.5, and `register_joint`'s signature;
* that refusals are `flexmb.FlexmbError` s: DESIGN.md ("``flexmb.FlexmbError``
  (root of every error flexmb raises on purpose)");
* the cantilever deflection ``P L^3 / (3 E I)``: linear Euler-Bernoulli beam
  theory (the dummy plugin switches shear deformation off).
"""

from __future__ import annotations

import sys
import warnings
from importlib.metadata import EntryPoint

import numpy as np
import pytest

import flexmb
from flexmb import registry
from tests.dummy_plugins import Good, NotAJoint

GROUP = "flexmb.joints"


def ep(name: str, value: str, group: str = GROUP) -> EntryPoint:
    return EntryPoint(name, value, group)


@pytest.fixture
def fake_entry_points(monkeypatch):
    """``install(*eps)`` makes the registry see exactly ``eps`` (and nothing installed)."""

    def install(*eps: EntryPoint) -> None:
        def entry_points(*, group=None, **_):
            return [e for e in eps if group is None or e.group == group]

        monkeypatch.setattr(registry, "entry_points", entry_points)
        registry.refresh()

    registry.refresh()
    yield install
    registry.refresh()  # runs while the patch is still active; the next lookup after undo is fresh


@pytest.fixture(autouse=True)
def restore_session_registry():
    """Undo `register_joint` calls of the test (the registry's ``_session`` dict)."""
    saved = dict(registry._session)
    yield
    registry._session.clear()
    registry._session.update(saved)


def discover() -> tuple[dict, list[warnings.WarningMessage]]:
    """`available_joints()` and every warning it emitted (none filtered away)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found = flexmb.available_joints()
    return found, list(caught)


# ---------------------------------------------------------------------------
# The installed entry points (flexmb's own pyproject.toml)
# ---------------------------------------------------------------------------


def test_available_joints_lists_the_shipped_entry_points():
    """pyproject.toml declares ``cross_flexure`` and ``leaf_spring`` in the ``flexmb.joints`` group."""
    registry.refresh()
    found, caught = discover()
    assert found["cross_flexure"] is flexmb.CrossFlexure
    assert found["leaf_spring"] is flexmb.LeafSpring
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], "the shipped plugins load cleanly"


def test_joint_by_name_returns_an_instance_with_the_given_parameters():
    j = flexmb.joint("cross_flexure", elements_per_leaf=2)
    assert isinstance(j, flexmb.CrossFlexure)
    assert j.elements_per_leaf == 2


def test_available_joints_returns_a_copy_that_callers_cannot_corrupt():
    found = flexmb.available_joints()
    found.pop("cross_flexure")
    found["bogus"] = NotAJoint
    assert "cross_flexure" in flexmb.available_joints()
    assert "bogus" not in flexmb.available_joints()


# ---------------------------------------------------------------------------
# Fabricated entry points
# ---------------------------------------------------------------------------


def test_good_plugin_is_found_without_warnings(fake_entry_points):
    fake_entry_points(ep("dummy", "tests.dummy_plugins:Good"))
    found, caught = discover()
    assert found == {"dummy": Good}
    assert caught == []
    assert isinstance(flexmb.joint("dummy", length=0.2), Good)


def test_entry_points_of_other_groups_are_ignored(fake_entry_points):
    fake_entry_points(ep("dummy", "tests.dummy_plugins:Good"), ep("other", "tests.dummy_plugins:Good", "other.group"))
    assert flexmb.available_joints() == {"dummy": Good}


def test_refresh_forgets_the_cached_entry_points(fake_entry_points):
    fake_entry_points(ep("dummy", "tests.dummy_plugins:Good"))
    assert "dummy" in flexmb.available_joints()
    fake_entry_points(ep("renamed", "tests.dummy_plugins:Good"))  # calls refresh()
    assert set(flexmb.available_joints()) == {"renamed"}


@pytest.mark.parametrize(
    "value",
    [
        "tests.no_such_plugin_module:Good",  # ModuleNotFoundError
        "tests.broken_plugin_module:Good",  # ImportError (sys.modules entry set to None below)
        "tests.dummy_plugins:DoesNotExist",  # AttributeError
        "tests.dummy_plugins:NotAJoint",  # a class, but not a flexmb.Joint subclass
        "tests.dummy_plugins:not_a_class",  # a function
    ],
)
def test_broken_plugin_gives_one_runtime_warning_and_is_skipped(fake_entry_points, monkeypatch, value):
    monkeypatch.setitem(sys.modules, "tests.broken_plugin_module", None)  # `import` raises ImportError
    fake_entry_points(ep("dummy", "tests.dummy_plugins:Good"), ep("broken", value))
    found, caught = discover()
    assert found == {"dummy": Good}, "the good plugin survives, the broken one is skipped"
    runtime = [w for w in caught if issubclass(w.category, RuntimeWarning)]
    assert len(runtime) == 1, [str(w.message) for w in caught]
    assert "broken" in str(runtime[0].message), "the warning names the entry point"
    # discovery is cached: asking again does not warn again
    _, again = discover()
    assert again == []


def test_broken_plugin_does_not_break_joint_by_name(fake_entry_points):
    fake_entry_points(ep("broken", "tests.dummy_plugins:NotAJoint"), ep("dummy", "tests.dummy_plugins:Good"))
    with pytest.warns(RuntimeWarning, match="broken"):
        j = flexmb.joint("dummy")
    assert isinstance(j, Good)
    with pytest.raises(flexmb.UnknownJointError, match="broken"):  # skipped, so unknown by that name
        flexmb.joint("broken")


def test_duplicate_entry_point_name_warns_and_keeps_the_first(fake_entry_points):
    fake_entry_points(ep("dummy", "tests.dummy_plugins:Good"), ep("dummy", "flexmb.joints.leaf_spring:LeafSpring"))
    found, caught = discover()
    assert found == {"dummy": Good}
    runtime = [w for w in caught if issubclass(w.category, RuntimeWarning)]
    assert len(runtime) == 1, [str(w.message) for w in caught]
    assert "dummy" in str(runtime[0].message)


def test_plugin_joint_found_by_entry_point_solves_like_a_cantilever(fake_entry_points):
    """A third-party joint takes the same path as the shipped ones: by name into a Mechanism, then solved.

    The dummy joint is one shear-free beam element of length L clamped in fixed link A; a small
    transverse dead force P on link B gives the linear Euler-Bernoulli cantilever values
    ``v = P L^3 / (3 E I)`` and ``theta = P L^2 / (2 E I)`` (exact for one cubic Hermite element
    under a tip load). ``P`` is chosen so that ``v / L = 1e-6``; the geometric non-linearity is
    then of relative order ``(v/L)^2``, so ``rtol = 1e-6`` is loose.
    """
    fake_entry_points(ep("dummy", "tests.dummy_plugins:Good"))
    proto = Good()
    L, EI = proto.length, proto.E * proto.Iz
    P = 1e-6 * L * 3.0 * EI / L**3
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(L, 0.0))
    m.add_joint("A", "B", "dummy")
    m.apply_force("B", (0.0, P))
    sol = flexmb.solve(m)
    assert sol.converged, sol.message
    _, theta = sol.pose("B")
    np.testing.assert_allclose(sol.displacement("B")[1], P * L**3 / (3 * EI), rtol=1e-6)
    np.testing.assert_allclose(theta, P * L**2 / (2 * EI), rtol=1e-6)


# ---------------------------------------------------------------------------
# Session registrations
# ---------------------------------------------------------------------------


def test_register_joint_adds_a_session_joint_usable_by_name():
    flexmb.register_joint("dummy", Good)
    assert flexmb.available_joints()["dummy"] is Good
    assert isinstance(flexmb.joint("dummy"), Good)
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.1, 0.0))
    assert isinstance(m.add_joint("A", "B", "dummy"), Good)


def test_session_registrations_sit_beside_the_installed_entry_points():
    flexmb.register_joint("dummy", Good)
    assert {"cross_flexure", "leaf_spring", "dummy"} <= set(flexmb.available_joints())


@pytest.mark.parametrize("name", ["dummy", "cross_flexure"])
def test_register_joint_refuses_to_clobber_without_clobber_true(name):
    """A second registration of ``dummy`` and a session joint shadowing the installed ``cross_flexure``."""
    if name == "dummy":
        flexmb.register_joint("dummy", Good)
    before = flexmb.available_joints()[name]
    with pytest.raises(ValueError, match=rf"{name}.*clobber=True"):
        flexmb.register_joint(name, flexmb.LeafSpring)
    assert flexmb.available_joints()[name] is before, "a refused registration changes nothing"


def test_register_joint_refusal_is_a_flexmb_error():
    """DESIGN.md: FlexmbError is the root of every error flexmb raises on purpose."""
    flexmb.register_joint("dummy", Good)
    with pytest.raises(flexmb.FlexmbError, match="dummy"):
        flexmb.register_joint("dummy", flexmb.LeafSpring)


def test_register_joint_replaces_with_clobber_true():
    flexmb.register_joint("dummy", Good)
    flexmb.register_joint("dummy", flexmb.LeafSpring, clobber=True)
    assert isinstance(flexmb.joint("dummy"), flexmb.LeafSpring)
    flexmb.register_joint("cross_flexure", Good, clobber=True)
    assert isinstance(flexmb.joint("cross_flexure"), Good)


def test_session_registrations_are_undone_by_the_fixture():
    """Guards the clean-up above: no test leaves ``dummy`` behind or ``cross_flexure`` replaced."""
    assert "dummy" not in flexmb.available_joints()
    assert flexmb.available_joints()["cross_flexure"] is flexmb.CrossFlexure


@pytest.mark.parametrize("cls", [NotAJoint, flexmb.CrossFlexure(), "cross_flexure", None])
def test_register_joint_rejects_what_is_not_a_joint_subclass(cls):
    with pytest.raises(TypeError, match="not a flexmb.Joint subclass"):
        flexmb.register_joint("dummy", cls)
    assert "dummy" not in flexmb.available_joints()


def test_register_joint_rejection_of_a_non_joint_is_a_flexmb_error():
    """DESIGN.md: FlexmbError is the root of every error flexmb raises on purpose."""
    with pytest.raises(flexmb.FlexmbError, match="NotAJoint"):
        flexmb.register_joint("dummy", NotAJoint)
