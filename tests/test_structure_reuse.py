"""A new mechanism of an already compiled structure (a design loop's `build(p)`) reuses the
structure's sparsity pattern, linear-solver analysis and KSD set-up, found by its structure, not
its identity (issue 31 item 1), and gives the answers it gives without that reuse, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import flexmb
from flexmb import compiled as compiled_module
from flexmb import models
from flexmb.compiled import compiled_for


@pytest.fixture
def no_reuse(monkeypatch):
    """Structure reuse switched off (and its store emptied) inside the test."""
    monkeypatch.setattr(compiled_module, "STRUCTURES_KEPT", 0)
    monkeypatch.setattr(compiled_module._LOCAL, "structures", {}, raising=False)


def _solve_all(builds, method):
    return [flexmb.solve(build(), method=method) for build in builds]


def _same(a, b) -> None:
    assert a.converged and b.converged
    assert a.iterations == b.iterations
    assert np.array_equal(a.node_positions(), b.node_positions())
    assert np.array_equal(a.residual, b.residual)


# beyond the papers: the four-bar's links moved (its width and height, so every placement and link
# position changes), and its leaves made thicker (other joint values, other element stiffnesses)
PLACEMENTS = [lambda w=w, h=h: models.fourbar(2, displacement=0.2, width=w, height=h)
              for w, h in ((0.4, 0.3), (0.35, 0.25), (0.5, 0.32))]
THICKNESS = [lambda t=t: models.fourbar(2, displacement=0.2, thickness=t) for t in (1e-3, 0.8e-3, 1.2e-3)]


@pytest.mark.parametrize("method", ["conventional", "ksd-reduced", "ksd-full"])
def test_a_design_loop_gives_the_answers_of_separate_solves(method, request):
    reused = _solve_all(PLACEMENTS, method)
    request.getfixturevalue("no_reuse")
    for a, b in zip(reused, _solve_all(PLACEMENTS, method)):
        _same(a, b)


def test_other_joint_values_reuse_the_pattern_and_give_the_same_answers(request):
    reused = _solve_all(THICKNESS, "conventional")
    request.getfixturevalue("no_reuse")
    for a, b in zip(reused, _solve_all(THICKNESS, "conventional")):
        _same(a, b)


def test_the_structure_is_found_by_its_topology_not_its_identity():
    """Two separately built mechanisms of one topology: the second's problem holds the first's
    pattern and solver, and KSD's set-up moved to its own numbers; another mesh gets its own."""
    first = PLACEMENTS[0]()
    flexmb.solve(first, method="ksd-reduced")
    flexmb.solve(first)
    c1 = compiled_for(first)
    c2 = compiled_for(PLACEMENTS[1]())
    assert vars(c2.problem)["_pattern"] is vars(c1.problem)["_pattern"]
    assert vars(c2.problem)["_tangent_solver"] is vars(c1.problem)["_tangent_solver"]
    (setup,) = c2.derived.values()
    assert setup.compiled is c2 and not np.array_equal(setup.X0, c1.derived[("ksd", None)].X0)
    finer = compiled_for(models.fourbar(3, displacement=0.2))
    assert "_pattern" not in vars(finer.problem)


def test_a_rebound_set_up_equals_a_new_one():
    """`ReducedMechanism.rebind` to another placement: the numbers a new set-up computes."""
    from flexmb.ksd.reduced import ReducedMechanism

    a, b = PLACEMENTS[0]().compile(), PLACEMENTS[2]().compile()
    moved, built = ReducedMechanism(a).rebind(b), ReducedMechanism(b)
    for name in ("X0", "b0", "D0", "values", "load_offset", "load_force", "load_moment"):
        assert np.array_equal(getattr(moved, name), getattr(built, name)), name
    for name in ("a", "b", "s_a", "s_b", "P"):
        assert np.array_equal(getattr(moved.frames, name), getattr(built.frames, name)), name
    assert ReducedMechanism(a).rebind(models.fourbar(3, displacement=0.2).compile()) is None


def test_location_case_unchanged_by_reuse(request):
    """The manipulator's location case (its end point from the joint case's kinematics, whose
    set-up is reused across calls) at three rotations, against the same without reuse."""
    builds = [lambda r=r: models.manipulator("location", math.radians(r)) for r in (30, -20, 45)]
    reused = _solve_all(builds, "ksd-reduced")
    request.getfixturevalue("no_reuse")
    for a, b in zip(reused, _solve_all(builds, "ksd-reduced")):
        _same(a, b)
