"""A third-party joint plugin, installed as a real package (tests/plugin_pkg, its own
pyproject.toml) during the test run: found through the ``flexmb.joints`` entry point, passes the
conformance suite and is solved in a mechanism."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import registry, testing

PACKAGE = Path(__file__).parent / "plugin_pkg"


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    target = tmp_path_factory.mktemp("site")
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(PACKAGE)]
    if all(importlib.util.find_spec(m) is not None for m in ("setuptools", "wheel")):
        cmd.insert(4, "--no-build-isolation")  # build with the local setuptools: no download
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, f"installing the test plugin failed:\n{done.stderr}"
    sys.path.insert(0, str(target))
    registry.refresh()
    yield flexmb.available_joints()["single_leaf"]
    sys.path.remove(str(target))
    for name in [m for m in sys.modules if m.startswith("flexmb_notch")]:
        del sys.modules[name]
    registry.refresh()


@pytest.mark.slow
def test_the_installed_plugin_is_found_through_its_entry_point(installed):
    assert installed.__module__ == "flexmb_notch"
    assert "fe_model" in flexmb.joint("single_leaf").capabilities


CHECKS = [name for name in dir(testing.JointConformance) if name.startswith("test_")]


@pytest.mark.parametrize("check", CHECKS)
def test_the_plugin_passes_the_conformance_suite(installed, check):
    suite = type("ConformanceSingleLeaf", (testing.JointConformance,), {"joint_class": installed})()
    getattr(suite, check)()


def test_the_plugin_joint_is_solved_in_a_mechanism(installed):
    """End moment M on the plugin's single element of length L: a cantilever under an end moment
    turns by M L / (E I) (closed form; the bending moment is constant, so one co-rotational element
    reproduces it; at 1e-4 rad the geometric non-linearity is ~1e-8, below the 1e-6 tolerance)."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("tip", position=(0.1, 0.0))
    m.add_joint("ground", "tip", "single_leaf", name="leaf")
    E, w, t, L = 200e9, 0.02, 1e-3, 0.1
    EI = E * w * t**3 / 12.0
    M = 1e-4 * EI / L
    m.apply_moment("tip", M)
    sol = flexmb.solve(m)
    assert sol.converged
    np.testing.assert_allclose(sol.pose("tip")[1], M * L / EI, rtol=1e-6)
