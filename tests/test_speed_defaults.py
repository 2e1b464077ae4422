"""Issue 31's defaults: the compiled kernels are what a plain install gets, the test suite keeps
their cache out of the user's cache folder, and the cheap builds give the values of the full ones."""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import models, sections

ROOT = Path(__file__).resolve().parents[1]


def test_the_test_suite_caches_kernels_in_a_temporary_folder():
    """tests/conftest.py points numba's cache into the system's temporary directory (set before
    numba reads it), never the user's cache folder."""
    folder = Path(os.environ["NUMBA_CACHE_DIR"]).resolve()
    assert Path(tempfile.gettempdir()).resolve() in folder.parents
    assert Path.home().resolve() / ".cache" not in folder.parents


def test_compiled_kernels_are_core_dependencies_where_wheels_exist():
    """numba and qdldl are in `dependencies`, each with the markers of the platforms with wheels;
    the `fast` extra still names both (a source build elsewhere)."""
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    core = {d.split(">=")[0].split(";")[0].strip(): d for d in project["dependencies"]}
    for name in ("numba", "qdldl"):
        assert name in core and "platform_python_implementation == 'CPython'" in core[name]
        assert "x86_64" in core[name] and "aarch64" in core[name]
        assert any(d.startswith(name) for d in project["optional-dependencies"]["fast"])
    packaging = pytest.importorskip("packaging.requirements")
    here = packaging.Requirement(core["numba"]).marker.evaluate()
    if here:  # this platform gets them with a plain install: the kernels run unless switched off
        assert flexmb.jit._AVAILABLE


def test_rectangle_is_built_once_per_value_and_equals_a_new_one():
    a = sections.rectangle(0.02, 1e-3, 200e9, 76.9e9)
    assert sections.rectangle(0.02, 1e-3, 200e9, 76.9e9) is a
    b = sections._rectangle(0.02, 1e-3, 200e9, 76.9e9)
    assert a == b
    c = sections.rectangle(np.float64(0.02), 1e-3, 200e9, 76.9e9)  # numpy numbers: not kept
    assert c == b and c is not a
    with pytest.raises(flexmb.FlexmbError, match="width"):
        sections.rectangle(-0.02, 1e-3, 200e9, 76.9e9)
    with pytest.raises(flexmb.FlexmbError, match="width"):  # an error is not kept either
        sections.rectangle(-0.02, 1e-3, 200e9, 76.9e9)


def test_cross_flexure_refuses_overflowing_coordinates_without_meshing():
    """The finiteness check reads the leaves' ends and n times their span, not the mesh: a length
    whose mesh overflows (the span times the element count) is still refused."""
    with pytest.raises(flexmb.FlexmbError, match="non-finite"):
        flexmb.CrossFlexure(length=1e308, thickness=1e-3, elements_per_leaf=10)


def test_manipulator_geometry_moves_its_joints():
    """`models.manipulator(geometry=)`: other placements of the same links and joints (a design
    loop's parameters); unknown or invalid entries are refused by name."""
    base = models.manipulator("joint", 0.3)
    moved = models.manipulator("joint", 0.3, geometry={"post": 0.2, "angle2": math.radians(20.0)})
    assert not np.allclose(base.links["link2"].position, moved.links["link2"].position)
    assert list(base.joints) == list(moved.joints)
    with pytest.raises(flexmb.FlexmbError, match="unknown geometry"):
        models.manipulator(geometry={"posts": 0.2})
    with pytest.raises(flexmb.FlexmbError, match="arm2"):
        models.manipulator(geometry={"arm2": -0.1})
