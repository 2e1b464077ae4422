"""The complex step through the build (issue 28): one complex build per parameter gives the model
numbers' rates to round-off. Central differences of the builds are the check (agreement 1e-8);
a build, a joint plugin or a ``configure`` that drops the imaginary part is refused naming the
parameter and where it happened; the conformance kit's `check_complex_step` teaches plugin authors."""

from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path
from typing import ClassVar

import attrs
import numpy as np
import pytest
from design_cases import PIVOT, PIVOT_BOUNDS, SPATIAL, pivot, spatial
from dummy_plugins import Good

import flexmb
from flexmb import testing
from flexmb.design import DesignPoint
from flexmb.design import responses as R
from flexmb.design.builds import CENTRAL, COMPLEX_STEP
from flexmb.design.parameters import MODEL_FIELDS, model_numbers
from flexmb.errors import ParameterError


def _benchmark():
    """benchmarks/bench_gradients.py as a module: its 3D hinge (20 parameters of every kind, 30
    elements, turned 0.5 rad) is a case here too."""
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_gradients.py"
    spec = importlib.util.spec_from_file_location("bench_gradients", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BENCH = _benchmark()
hinge, HINGE, HINGE_BOUNDS = BENCH.hinge, BENCH.P, BENCH.BOUNDS


def chained(p):
    """A leaf turned by a chain of two rotations whose first angle is a parameter; a named point."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(p["L"], 0.0, 0.0))
    m.add_joint("A", "B", "leaf_spring", length=p["L"], thickness=1e-3, elements=6)
    m.prescribe("B", rotation=[(0.0, 0.0, p["a"]), (0.1, 0.0, 0.0)])
    m.add_point("B", "tip", (p["L"] + 0.01, 0.0, 0.0))
    return m


def arc(p):
    """A planar curved beam placed by `CurvedBeam.through` (its radius and angle from points)."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    start, end = (0.0, 0.0), (p["r"] * np.sin(1.2), p["r"] * (1 - np.cos(1.2)))
    joint, placement = flexmb.joints.curved_beam.CurvedBeam.through((0.0, p["r"]), start, end, width=0.01,
                                                                    height=p["h"], E=2e11, elements=8)
    m.add_link("B", position=end)
    m.add_joint("A", "B", joint, **placement)
    m.apply_force("B", (0.0, 1.0))
    return m


CASES = {"pivot2": (lambda q: pivot(q, 2), PIVOT, PIVOT_BOUNDS), "pivot3": (lambda q: pivot(q, 3), PIVOT, PIVOT_BOUNDS),
         "spatial": (spatial, SPATIAL, None), "hinge": (hinge, HINGE, HINGE_BOUNDS),
         "chained": (chained, {"L": 0.1, "a": 0.35}, None), "arc": (arc, {"r": 0.05, "h": 1e-3}, None)}


@pytest.mark.parametrize("case", sorted(CASES))
def test_complex_step_rates_equal_central_differences_of_the_builds(case):
    build, p, bounds = CASES[case]
    point = DesignPoint(build, p, bounds)
    compiled = point.design.mechanism().compile("fe_model")
    rates = point.rates(compiled)
    for k, q in enumerate(point.design.parameters):
        h = q.step
        side = [point.design.mechanism({**point.design.values, q.name: q.value + s * h}).compile("fe_model")
                for s in (1.0, -1.0)]
        for field in MODEL_FIELDS:
            fd = (model_numbers(side[0], field) - model_numbers(side[1], field)) / (2 * h)
            cs = rates.rate(field)[k]
            base = model_numbers(compiled, field)
            size = max(np.abs(fd).max(initial=0.0), np.abs(cs).max(initial=0.0))
            if field == "point_offset":  # differences of positions: their round-off is the positions'
                base = model_numbers(compiled, "x0")
            floor = 1e3 * np.finfo(float).eps * np.abs(base).max(initial=0.0) / h  # the differences' round-off
            assert np.abs(cs - fd).max(initial=0.0) <= 1e-8 * size + floor, (case, q.name, field)


@pytest.mark.parametrize("case", ["hinge", "pivot2", "chained"])
def test_the_complex_build_s_real_parts_are_the_float_build(case):
    build, p, bounds = CASES[case]
    point = DesignPoint(build, p, bounds)
    compiled = point.design.mechanism().compile("fe_model")
    rates = point.rates(compiled)
    from flexmb.design.parameters import numbers_field

    for k in range(len(point.names)):
        b = rates.build(k)
        assert b.method == COMPLEX_STEP and b.reason == "", (k, b.reason)
        ((_, _, nums),) = b.points
        for field in ("x0", "point_offset", "L0", "S", "ny0", "alpha0", "values", "load_force", "rigid_mass"):
            ref = model_numbers(compiled, field)
            got = np.real(numbers_field(nums, field, compiled.problem.model.dim))
            assert np.abs(got - ref).max(initial=0.0) <= 1e-14 * np.abs(ref).max(initial=0.0), (k, field)


def test_a_build_with_math_functions_falls_back_to_differences_naming_the_line():
    def build(p):
        m = pivot(p, 2)
        m.apply_force("B", (0.0, math.sin(p["F"])))  # math.sin: no complex numbers
        return m

    point = DesignPoint(build, PIVOT, PIVOT_BOUNDS)
    methods = dict(zip(point.names, point.rates(None).methods))
    method, reason = methods["F"]
    assert method == CENTRAL and re.search(r"test_design_complex_step.py, line \d+ \(in build\).*TypeError", reason)
    assert all(m == COMPLEX_STEP for n, (m, _) in methods.items() if n != "F")
    assert testing.check_gradient(build, PIVOT, R.displacement("B", "y"), bounds=PIVOT_BOUNDS).ok


@attrs.frozen(kw_only=True)
class _FloatOnly(Good):
    """Good whose interface drops the imaginary part (a float array filled with complex numbers)."""

    kind: ClassVar[str] = "float_only"

    def interface_b(self, dim: int) -> np.ndarray:
        b = np.zeros(dim)
        b[0] = self.length
        return b


@attrs.frozen(kw_only=True)
class _Modulus(Good):
    """Good whose mesh takes the length as a modulus (silently real: no warning, no TypeError)."""

    kind: ClassVar[str] = "modulus"

    def interface_b(self, dim: int) -> np.ndarray:
        b = np.zeros(dim, dtype=complex if isinstance(self.length, complex) else float)
        b[0] = abs(self.length)
        return b


def _plugin_design(cls):
    def build(p):
        m = flexmb.Mechanism(dim=2)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(0.1, 0.0))
        m.add_joint("A", "B", cls(length=p["L"], thickness=p["t"]))
        m.apply_force("B", (0.0, 1e-3))  # v / L = 1e-5: the closed form's small deflection (corrections ~1e-10)
        return m
    return build


@pytest.mark.parametrize("cls", [_FloatOnly, _Modulus])
def test_a_plugin_that_drops_the_imaginary_part_falls_back_naming_the_joint(cls):
    build, p, response = _plugin_design(cls), {"L": 0.1, "t": 1e-3}, R.displacement("B", "y")
    point = DesignPoint(build, p)
    (m_L, why), (m_t, _) = point.rates(None).methods
    assert m_L == CENTRAL and m_t == COMPLEX_STEP
    if cls is _FloatOnly:  # an error on the way: named with the joint's class and line
        assert re.search(r"joint 'float_only' \(test_design_complex_step._FloatOnly, line \d+\)", why)
    else:  # abs() drops it silently: the check along one direction finds it
        assert "dropped silently" in why and "point_offset" in why
    value, grad = flexmb.value_and_grad(build, p, response)
    # a cantilever under an end force (Euler-Bernoulli, the plugin's element): d ln v / d ln t = -3
    assert grad["t"] * 1e-3 / value == pytest.approx(-3.0, rel=1e-6)
    assert testing.check_gradient(build, p, response).ok


def test_a_safe_plugin_takes_the_complex_step():
    point = DesignPoint(_plugin_design(Good), {"L": 0.1, "t": 1e-3})
    assert [m for m, _ in point.rates(None).methods] == [COMPLEX_STEP, COMPLEX_STEP]


def test_the_kit_s_complex_step_check():
    for cls, dims in ((flexmb.CrossFlexure, (2, 3)), (flexmb.LeafSpring, (2, 3)), (Good, (2, 3))):
        for dim in dims:
            testing.check_complex_step(cls(), dim)
    with pytest.raises(AssertionError, match="drops the complex step of 'length'.*float_only"):
        testing.check_complex_step(_FloatOnly(), 2)
    with pytest.raises(AssertionError, match="points drops .*complex step of 'length'"):  # silent: caught by the check
        testing.check_complex_step(_Modulus(), 2)


@pytest.mark.parametrize("read", ["float", "real"])
def test_a_configure_that_drops_the_imaginary_part_falls_back(read):
    """A configure step whose load follows the link's position (L sin a): reading it with float()
    (an error on a complex mechanism: that parameter takes central differences) or with np.real
    (silent: caught along the design's check direction) gives the gradient of a configure that
    keeps it complex (within 1e-7; without the fallback dJ/dL and dJ/da would miss the load's change)."""
    point = DesignPoint(lambda q: pivot(q, 2), PIVOT, PIVOT_BOUNDS)
    drop = {"float": float, "real": np.real}[read]

    def exact(m):
        m.apply_force("B", (0.0, 100.0 * m.link("B").position[1]))

    def dropping(m):
        m.apply_force("B", (0.0, 100.0 * drop(m.link("B").position[1])))

    response = R.displacement("B", "y")
    ref = point.evaluate(response, configure=exact).jacobian
    got = point.evaluate(response, configure=dropping).jacobian
    np.testing.assert_allclose(got, ref, rtol=1e-7, atol=1e-7 * np.abs(ref).max())
    held = point.evaluate(response, configure=lambda m: m.apply_force("B", (0.0, 100.0 * 0.1 * np.sin(np.pi / 4))))
    L = point.names.index("L")  # the load's own change matters: dJ/dL without it is off by > 1e-3
    assert abs(held.jacobian[0, L] - ref[0, L]) > 1e-3 * abs(ref[0, L])


def test_points_inside_joints_take_differences_of_the_compiled_builds():
    """A point inside a leaf (`Mechanism.add_joint_point`: a refined mesh only `compile` makes):
    its parameters fall back to central differences, and the gradient holds (checker)."""

    def build(p):
        m = flexmb.Mechanism(dim=2)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(p["L"], 0.0))
        m.add_joint("A", "B", "leaf_spring", name="leaf", length=p["L"], thickness=p["t"], elements=6)
        m.add_joint_point("leaf", "P", 0.3)
        m.apply_force("P", (0.0, 0.5))  # a load at 0.3 L
        return m

    p, response = {"L": 0.1, "t": 1e-3}, R.displacement("B", "y")
    methods = DesignPoint(build, p).rates(None).methods
    assert all(m == CENTRAL and "points inside joints" in why for m, why in methods)
    assert testing.check_gradient(build, p, response).ok


def test_complex_input_outside_a_complex_step_is_refused():
    """Complex numbers are design quantities only within a complex-step build
    (`flexmb._validate.complex_step`); elsewhere they are refused as any non-real input."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    with pytest.raises(ParameterError, match="position"):
        m.add_link("B", position=(0.1 + 1e-30j, 0.0))
    with pytest.raises(ParameterError, match="not a real number"):
        m.add_link("C", mass=1.0 + 1e-30j)
    with pytest.raises(ParameterError, match="not a real number"):
        flexmb.rectangle(0.01, 1e-3, 200e9 + 1e-30j, nu=0.3)
    with pytest.raises(ParameterError):
        flexmb.LeafSpring(length=0.1 + 1e-30j)
    with flexmb._validate.complex_step():  # within one: kept, judged by the real part
        assert flexmb.LeafSpring(length=0.1 + 1e-30j).length == 0.1 + 1e-30j
        with pytest.raises(ParameterError, match="must be > 0"):
            flexmb.LeafSpring(length=-0.1 + 1e-30j)
