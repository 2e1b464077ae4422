"""The conformance kit for joint plugins (`JointConformance`, `conformance_report`) and its checks:
finite-difference tangents, perturbed states, frame invariance, reciprocity, energy, vibration,
and KSD on a trained shape (`check_ksd`; docs/plugins.md)."""

from __future__ import annotations

import math

import attrs
import numpy as np
import scipy.sparse as sp

from .fe.model import State
from .problem import StaticProblem
from .solvers.ksd import KSDFull, KSDReduced
from .testing_ksd import (KSD_FULL_TOLERANCE, KSD_REDUCED_REACTION, KSD_REDUCED_TOLERANCE, KSDShape, check_ksd_database,
                          trained_shape)

__all__ = ["finite_difference_tangent", "perturbed_state", "scaled_error", "joint_mechanism", "check_rest",
           "check_tangent", "check_rigid_motion", "check_frame_invariance", "check_reciprocity", "check_energy",
           "check_strategies", "check_mass", "check_modes_rigid_move", "check_floating_modes", "check_rayleigh",
           "check_complex_step", "joints", "placements", "JointConformance", "joint_size", "force_scale", "solver_tolerance",
           "CheckSkipped", "ConformanceReport", "conformance_report", "strategy_skips", "KSDShape", "check_ksd",
           "check_ksd_database", "trained_shape", "KSD_FULL_TOLERANCE", "KSD_REDUCED_TOLERANCE", "KSD_REDUCED_REACTION"]


def scaled_error(K: np.ndarray, Kfd: np.ndarray, diag_rows: np.ndarray, diag_cols: np.ndarray) -> float:
    """max |K - Kfd|_ij / sqrt(|d_i d_j|): translations and rotations weigh alike, so a wrong
    rotation-rotation entry of a thin leaf is not hidden by a large axial stiffness."""
    scale = np.sqrt(np.outer(np.abs(diag_rows), np.abs(diag_cols)))
    return float(np.max(np.abs(K - Kfd) / scale))


def finite_difference_tangent(problem: StaticProblem, state: State, lam: float = 1.0, step: float | None = None,
                              size: float | None = None, rotation_step: float = 1e-6):
    """Analytic ``[K_ff | K_fp]`` and its central finite-difference counterpart at ``state``.

    Columns are ``(r(u + h e_j) - r(u - h e_j)) / 2h`` with the increment applied exactly as the
    solver does (positions add, rotations compose by the exponential map), so the comparison
    checks the tangent Newton actually uses. ``step`` defaults to ``1e-6`` times ``size`` (default:
    the model's extent along its longest axis) for positions and ``rotation_step`` [rad] for rotations. Returns ``(K_analytic, K_fd)`` as dense arrays of
    shape (n_free, n_free + n_prescribed): the free DOFs' columns first, then the prescribed ones.
    """
    model = problem.model
    size = size or float(np.ptp(model.x0, axis=0).max()) or 1.0
    _, Kff, Kfp, _ = problem.evaluate(state, lam)
    K = np.hstack([Kff.toarray(), Kfp.toarray()])
    Kfd = np.empty_like(K)
    for col, dof in enumerate(np.concatenate([problem.free, problem.prescribed])):
        h = step if step is not None else (1e-6 * size if dof % model.ndof < model.dim else rotation_step)
        du = np.zeros(model.n_dofs)
        du[dof] = h
        rp = problem.residual(model.apply_increment(state, du), lam)[problem.free]
        rm = problem.residual(model.apply_increment(state, -du), lam)[problem.free]
        Kfd[:, col] = (rp - rm) / (2.0 * h)
    return K, Kfd


class CheckSkipped(Exception):
    """A check with nothing to check for this joint (no mass, no database, one compliant
    direction ...): its message says why. Never a pass: `JointConformance` reports it as a skipped
    test with the reason, and `conformance_report` lists it."""


def _finite(joint, dim: int, compiled, state, values, what: str) -> None:
    """AssertionError naming the elements when ``values`` (a residual on all DOFs or the free ones,
    or a tangent: free rows, then free and prescribed columns) hold NaN or inf: the elements whose
    own generalised stresses are not finite, else those at the first bad entry's nodes."""
    a = np.asarray(values)
    bad = ~np.isfinite(a)
    if not bad.any():
        return
    problem = compiled.problem
    model = problem.model
    spaces = [np.arange(model.n_dofs) if a.shape[0] == model.n_dofs else problem.free,
              np.concatenate([problem.free, problem.prescribed])]
    entries = [[int(spaces[k][i]) for k, i in enumerate(e)] for e in np.argwhere(bad)]
    # a tangent entry between two nodes belongs to the elements joining them: take one if any
    coupling = [e for e in entries if len(e) == 2 and e[0] // model.ndof != e[1] // model.ndof]
    dofs = (coupling or entries)[0]
    raise AssertionError(f"{joint.kind} {dim}D: the {what} holds {int(bad.sum())} NaN/inf entries (the first at "
                         f"{', column '.join(_dof_name(model, d) for d in dofs)}): {_culprits(compiled, state, dofs)}")


def _dof_name(model, dof: int) -> str:
    if dof >= model.n_node_dofs:
        return f"hinge multiplier {dof - model.n_node_dofs}"
    names = ("x", "y", "rotation") if model.dim == 2 else ("x", "y", "z", "rx", "ry", "rz")
    return f"node {dof // model.ndof} {names[dof % model.ndof]}"


def _culprits(compiled, state, dofs) -> str:
    """The elements that make a residual or tangent non-finite, named by joint and mesh index."""
    model = compiled.problem.model
    try:
        with np.errstate(all="ignore"):
            sig = model.stresses(state)[1]
        own = np.flatnonzero(~np.all(np.isfinite(sig), axis=1))
    except Exception:  # an element that cannot even be evaluated: fall back on the nodes
        own = np.zeros(0, dtype=np.int64)
    if len(own):
        how = "elements whose own forces are not finite"
    else:
        nodes = {d // model.ndof for d in dofs if d < model.n_node_dofs}
        ends = model.point_master[model.elements.ends]
        if nodes:  # the elements that touch every node of the entry
            own = np.flatnonzero(np.all([(ends == n).any(axis=1) for n in nodes], axis=0))
        how = "elements joining those nodes" if len(nodes) > 1 else "elements at that node"
    names = []
    for e in own[:6]:
        where = [f"joint {k!r} element {int(np.flatnonzero(idx == e)[0])}"
                 for k, idx in compiled.joint_elements.items() if e in idx]
        names.append(where[0] if where else f"element {int(e)}")
    more = f" and {len(own) - 6} more" if len(own) > 6 else ""
    return f"{how}: {', '.join(names) or 'none'}{more}"


def perturbed_state(problem: StaticProblem, state: State, rng: np.random.Generator, *, displacement: float,
                    rotation: float) -> State:
    """``state`` with random free-DOF increments: positions ~ ``displacement`` [m], rotations ~ ``rotation`` [rad]."""
    model = problem.model
    du = np.zeros(model.n_dofs)
    is_pos = (problem.free % model.ndof) < model.dim
    du[problem.free] = np.where(is_pos, displacement, rotation) * rng.standard_normal(len(problem.free))
    return model.apply_increment(state, du)


# -- joint conformance suite -------------------------------------------------------
#
# Every check builds the smallest mechanism around one joint: link "A" fixed, link "B" free at the
# joint's interface node B, the joint frame placed at ``origin`` with ``rotation``. The checks are
# scale free: every tolerance is relative to the joint's own size (`joint_size`) and stiffness
# (`force_scale`), and the solves converge relative to the problem's own forces (the conventional
# method's default) or to `solver_tolerance` (strategies with an absolute ``tol``), so a joint
# passes alike in SI, mm-N-MPa or um-uN-MPa, at mm or um scale, placed anywhere within 100 joint
# sizes of the origin (tests/test_conformance.py, tests/test_plugin_notch.py). A failed check raises
# AssertionError saying what broke (a NaN or inf as such, naming the element); a check with nothing
# to check raises `CheckSkipped` with the reason.

#: Richardson-extrapolated central differences (steps 1e-5 and 2e-5 of the joint's size or rad,
#: `check_tangent`): measured 4e-11 to 1.6e-8 (thin leaves at the origin and 100 sizes away, the
#: notch 100 sizes away): an entry wrong by more than 1e-6 of its scale sqrt(K_ii K_jj) fails.
FD_TOLERANCE = 1e-6
#: Relative agreement of two solves: the conventional method's default relative criterion
#: (``rtol`` 1e-8 of the problem's force scale) and `solver_tolerance` for the other strategies
#: leave position errors of ~1e-10-1e-8 of the joint size, below 1e-7 of it.
SOLVE_TOLERANCE = 1e-7
#: Strategies with an absolute ``tol`` (KSD, the closed-form Newton) stop at this fraction of the
#: joint's force scale (`force_scale`): the residual then moves B by ~1e-10 of the joint size in
#: its softest direction (linear theory), three orders below `SOLVE_TOLERANCE`.
SOLVE_RESIDUAL = 1e-10


def joint_size(joint, dim: int) -> float:
    """The joint's own length scale [length units]: the distance of node B from node A, or the
    extent of its mesh when B sits on A, or 1 for a joint of no extent (an ideal hinge: its
    placement_range is then in length units)."""
    size = float(np.linalg.norm(joint.interface_b(dim)))
    if size > 0:
        return size
    if "fe_model" not in joint.capabilities:
        return 1.0
    pts = np.asarray(joint.mesh(dim).points, dtype=float)
    return float(np.ptp(pts, axis=0).max()) or 1.0


def joint_mechanism(joint, dim: int, origin=None, rotation=None, *, motion: float = 0.0, force=None,
                    moment=None):
    """Link ``A`` fixed, link ``B`` at the joint's node B, ``joint`` between them placed at
    ``origin`` [m] with ``rotation`` (2D angle, 3D rotation vector [rad]). ``motion`` [rad]
    prescribes B's rotation about the joint's z axis (its intended motion; the rest of B is free);
    ``force`` [N] / ``moment`` [N m] (global axes) load B."""
    from .mechanism import Mechanism

    origin = np.zeros(dim) if origin is None else np.asarray(origin, dtype=float)
    Q = _rotation(dim, rotation)
    m = Mechanism(dim=dim)
    m.add_link("A", position=origin, fixed=True)
    m.add_link("B", position=origin + Q @ np.asarray(joint.interface_b(dim), dtype=float))
    m.add_joint("A", "B", joint, name="joint", origin=origin,
                rotation=None if rotation is None else (float(rotation) if dim == 2 else np.asarray(rotation, float)))
    if motion:
        m.prescribe("B", rotation=motion if dim == 2 else motion * Q[:, 2])
    if force is not None:
        m.apply_force("B", force)
    if moment is not None:
        m.apply_moment("B", moment)
    return m


def _rotation(dim: int, rotation) -> np.ndarray:
    from .rotations import expm_so3, rot2

    if rotation is None:
        return np.eye(dim)
    return rot2(float(rotation)) if dim == 2 else expm_so3(np.asarray(rotation, dtype=float))


def _solve(mechanism, joint, dim: int, origin=None, **options):
    """Solve ``mechanism`` (built around ``joint`` placed at ``origin``). A strategy that judges
    its residual relative to the problem's own force scale (it has an ``rtol`` option, as the
    conventional method) keeps its default; any other gets ``tol`` = `solver_tolerance` unless
    ``options`` set one. When that tolerance lies below the roundoff floor the solver meets (the
    residual stalls) but the floor is below half `SOLVE_TOLERANCE` of the joint's force scale (it
    moves B by less than that fraction of its size), the solve is repeated with 2x, then 4x it."""
    from .solvers import solve

    derived = "tol" not in options and not _relative(options.get("method", "conventional"))
    if derived:
        options["tol"] = solver_tolerance(joint, dim, origin)
    sol = solve(mechanism, **options)
    if not sol.converged and derived and len(sol.residual_history):
        floor = float(np.min(sol.residual_history))
        for factor in (2.0, 4.0):  # the floor is noisy: a residual may dip below its typical level
            if sol.converged or factor * floor > 0.5 * SOLVE_TOLERANCE * _scales(joint, dim)[0]:
                break
            sol = solve(mechanism, **{**options, "tol": factor * floor})
    if not sol.converged:
        _diagnose(sol, joint, dim)
    assert sol.converged, f"{joint.kind} {dim}D: the joint mechanism did not converge: {sol.message}"
    return sol


def _diagnose(sol, joint, dim: int) -> None:
    """A solve that failed: a NaN or inf in the residual or tangent at rest or where it stopped
    (a broken element), named with its element, is the likelier cause."""
    compiled = sol.compiled
    problem = compiled.problem
    states = [problem.model.initial_state()]
    if sol.state is not None and np.all(np.isfinite(sol.state.positions)):
        states.append(sol.state)
    for state in states:
        with np.errstate(all="ignore"):
            r, Kff, Kfp, _ = problem.evaluate(state, 0.0)
        _finite(joint, dim, compiled, state, r, "residual (internal force)")
        _finite(joint, dim, compiled, state, np.hstack([Kff.toarray(), Kfp.toarray()]), "analytic tangent")


def _relative(method: str) -> bool:
    """Whether the strategy ``method`` judges its residual relative (has an ``rtol`` option)."""
    from .solvers import STRATEGIES

    cls = STRATEGIES.get(method)
    return cls is not None and attrs.has(cls) and "rtol" in attrs.fields_dict(cls)


@attrs.frozen(eq=False)
class _Rest:
    """The joint mechanism at rest: compiled model, residual (all DOFs), free tangent (dense), the
    model size [m] and its internal force scale: the largest force (or moment) a stiffness entry
    gives for a displacement of the model's size or a rotation of 1 rad, taken per residual row
    type so that forces and moments are not compared (the roundoff of the residual is ~1e-16 of
    it: a coordinate's roundoff, ~1e-16 x size, times the stiffness)."""

    compiled: object
    r: np.ndarray
    K: np.ndarray
    size: float
    internal: float


def _at_rest(joint, dim: int) -> _Rest:
    compiled = joint_mechanism(joint, dim).compile()
    problem = compiled.problem
    model = problem.model
    r, K, _, _ = problem.evaluate(model.initial_state(), 0.0)
    _finite(joint, dim, compiled, model.initial_state(), r, "residual at rest")
    K = K.toarray()
    _finite(joint, dim, compiled, model.initial_state(), K, "tangent at rest")
    size = joint_size(joint, dim)
    t = (problem.free % model.ndof) < model.dim  # translation rows/columns, the rest rotations

    def most(rows, cols):
        block = K[np.ix_(rows, cols)]
        return float(np.abs(block).max()) if block.size else 0.0

    internal = max(most(t, t) * size + most(t, ~t), most(~t, t) * size + most(~t, ~t))
    return _Rest(compiled, r, K, size, internal)


def _rest_compliance(joint, dim: int):
    """Linear compliance of node B at rest (A fixed), (3, 3) in 2D / (6, 6) in 3D: forces [N] and
    moments [N m] to displacements [m] and rotations [rad]; and the residual's roundoff floor
    (1e-16 of the internal force scale, `_Rest`: the 4 mm leaf spring stalls at 4e-17 of it)."""
    rest = _at_rest(joint, dim)
    problem = rest.compiled.problem
    where = np.searchsorted(problem.free, problem.model.node_dofs[rest.compiled.link_node["B"]])
    return np.linalg.inv(rest.K)[np.ix_(where, where)], 1e-16 * rest.internal


def force_scale(joint, dim: int) -> float:
    """The joint's own force scale [force units]: the force that moves node B by `joint_size` in
    its softest direction (linear, at rest, node A fixed)."""
    C0, _ = _rest_compliance(joint, dim)
    return float(joint_size(joint, dim) / np.abs(np.diag(C0))[:dim].max())


def solver_tolerance(joint, dim: int, origin=None) -> float:
    """The residual tolerance of the kit's solves with strategies that have an absolute ``tol``:
    `SOLVE_RESIDUAL` x the smaller of `force_scale` and the moment that turns B 1 rad, at least 10x
    the round-off floor of the joint's residual (1e-16 of its internal force scale: its stiffness
    times its size, per force and moment rows), which grows with the distance of its ``origin``
    from the global origin (coordinates carry roundoff in proportion to their magnitude)."""
    force, floor = _scales(joint, dim)
    reach = 0.0 if origin is None else float(np.linalg.norm(origin)) / joint_size(joint, dim)
    return max(SOLVE_RESIDUAL * force, 10.0 * floor * (1.0 + reach))


def _scales(joint, dim: int) -> tuple[float, float]:
    """The residual's scale (the smaller of `force_scale` and the moment that turns B 1 rad about
    its softest axis: a tolerance on the residual's norm must resolve both) and its roundoff floor."""
    C0, floor = _rest_compliance(joint, dim)
    d = np.abs(np.diag(C0))
    with np.errstate(divide="ignore"):  # an ideal joint's rigid directions (compliance 0): infinite scale, not the min
        return float(min(joint_size(joint, dim) / d[:dim].max(), 1.0 / d[dim:].max())), float(floor)


def check_rest(joint, dim: int) -> None:
    """Zero residual at rest and a symmetric, positive definite tangent at rest (unloaded)."""
    from .solvers.conventional import is_stable

    rest = _at_rest(joint, dim)
    # zero up to the roundoff of coordinates (~1e-16 x model size) times the stiffness
    res = np.abs(rest.r).max()
    assert res <= 1e-13 * rest.internal, f"{joint.kind} {dim}D: residual at rest {res:.3g}"
    # unit free: scaled by the diagonal (a row without one, an ideal joint's multiplier, by its largest entry)
    d = np.abs(np.diag(rest.K))
    d = np.sqrt(np.where(d > 0, d, np.abs(rest.K).max(axis=1)))
    d[d == 0] = 1.0
    asym = np.abs((rest.K - rest.K.T) / np.outer(d, d)).max()
    assert asym <= 1e-12, f"{joint.kind} {dim}D: tangent at rest not symmetric ({asym:.3g}, scaled)"
    # on the motions an ideal joint's constraints allow (the saddle point's Z^T K Z; K itself otherwise)
    K = rest.compiled.problem.reduced_tangent(sp.csr_array(rest.K))
    assert is_stable(K), f"{joint.kind} {dim}D: tangent at rest not positive definite"


def check_tangent(joint, dim: int, origin=None, rotation=None, *, motion: float = 0.3, seed: int = 0,
                  **options) -> float:
    """Analytic tangent = central differences of the residual in a deformed configuration (the
    solved intended motion ``motion``, then randomly perturbed); returns the scaled error.
    ``options`` go to the solve (default: see `_solve`)."""
    sol = _solve(joint_mechanism(joint, dim, origin, rotation, motion=motion), joint, dim, origin, **options)
    problem = sol.compiled.problem
    # perturbations and steps relative to the joint's own size, wherever it is placed (the spread
    # of its global coordinates grows with the placement: 100 sizes away it broke the elements)
    size = joint_size(joint, dim)
    displacement, rotation = _perturbation(problem.model, size)
    state = perturbed_state(problem, sol.state, np.random.default_rng(seed), displacement=displacement,
                            rotation=rotation)
    _finite(joint, dim, sol.compiled, state, problem.residual(state, 1.0), "residual (internal force)")
    # Richardson's extrapolation of central differences at steps h and 2h, (4 D(h) - D(2h)) / 3:
    # truncation O(h^4), so h can be 1e-5 of the joint's size (1e-5 rad) and the roundoff of
    # coordinates 100 sizes away (~1e-16 |x| / h) stays small. Plain differences at 1e-6 of the size
    # failed both ways: 1.2e-6 on a 799 um leaf (L/t 150) 100 sizes away, 1.0e-6 on an 8 mm one at
    # the origin (truncation ~ 12 (h / t)^2); extrapolated 1.6e-8 and 3e-10, the notch 1.3e-8.
    _, D1 = finite_difference_tangent(problem, state, size=10.0 * size, rotation_step=1e-5)
    K, D2 = finite_difference_tangent(problem, state, size=20.0 * size, rotation_step=2e-5)
    Kfd = (4.0 * D1 - D2) / 3.0
    _finite(joint, dim, sol.compiled, state, K, "analytic tangent")
    _finite(joint, dim, sol.compiled, state, Kfd, "central differences of the residual")
    nf = problem.n_free
    d = np.abs(np.diag(K[:, :nf]))
    d = np.where(d > 0, d, np.abs(K[:, :nf]).max(axis=1))  # an ideal joint's multiplier rows: zero diagonal
    cols = np.concatenate([d, np.abs(K[:, nf:]).max(axis=0)]) if K.shape[1] > nf else d
    cols = np.where(cols > 0, cols, np.abs(K).max())  # a column without stiffness (a hinge's ground DOF)
    err = scaled_error(K, Kfd, d, cols)
    assert err <= FD_TOLERANCE, f"{joint.kind} {dim}D: tangent differs from central differences by {err:.3g} (scaled)"
    return err


def _perturbation(model, size: float) -> tuple[float, float]:
    """The random perturbation of `check_tangent`: displacements ~1e-3 of the joint's size and
    rotations ~0.05 rad, each at most a few per cent of the shortest element (an element's end on a
    rigid body turns with the body's lever arm: 0.05 rad at a 21 mm arm moved a 1.8 mm element's
    end by 1 mm in a three_x_infinity and broke it; an element's validity ends at 90 degrees)."""
    L0 = model.elements.L0
    if not len(L0):
        return 1e-3 * size, 0.05
    arm = float(np.linalg.norm(model.point_offset[model.elements.ends], axis=-1).max())
    shortest = float(L0.min())
    return min(1e-3 * size, 0.03 * shortest), 0.05 * min(1.0, shortest / arm) if arm > 0 else 0.05


def check_rigid_motion(joint, dim: int, translation, rotation) -> None:
    """A rigid motion of the whole joint (every node moved and turned alike) stores no energy and
    gives no internal force."""
    rest = _at_rest(joint, dim)
    model = rest.compiled.problem.model
    Q = _rotation(dim, rotation)
    x = model.x0 @ Q.T + np.asarray(translation, dtype=float)
    if dim == 2:
        rot = np.full(model.n_nodes, float(rotation))
    else:
        rot = np.broadcast_to(Q, (model.n_nodes, 3, 3)).copy()
    f = model.internal_force(State(x, rot))
    _finite(joint, dim, rest.compiled, State(x, rot), f, "internal force after a rigid motion")
    # roundoff of rotated and moved coordinates: ~1e-15 x their magnitude, times the stiffness
    scale = 1e-12 * rest.internal * (1.0 + float(np.linalg.norm(translation)) / rest.size)
    assert np.abs(f).max() <= scale, (f"{joint.kind} {dim}D: a rigid motion gives internal forces "
                                      f"{np.abs(f).max():.3g} (allowed {scale:.3g})")


def _below_buckling(joint, dim: int, motion: float, w: np.ndarray, fraction: float = 0.5) -> float:
    """The factor (<= 1) that keeps the load ``w`` below ``fraction`` of its linearised buckling
    load about the prescribed ``motion`` (`flexmb.buckling` with ``base=``): a random wrench of a
    few per cent of the joint's size in displacement can carry a thin leaf past buckling (the
    three_x_infinity at 0.3 mm: limit at ~6 % of it), where no equilibrium need exist to compare.
    1 for joints without a finite-element model or with no buckling under the load."""
    from .errors import FlexmbError
    from .linearised import buckling
    from .solvers import solve

    eps = 1e-3
    f, mom = w[:dim] * eps, (w[dim] if dim == 2 else w[dim:]) * eps
    try:
        base = solve(joint_mechanism(joint, dim, motion=motion))
        small = solve(joint_mechanism(joint, dim, motion=motion, force=f, moment=mom))
        if not (base.converged and small.converged):
            return 1.0
        mu = float(buckling(small, base=base)[0])
    except FlexmbError:  # no finite-element model, nothing to buckle, ...
        return 1.0
    return min(1.0, fraction * eps * mu) if np.isfinite(mu) and mu > 0 else 1.0


def check_frame_invariance(joint, dim: int, origin, rotation, *, motion: float = 0.2, load=0.05,
                           method: str = "conventional", **options) -> None:
    """The mechanism placed at ``origin``/``rotation`` with its loads turned alike gives the turned
    solution: node positions, the reaction wrench on A and the strain energy."""
    Q = _rotation(dim, rotation)
    C0, _ = _rest_compliance(joint, dim)
    size = joint_size(joint, dim)
    rng = np.random.default_rng(7)
    w = rng.standard_normal(len(C0))
    move = C0 @ w  # an ideal joint's node B does not move: then turn it by ~ load [rad]
    w *= load * size / (np.linalg.norm(move[:dim]) or size * np.linalg.norm(move[dim:]))
    w *= _below_buckling(joint, dim, motion, w)
    f_scale = np.abs(w).max()
    f, mom = w[:dim], (w[dim] if dim == 2 else w[dim:])
    ref = _solve(joint_mechanism(joint, dim, motion=motion, force=f, moment=mom), joint, dim, method=method,
                 **options)
    o = np.asarray(origin, dtype=float)
    moved = _solve(joint_mechanism(joint, dim, o, rotation, motion=motion, force=Q @ f,
                                   moment=mom if dim == 2 else Q @ mom), joint, dim, o, method=method, **options)
    x_ref, x_mov = ref.node_positions(), moved.node_positions()
    err = np.abs(x_ref @ Q.T + o - x_mov).max() / size
    assert err <= SOLVE_TOLERANCE, f"{joint.kind} {dim}D {method}: positions not frame invariant ({err:.3g} of its size)"
    w_ref, w_mov = ref.reaction("A"), moved.reaction("A")
    turned = np.concatenate([Q @ w_ref[:dim], w_ref[dim:] if dim == 2 else Q @ w_ref[dim:]])
    # the moment is about A's reference point, which moves with the frame: compare directly
    wscale = max(np.abs(w_ref).max(), f_scale * size)
    err_w = np.abs(turned - w_mov).max() / wscale
    # a reaction sums internal forces, each carrying the residual's roundoff (the floor at the moved
    # placement: 1.8e-7 of the loads for a 0.2 mm curved beam of E = 1 GPa, above 1e-7)
    allowed = SOLVE_TOLERANCE + 10.0 * _scales(joint, dim)[1] * (1.0 + float(np.linalg.norm(o)) / size) / wscale
    assert err_w <= allowed, (f"{joint.kind} {dim}D {method}: reaction on A not frame invariant ({err_w:.3g}, "
                              f"allowed {allowed:.3g})")
    if method in ("conventional", "ksd-full"):
        e_ref, e_mov = ref.strain_energy(), moved.strain_energy()
        # relative, down to roundoff of the loads' work scale (a prescribed hinge stores ~nothing)
        assert abs(e_ref - e_mov) <= SOLVE_TOLERANCE * max(abs(e_ref), 1e-12 * f_scale * size * load), (
            f"{joint.kind} {dim}D {method}: strain energy {e_ref:.12g} vs {e_mov:.12g} after moving the frame")


def strategy_skips(joint, dim: int) -> dict:
    """Why each registered strategy other than the conventional one does not apply to ``joint``
    in ``dim`` (it needs a model the joint does not offer, or supports other dimensions):
    ``{name: reason}``; the strategies that apply are absent."""
    from .solvers import STRATEGIES

    out = {}
    for name, cls in STRATEGIES.items():
        if name == "conventional":
            continue
        missing = sorted(set(getattr(cls, "needs", ())) - joint.capabilities)
        if missing:
            out[name] = f"{joint.kind} offers no {' and no '.join(missing)} (it offers {sorted(joint.capabilities)})"
        elif dim not in getattr(cls, "dims", (dim,)):
            out[name] = f"{name} solves {' and '.join(f'{d}D' for d in cls.dims)} mechanisms only"
    return out


def check_strategy_frame_invariance(joint, dim: int, origin, rotation, *, motion: float = 0.2, shape=None,
                                    **options) -> list:
    """`check_frame_invariance` with every registered strategy other than the conventional one
    that applies to the joint (it offers what the strategy ``needs``, in this dimension).

    KSD is displacement controlled, so the intended rotation is at least 0.05 rad (and inside the
    trained range). Strategies that need a joint database run on ``shape`` (a
    `flexmb.testing_ksd.KSDShape`: a joint and its database folder; default: the joint itself
    with the user's and the shipped data), and a missing database fails the check. Returns the
    strategies checked; `CheckSkipped` naming why when none applies."""
    from .solvers import STRATEGIES
    from .testing_ksd import KSDShape

    skips = strategy_skips(joint, dim)
    checked = []
    for name in STRATEGIES:
        if name == "conventional" or name in skips:
            continue
        j, opts, mo = joint, options, (motion if abs(motion) >= 0.05 else math.copysign(0.05, motion))
        if "database" in getattr(STRATEGIES[name], "needs", ()):
            sh = shape or KSDShape(joint)
            j, mo = sh.joint, _in_trained_range(sh, dim, motion)
            # the shape has its own scale: the kit's tolerance for it, not the one given
            opts = {**({k: v for k, v in options.items() if k != "tol"} if j is not joint else options),
                    "database": sh.folder}
        check_frame_invariance(j, dim, origin, rotation, motion=mo, method=name, **opts)
        checked.append(name)
    if not checked:
        raise CheckSkipped("; ".join(f"{k}: {v}" for k, v in skips.items()) or "no strategy besides the conventional")
    return checked


def _in_trained_range(shape, dim: int, motion: float) -> float:
    from .errors import DatabaseError
    from .testing_ksd import ksd_motion

    try:
        return ksd_motion(shape, dim, motion)
    except DatabaseError as exc:  # the kit trained it or the author named it: a failure, not a skip
        raise AssertionError(f"{shape.joint.kind} {dim}D: the KSD checks' database: {exc}") from None


def check_ksd(shape: KSDShape, dim: int, origin=None, rotation=None, *, motion: float = 0.05,
              load: float = 0.01, seed: int = 11) -> dict:
    """KSD-full and KSD-reduced against the conventional method on the shape's joint placed at
    ``origin`` with ``rotation``, B turned by ``motion`` (moved into the trained range:
    `ksd_motion`) and loaded by a wrench that moves it ``load`` times its size (linear theory,
    kept below half its buckling load). Returns the errors ``{method name: (position, reaction)}``
    of KSD-full and KSD-reduced as fractions of the joint's size and of the load scale."""
    from .errors import FlexmbError

    joint = shape.joint
    motion = _in_trained_range(shape, dim, motion)
    Q = _rotation(dim, rotation)
    o = np.zeros(dim) if origin is None else np.asarray(origin, dtype=float)
    C0, _ = _rest_compliance(joint, dim)
    size = joint_size(joint, dim)
    # a random wrench in the joint's own units (forces over its force scale, moments over that
    # times its size), so it is the same load in any unit system
    w = np.random.default_rng(seed).standard_normal(len(C0))
    w[dim:] *= size
    w *= load * size / (np.linalg.norm((C0 @ w)[:dim]) or size * np.linalg.norm((C0 @ w)[dim:]))
    w *= _below_buckling(joint, dim, motion, w)
    f, mom = w[:dim], (w[dim] if dim == 2 else w[dim:])
    m = joint_mechanism(joint, dim, o, rotation, motion=motion, force=Q @ f, moment=mom if dim == 2 else Q @ mom)
    ref = _solve(m, joint, dim, o)
    units = np.r_[np.ones(dim), np.full(len(w) - dim, size)]  # a force, a moment over the size: comparable
    wscale = max(np.abs(ref.reaction("A") / units).max(), np.abs(w / units).max())
    floor = 10.0 * _scales(joint, dim)[1] * (1.0 + float(np.linalg.norm(o)) / size) / wscale  # roundoff
    out = {}
    for method, tol, tol_reaction in ((KSDFull.name, KSD_FULL_TOLERANCE, KSD_FULL_TOLERANCE),
                                      (KSDReduced.name, KSD_REDUCED_TOLERANCE, KSD_REDUCED_REACTION)):
        try:
            sol = _solve(m, joint, dim, o, method=method, database=shape.folder)
        except FlexmbError as exc:  # the kit trained the data or the author named them: a failure
            raise AssertionError(f"{joint.kind} {dim}D {method}: {type(exc).__name__}: {exc}") from None
        if method == KSDFull.name:
            pos = np.abs(sol.node_positions() - ref.node_positions()).max() / size
        else:
            pos = np.abs(sol.pose("B")[0] - ref.pose("B")[0]).max() / size
        reac = np.abs((sol.reaction("A") - ref.reaction("A")) / units).max() / wscale
        out[method] = (float(pos), float(reac))
        assert pos <= tol, (f"{joint.kind} {dim}D {method}: positions differ from the conventional method's by "
                            f"{pos:.3g} of the joint's size (allowed {tol:.3g})")
        assert reac <= tol_reaction + floor, (f"{joint.kind} {dim}D {method}: the reaction on A differs from the "
                                              f"conventional method's by {reac:.3g} of the load scale (allowed "
                                              f"{tol_reaction + floor:.3g})")
    return out


def _b_displacement(sol, dim):
    x, R = sol.pose("B")
    x0 = sol.compiled.problem.model.x0[sol.compiled.link_node["B"]]
    if dim == 2:
        return np.concatenate([x - x0, [R]])
    from .rotations import logm_so3

    return np.concatenate([x - x0, logm_so3(R)])


def check_reciprocity(joint, dim: int, rotation=None, **options) -> None:
    """Maxwell-Betti for small loads on node B: displacement j under load i equals displacement i
    under load j (the compliance is symmetric), from full non-linear solves (``options`` go to
    them; the conventional method's relative criterion follows the small loads, another strategy
    gets ``tol`` 1e-8 of each load, at least the round-off floor)."""
    C0, floor = _rest_compliance(joint, dim)
    n = len(C0)
    size = joint_size(joint, dim)
    Q = _rotation(dim, rotation)
    T = np.eye(n)
    T[:dim, :dim] = Q
    if dim == 3:
        T[3:, 3:] = Q
    live = np.flatnonzero(np.diag(C0) > 0)  # an ideal joint's constrained directions do not comply
    if len(live) < 2:
        raise CheckSkipped(f"Maxwell-Betti relates two compliant directions of node B; {joint.kind} has "
                           f"{len(live)} (an ideal joint)")
    C0 = C0[np.ix_(live, live)]
    T = T[:, live]
    n = len(live)
    C = np.empty((n, n))
    for i in range(n):
        # loads +-eps that move B by ~1e-5 of its size (or turn it 1e-5 rad); the central difference
        # cancels the second-order (geometric) response, leaving O(1e-10)
        eps = 1e-5 * (size if live[i] < dim else 1.0) / C0[i, i]
        u = []
        for sign in (1.0, -1.0):
            w = T[:, i] * sign * eps
            sol = _solve(joint_mechanism(joint, dim, None, rotation, force=w[:dim],
                                         moment=w[dim] if dim == 2 else w[dim:]), joint, dim,
                         **({} if _relative(options.get("method", "conventional"))
                            else {"tol": max(1e-8 * eps, floor)}), **options)
            u.append(T.T @ _b_displacement(sol, dim))
        C[:, i] = (u[0] - u[1]) / (2.0 * eps)
    d = np.sqrt(np.abs(np.diag(C)))
    err = np.abs((C - C.T) / np.outer(d, d)).max()
    assert err <= 1e-4, f"{joint.kind} {dim}D: compliance not symmetric (Maxwell-Betti) by {err:.3g}"


def check_energy(joint, dim: int, rotation=None, *, deflection: float = 0.1, steps: int = 16, **options) -> None:
    """A dead force on link B, at a lever of the joint's size from node B along the joint's x
    axis (so it turns B about the joint axis also when B sits on that axis), swept from 0 to a
    value that would move its point by ``deflection`` times the size in linear theory: the work
    of the load (Simpson's rule over ``steps`` equal load steps) equals the strain energy
    stored, as for any conservative joint. ``options`` go to the solves (default: see `_solve`)."""
    C0, _ = _rest_compliance(joint, dim)
    size = joint_size(joint, dim)
    Q = _rotation(dim, rotation)
    arm = np.zeros(dim)
    arm[0] = size  # joint frame
    G = np.zeros((dim, len(C0)))  # point displacement from B's displacement and rotation
    G[:, :dim] = np.eye(dim)
    if dim == 2:
        G[:, 2] = (-arm[1], arm[0])
    else:
        from .rotations import skew

        G[:, 3:] = -skew(arm)
    Cp = G @ C0 @ G.T
    local = np.r_[0.3, 1.0, 0.2][:dim] / np.linalg.norm(np.r_[0.3, 1.0, 0.2][:dim])  # in the joint frame
    F = Q @ (deflection * size / np.linalg.norm(Cp @ local) * local)
    lam = np.linspace(0.0, 1.0, steps + 1)
    u = np.zeros((steps + 1, dim))
    energy = 0.0
    for s, l in enumerate(lam[1:], start=1):
        m = joint_mechanism(joint, dim, None, rotation)
        point = m.link("B").position + Q @ arm
        m.add_point("B", "load", point)
        m.apply_force("B", l * F, point=point)
        sol = _solve(m, joint, dim, **options)
        u[s] = sol.point("B", "load") - point
        energy = sol.strain_energy()
    g = u @ F  # W = int lambda F . du = F . u(1) - int_0^1 F . u dlambda
    simpson = (lam[1] - lam[0]) / 3.0 * (g[0] + g[-1] + 4.0 * g[1:-1:2].sum() + 2.0 * g[2:-1:2].sum())
    work = g[-1] - simpson
    err = abs(work - energy) / abs(energy)
    assert err <= 1e-5, f"{joint.kind} {dim}D: work of the load {work:.9g} J vs strain energy {energy:.9g} J ({err:.3g})"


def check_strategies(joint, dim: int, motion: float = 0.2, **options) -> dict:
    """Every registered strategy either solves the joint mechanism or raises the documented
    `FlexmbError` (a joint without the model a strategy needs: `UnsupportedStrategyError`);
    ``options`` go to every solve (default: the conventional method's relative criterion,
    `solver_tolerance` for strategies with an absolute ``tol``)."""
    from .errors import FlexmbError, UnsupportedStrategyError
    from .solvers import STRATEGIES, solve

    out = {}
    for name, cls in STRATEGIES.items():
        m = joint_mechanism(joint, dim, motion=motion)
        try:
            extra = {} if "tol" in options or _relative(name) else {"tol": solver_tolerance(joint, dim)}
            out[name] = solve(m, method=name, **extra, **options)
        except UnsupportedStrategyError as exc:
            can = set(getattr(cls, "needs", ())) <= joint.capabilities and dim in getattr(cls, "dims", (dim,))
            assert not can, f"{joint.kind} {dim}D: {name} refused a joint that offers what it needs: {exc}"
            out[name] = exc
        except FlexmbError as exc:
            out[name] = exc
    return out


# -- vibration invariants: the joint's own mass, B free ------------------------------
#
# These checks linearise the joint mechanism with its leaves' own mass (the sections' density);
# a joint without mass has nothing to check and returns None.

#: Relative agreement of frequencies of two solves converged to the default criterion.
MODES_TOLERANCE = 1e-6


def _massive_solution(joint, dim: int, origin=None, rotation=None, motion: float = 0.0):
    """The solved joint mechanism; `CheckSkipped` when the joint's sections carry no mass."""
    m = joint_mechanism(joint, dim, origin, rotation, motion=motion)
    if all(getattr(s, "density", 0.0) == 0.0 for s in m.compile().problem.model.elements.sections):
        raise CheckSkipped(f"{joint.kind}: its sections carry no mass (density 0): no vibration to check")
    return _solve(m, joint, dim, origin)


def _rigid_velocities(model) -> np.ndarray:
    """(N ndof, 3 or 6) nodal velocities of the rigid motions: unit translations, unit spins about
    the global axes through the origin."""
    d = model.dim
    spins = 1 if d == 2 else 3
    V = np.zeros((model.n_dofs, d + spins))
    for i in range(d):
        V[model.node_dofs[:, i], i] = 1.0
    for i in range(spins):
        axis = np.eye(3)[2 if d == 2 else i]
        x = np.column_stack([model.x0, np.zeros(len(model.x0))]) if d == 2 else model.x0
        V[model.node_dofs[:, :d].ravel(), d + i] = np.cross(axis, x)[:, :d].ravel()
        V[model.node_dofs[:, d + i], d + i] = 1.0
    return V


def check_mass(joint, dim: int, rotation=None, *, motion: float = 0.2):
    """The consistent mass on every DOF at a deformed configuration is symmetric (to 1e-14 of its
    largest entry) and positive definite (Cholesky), and its rigid-body part is the joint's
    total mass on each translation. Returns the mass matrix (dense); `CheckSkipped` for a massless joint."""
    from .fe.mass import mass_matrix

    sol = _massive_solution(joint, dim, rotation=rotation, motion=motion)
    model = sol.compiled.problem.model
    M = mass_matrix(model, sol.state, model.rigid_masses).toarray()
    scale = np.abs(M).max()
    assert np.abs(M - M.T).max() <= 1e-14 * scale, f"{joint.kind} {dim}D: the mass matrix is not symmetric"
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise AssertionError(f"{joint.kind} {dim}D: the mass matrix is not positive definite") from None
    V = _rigid_velocities(model)[:, :dim]
    MR = V.T @ M @ V
    assert np.allclose(MR, MR[0, 0] * np.eye(dim), rtol=1e-12, atol=1e-12 * MR[0, 0]), \
        f"{joint.kind} {dim}D: the rigid translations do not see one total mass: {np.diag(MR)}"
    return M


def check_modes_rigid_move(joint, dim: int, origin, rotation, *, motion: float = 0.2, n: int = 6):
    """The ``n`` lowest frequencies (prescribed DOFs held) of the joint placed at ``origin`` with
    ``rotation`` equal those of the joint in its own frame, to `MODES_TOLERANCE`."""
    from .modal import modes

    a = _massive_solution(joint, dim, motion=motion)
    b = _massive_solution(joint, dim, origin, rotation, motion=motion)
    n = min(n, len(a.compiled.problem.free) - 1)
    fa, fb = modes(a, n_modes=n).frequencies, modes(b, n_modes=n).frequencies
    assert np.allclose(fb, fa, rtol=MODES_TOLERANCE, atol=MODES_TOLERANCE * np.abs(fa).max()), \
        f"{joint.kind} {dim}D: a rigid move changed the frequencies: {fa} -> {fb}"
    return fa


def check_floating_modes(joint, dim: int, rotation=None):
    """Unsupported (``held="floating"``) at rest, the joint has exactly its rigid-body zero modes
    (3 in 2D, 6 in 3D): those eigenvalues below 1e-8 of the first elastic one, their shapes rigid
    motions (residual after projection on the rigid velocities below 1e-6), the next one elastic."""
    from .modal import modes

    sol = _massive_solution(joint, dim, rotation=rotation)
    k = 3 if dim == 2 else 6
    md = modes(sol, n_modes=k + 1, held="floating")
    lam = md.eigenvalues
    assert lam[k] > 0 and np.all(np.abs(lam[:k]) <= 1e-8 * lam[k]), \
        f"{joint.kind} {dim}D: floating eigenvalues {lam} are not {k} zeros and an elastic one"
    model = sol.compiled.problem.model
    V = _rigid_velocities(model)
    for shape in md.shapes[:k]:
        phi = shape.ravel()
        coef = np.linalg.lstsq(V, phi, rcond=None)[0]
        assert np.linalg.norm(V @ coef - phi) <= 1e-6 * np.linalg.norm(phi), \
            f"{joint.kind} {dim}D: a zero mode is not a rigid motion"
    return lam


def check_rayleigh(joint, dim: int, rotation=None, *, motion: float = 0.2, n: int = 6):
    """Each mode's Rayleigh quotient ``phi^T K phi / phi^T M phi`` with the full tangent and mass
    on the free DOFs equals its ``omega^2`` (to 1e-8 of the largest), and the shapes are
    mass-normalised (``phi^T M phi = 1``)."""
    from .modal import modes, stiffness_and_mass

    sol = _massive_solution(joint, dim, rotation=rotation, motion=motion)
    n = min(n, len(sol.compiled.problem.free) - 1)
    md = modes(sol, n_modes=n)
    K, M = stiffness_and_mass(sol)
    phi = md.shapes.reshape(n, -1).T
    mass = np.einsum("ik,ik->k", phi, M @ phi)
    quotient = np.einsum("ik,ik->k", phi, K @ phi) / mass
    assert np.allclose(mass, 1.0, rtol=1e-9), f"{joint.kind} {dim}D: shapes not mass-normalised: {mass}"
    assert np.allclose(quotient, md.eigenvalues, rtol=1e-8, atol=1e-8 * np.abs(md.eigenvalues).max()), \
        f"{joint.kind} {dim}D: Rayleigh quotients {quotient} != omega^2 {md.eigenvalues}"
    return quotient


# -- hypothesis strategies and the pytest base class ----------------------------------------


def _real_parameters(joint) -> dict:
    """The joint's real-valued parameters ``{name: value}``: its attrs fields holding floats and,
    for a `flexmb.joints.MaterialJoint`, its material's ``E``, ``G``, ``density``."""
    out = {}
    if attrs.has(type(joint)):
        for a in attrs.fields(type(joint)):
            value = getattr(joint, a.name)
            if a.init and not a.name.startswith("_") and isinstance(value, float):
                out[a.alias or a.name] = value
    material = getattr(joint, "material", None)
    if hasattr(material, "E") and hasattr(material, "G"):
        out.update(E=float(material.E), G=float(material.G), density=float(material.density))
    return out


def _mesh_numbers(joint, dim: int) -> dict:
    from .fe.build import _checked_mesh
    from .sections import section_values

    mesh = _checked_mesh("under test", joint, dim)
    rho, A = section_values(mesh.sections, ("density", "A"))
    out = {"points": mesh.points, "L0": mesh.L0, "S": mesh.S, "rho A": rho * A}
    if dim == 3:
        out.update(ny0=mesh.ny0, nz0=mesh.nz0)
    return out


def _differences(joint, dim: int, name: str, x: float, d: float, base: dict) -> dict:
    """Central differences of `_mesh_numbers` in parameter ``name`` (one-sided of second order
    where the joint refuses ``x - d``, e.g. a gap of 0)."""
    from .errors import FlexmbError

    plus = _mesh_numbers(attrs.evolve(joint, **{name: x + d}), dim)
    try:
        minus = _mesh_numbers(attrs.evolve(joint, **{name: x - d}), dim)
    except FlexmbError:
        far = _mesh_numbers(attrs.evolve(joint, **{name: x + 2 * d}), dim)
        return {f: (-3 * np.asarray(base[f]) + 4 * np.asarray(plus[f]) - np.asarray(far[f])) / (2 * d) for f in base}
    return {f: (np.asarray(plus[f]) - np.asarray(minus[f])) / (2 * d) for f in base}


def check_complex_step(joint, dim: int, *, parameters=None, agreement: float = 1e-6) -> None:
    """The joint's mesh carries a complex step (design gradients, `flexmb.design`: the build at
    ``p + i h``): for each real parameter (``parameters``: names, default every float field and
    the material's ``E``, ``G``, ``density``), the joint made with it complex builds its mesh with
    numpy's ``ComplexWarning`` as an error and no ``TypeError`` (``float()``, ``math.*``, a
    comparison), and the imaginary parts of its points, lengths, stiffness, mass per length (and
    frames in 3D) over the step equal central differences of the real meshes within
    ``agreement`` (relative to each field's largest rate): no imaginary part dropped silently
    (``abs``, ``np.linalg.norm``, ``.real``). See docs/plugins.md, "Complex-step safe joints"."""
    import warnings

    from . import _validate as v
    from .design.builds import culprit
    from .design.parameters import H

    values = _real_parameters(joint)
    names = list(values) if parameters is None else list(parameters)
    base = _mesh_numbers(joint, dim)
    for name in names:
        x = values[name]
        scale = abs(x) or 1.0
        h, d = H * scale, 1e-6 * scale
        with warnings.catch_warnings(), v.complex_step():
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
            try:
                cs = _mesh_numbers(attrs.evolve(joint, **{name: complex(x, h)}), dim)
            except (TypeError, np.exceptions.ComplexWarning) as exc:
                raise AssertionError(f"{joint.kind} (dim={dim}): its mesh drops the complex step of {name!r} at "
                                     f"{culprit(exc)}: {type(exc).__name__}: {exc}") from exc
        diffs = _differences(joint, dim, name, x, d, base)
        for field, ref in base.items():
            fd = diffs[field]
            rate = np.imag(cs[field]) / h
            size = max(float(np.abs(fd).max(initial=0.0)), float(np.abs(rate).max(initial=0.0)))
            floor = 1e3 * np.finfo(float).eps * float(np.abs(ref).max(initial=0.0)) / d  # the differences' round-off
            err = float(np.abs(rate - fd).max(initial=0.0))
            if err > agreement * size + floor:
                raise AssertionError(f"{joint.kind} (dim={dim}): the mesh's {field} drops (part of) the complex step "
                                     f"of {name!r}: its rate {err:.3g} off central differences (largest rate "
                                     f"{size:.3g}); keep p's numbers complex (sqrt(x @ x), not abs or np.linalg.norm)")


def joints(cls, ranges: dict | None = None, fixed: dict | None = None):
    """Hypothesis strategy of ``cls`` instances with the shape parameters of ``ranges`` (default
    ``cls.parameter_ranges``) drawn uniformly in their ranges, ``fixed`` parameters as given (e.g.
    moduli in the unit system of the ranges) and the others at their defaults."""
    from hypothesis import strategies as st

    ranges = getattr(cls, "parameter_ranges", {}) if ranges is None else ranges
    fixed = dict(fixed or {})
    return st.fixed_dictionaries({k: st.floats(lo, hi, allow_nan=False) for k, (lo, hi) in ranges.items()}).map(
        lambda params: cls(**fixed, **params))


def placements(dim: int, scale: float = 1.0):
    """Hypothesis strategy of ``(origin, rotation)``: origins within ``scale`` [length units] of the
    global origin in every coordinate, any rotation (2D angle in (-pi, pi], 3D rotation vector of
    angle below pi). `JointConformance` draws them with ``scale=1`` and multiplies the origin by
    its ``placement_range`` times the joint's size."""
    from hypothesis import strategies as st

    coord = st.floats(-1.0, 1.0, allow_nan=False)
    origin = st.lists(coord, min_size=dim, max_size=dim).map(lambda v: float(scale) * np.array(v))
    if dim == 2:
        return st.tuples(origin, st.floats(-np.pi, np.pi, allow_nan=False))
    axis = st.lists(coord, min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.1)
    rot = st.tuples(axis, st.floats(0.0, 3.0)).map(lambda a: np.asarray(a[0]) / np.linalg.norm(a[0]) * a[1])
    return st.tuples(origin, rot)


class JointConformance:
    """Base class of a pytest test class that runs the conformance checks on one joint class::

        class TestMyJoint(flexmb.testing.JointConformance):
            joint_class = MyJoint

    Hypothesis draws the shape parameters (``joint_class.parameter_ranges``), placements and
    intended motions (within ``joint_class.motion_range`` [rad]); the number of examples per
    test is a fifth of the active hypothesis profile's ``max_examples`` (at least 2).

    Every check is relative to the joint's own size and stiffness, so any consistent unit system
    and scale works, and the joint is placed anywhere within ``placement_range`` joint sizes of
    the global origin (default 100), turned any way. A joint that offers a database
    (``database_key``) also gets the KSD checks on `ksd_shape`: by default the kit trains a
    representative joint (the middle of the drawn ranges) with its own ``training`` settings into
    a temporary folder. A check with nothing to check (a massless joint's vibration, the KSD
    checks of a joint without a database, a strategy for another dimension) is reported as a
    skipped test with the reason (``pytest -ra`` lists them), never as a pass; `conformance_report`
    gives the same outcome without pytest. Hooks (class attributes and methods)::

        class TestMyMemsJoint(flexmb.testing.JointConformance):   # um, uN, MPa
            joint_class = MyJoint
            parameter_ranges = {"length": (200.0, 800.0), "thickness": (5.0, 20.0)}
            joint_parameters = {"E": 169e3, "G": 66e3}              # fixed in every drawn joint
            placement_range = 10.0                                  # origins within 10 joint sizes

            def solver_options(self, joint, dim):                   # options of every solve
                return {"tol": 1e-9 * flexmb.testing.force_scale(joint, dim)}

            def ksd_shape(self, dim):                               # KSD on data you ship
                return flexmb.testing.KSDShape(MyJoint(), folder="mypackage/data")
    """

    joint_class: type | None = None
    #: Shape parameter ranges drawn (default: ``joint_class.parameter_ranges``).
    parameter_ranges: dict | None = None
    #: Parameters given to every drawn joint (e.g. moduli in the ranges' unit system).
    joint_parameters: dict = {}
    #: Joint origins are drawn within this many joint sizes (`joint_size`) of the global origin.
    placement_range: float = 100.0

    def joint_size(self, joint, dim: int) -> float:
        """The length that scales the placements (default: `joint_size`)."""
        return joint_size(joint, dim)

    def solver_options(self, joint, dim: int) -> dict:
        """Options of every solve of the checks (default none: the conventional method's relative
        criterion, `solver_tolerance` for strategies with an absolute ``tol``)."""
        return {}

    def representative(self):
        """The joint of the KSD checks' trained shape: ``joint_parameters`` and the middle of each
        drawn range (`parameter_ranges`), the class's defaults otherwise."""
        ranges = self.parameter_ranges if self.parameter_ranges is not None else \
            getattr(self.joint_class, "parameter_ranges", {})
        return self.joint_class(**self.joint_parameters, **{k: 0.5 * (lo + hi) for k, (lo, hi) in ranges.items()})

    def ksd_shape(self, dim: int):
        """The `KSDShape` the KSD checks run on in ``dim`` (default: `representative`, trained by
        `flexmb.testing_ksd.trained_shape` into a temporary folder). Override it to name a shape
        and the folder of its database (None: the user's and the shipped data)."""
        from .testing_ksd import trained_shape

        return trained_shape(self.representative(), dim)

    @staticmethod
    def _settings():
        from hypothesis import HealthCheck, settings

        return settings(max_examples=max(2, settings.default.max_examples // 5), deadline=None,
                        suppress_health_check=[HealthCheck.too_slow, HealthCheck.differing_executors])

    def _run(self, body, *extra, skip=None):
        """Run ``body(joint, dim, (origin, rotation), motion, *extra, **solver_options)`` on drawn
        cases in every dimension the joint supports. ``skip(joint, dim)``: a reason not to run in
        that dimension, or None. A body that raises `CheckSkipped` is recorded too; the check is
        then reported skipped with every reason (`_skipped`), after the dimensions that ran."""
        from hypothesis import given
        from hypothesis import strategies as st

        cls = self.joint_class
        reasons, ran = {}, []
        for dim in cls.dims:
            why = None if skip is None else skip(self.representative(), dim)
            if why:
                reasons[dim] = why
                continue
            motion = st.floats(-getattr(cls, "motion_range", 0.3), getattr(cls, "motion_range", 0.3))

            def check(case):
                j, d, (origin, rotation), *rest = case
                origin = origin * self.placement_range * self.joint_size(j, d)
                try:
                    body(j, d, (origin, rotation), *rest, **self.solver_options(j, d))
                except CheckSkipped as exc:
                    reasons[d] = str(exc)

            drawn = joints(cls, self.parameter_ranges, self.joint_parameters)
            cases = st.tuples(drawn, st.just(dim), placements(dim), motion, *extra)
            given(cases)(self._settings()(check))()
            if dim not in reasons:
                ran.append(dim)
        if reasons:
            _skipped(reasons, ran)

    def test_rest(self):
        """`check_rest`: zero residual, symmetric positive definite tangent at rest."""
        self._run(lambda j, dim, pl, mo, **o: check_rest(j, dim))

    def test_tangent_matches_finite_differences(self):
        """`check_tangent`: analytic tangent = central differences in deformed states."""
        from hypothesis import strategies as st

        self._run(lambda j, dim, pl, mo, seed, **o: check_tangent(j, dim, pl[0], pl[1], motion=mo, seed=seed, **o),
                  st.integers(0, 2**16))

    def test_rigid_motion_gives_no_force(self):
        """`check_rigid_motion`: a rigid motion of the whole joint gives no internal force."""
        self._run(lambda j, dim, pl, mo, **o: check_rigid_motion(j, dim, pl[0], pl[1]))

    def test_frame_invariance(self):
        """`check_frame_invariance`: a moved and turned mechanism gives the moved and turned solution."""
        self._run(lambda j, dim, pl, mo, **o: check_frame_invariance(j, dim, pl[0], pl[1], motion=mo, **o))

    def test_frame_invariance_of_every_strategy(self):
        """`check_strategy_frame_invariance`: KSD (on `ksd_shape`) and the closed-form Newton are
        frame invariant too."""
        def body(j, dim, pl, mo, **o):
            shape = self.ksd_shape(dim) if _ksd_applies(j, dim) else None
            check_strategy_frame_invariance(j, dim, pl[0], pl[1], motion=mo, shape=shape, **o)

        self._run(body)

    def test_ksd_database_matches_the_joint(self):
        """`flexmb.testing_ksd.check_ksd_database`: the KSD shape's database is found, valid and
        matches the joint's finite-element model (`flexmb.database.verify`)."""
        from .testing_ksd import check_ksd_database

        reasons, ran = {}, []
        for dim in self.joint_class.dims:
            why = _ksd_skip(self.representative(), dim)
            if why:
                reasons[dim] = why
                continue
            check_ksd_database(self.ksd_shape(dim), dim)
            ran.append(dim)
        if reasons:
            _skipped(reasons, ran)

    def test_ksd_matches_the_conventional_method(self):
        """`check_ksd`: on `ksd_shape`, placed anywhere and loaded, KSD-full is
        the conventional solution and KSD-reduced within its stated tolerance of it."""
        def body(j, dim, pl, mo, **o):
            shape = self.ksd_shape(dim)
            size = joint_size(shape.joint, dim)  # the shape's own placement
            check_ksd(shape, dim, pl[0] / self.joint_size(j, dim) * size, pl[1], motion=mo)

        self._run(body, skip=_ksd_skip)

    def test_maxwell_betti_reciprocity(self):
        """`check_reciprocity`: the small-load compliance is symmetric (Maxwell-Betti)."""
        def body(j, dim, pl, mo, tol=None, **o):  # its loads are tiny: it sets its own tolerance
            check_reciprocity(j, dim, pl[1], **o)

        self._run(body)

    def test_work_equals_stored_energy(self):
        """`check_energy`: the work of a load along its path equals the stored strain energy."""
        self._run(lambda j, dim, pl, mo, **o: check_energy(j, dim, pl[1], **o))

    def test_every_strategy_solves_or_refuses_cleanly(self):
        """`check_strategies`: every strategy solves the joint or raises its documented error."""
        self._run(lambda j, dim, pl, mo, **o: check_strategies(j, dim, motion=mo, **o))

    def test_mass_symmetric_positive_definite(self):
        """`check_mass`: the consistent mass is symmetric positive definite, one total mass."""
        self._run(lambda j, dim, pl, mo, **o: check_mass(j, dim, pl[1], motion=mo))

    def test_frequencies_unchanged_by_a_rigid_move(self):
        """`check_modes_rigid_move`: a moved and turned joint vibrates at the same frequencies."""
        self._run(lambda j, dim, pl, mo, **o: check_modes_rigid_move(j, dim, pl[0], pl[1], motion=mo))

    def test_unsupported_joint_has_its_rigid_body_zero_modes(self):
        """`check_floating_modes`: with nothing held, exactly the rigid-body zero modes."""
        self._run(lambda j, dim, pl, mo, **o: check_floating_modes(j, dim, pl[1]))

    def test_rayleigh_quotients_are_the_eigenvalues(self):
        """`check_rayleigh`: each mode's Rayleigh quotient is its omega^2."""
        self._run(lambda j, dim, pl, mo, **o: check_rayleigh(j, dim, pl[1], motion=mo))

    #: Whether the joint's mesh is meant to carry a complex step (design gradients with respect to
    #: its dimensions: one build per parameter); False skips `test_mesh_is_complex_step_safe` with
    #: that reason (the design gradients then take central differences of the build: two builds).
    complex_step: bool = True

    def test_mesh_is_complex_step_safe(self):
        """`check_complex_step`: the mesh carries a complex step in every real parameter (design
        gradients with respect to the joint's dimensions and material, `flexmb.design`)."""
        if "fe_model" not in self.representative().capabilities:
            _skipped({d: "the joint has no finite-element mesh" for d in self.joint_class.dims}, [])
        if not self.complex_step:
            _skipped({d: "complex_step = False: design gradients with respect to the joint's own parameters take "
                         "central differences of the build (flexmb.design.builds)" for d in self.joint_class.dims}, [])
        self._run(lambda j, dim, pl, mo, **o: check_complex_step(j, dim))


def _ksd_applies(joint, dim: int) -> bool:
    return not _ksd_skip(joint, dim)


def _ksd_skip(joint, dim: int) -> str | None:
    """Why the KSD checks do not apply to ``joint`` in ``dim`` (None: they do)."""
    from .solvers import STRATEGIES

    reasons = strategy_skips(joint, dim)
    ksd = [n for n, c in STRATEGIES.items() if "database" in getattr(c, "needs", ())]
    if ksd and all(n in reasons for n in ksd):
        return "; ".join(f"{n}: {reasons[n]}" for n in ksd)
    return None if ksd else "no KSD strategy is registered"


def _skipped(reasons: dict, ran: list) -> None:
    """Report a check skipped in the dimensions of ``reasons`` ({dim: why}): pytest's skip under
    pytest (the test shows as skipped with the reasons, never as passed), else `CheckSkipped`."""
    text = "; ".join(f"skipped in {d}D: {r}" for d, r in sorted(reasons.items()))
    if ran:
        text += f" (passed in {', '.join(f'{d}D' for d in ran)})"
    try:
        import pytest
    except ImportError:
        raise CheckSkipped(text) from None
    pytest.skip(text)


@attrs.frozen
class ConformanceReport:
    """The outcome of every check of `JointConformance` on one joint class: ``outcomes`` a tuple
    of ``(check, status, detail)`` with status ``"passed"``, ``"failed"`` or ``"skipped"`` and the
    failure's message or the skip's reason."""

    outcomes: tuple

    @property
    def passed(self) -> bool:
        """True when no check failed (skipped checks are listed, not counted as passes)."""
        return all(status != "failed" for _, status, _ in self.outcomes)

    def __str__(self) -> str:
        return "\n".join(f"{status:7s} {check}" + (f": {detail}" if detail else "")
                         for check, status, detail in self.outcomes)


def conformance_report(suite) -> ConformanceReport:
    """Run every check of ``suite`` (a `JointConformance` subclass or instance: its joint class
    and hooks) and report each as passed, failed (with the message) or skipped (with the reason);
    what pytest shows for the same class, for a script or a notebook."""
    instance = suite() if isinstance(suite, type) else suite
    try:
        import pytest

        skip = (CheckSkipped, pytest.skip.Exception)
    except ImportError:
        skip = (CheckSkipped,)
    out = []
    for name in sorted(n for n in dir(type(instance)) if n.startswith("test_")):
        try:
            getattr(instance, name)()
            out.append((name, "passed", ""))
        except skip as exc:
            out.append((name, "skipped", str(getattr(exc, "msg", exc))))
        except AssertionError as exc:
            out.append((name, "failed", " ".join(str(exc).split())[:2000]))
    return ConformanceReport(tuple(out))


from .design.check import check_gradient, central_differences, taylor_test  # noqa: E402 (the design layer's checker)
__all__ += ["check_gradient", "central_differences", "taylor_test"]
