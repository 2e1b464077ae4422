"""The compiled element kernels (numba) against the numpy code they replace (issue 21 item 1).

Both paths must agree to 1e-12 (relative to the largest entry) on every output, in deformed
states, with and without a geometric-stress override, and mark invalid elements alike; and whole
solves must give the same equilibrium and Newton iterations with either path.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb
from flexmb import jit
from flexmb.fe import beam2d, beam3d
from flexmb.rotations import expm_so3
from flexmb.sections import rectangle

pytestmark = pytest.mark.skipif(not jit._AVAILABLE, reason="numba not installed (the numpy path is the only one)")


def _rel(a, b):
    """Largest difference relative to the largest entry; NaN entries (invalid elements) must match."""
    assert np.array_equal(np.isnan(a), np.isnan(b))
    a, b = a[~np.isnan(a)], b[~np.isnan(b)]
    return float(np.abs(a - b).max() / max(np.abs(a).max(), 1e-300))


def _batch3d(rng, n=60, turn=0.4):
    L0 = rng.uniform(1e-3, 5e-2, n)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    xp = rng.normal(size=(n, 3)) * 0.01
    xq = xp + d * L0[:, None] * (1 + 0.02 * rng.normal(size=(n, 1)))
    t = rng.normal(size=(n, 3))
    ny0 = t - (t * d).sum(1)[:, None] * d
    ny0 /= np.linalg.norm(ny0, axis=1)[:, None]
    nz0 = np.cross(d, ny0)
    Rp, Rq = expm_so3(turn * rng.normal(size=(n, 3))), expm_so3(turn * rng.normal(size=(n, 3)))
    sections = [rectangle(w, t, 200e9, 77e9) for w, t in zip(rng.uniform(5e-3, 2e-2, n), rng.uniform(1e-4, 1e-3, n))]
    return xp, xq, Rp, Rq, ny0, nz0, L0, beam3d.local_stiffness(sections, L0)


def _batch2d(rng, n=60, turn=1.0):
    L0 = rng.uniform(1e-3, 5e-2, n)
    a = rng.uniform(-np.pi, np.pi, n)
    xp = rng.normal(size=(n, 2)) * 0.01
    xq = xp + np.stack([np.cos(a), np.sin(a)], 1) * L0[:, None] * (1 + 0.02 * rng.normal(size=(n, 1)))
    sections = [rectangle(0.01, 5e-4, 200e9, 77e9)] * n
    alpha0 = a + 0.1 * rng.normal(size=n)
    return (xp, xq, turn * rng.normal(size=n), turn * rng.normal(size=n), alpha0, L0,
            beam2d.local_stiffness(sections, L0))


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("override", [None, lambda s: 0.5 * s + 1.0])
def test_3d_kernel_equals_numpy(seed, override):
    args = _batch3d(np.random.default_rng(seed))
    ref = beam3d.numpy_internal_force_and_tangent(*args, geometric_stress=override)
    from flexmb.fe import beam3d_jit

    got = beam3d_jit.internal_force_and_tangent(*args, True, override)
    for a, b in zip(ref, got):
        assert _rel(a, b) < 1e-12
    F = beam3d_jit.internal_force_and_tangent(*args, False, None)
    assert F[1] is None and _rel(ref[0], F[0]) < 1e-12


def test_3d_kernel_marks_invalid_elements_like_numpy():
    xp, xq, Rp, Rq, ny0, nz0, L0, S = _batch3d(np.random.default_rng(3))
    Rq[:5] = expm_so3(np.tile([np.pi * 0.9, 0.0, 0.0], (5, 1))) @ Rq[:5]  # sections twisted far apart
    Rp[5:8] = expm_so3(np.cross(ny0[5:8], nz0[5:8]) * 0 + ny0[5:8] * 2.0) @ Rp[5:8]  # axis past 90 deg
    ref = beam3d.numpy_internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S)
    from flexmb.fe import beam3d_jit

    got = beam3d_jit.internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S)
    bad = np.isnan(ref[2]).any(axis=1)
    assert bad.sum() >= 5
    for a, b in zip(ref, got):
        assert _rel(a[~bad], b[~bad]) < 1e-12
        assert np.isnan(a[bad]).all() and np.isnan(b[bad]).all()


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("override", [None, lambda s: -2.0 * s])
def test_2d_kernel_equals_numpy(seed, override):
    args = _batch2d(np.random.default_rng(seed))
    ref = beam2d.numpy_internal_force_and_tangent(*args, geometric_stress=override)
    from flexmb.fe import beam2d_jit

    got = beam2d_jit.internal_force_and_tangent(*args, True, override)
    for a, b in zip(ref, got):
        assert _rel(a, b) < 1e-12


def _deformed(problem, seed):
    """A state of ``problem`` away from equilibrium: every node moved and turned at random."""
    model = problem.model
    rng = np.random.default_rng(seed)
    du = rng.normal(size=model.n_dofs)
    size = np.ptp(model.x0, axis=0).max()
    du[: model.n_node_dofs] *= np.tile(np.where(np.arange(model.ndof) < model.dim, 1e-3 * size, 0.1), model.n_nodes)
    return model.apply_increment(model.initial_state(), du)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("override", [None, lambda s: 0.5 * s + 1.0])
def test_compiled_assembly_equals_numpy(kernels, dim, override):
    # the four-bar (Dwarshuis et al. 2020 Sec. 4.3) in 2D and 3D: its connector blocks put element
    # ends at offsets from their link nodes, so the transfer to the masters is exercised
    problem = flexmb.models.fourbar(2, displacement=0.1, dim=dim).compile().problem
    assert problem.model._ends[2].any()
    state = _deformed(problem, dim)
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        r, Kff, Kfp, sig = problem.evaluate(state, 0.7, geometric_stress=override)
        if override is not None:  # the geometric stresses given as an array: the same tangent
            Kff_held = problem.evaluate(state, 0.7, geometric_stress=override(sig))[1]
            assert _rel(Kff_held.toarray(), Kff.toarray()) < 1e-12
        forces = problem.model.assemble(state)
        out[path] = (r, Kff.toarray(), Kfp.toarray(), sig, forces[0], forces[3], forces[4], forces[5],
                     np.array(problem.model.largest_by_kind(forces[3])), np.array(forces[6]))
    for a, b in zip(out["numpy"], out["numba"]):
        assert _rel(a, b) < 1e-12
    assert out["numba"][1].shape == (problem.n_free, problem.n_free) and np.isfinite(out["numba"][0]).all()


def test_compiled_rotation_updates_equal_numpy(kernels):
    # the spin update R <- exp(w) R (Eq. A.8) and its inverse log(R_to R_from^T), at angles up to
    # and across the near-pi branch of the logarithm (within 1e-3 of pi)
    model = flexmb.models.fourbar(1).compile().problem.model
    rng = np.random.default_rng(7)
    du = rng.normal(size=model.n_dofs)
    w = du.reshape(model.n_nodes, 6)[:, 3:]
    w *= (np.linspace(0.0, np.pi, model.n_nodes) / np.linalg.norm(w, axis=1))[:, None]  # 0 ... pi
    w[1] *= 1e-9 / np.linalg.norm(w[1])
    w[-2] *= (np.pi - 5e-4) / np.linalg.norm(w[-2])
    start = model.apply_increment(model.initial_state(), 0.3 * rng.normal(size=model.n_dofs))
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        moved = model.apply_increment(start, du)
        out[path] = (moved.rotations, model.increment(start, moved), np.array(model.largest_motion(du)))
    assert _rel(out["numpy"][0], out["numba"][0]) < 1e-14
    assert np.abs(out["numpy"][1] - out["numba"][1]).max() < 1e-12
    assert np.abs(out["numba"][1] - du).max() < 1e-9  # the logarithm inverts the update (angles < pi)
    assert np.array_equal(out["numpy"][2], out["numba"][2]) and out["numba"][2][1] == pytest.approx(np.pi)


@pytest.mark.parametrize("dim", [2, 3])
def test_whole_solves_agree_with_either_path(kernels, dim):
    # a case no paper has: a two-leaf cross flexure in mm-N-MPa units turned 40 degrees
    def solve():
        m = flexmb.models.cross_flexure_pivot(elements_per_leaf=4, dim=dim, rotation=np.radians(40.0),
                                              length=100.0, width_inner=20.0, width_outer=10.0,
                                              thickness=1.0, E=200e3, G=76.9e3)
        return flexmb.solve(m)

    kernels("numpy")
    a = solve()
    kernels("numba")
    b = solve()
    assert a.converged and b.converged and a.iterations == b.iterations
    assert _rel(a.node_positions(), b.node_positions()) < 1e-12
    assert _rel(a.reaction("B"), b.reaction("B")) < 1e-9


def test_ksd_rotation_updates_equal_numpy(kernels):
    # KSD's spin updates (Eq. A.8) on stacks of any leading shape, one rotation or a shared one,
    # angles 0 ... pi: the compiled Rodrigues terms equal expm_so3's
    from flexmb.ksd.geometry import compose, expm

    rng = np.random.default_rng(11)
    w = rng.normal(size=(4, 5, 3))
    w *= (np.linspace(0.0, np.pi, 20).reshape(4, 5) / np.linalg.norm(w, axis=-1))[..., None]
    R = expm_so3(rng.normal(size=(4, 5, 3)))
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        out[path] = (compose(w, R), compose(w[0], R[0, 0]), expm(w), expm(w[:0]))
    for a, b in zip(out["numpy"], out["numba"]):
        assert a.shape == b.shape and (a.size == 0 or _rel(a, b) < 1e-14)
    assert np.abs(out["numba"][0] - expm_so3(w) @ R).max() < 1e-14


def test_ksd_reduced_solves_agree_with_either_path(kernels):
    # the manipulator of Dwarshuis et al. (2020) Sec. 4.4, joint case at -30 degrees (not a figure's value)
    m = flexmb.models.manipulator("joint", np.radians(-30.0))
    kernels("numpy")
    a = flexmb.solve(m, method="ksd-reduced")
    kernels("numba")
    b = flexmb.solve(m, method="ksd-reduced")
    assert a.converged and b.converged
    assert np.abs(a.node_positions() - b.node_positions()).max() < 1e-12
    assert np.abs(a.state.rotations - b.state.rotations).max() < 1e-12


@pytest.mark.parametrize("case", ["manipulator", "fourbar"])
def test_ksd_equilibrium_kernel_equals_numpy(kernels, case):
    # KSD step 3's residual and tangent (Dwarshuis et al. 2020 Eq. 2.4 per joint) and the joints'
    # relative poses (node B in the joint frame, Sec. 2.2) at link poses
    # moved and turned at random, with random condensed stiffnesses and forces: the 3D
    # manipulator (Sec. 4.4) and the planar four-bar (Sec. 4.3) in 3D form
    from flexmb.ksd.geometry import intended_angle, rz
    from flexmb.solvers.ksd import reduced_mechanism

    m = (flexmb.models.manipulator("joint", np.radians(30.0)) if case == "manipulator"
         else flexmb.models.fourbar(2, displacement=0.1))
    red = reduced_mechanism(m.compile())
    rng = np.random.default_rng(5)
    J = len(red.joint_names)
    poses = red.rest().moved(np.concatenate([1e-3 * rng.normal(size=(red.n_links, 3)),
                                             0.3 * rng.normal(size=(red.n_links, 3))], axis=1))
    K = rng.normal(size=(J, 6, 6))
    K = K @ np.swapaxes(K, 1, 2) * 1e2
    Fh, p_hat, R_hat = rng.normal(size=(J, 6)), 1e-3 * rng.normal(size=(J, 3)), rz(rng.normal(size=J))
    tilt = expm_so3(rng.normal(size=(J, 3)))
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        r, T = red.equilibrium(poses, K, Fh, p_hat, R_hat, tangent=True)
        r2, deferred = red.equilibrium(poses, K, Fh, p_hat, R_hat, tangent="deferred")
        r3, none = red.equilibrium(poses, K, Fh, p_hat, R_hat, tangent=False)
        assert none is None and np.array_equal(r, r2) and np.array_equal(r, r3)
        assert np.array_equal(T, deferred())
        p, Rrel, geo = red.frames.relative(poses)  # the joints' relative poses (steps 1, 3, 4)
        theta, dtheta = intended_angle(Rrel @ tilt)  # tilted: every term of the gradient
        out[path] = r, T, p, Rrel, geo["F"], geo["Ft"], geo["rb"], geo["ra"], theta, dtheta
    for a, b in zip(out["numpy"], out["numba"]):
        assert a.shape == b.shape and _rel(a, b) < 1e-12


def _two_kinds(dim):
    """The four-bar (Dwarshuis et al. 2020 Sec. 4.3) with thicker upper flexures: two joint
    values, two constraint groups (not a paper case)."""
    import attrs

    m = flexmb.models.fourbar(2, displacement=0.1, dim=dim)
    thick = attrs.evolve(m.graph.edges["left", "top", "top_left"]["joint"], thickness=1.5e-3)
    for link, name in (("left", "top_left"), ("right", "top_right")):
        m.graph.edges[link, "top", name]["joint"] = thick
    return m


def _ksd_cases():
    """Mechanisms for the KSD kernels: the manipulator (Sec. 4.4) in both cases, at 45 deg and
    another rotation, the four-bar in 2D and 3D and with two joint kinds, the cross-flexure pivot
    in 2D and 3D (none of these but the 45 deg manipulator is a paper value)."""
    man = flexmb.models.manipulator
    return {"joint 45": lambda: man("joint", np.radians(45.0)), "location 45": lambda: man("location", np.radians(45.0)),
            "joint -20": lambda: man("joint", np.radians(-20.0)),
            "location -30": lambda: man("location", np.radians(-30.0)),
            "cross pivot 2d": lambda: flexmb.models.cross_flexure_pivot(dim=2, rotation=0.3),
            "cross pivot 3d": lambda: flexmb.models.cross_flexure_pivot(dim=3, rotation=-0.25),
            "fourbar 2d": lambda: flexmb.models.fourbar(3, displacement=0.05, moment=2.0, dim=2),
            "fourbar 3d": lambda: flexmb.models.fourbar(3, displacement=0.05, moment=2.0),
            "two kinds 2d": lambda: _two_kinds(2), "two kinds 3d": lambda: _two_kinds(3)}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.slow
def test_ksd_constraint_kernel_equals_numpy(kernels, dim):
    # KSD step 1's constraints (Dwarshuis et al. 2020 Sec. 2.2, every kind of row: x, y, z, tilts,
    # symmetric, length) at random deformed link poses: the compiled values and Jacobian equal
    # ReducedMechanism.constraint_equations' numpy ones
    from flexmb.ksd.kinematics import compiled_constraints
    from flexmb.ksd.reduced import ReducedMechanism

    for m in (_two_kinds(dim), flexmb.models.manipulator("joint", np.radians(30.0))):
        red = ReducedMechanism(m.compile())
        rng = np.random.default_rng(7)
        dz = np.zeros((red.n_links, 6))
        dz[:, red.active] = 0.05 * rng.standard_normal((red.n_links, len(red.active)))
        poses = red.rest().moved(dz)
        kernels("numpy")
        c, J, theta, p = red.constraint_equations(poses)
        kernels("numba")
        c2, J2, theta2, p2 = compiled_constraints(red, poses)
        for a, b in ((c, c2), (J, J2), (theta, theta2), (p, p2)):
            assert a.shape == b.shape and _rel(a, b) < 1e-12


@pytest.mark.parametrize("case", list(_ksd_cases()))
def test_ksd_kinematics_kernel_equals_numpy(kernels, case):
    # KSD step 1 (Sec. 2.2: Newton on the database constraints, the motion in steps) in one
    # compiled call against solve_kinematics' numpy loop: the same poses, rotations, iterations
    from flexmb.ksd.kinematics import solve_kinematics
    from flexmb.ksd.reduced import ReducedMechanism

    red = ReducedMechanism(_ksd_cases()[case]().compile())
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        out[path] = solve_kinematics(red, stop_beyond_half_turn=True)
    (a, ta, pa, ia), (b, tb, pb, ib) = out["numpy"], out["numba"]
    assert ia["iterations"] == ib["iterations"] and ia["removed_equations"] == ib["removed_equations"]
    assert ia["load_factor"] == ib["load_factor"] == 1.0
    assert np.allclose(ia["history"], ib["history"], rtol=1e-9, atol=1e-14)
    for u, v in ((a.x, b.x), (a.R, b.R), (a.angle, b.angle), (ta, tb), (pa, pb)):
        assert np.abs(u - v).max() <= 1e-12 * max(np.abs(u).max(), 1.0)


@pytest.mark.parametrize("case", list(_ksd_cases()))
def test_ksd_reduced_compiled_stages_equal_numpy(kernels, case):
    # KSD-reduced steps 1-4 (Dwarshuis et al. 2020 Sec. 2) with the compiled stages (one call each:
    # kinematics, tabulated EOBs, step 3's Newton loop, step 4) against the numpy path: the same
    # iterations, node positions and rotations to 1e-12, the reduced residual (reactions) to 1e-9
    # of its largest entry (its free entries are the converged residual, ~1e-11 N: roundoff)
    m = _ksd_cases()[case]()
    out = {}
    for path in ("numpy", "numba"):
        kernels(path)
        out[path] = flexmb.solve(m, method="ksd-reduced")
    a, b = out["numpy"], out["numba"]
    assert a.converged and b.converged and a.iterations == b.iterations
    assert a.stages["eob"]["tabulated"] == b.stages["eob"]["tabulated"]
    assert _rel(a.node_positions(), b.node_positions()) < 1e-12
    assert _rel(a.state.rotations, b.state.rotations) < 1e-12
    assert _rel(a.residual, b.residual) < 1e-9


def _table_2d():
    """A cross-flexure pivot's joint (2D, not the shipped table's joint) with its condensation
    tabulated on a coarse grid (flexmb.ksd.eob_table.tabulate) attached to its template."""
    from flexmb.ksd.eob_table import Lookup, tabulate
    from flexmb.ksd.reduced import ReducedMechanism

    red = ReducedMechanism(flexmb.models.cross_flexure_pivot(dim=2, rotation=0.3).compile())
    tpl = red.groups[0][0]
    return Lookup(tpl, tabulate(tpl, {}, step_deg=2.0, degree=5))


@pytest.mark.parametrize("dim", [2, 3])
def test_ksd_tabulated_eob_kernel_equals_numpy(kernels, dim):
    # step 2's tabulated condensation (Eqs. 2.4-2.6 sampled against theta, flexmb.ksd.eob_table):
    # the compiled de Boor evaluation equals scipy's BSpline to 1e-13 over the whole range and
    # beyond its ends by the slack, and eob_lookup's stiffness, force, recovery and near poses
    # equal Lookup.__call__'s; 3D: the manipulator's shipped table, 2D: a table made here
    from flexmb.ksd.geometry import ACTIVE
    from flexmb.ksd.reduced import ReducedMechanism
    from flexmb.ksd.reduced_jit import bspline

    if dim == 3:
        red = ReducedMechanism(flexmb.models.manipulator("joint", np.radians(10.0)).compile())
        lookup = red.groups[0][0].lookup
    else:
        lookup = _table_2d()
    lo, hi = lookup.range
    theta = np.concatenate([np.linspace(lo, hi, 301), [lo - 1e-9, hi + 1e-9, lo, hi]])
    kernels("numba")
    b = 1e-3 * np.random.default_rng(3).normal(size=(7, dim))
    K, F, rec, x_int, rot_int = lookup.compiled(theta[:7], b)
    # a group's joints in rows of the whole mechanism's arrays: the same numbers there
    at = np.array([6, 0, 1, 2, 3, 4, 5])
    K2, F2, rec2, *_ = lookup.compiled(theta[:9], np.concatenate([b, np.ones((2, dim))]), at)
    assert np.array_equal(K2[:7], K) and np.array_equal(F2[:7], F) and np.array_equal(rec2, rec[at])
    assert np.all(K2[7:] == 0.0) and np.all(F2[7:] == 0.0)
    t, c, k = lookup._compiled_args[:3]
    values = np.empty((len(theta), c.shape[1]))
    bspline(t, c, k, theta, values)
    assert np.abs(values - lookup._spline(theta)).max() <= 1e-13 * np.abs(lookup.table.values).max()
    kernels("numpy")
    e = lookup(theta[:7], 1e-3 * np.random.default_rng(3).normal(size=(7, dim)))
    emb = ACTIVE[dim]
    assert _rel(K[:, emb[:, None], emb], e.K_T) < 1e-12 and _rel(F[:, emb], e.F_hat_T) < 1e-12
    assert np.all(K[:, np.setdiff1d(np.arange(6), emb)] == 0.0)
    assert _rel(rec, e.recover) < 1e-12 and _rel(x_int, e.node_position[:, 2:]) < 1e-12
    assert _rel(rot_int, e.node_rotation[:, 2:] if dim == 3 else e.node_angle[:, 2:]) < 1e-12


def _rod(dim):
    """A cantilevered rod of circular section (a LeafSpring given flexmb.circle, 1 mm, 50 mm) bent
    and pulled at its end: not a paper case; the circle's resultant-moment stress in 3D."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.05, 0.0, 0.0)[:dim])
    m.add_joint("A", "B", flexmb.LeafSpring(length=0.05, elements=4, section=flexmb.circle(1e-3, 200e9, 76.9e9)))
    m.apply_force("B", (2.0, 0.3, 0.2)[:dim])
    if dim == 3:
        m.apply_moment("B", (0.0, 0.004, 0.0))
    return m


@pytest.mark.parametrize("build", [lambda: flexmb.models.manipulator("joint", np.radians(30.0)),
                                   lambda: flexmb.models.fourbar(3, displacement=0.05, moment=2.0, dim=2),
                                   lambda: _rod(3), lambda: _rod(2)])
def test_peak_stress_kernel_equals_numpy(kernels, build):
    # the plausibility check's peak normal stress (|N|/A plus the larger end's bending stress,
    # flexmb.fe.stress.peak_normal_stress) from the compiled pass equals the numpy function on
    # the manipulator (rectangles, 3D), the planar four-bar and a rod of circular section
    from flexmb.fe.stress import peak_normal_stress
    from flexmb.plausibility import peak_stress

    sol = flexmb.solve(build(), raise_on_failure=True)
    model = sol.compiled.problem.model
    kernels("numba")  # the same element stresses (the compiled assembly) into both
    a, b = peak_stress(model, sol.state), peak_normal_stress(model, sol.state)
    assert a.shape == b.shape and _rel(a, b) < 1e-12 and np.all(b > 0)
    kernels("numpy")  # without the kernels: the numpy function itself
    assert np.array_equal(peak_stress(model, sol.state), peak_normal_stress(model, sol.state))


def test_bad_kernel_choice_is_refused():
    with pytest.raises(flexmb.ParameterError, match="FLEXMB_KERNELS"):
        jit.use("fortran")
