"""Specification of flexmb's answers to bad input and to solver failure.

Where the expectations come from:

* the issue's "bad input" requirements: every invalid joint parameter,
  topology, load, prescribed motion, link name and solver choice is rejected
  with a subclass of `flexmb.FlexmbError` whose message names the offending
  link / joint / parameter (each ``match=`` below checks that name, and where
  useful the offending value);
* the valid ranges are the documented ones: the docstrings of `CrossFlexure`
  ("angle in (0, pi/2)", "thickness less than length / 10", "elements_per_leaf
  1 or more") and `LeafSpring` ("thickness < length", "elements 1 or more");
  lengths, widths and moduli are physical magnitudes, so finite and > 0;
* DESIGN.md: "FlexmbError (root of every error flexmb raises on purpose)" and
  "Convergence is ... reported, not assumed"; STYLE.md Sec. 3.4:
  "Non-convergence returns converged=False with a reason. An opt-in
  raise_on_failure=True raises a ConvergenceError"; the `Mechanism` docstring:
  "Solving never modifies the mechanism".

Everything here is deterministic (hypothesis runs derandomized) and fast.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import Phase, example, given, settings
from hypothesis import strategies as st

import flexmb
from flexmb import CrossFlexure, LeafSpring

NAN, INF = math.nan, math.inf
NON_POSITIVE = [0.0, -0.0, -1.0, NAN, INF, -INF]  # zero, negative, NaN, inf: none is a length or a modulus


def names(name: str, value=None) -> str:
    """Regex: the message names parameter ``name`` (as ``name=``), with ``value`` when given."""
    return rf"\b{re.escape(name)}=" + ("" if value is None else re.escape(repr(value)))


def pivot_2d(**joint_params) -> flexmb.Mechanism:
    """Fixed link A, free link B, joined by a 2-element-per-leaf cross flexure."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, 0.1 * math.sin(math.pi / 4)))
    m.add_joint("A", "B", "cross_flexure", name="pivot", elements_per_leaf=2, **joint_params)
    return m


# ---------------------------------------------------------------------------
# Joint parameters
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("value", NON_POSITIVE)
@pytest.mark.parametrize("name", ["length", "thickness", "width_inner", "width_outer", "E", "G"])
def test_cross_flexure_rejects_non_positive_or_non_finite_dimensions_and_moduli(name, value):
    with pytest.raises(flexmb.ParameterError, match=names(name, value)):
        CrossFlexure(**{name: value})


@pytest.mark.parametrize("value", NON_POSITIVE)
@pytest.mark.parametrize("name", ["length", "width", "thickness", "E", "G"])
def test_leaf_spring_rejects_non_positive_or_non_finite_dimensions_and_moduli(name, value):
    with pytest.raises(flexmb.ParameterError, match=names(name, value)):
        LeafSpring(**{name: value})


@pytest.mark.parametrize("value", [0.0, -0.1, math.pi / 2, 2.0, math.pi, NAN, INF, -INF])
def test_cross_flexure_rejects_angle_outside_zero_to_half_pi(value):
    """Docstring: angle in the open interval (0, pi/2); both ends excluded."""
    with pytest.raises(flexmb.ParameterError, match=names("angle", value)):
        CrossFlexure(angle=value)


@pytest.mark.parametrize("value", [0, -1, 2.5, NAN, "3", None])
def test_cross_flexure_rejects_elements_per_leaf_zero_or_non_integer(value):
    with pytest.raises(flexmb.ParameterError, match=names("elements_per_leaf", value)):
        CrossFlexure(elements_per_leaf=value)


@pytest.mark.parametrize("value", [0, -3, 1.5])
def test_leaf_spring_rejects_elements_zero_or_non_integer(value):
    with pytest.raises(flexmb.ParameterError, match=names("elements", value)):
        LeafSpring(elements=value)


@pytest.mark.parametrize("value", [-1e-3, NAN, INF])
def test_cross_flexure_rejects_negative_or_non_finite_gap(value):
    with pytest.raises(flexmb.ParameterError, match=names("gap", value)):
        CrossFlexure(gap=value)


@pytest.mark.parametrize(("thickness", "length"), [(0.02, 0.1), (0.1, 0.1), (1.0, 0.1)])
def test_cross_flexure_rejects_thickness_that_is_not_slender(thickness, length):
    """Docstring: thickness less than length / 10."""
    with pytest.raises(flexmb.ParameterError, match=names("thickness", thickness)):
        CrossFlexure(thickness=thickness, length=length)


def test_cross_flexure_rejects_thickness_equal_to_a_tenth_of_the_length():
    """The bound of "thickness < length / 10" is excluded: thickness 0.01 m, length 0.1 m is not valid.

    (0.1 * 0.1 rounds to 0.010000000000000002 in binary floating point, so a check written as
    ``thickness >= 0.1 * length`` lets the boundary through; ``length / 10`` is exactly 0.01.)
    """
    with pytest.raises(flexmb.ParameterError, match=names("thickness", 0.01)):
        CrossFlexure(thickness=0.01, length=0.1)


def test_cross_flexure_accepts_thickness_just_below_a_tenth_of_the_length():
    CrossFlexure(thickness=0.0099, length=0.1)


@pytest.mark.parametrize(("thickness", "length"), [(0.2, 0.1), (0.1, 0.1)])
def test_leaf_spring_rejects_thickness_not_below_length(thickness, length):
    """Docstring: thickness < length."""
    with pytest.raises(flexmb.ParameterError, match=names("thickness", thickness)):
        LeafSpring(thickness=thickness, length=length)


@pytest.mark.parametrize("name", ["length", "thickness", "width_inner", "E", "angle"])
@pytest.mark.parametrize("value", ["abc", None, [0.1], object()])
def test_cross_flexure_rejects_non_numbers_naming_the_parameter(name, value):
    with pytest.raises(flexmb.ParameterError, match=names(name)):
        CrossFlexure(**{name: value})


@pytest.mark.parametrize(("name", "value"), [("length", "0.1"), ("thickness", "0.001")])
@pytest.mark.parametrize("cls", [CrossFlexure, LeafSpring])
def test_joint_given_a_numeric_string_either_converts_it_or_raises_a_parameter_error(cls, name, value):
    """A string such as "0.1" (from a config file) is either read as the number or rejected naming
    the parameter; never a bare TypeError from comparing a string with a float."""
    try:
        j = cls(**{name: value})
    except flexmb.FlexmbError as exc:
        assert re.search(names(name), str(exc)), str(exc)
    else:
        assert getattr(j, name) == float(value)


def test_joint_by_name_rejects_a_negative_length():
    with pytest.raises(flexmb.ParameterError, match=names("length", -1)):
        flexmb.joint("cross_flexure", length=-1)


def test_add_joint_by_name_rejects_a_negative_length():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, 0.07))
    with pytest.raises(flexmb.ParameterError, match=names("length", -1)):
        m.add_joint("A", "B", "cross_flexure", length=-1)
    assert m.joints == {}, "the rejected joint was not added"


def test_joint_by_name_rejects_a_misspelled_parameter_naming_it():
    with pytest.raises(flexmb.FlexmbError, match="lenght"):
        flexmb.joint("cross_flexure", lenght=0.1)


def test_moduli_in_the_wrong_units_are_reported_naming_them():
    """G typed in GPa (76.9) with E in Pa implies Poisson's ratio E/2G - 1 ~ 1e9, outside (-1, 0.5):
    reported (at construction or at the latest when solving) naming G."""
    with pytest.raises(flexmb.ParameterError, match=names("G")):
        m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.1, G=76.9)
        flexmb.solve(m)


# -- fuzzing: one parameter at a time over every float, NaN and inf included ------------------

DEFAULTS = CrossFlexure()


def expected_valid(name: str, x: float) -> bool | None:
    """The documented valid ranges (docstring of `CrossFlexure`); ``None`` near a bound where
    rounding may go either way."""
    if not math.isfinite(x):
        return False
    if name == "angle":
        return 0.0 < x < math.pi / 2
    if name == "gap":
        return x >= 0.0
    if x <= 0.0:
        return False
    if name in ("E", "G"):  # docstring: Poisson's ratio E/(2G) - 1 in (-1, 0.5)
        E = x if name == "E" else DEFAULTS.E
        G = x if name == "G" else DEFAULTS.G
        nu = E / (2 * G) - 1
        if math.isclose(nu, 0.5, rel_tol=1e-12) or math.isclose(nu, -1.0, rel_tol=1e-12):
            return None
        return -1.0 < nu < 0.5
    if not 1e-60 < x < 1e60:  # magnitudes whose cubes over/underflow: either outcome, but a FlexmbError
        return None
    if name in ("length", "thickness"):
        t = x if name == "thickness" else DEFAULTS.thickness
        length = x if name == "length" else DEFAULTS.length
        if math.isclose(t, length / 10, rel_tol=1e-12):
            return None
        return t < length / 10
    return True  # widths: any finite positive value of representable magnitude


@pytest.mark.parametrize(
    "name", ["length", "angle", "thickness", "width_inner", "width_outer", "E", "G", "gap", "elements_per_leaf"]
)
@settings(deadline=None, max_examples=40, derandomize=True, database=None)
@given(x=st.floats(allow_nan=True, allow_infinity=True))
def test_cross_flexure_constructor_fuzzed_one_parameter_raises_only_flexmb_errors(name, x):
    """Either the constructor accepts a valid value or it raises a FlexmbError naming the parameter;
    never any other exception (no bare ValueError, TypeError, numpy error)."""
    try:
        j = CrossFlexure(**{name: x})
    except flexmb.FlexmbError as exc:
        assert re.search(names(name), str(exc)), str(exc)
        ok = False
    else:
        assert getattr(j, name) == x
        ok = True
    if name == "elements_per_leaf":  # an element count is never a float
        assert not ok
        return
    want = expected_valid(name, x)
    if want is not None:
        assert ok == want, f"{name}={x!r}: expected {'valid' if want else 'invalid'}"


@pytest.mark.parametrize("name", ["length", "thickness", "width_inner", "width_outer", "E", "G"])
@settings(deadline=None, max_examples=40, derandomize=True, database=None,
          phases=(Phase.explicit, Phase.generate))  # no shrinking: a failing run stays fast
@given(x=st.floats(min_value=0.0, exclude_min=True, allow_infinity=False))
@example(x=1e200)  # 1e200**3 overflows a Python float
@example(x=1e308)
def test_cross_flexure_accepted_by_the_constructor_meshes_or_raises_a_flexmb_error(name, x):
    """A joint the constructor accepted reaches the model builder (`mesh`, run by `Mechanism.compile`):
    there too, parameters it cannot handle (extreme magnitudes, inconsistent moduli) must come out
    as a FlexmbError, never as another exception (OverflowError, ZeroDivisionError, ...), and a mesh
    that is built has finite coordinates (a silently infinite model would only fail later, as NaN)."""
    try:
        j = CrossFlexure(**{name: x})
    except flexmb.FlexmbError:
        return
    for dim in (2, 3):
        try:
            mesh = j.mesh(dim)
        except flexmb.FlexmbError:
            continue
        assert np.all(np.isfinite(mesh.points)), f"{name}={x!r}: non-finite mesh points in {dim}D"


# ---------------------------------------------------------------------------
# Topology
# ---------------------------------------------------------------------------


def test_mechanism_without_fixed_link_is_rejected_when_solved():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A")
    m.add_link("B", position=(0.0, 0.07))
    m.add_joint("A", "B", "cross_flexure", elements_per_leaf=2)
    with pytest.raises(flexmb.TopologyError, match="no fixed link"):
        flexmb.solve(m)


def test_mechanism_without_links_is_rejected_when_solved():
    with pytest.raises(flexmb.TopologyError, match="no links"):
        flexmb.solve(flexmb.Mechanism(dim=2))


def test_link_not_connected_to_the_ground_is_named():
    m = pivot_2d()
    m.add_link("loose", position=(1.0, 1.0))
    with pytest.raises(flexmb.TopologyError, match="'loose'"):
        flexmb.solve(m)


def test_island_of_links_not_connected_to_the_ground_is_named():
    """Two links joined to each other but not to the fixed link A."""
    m = pivot_2d()
    m.add_link("C", position=(1.0, 0.0))
    m.add_link("D", position=(1.0, 0.07))
    m.add_joint("C", "D", "cross_flexure", elements_per_leaf=2)
    with pytest.raises(flexmb.TopologyError, match=r"'C'.*'D'|'D'.*'C'"):
        m.check()


def test_joint_connecting_a_link_to_itself_is_rejected_naming_the_link():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    with pytest.raises(flexmb.TopologyError, match="'A'"):
        m.add_joint("A", "A", "cross_flexure")


def test_unknown_joint_name_lists_the_known_ones():
    with pytest.raises(flexmb.UnknownJointError, match=r"'crossflexure'.*cross_flexure.*leaf_spring"):
        flexmb.joint("crossflexure")


def test_unknown_joint_name_in_add_joint_lists_the_known_ones():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B")
    with pytest.raises(flexmb.UnknownJointError, match=r"'ball_joint'.*cross_flexure"):
        m.add_joint("A", "B", "ball_joint")


def test_unknown_joint_error_message_is_readable():
    """UnknownJointError is also a KeyError, whose str() would be the quoted repr of the message."""
    with pytest.raises(flexmb.UnknownJointError) as info:
        flexmb.joint("ball_joint")
    assert str(info.value).startswith("unknown joint 'ball_joint'")


def test_duplicate_link_and_joint_names_are_rejected_naming_them():
    m = pivot_2d()
    with pytest.raises(flexmb.ModelError, match="'B'"):
        m.add_link("B")
    with pytest.raises(flexmb.ModelError, match="'pivot'"):
        m.add_joint("A", "B", "cross_flexure", name="pivot")


def test_joint_parameters_with_a_joint_instance_are_rejected():
    m = flexmb.Mechanism(dim=2)
    m.add_link("A", fixed=True)
    m.add_link("B")
    with pytest.raises(flexmb.ModelError, match="joint parameters"):
        m.add_joint("A", "B", CrossFlexure(), length=0.2)


def test_mechanism_dimension_other_than_2_or_3_is_rejected():
    with pytest.raises(flexmb.ParameterError, match=names("dim", 4)):
        flexmb.Mechanism(dim=4)


# ---------------------------------------------------------------------------
# Loads and prescribed motions
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [NAN, INF, -INF])
def test_non_finite_force_is_rejected_naming_link_and_parameter(bad):
    m = pivot_2d()
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bforce\b"):
        m.apply_force("B", (0.0, bad))
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bpoint\b"):
        m.apply_force("B", (0.0, 1.0), point=(bad, 0.0))


@pytest.mark.parametrize("bad", [NAN, INF, -INF])
def test_non_finite_moment_is_rejected_naming_link_and_parameter(bad):
    m = pivot_2d()
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bmoment\b"):
        m.apply_moment("B", bad)
    m3 = flexmb.models.cross_flexure_pivot(elements_per_leaf=1)
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bmoment\b"):
        m3.apply_moment("B", (0.0, 0.0, bad))


def test_rejected_loads_are_not_recorded():
    """A rejected load leaves the mechanism as it was: solving it afterwards gives the unloaded state."""
    m = pivot_2d()
    for call in (lambda: m.apply_force("B", (NAN, 0.0)), lambda: m.apply_moment("B", INF)):
        with pytest.raises(flexmb.ParameterError):
            call()
    sol = flexmb.solve(m)
    assert sol.converged
    np.testing.assert_allclose(sol.displacement("B"), 0.0, atol=1e-15)


@pytest.mark.parametrize("bad", [NAN, INF])
def test_non_finite_prescribed_motion_is_rejected_naming_the_component(bad):
    m = pivot_2d()
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\brotation\b"):
        m.prescribe("B", rotation=bad)
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bx\b"):
        m.prescribe("B", x=bad)


def test_prescribed_motion_on_a_fixed_link_is_rejected_naming_it():
    m = pivot_2d()
    with pytest.raises(flexmb.ModelError, match="'A'.*fixed"):
        m.prescribe("A", rotation=0.1)


def test_fixing_a_link_with_a_prescribed_motion_is_rejected_naming_it():
    m = pivot_2d()
    m.prescribe("B", rotation=0.1)
    with pytest.raises(flexmb.ModelError, match="'B'.*prescribed"):
        m.fix("B")


def test_prescribing_an_unknown_component_lists_the_valid_ones():
    m = pivot_2d()
    with pytest.raises(flexmb.ModelError, match=r"'z'.*x, y, rotation"):
        m.prescribe("B", z=0.0)  # a planar link has no z


# ---------------------------------------------------------------------------
# Shapes and names
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("position", [(0.0, 0.0, 0.0), (0.0,), [[0.0, 0.0]], ()])
def test_wrong_shape_link_position_is_rejected_naming_link_and_shape(position):
    m = flexmb.Mechanism(dim=2)
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*position.*\(2,\)"):
        m.add_link("B", position=position)
    assert "B" not in m.links


def test_wrong_shape_vectors_are_rejected_naming_the_parameter():
    m = pivot_2d()
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bforce\b.*\(2,\)"):
        m.apply_force("B", (1.0, 0.0, 0.0))
    with pytest.raises(flexmb.ParameterError, match=r"point 'tip'.*position"):
        m.add_point("B", "tip", (0.0, 0.0, 0.0))
    with pytest.raises(flexmb.ParameterError, match=r"joint 'j2'.*origin"):
        m.add_joint("A", "B", "cross_flexure", name="j2", origin=(0.0,))
    m3 = flexmb.models.cross_flexure_pivot(elements_per_leaf=1)
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*rotation.*\(3,\)"):
        m3.prescribe("B", rotation=0.1)  # 3D: a rotation vector, not an angle
    with pytest.raises(flexmb.ParameterError, match=r"link 'B'.*\bmoment\b.*\(3,\)"):
        m3.apply_moment("B", 1.0)


def test_non_rotation_matrix_is_rejected_naming_the_joint():
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B")
    with pytest.raises(flexmb.ParameterError, match=r"joint 'j'.*rotation"):
        m.add_joint("A", "B", "cross_flexure", name="j", rotation=2.0 * np.eye(3))


def test_rotation_matrix_within_the_tolerance_is_made_an_exact_rotation():
    """A matrix orthonormal to 1e-9 is accepted as its nearest rotation (polar factor), so the
    joint's element frames turned with it stay orthonormal to rounding."""
    from flexmb.rotations import expm_so3

    R = expm_so3(np.array([0.3, -0.2, 0.5]))
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B")
    m.add_joint("A", "B", "cross_flexure", name="j", rotation=R + 4e-10 * np.eye(3))
    P = m.graph.edges["A", "B", "j"]["placement"].rotation
    assert np.abs(P.T @ P - np.eye(3)).max() < 1e-15
    assert np.abs(P - R).max() < 1e-9


@pytest.mark.parametrize(
    "call",
    [
        lambda m: m.link("Z"),
        lambda m: m.add_joint("A", "Z", "cross_flexure"),
        lambda m: m.add_joint("Z", "B", "cross_flexure"),
        lambda m: m.apply_force("Z", (1.0, 0.0)),
        lambda m: m.apply_moment("Z", 1.0),
        lambda m: m.prescribe("Z", rotation=0.1),
        lambda m: m.fix("Z"),
        lambda m: m.add_point("Z", "tip", (0.0, 0.0)),
    ],
    ids=["link", "add_joint_b", "add_joint_a", "apply_force", "apply_moment", "prescribe", "fix", "add_point"],
)
def test_unknown_link_name_is_rejected_naming_it_and_the_known_links(call):
    m = pivot_2d()
    with pytest.raises(flexmb.ModelError, match=r"'Z'.*'A', 'B'"):
        call(m)


def test_unknown_link_name_in_a_solution_is_rejected_naming_it():
    m = pivot_2d()
    sol = flexmb.solve(m)
    for query in (sol.pose, sol.displacement, sol.reaction, sol.rotation_vector):
        with pytest.raises(flexmb.ModelError, match="'Z'"):
            query("Z")


def test_unknown_point_name_in_a_solution_is_rejected_naming_it():
    m = pivot_2d()
    m.add_point("B", "tip", (0.0, 0.1))
    sol = flexmb.solve(m)
    with pytest.raises(flexmb.ModelError, match="'nose'"):
        sol.point("B", "nose")


# ---------------------------------------------------------------------------
# Solver choice and options (through flexmb.solve)
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["newton-raphson", "Conventional", ""])
def test_unknown_solver_method_is_rejected_listing_the_available_ones(method):
    with pytest.raises(flexmb.UnsupportedStrategyError, match=rf"{re.escape(repr(method))}.*conventional"):
        flexmb.solve(pivot_2d(), method)


@pytest.mark.parametrize("method", [None, 42])
def test_solver_method_that_is_neither_a_name_nor_a_strategy_is_rejected(method):
    with pytest.raises(flexmb.FlexmbError, match="method"):
        flexmb.solve(pivot_2d(), method)


def test_unknown_solver_option_is_rejected_naming_it():
    with pytest.raises(flexmb.UnsupportedStrategyError, match="tolerance"):
        flexmb.solve(pivot_2d(), tolerance=1e-9)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("tol", -1.0),
        ("tol", 0.0),
        ("tol", NAN),
        ("tol", INF),  # every residual is below inf: "converged" would mean nothing
        ("tol", "1e-9"),
        ("max_iter", 0),
        ("max_iter", 2.5),
        ("min_step", 0.0),
        ("min_step", NAN),
        ("initial_step", 0.0),
        ("initial_step", 1.5),  # a load factor step beyond the whole load
        ("initial_step", NAN),
        ("divergence", -1.0),
    ],
)
def test_invalid_solver_option_value_is_rejected_naming_it(option, value):
    with pytest.raises(flexmb.ParameterError, match=rf"\b{option}\b"):
        flexmb.solve(pivot_2d(), **{option: value})


@pytest.mark.parametrize("value", [1.0, 5.0, 0.0, -1e-3, NAN, INF])
def test_a_relative_tolerance_outside_zero_to_one_is_refused_naming_the_range(value):
    # rtol >= 1 accepted every state as converged (the undeformed one included): a silent wrong answer
    with pytest.raises(flexmb.ParameterError, match=r"rtol=.*(valid range \(0, 1\)|finite)"):
        flexmb.solve(pivot_2d(), rtol=value)
    with pytest.raises(flexmb.ParameterError, match=r"rtol=.*(valid range \(0, 1\)|finite)"):
        flexmb.trace(pivot_2d(), rtol=value, progress=False)


# ---------------------------------------------------------------------------
# Non-convergence is reported, not hidden
# ---------------------------------------------------------------------------

ROTATION = math.radians(75)
TOL = 5e-7  # the solver's default, the KSD paper's threshold


def hard_pivot() -> flexmb.Mechanism:
    """The cross-flexure pivot of Dwarshuis et al. (2020) rotated 75 degrees in one go."""
    return flexmb.models.cross_flexure_pivot(elements_per_leaf=3, rotation=ROTATION)


def test_starved_solver_reports_non_convergence_with_the_load_factor_reached():
    """max_iter=1 allows one Newton correction per step, far too few for a 75-degree rotation.

    Step control (`newton_steps`, the continuation): the full step's linear predictor stretches
    the leaves by more than 10 %, so the step is shortened before any iteration, to min_step = 0.3
    at most (not a rejection); its one correction fails, it is halved to 0.15 < min_step and the
    solver gives up. So no step was accepted: load factor 0, one rejected step, one residual
    recorded per attempt. (Fig. 18's control, before issue 31's stretch bound: 1.0 and 0.5 failed.)
    """
    sol = flexmb.solve(hard_pivot(), max_iter=1, min_step=0.3)
    assert sol.converged is False
    assert re.search(r"not converged", sol.message), sol.message
    assert re.search(r"load factor 0\b", sol.message), sol.message
    assert sol.load_factor == 0.0
    assert sol.steps == 0 and sol.rejected_steps == 1
    assert len(sol.residual_history) == sol.iterations == 1
    paper = flexmb.solve(hard_pivot(), max_iter=1, min_step=0.3, step_control="paper")
    assert paper.steps == 0 and paper.rejected_steps == 2 and len(paper.residual_history) == paper.iterations == 2
    assert np.all(sol.residual_history > TOL), "an honest failure: no iteration was within tolerance"


def test_the_same_pivot_converges_with_default_options():
    """The failure above comes from the starved options, not from the model."""
    sol = flexmb.solve(hard_pivot())
    assert sol.converged, sol.message
    assert sol.load_factor == 1.0
    assert sol.residual_history[-1] < TOL
    np.testing.assert_allclose(sol.rotation_vector("B")[2], ROTATION, rtol=1e-12)


def test_raise_on_failure_raises_convergence_error_carrying_the_solution():
    with pytest.raises(flexmb.ConvergenceError, match=r"not converged.*load factor 0\b") as info:
        flexmb.solve(hard_pivot(), max_iter=1, min_step=0.3, raise_on_failure=True)
    assert info.value.solution is not None
    assert info.value.solution.converged is False
    assert len(info.value.solution.residual_history) > 0


def test_failed_solve_leaves_the_mechanism_unchanged_and_usable():
    """Mechanism docstring: "Solving never modifies the mechanism". After a failed solve the same
    mechanism converges with default options to exactly what a freshly built one gives (same
    inputs, deterministic algorithm: agreement to rounding, rtol 1e-12)."""
    m = hard_pivot()
    before = (dict(m.links), dict(m.joints), m.prescribed("B"), list(m._loads))
    failed = flexmb.solve(m, max_iter=1, min_step=0.3)
    assert not failed.converged
    assert (dict(m.links), dict(m.joints), m.prescribed("B"), list(m._loads)) == before

    again = flexmb.solve(m)
    fresh = flexmb.solve(hard_pivot())
    assert again.converged and fresh.converged
    assert again.iterations == fresh.iterations
    np.testing.assert_allclose(again.node_positions(), fresh.node_positions(), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(again.reaction("B"), fresh.reaction("B"), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(again.pose("B")[1], fresh.pose("B")[1], rtol=1e-12, atol=1e-15)


# -- found in review: bare exceptions from public calls -------------------------------------------

@pytest.mark.parametrize("call", [
    lambda m: m.add_joint("A", "B", flexmb.LeafSpring(), rotation="abc"),
    lambda m: m.add_joint("A", "B", flexmb.LeafSpring(), rotation=[[1, 0], [0]]),
    lambda m: m.link(["A"]),
    lambda m: flexmb.solve(None),
    lambda m: flexmb.models.cross_flexure_pivot(lenght=0.1),
    lambda m: flexmb.models.cantilever(lenght=0.1),
    lambda m: flexmb.Mechanism(dim=2.0),
    lambda m: flexmb.solve(m, min_step=2.0),
    lambda m: flexmb.solve(m, divergence=0.5),
    lambda m: flexmb.solve(m, raise_on_failure="no"),
])
def test_review_findings_raise_flexmb_errors(call):
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.1, 0, 0))
    with pytest.raises(flexmb.FlexmbError):
        call(m)


def test_plugin_mesh_with_cross_section_axis_along_the_element_is_refused():
    import attrs

    class Bad(flexmb.LeafSpring):
        def mesh(self, dim):
            mesh = super().mesh(dim)
            return attrs.evolve(mesh, ny0=np.tile([1.0, 0.0, 0.0], (len(mesh.elements), 1)))

    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.1, 0, 0))
    m.add_joint("A", "B", Bad(), name="bad")
    with pytest.raises(flexmb.ModelError, match="'bad'.*ny0"):
        flexmb.solve(m)


def test_plugin_mesh_with_a_zero_length_element_is_refused_naming_joint_and_element():
    import attrs

    class Bad(flexmb.LeafSpring):
        def mesh(self, dim):
            mesh = super().mesh(dim)
            el = np.array(mesh.elements)
            el[1, 1] = el[1, 0]  # element 1 from a point to itself
            return attrs.evolve(mesh, elements=el)

    for dim in (2, 3):
        m = flexmb.Mechanism(dim=dim)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(0.1, 0, 0)[:dim])
        m.add_joint("A", "B", Bad(), name="bad")
        with pytest.raises(flexmb.ModelError, match="'bad'.*element 1 has zero length"):
            flexmb.solve(m)


def test_peak_stress_of_a_closed_form_solution_is_refused_naming_the_method():
    """The closed-form model (method='newton') has no beam elements, so no stresses: a flexmb
    error that says so and names the method that has them, not an AttributeError."""
    sol = flexmb.solve(flexmb.models.gripper(force=10.0), method="newton")
    with pytest.raises(flexmb.UnsupportedStrategyError, match="'newton'.*conventional"):
        sol.peak_stress()
