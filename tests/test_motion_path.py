"""Curved prescribed motions (`Mechanism.prescribe`'s ``path``, `flexmb.problem.motion_path`): the
load steps follow the given curve, the equilibrium at load factor 1 is the straight line's; the
manipulator's location case (Dwarshuis et al. 2020, Sec. 4.4) moves its end point along the
mechanism's kinematic path."""

from __future__ import annotations

import numpy as np
import pytest

import flexmb
from flexmb.errors import ModelError, ParameterError
from flexmb.problem import motion_path, path_load_factors


def _straight(build):
    m = build()
    for name in m.links:
        if "path" in m.prescribed(name):
            m.prescribe(name, path=None)
    return m


@pytest.mark.parametrize("deg", [-45.0, 45.0])
def test_location_case_at_45_degrees_within_60_iterations_same_equilibrium(deg):
    # issue 31: the straight end-point line took 89 / 89 iterations (joint 3 to 56 deg and back);
    # along the kinematic path 45 / 39. The same equilibrium: positions to round-off, reactions
    # within the convergence tolerance of a tightly converged solve of the straight line
    build = lambda: flexmb.models.manipulator("location", np.radians(deg))  # noqa: E731
    curved = flexmb.solve(build())
    assert curved.converged and curved.iterations <= 60, curved.iterations
    tight = flexmb.solve(_straight(build), rtol=1e-13)
    x = tight.node_positions()
    np.testing.assert_allclose(curved.node_positions(), x, rtol=0, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(curved.reaction("link3")[:3], tight.reaction("link3")[:3], rtol=0,
                               atol=curved.tolerance)


def test_a_curved_path_is_followed_and_ends_where_the_line_does():
    # beyond the papers: a 2D cantilever's tip moved along a bulging curve (its waypoints at the
    # Chebyshev-Lobatto load factors), against the straight line to the same displacement
    def build(path=True):
        m = flexmb.models.cantilever(elements=8, dim=2)
        end = np.array([-0.002, 0.02])
        lam = path_load_factors(6)
        arc = lam[:, None] * end + 0.01 * np.sin(np.pi * lam)[:, None] * np.array([-0.3, 1.0])
        arc[-1] = end
        m.prescribe("tip", x=end[0], y=end[1], rotation=0.0, path=arc if path else None)
        return m, arc, lam

    m, arc, lam = build()
    problem = m.compile().problem
    slots = np.searchsorted(problem.prescribed, problem.motion_paths[0][0])
    for k, at in enumerate(lam):  # the polynomial passes through the waypoints
        np.testing.assert_allclose(problem.prescribed_increment(at, 0.0)[slots], arc[k], rtol=0, atol=1e-15)
    h = 1e-6  # curve_rate: the derivative of the prescribed motion's offset from its line
    fd = (problem.prescribed_increment(h, 0.4) - problem.prescribed_increment(-h, 0.4)) / (2 * h)
    np.testing.assert_allclose(fd, problem._motion_scale * problem.values + problem.curve_rate(0.4), atol=1e-8)
    curved, line = flexmb.solve(m), flexmb.solve(build(path=False)[0], rtol=1e-13)
    assert curved.converged
    x = line.node_positions()
    np.testing.assert_allclose(curved.node_positions(), x, rtol=0, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(curved.reaction("tip"), line.reaction("tip"), rtol=0, atol=curved.tolerance)


def test_a_new_motion_drops_the_path():
    # a sweep's warm start moves on from another state: the straight line from there
    m = flexmb.models.manipulator("location", np.radians(30))
    problem = m.compile().problem
    assert problem.motion_paths and not problem.with_motion(problem.values).motion_paths


def test_the_offset_is_zero_at_both_ends():
    end = np.array([1.0, -2.0])
    pts = np.array([[0.3, 0.1], [0.9, -1.0], end])
    curve = motion_path(pts, end)
    np.testing.assert_allclose(curve(0.0), 0.0, atol=1e-15)
    np.testing.assert_allclose(curve(1.0), 0.0, atol=1e-15)


@pytest.mark.parametrize("path, error, words", [
    (np.zeros((3, 2)), ParameterError, "shape (m, 3)"),
    ([[0.0, 0.0, np.nan]], ParameterError, "finite"),
    ([[0.1, 0.0, 0.0]], ModelError, "not at the prescribed displacement"),
])
def test_a_bad_path_names_the_link(path, error, words):
    m = flexmb.models.manipulator("location", np.radians(10))
    with pytest.raises(error, match="link3") as exc:
        m.prescribe("link3", path=path)
        m.compile()
    assert words in str(exc.value)


def test_a_path_needs_every_translation():
    m = flexmb.models.cantilever(elements=4, dim=3)
    m.prescribe("tip", x=0.01, path=[[0.01, 0.0, 0.0]])
    with pytest.raises(ModelError, match="'tip'.*x, y, z"):
        m.compile()


def test_a_new_displacement_drops_the_old_path():
    # a motion sweep sets x again: the path led to the old end point, the new one is reached straight
    m = flexmb.models.manipulator("location", np.radians(30))
    x = m.prescribed("link3")["x"]
    m.prescribe("link3", x=x + 0.01)
    assert "path" not in m.prescribed("link3") and not m.compile().problem.motion_paths


def test_the_papers_control_keeps_the_straight_line():
    # Fig. 18 as published (step_control="paper") moves the end point on the straight line: the same
    # steps and numbers with and without the path (30 deg: 676 iterations, the papers' baseline)
    build = lambda: flexmb.models.manipulator("location", np.radians(30))  # noqa: E731
    a, b = flexmb.solve(build(), step_control="paper"), flexmb.solve(_straight(build), step_control="paper")
    assert a.iterations == b.iterations and np.array_equal(a.node_positions(), b.node_positions())
