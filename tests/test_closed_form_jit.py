"""The compiled closed-form linkage (flexmb.closed_form.linkage_jit) against the numpy code it
replaces (issue 21 items 1 and 3).

Residual and every tangent term agree to 1e-12 (relative to the largest entry) in deformed
states; whole solves give the same iterations and equilibria (1e-12 m) with either path for the
three tangents; the compiled force sweep gives the per-solve path's answers, builds its
Solutions on demand, keeps failures and raises when asked. The gripper is the paper's case; the
parallel-leaf stage in SI, loaded away from its reference point, is one no paper contains.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb
from flexmb import jit
from flexmb.fe.model import State
from flexmb.joints import LeafSpring
from flexmb.sweeps import iter_sweep

pytestmark = pytest.mark.skipif(not jit._AVAILABLE, reason="numba not installed (the numpy path is the only one)")


@pytest.fixture
def numpy_path():
    """Run the body with the numpy kernels, restoring the choice afterwards."""
    def call(fn, *args, **kw):
        previous = jit.use("numpy")
        try:
            return fn(*args, **kw)
        finally:
            jit.use("numba" if previous else "numpy")
    return call


@pytest.fixture
def compiled_path():
    """The compiled kernels for the test (also when the suite runs with FLEXMB_KERNELS=numpy)."""
    previous = jit.use("numba")
    yield
    jit.use("numba" if previous else "numpy")


def _stage(force: float = 0.0) -> flexmb.Mechanism:
    """A stage on two parallel 60 mm leaves (SI), its actuation 15 mm off its reference point
    (so the dead force has a load stiffness) and a dead moment."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("stage", position=(0.06, 0.0))
    for name, y in (("upper", 0.02), ("lower", -0.02)):
        m.add_joint("ground", "stage", LeafSpring(length=0.06, thickness=8e-4), name=name, origin=(0.0, y))
    m.set_actuation("stage", (0.2, 1.0), value=force, point=(0.075, 0.005))
    m.apply_moment("stage", 0.3)
    return m


def _rel(a, b):
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def _cases():
    return [("gripper", flexmb.models.gripper(force=40.0)), ("gripper linear", flexmb.models.gripper(model="linear")),
            ("stage", _stage(20.0))]


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("case", range(3))
def test_residual_and_every_term_equal_numpy(case, seed, numpy_path):
    name, m = _cases()[case]
    problem = m.compile("closed_form").problem
    rng = np.random.default_rng(seed)
    x0 = problem.model.x0
    state = State(x0 + 0.05 * np.abs(x0).max() * rng.normal(size=x0.shape), 0.3 * rng.normal(size=len(x0)))
    r, terms = problem.evaluate(state)
    r0, terms0 = numpy_path(problem.evaluate, state)
    assert _rel(r, r0) < 1e-12, name
    assert problem.evaluate(state, tangent=False)[1] is None
    assert _rel(problem.evaluate(state, tangent=False)[0], r0) < 1e-12
    for key in terms0:
        assert _rel(terms[key], terms0[key]) < 1e-12 or np.abs(terms0[key]).max() == 0 == np.abs(terms[key]).max()
    if name == "stage":  # the offset actuation and the moment: a load stiffness on theta
        assert np.abs(terms0["load"]).max() > 0


@pytest.mark.parametrize("tangent", ["full", "first-term", "constant"])
@pytest.mark.parametrize("case", range(3))
def test_solves_equal_numpy(case, tangent, numpy_path):
    name, m = _cases()[case]
    sol = flexmb.solve(m, method="newton", tangent=tangent, max_iter=400)
    ref = numpy_path(flexmb.solve, m, method="newton", tangent=tangent, max_iter=400)
    assert sol.converged == ref.converged and sol.iterations == ref.iterations, (name, sol.message, ref.message)
    assert sol.message == ref.message
    np.testing.assert_allclose(sol.state.positions, ref.state.positions, rtol=0, atol=1e-12 * np.abs(ref.state.positions).max())
    np.testing.assert_allclose(sol.state.rotations, ref.state.rotations, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.residual_history, ref.residual_history, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("start", ["previous", "undeformed"])
@pytest.mark.parametrize("tangent", ["full", "constant"])
def test_compiled_sweep_equals_the_per_solve_path(start, tangent, compiled_path):
    """`sweep` (compiled loops, Solutions on demand) = `iter_sweep` (one `solve` per force)."""
    for m, forces in ((flexmb.models.gripper(), np.linspace(-60.0, 140.0, 21)), (_stage(), np.linspace(-40, 60, 11))):
        fast = flexmb.sweep(m, forces, method="newton", tangent=tangent, start=start)
        # built so far: only what the sweep's plausibility check reads (each failed value and the
        # converged value that moved farthest, flexmb.sweeps._checked_lazily), not one per force
        assert len(fast.solutions._built) <= 1 + int(np.sum(~fast.converged))
        assert len(fast.solutions._built) <= 1 + int(np.sum(~fast.converged))  # reading the flags builds nothing
        slow = list(iter_sweep(m, forces, method="newton", tangent=tangent, start=start))
        assert len(fast) == len(slow) == len(forces)
        for a, b in zip(fast, slow):
            # the starts differ by rounding (prescribed_state re-adds x0), so the last residuals by ~1e-12
            assert (a.converged, a.iterations) == (b.converged, b.iterations)
            assert a.message.split(":")[0] == b.message.split(":")[0]
            np.testing.assert_allclose(a.state.positions, b.state.positions, rtol=0, atol=1e-12)
            np.testing.assert_allclose(a.residual, b.residual, rtol=0, atol=1e-9)
            assert a.compiled.problem.loads.force.tolist() == b.compiled.problem.loads.force.tolist()
        link = list(fast[0].compiled.link_node)[1]
        np.testing.assert_allclose(fast.table()[f"{link}.x"], [s.pose(link)[0][0] for s in slow], rtol=0, atol=1e-12)
        assert fast[-1] is fast[len(forces) - 1] and len(fast[2:5]) == 3


@pytest.fixture(params=["numba", "numpy"])
def either_path(request):
    """The test once with each kernel path."""
    previous = jit.use(request.param)
    yield request.param
    jit.use("numba" if previous else "numpy")


def test_sweep_keeps_failures_and_raises_when_asked(either_path):
    """A force far beyond the gripper's range fails within max_iter=3; the others are kept; the
    failed Solution holds its start state (as a `solve` would)."""
    forces = [10.0, 1e6, 20.0]
    res = flexmb.sweep(flexmb.models.gripper(), forces, method="newton", max_iter=3)
    assert res.converged.tolist() == [True, False, True]
    assert "not converged" in res[1].message
    np.testing.assert_array_equal(res[1].state.positions, res[0].state.positions)  # warm start from force 1
    with pytest.raises(flexmb.ConvergenceError):
        flexmb.sweep(flexmb.models.gripper(), forces, method="newton", max_iter=3, raise_on_failure=True)
