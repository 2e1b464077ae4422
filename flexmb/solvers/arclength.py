"""Arc-length path following on the full finite-element model (Riks 1979, Crisfield 1981).

The mechanism's loads and prescribed motions scale with one load factor ``lam`` (``lam = 1``: the
mechanism as given, ``lam = 0``: undeformed). The unknowns are the free DOFs ``u_f`` and ``lam``;
the prescribed DOFs follow ``lam`` exactly (`StaticProblem.prescribed_increment`). Each step adds
the constraint that the step's increment has length ``ds`` in the scaled metric

    |(du, dlam)|^2 = (|D du|^2 / c^2 + psi^2 dlam^2) / (1 + psi^2),

``D`` dividing translations by the mechanism's size (rotations stay in rad) and ``c = |D t_0|``
the size of the initial path tangent per unit load factor: so ``ds`` is dimensionless, the same in
any unit system, and the first step's ``ds`` is its load-factor increment. ``psi = 1`` is
Crisfield's spherical constraint, ``psi = 0`` the cylindrical one. The corrector solves the
constraint's quadratic in ``dlam`` (Crisfield 1981, Eq. 17) and takes the root whose increment
makes the smaller angle with the one before (no doubling back); the predictor follows the path
tangent in the direction of the previous step, and a step whose tangent turns by more than
``max_turn`` is cut (it may have jumped to a nearby branch).

Along the path: stability is the inertia of the symmetric part of the free tangent ``K_ff``
(positive definite: stable; the count of negative eigenvalues is kept). Under the dead loads of
2D mechanisms ``K_ff`` is symmetric already; a 3D dead moment adds a skew part
``-1/2 skew(m)``, which adds nothing to the quadratic form ``du^T K du`` and is left out, as
`flexmb.solvers.conventional.is_stable` does. A limit point is a zero of ``dlam/ds`` (the load
factor's extremum); a bifurcation point is a change of the negative count without one (the
crossing eigenvalue's zero). Both are located between the two points that bracket them by the
Illinois variant of regula falsi on the arc length, each trial a converged equilibrium.
"""

from __future__ import annotations

import math
import time
from typing import ClassVar

import attrs
import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from ..errors import ParameterError
from ..fe.model import State
from .branching import DENSE_EIGEN_BELOW, branch_points, choose, critical_modes, is_bifurcation, multiplicity, switch_arc
from .conventional import is_stable, positive_float, positive_int, relative_tolerance, unit_interval

__all__ = ["ArcLength", "PathPoint", "load_tangent", "inertia", "DENSE_EIGEN_BELOW"]

#: Below this many free DOFs the eigenvalues of the symmetric tangent come from LAPACK's dense
#: ``eigvalsh`` (all of them, a cost growing with the cube of the DOFs); above, the negative count from a sparse symmetric LDL^T and the
#: eigenvalues nearest zero from ARPACK (shift-invert at 0). (`flexmb.solvers.branching`'s.)

#: Eigenvalue crossings located within this fraction of a step's arc length of each other are
#: one critical point of that multiplicity. A double eigenvalue splits by round-off where the
#: eigenvalues near zero are tiny beside the tangent's entries: Qiu's double beam with its
#: shuttle (two halves decoupled) at 40 elements per half, eigenvalues 2e-14 of the largest
#: entry, split by 0.2 %: their crossings were located 0.13 % of the step apart (reported as two
#: simple points, and the path left onto a one-half branch); an exact double eigenvalue's agree
#: to ``locate_tol`` (1e-6).
SAME_CRITICAL = 2e-2

#: An eigenvalue that changes sign between two points while staying below this fraction of the
#: eigenvalues nearest zero there is round-off, no critical point: on a strut's post-buckling
#: branch next to the bifurcation the buckling mode's eigenvalue is ~1e-9 of the next one and
#: its sign flickered from point to point (20 "bifurcations" at the same load).
ROUNDOFF_EIGENVALUE = 1e-7


def _nonnegative_float(instance, attribute, value):
    from .. import _validate as v

    v.nonnegative(type(instance).name, attribute.name, value)


def inertia(Kff, k: int = 4):
    """``(negative count, eigenvalues nearest zero)`` of the symmetric part of ``Kff``.

    The eigenvalues are the ``k`` of smallest magnitude, sorted ascending (signed); dense below
    `DENSE_EIGEN_BELOW` free DOFs, else the count from a sparse LDL^T (Sylvester's law of
    inertia, `is_stable`'s factorisation) and the eigenvalues from shift-invert ARPACK at 0
    (dense LAPACK when either cannot deliver: SuperLU pivoted off the diagonal, ARPACK did not
    converge or the matrix is singular).
    """
    n = Kff.shape[0]
    if n == 0:
        return 0, np.zeros(0)
    if n < DENSE_EIGEN_BELOW:
        return _dense_inertia(Kff, k)
    A = (0.5 * (Kff + Kff.T)).tocsc()
    try:
        near = np.sort(spla.eigsh(A, k=min(k, n - 1), sigma=0.0, which="LM", return_eigenvectors=False))
    except (spla.ArpackNoConvergence, RuntimeError, ValueError):
        return _dense_inertia(A, k)
    if is_stable(A):
        return 0, near
    from scipy.sparse.linalg import splu

    try:
        lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:  # exactly singular
        return _dense_inertia(A, k)
    if np.array_equal(lu.perm_r, lu.perm_c):
        return int(np.sum(lu.U.diagonal() < 0.0)), near
    return _dense_inertia(A, k)  # SuperLU pivoted off the diagonal: no inertia from it


def _dense_inertia(K, k: int):
    A = K.toarray() if hasattr(K, "toarray") else np.asarray(K)
    ev = sla.eigvalsh(0.5 * (A + A.T))
    return int(np.sum(ev < 0.0)), np.sort(ev[np.argsort(np.abs(ev))[:k]])


def load_tangent(problem, state: State, lam: float, Kfp=None):
    """``(d r_f / d lam, v_p)`` at fixed free DOFs: the derivative of the free residual with
    respect to the load factor, the prescribed DOFs following it, and their rate ``v_p`` (n_p,).

    ``r_f(u, lam) = f_int,f(u) - f_ext,f(u, lam)`` with the prescribed DOFs at ``u_p(lam)``:
    ``d r_f / d lam = -q_f + K_fp v_p``, ``q = f_ext(u, 1) - f_ext(u, 0)`` (the dead loads are
    linear in ``lam``; their offsets' turning is in ``K``), ``v_p`` the prescribed values (a 3D
    orientation ``exp(lam w)`` has spin rate ``w``; a rotation chain ``exp(lam w_1) ...
    exp(lam w_k)`` the spin rate ``sum_i R_1 ... R_{i-1} w_i``). ``Kfp``: the tangent block at
    ``(state, lam)`` (evaluated if None).
    """
    q = problem.external_force(state, 1.0)[0] - problem.external_force(state, 0.0)[0]
    vp = _prescribed_rate(problem, lam)
    if Kfp is None:
        Kfp = problem.evaluate(state, lam)[2]
    return (_motor_rate(problem) - q)[problem.free] + Kfp @ vp, vp


def _motor_rate(problem) -> np.ndarray:
    """d r / d lam of the hinges' motors (`flexmb.joints.Hinge`): a motor row's constraint is
    ``theta - lam angle`` (scaled), so its rate is ``-angle scale`` while the motor ramps."""
    model = problem.model
    hinges = getattr(model, "hinges", None)
    out = np.zeros(model.n_dofs)
    if hinges is None or problem.motor_fraction(0.0) == 1.0:
        return out
    rows = hinges.active.shape[1]
    n = model.hinge_dofs.shape[1]
    F = np.zeros((len(hinges.node), n))
    F[:, n - 1] = np.where(hinges.active[:, -1], -np.nan_to_num(hinges.angle) * hinges.scale[rows - 1], 0.0)
    np.add.at(out, model.hinge_dofs.ravel(), F.ravel())
    return out


def _prescribed_rate(problem, lam: float) -> np.ndarray:
    from ..rotations import expm_so3

    vp = problem._motion_scale * problem.values
    if getattr(problem, "motion_paths", ()):  # curved prescribed motions (`StaticProblem.motion_paths`)
        vp = vp + problem.curve_rate(lam)
    if problem._motion_scale and problem.rotation_paths:
        vp = vp.copy()
        for dofs, w in problem.rotation_paths:
            R, rate = np.eye(3), np.zeros(3)
            for wi in w:
                rate = rate + R @ wi
                R = R @ expm_so3(lam * wi[None])[0]
            vp[np.searchsorted(problem.prescribed, dofs)] = rate
    return vp


@attrs.frozen(eq=False)
class PathPoint:
    """A converged equilibrium on the path, with what the stepping and the detection need.

    ``tangent``, ``tangent_lam``: the unit path tangent (arc-length metric) on all DOFs (N ndof,)
    and its load-factor part; ``direction``: +1 or -1, the way the path runs through it along
    the tangent (so ``dlam/ds = direction * tangent_lam``);
    ``negative``: the count of negative eigenvalues of the symmetric free tangent, ``near``
    the eigenvalues nearest zero; ``arc``: arc length from the start.
    """

    state: State
    lam: float
    residual: np.ndarray
    tangent: np.ndarray
    tangent_lam: float
    direction: float
    negative: int
    near: np.ndarray
    dlam_ds: float
    arc: float
    iterations: int
    history: tuple = ()
    wall_time: float = 0.0


@attrs.frozen(kw_only=True)
class ArcLength:
    """Arc-length continuation of the full finite-element model [``arc-length``].

    Parameters
    ----------
    tol
        Absolute threshold on the 2-norm of the free residual [N, N m]; None (default): the
        relative test ``rtol``.
    rtol
        Relative threshold: the free residual's forces against the largest of the internal and
        applied forces (all DOFs, reactions included), its moments against the moments or the
        forces times the mechanism's size (1e-9, in (0, 1); round-off sits near 1e-13 on Lee's frame).
    max_iter
        Corrector iterations before the step is cut in half (12).
    desired_iterations
        The arc length of the next step scales by ``sqrt(desired / used)`` (Crisfield 1981),
        within a factor 0.5 ... 2 (5).
    psi
        Weight of the load factor in the constraint: 1 spherical (default), 0 cylindrical.
    min_arc, max_arc
        Bounds of the arc length relative to the first step's (1e-4, 1000).
    max_rotation
        A corrector that turns a node by more than this [rad] cuts the step (it is leaving the
        branch; as in `Conventional`), None disables the check (1.0).
    max_turn
        A step whose end tangent turns from its start tangent by more than this [rad] is cut in
        half (0.2): the path keeps its resolution through sharp turns and does not jump to a
        nearby branch (Qiu's bistable with a 1e-3 imperfection, where two branches pass close:
        at 0.5 the path jumped onto the other and went round it; at 0.2 it snaps through).
    locate_tol
        Critical points are located to this fraction of the arc length between the two
        bracketing points (1e-6).
    """

    name: ClassVar[str] = "arc-length"
    capability: ClassVar[str] = "fe_model"
    tol: float | None = attrs.field(default=None, validator=attrs.validators.optional(positive_float))
    rtol: float = attrs.field(default=1e-9, validator=relative_tolerance)
    max_iter: int = attrs.field(default=12, validator=positive_int)
    desired_iterations: int = attrs.field(default=5, validator=positive_int)
    psi: float = attrs.field(default=1.0, validator=_nonnegative_float)
    min_arc: float = attrs.field(default=1e-4, validator=positive_float)
    max_arc: float = attrs.field(default=1000.0, validator=positive_float)
    max_rotation: float | None = attrs.field(default=1.0, validator=attrs.validators.optional(positive_float))
    locate_tol: float = attrs.field(default=1e-6, validator=unit_interval)
    max_turn: float = attrs.field(default=0.2, validator=positive_float)

    def __attrs_post_init__(self):
        if not self.min_arc < self.max_arc:
            raise ParameterError(f"{self.name}: min_arc={self.min_arc!r} must be below max_arc={self.max_arc!r} "
                                 "(both in units of the first step's arc length)")

    # -- the pieces --------------------------------------------------------------------------
    def setup(self, problem, state: State | None = None):
        """``(metric, t_0, K_ff)``: the constraint's metric from the path tangent ``t_0`` at the
        start ``state`` (default: undeformed; see the module notes) and the tangent there."""
        state = problem.model.initial_state() if state is None else state
        x = problem.model.point_positions(problem.model.initial_state())
        size = float(np.max(np.ptp(x, axis=0))) if len(x) > 1 else 1.0
        metric = _Metric(problem.model, size if size > 0 else 1.0, 1.0, self.psi)
        _, Kff, Kfp, _ = problem.evaluate(state, 0.0)
        t = _rate(problem, state, 0.0, Kff, Kfp)
        c = metric.norm(t) if t is not None else 0.0
        metric = attrs.evolve(metric, scale=c if c > 0 else 1.0)
        return metric, _unit_tangent(problem, metric, state, 0.0, Kff, Kfp), Kff

    def start(self, problem, metric, t0, Kff0, state: State | None = None) -> PathPoint:
        """The path's first point at load factor 0: ``state`` (default: undeformed)."""
        state = problem.model.initial_state() if state is None else state
        r = problem.evaluate(state, 0.0, tangent=False)[0]
        neg, near = inertia(problem.reduced_tangent(Kff0))  # hinges: on the motions they allow
        t, tl = t0
        direction = 1.0 if tl >= 0 else -1.0  # towards positive load factors
        return PathPoint(state, 0.0, r, t, tl, direction, neg, near, direction * tl, 0.0, 0)

    def step(self, problem, metric, a: PathPoint, ds: float, fix_lam: float | None = None):
        """A converged point at arc length ``ds`` from ``a`` along its direction (or, with
        ``fix_lam``, at that load factor by Newton at fixed ``lam`` from the tangent predictor);
        None if the corrector fails (diverges, leaves the branch or runs out of iterations)."""
        t0 = time.perf_counter()
        free = problem.free
        if fix_lam is None:
            pred_u, dlam = a.direction * ds * a.tangent, a.direction * ds * a.tangent_lam
        else:
            dlam = fix_lam - a.lam
            pred_u = dlam / a.tangent_lam * a.tangent if a.tangent_lam else np.zeros_like(a.tangent)
        state = problem.model.apply_increment(a.state, _split(problem, pred_u, dlam, a.lam))
        lam = a.lam + dlam
        history = []
        for it in range(self.max_iter + 1):
            r, Kff, Kfp, _ = problem.evaluate(state, lam)
            rf = r[free]
            res = float(np.linalg.norm(rf))
            history.append(res)
            if not np.isfinite(res):
                return None
            ok = self._converged(problem, metric, state, lam, r)
            if ok:
                break
            if it == self.max_iter or (it > 1 and res > 1e3 * history[-2]):
                return None
            try:
                du_r = problem.solve_linear(Kff, -rf)
                g, _ = load_tangent(problem, state, lam, Kfp)
                du_t = problem.solve_linear(Kff, -g)
            except (np.linalg.LinAlgError, RuntimeError, ValueError):
                return None
            if not (np.all(np.isfinite(du_r)) and np.all(np.isfinite(du_t))):
                return None
            vp = _prescribed_rate(problem, lam)
            Du = metric.difference(state, a.state)
            Dl = lam - a.lam
            dr = problem.full_increment(du_r, np.zeros_like(vp))
            dt = problem.full_increment(du_t, vp)
            if fix_lam is None:
                dl = metric.root(Du, Dl, dr, dt, ds)
            else:
                dl = 0.0
            du = dr + dl * dt
            if it > 0 and ok is None and _negligible(problem.model, du, metric.size):
                break  # the round-off floor: the residual stalls and the correction moves nothing
            if self.max_rotation is not None and problem.model.largest_motion(du)[1] > self.max_rotation:
                return None
            state = problem.model.apply_increment(state, _split(problem, du, dl, lam))
            lam += dl
        if fix_lam is None:  # a corrector that came back against the predictor has doubled back
            chord = metric.difference(state, a.state)
            if a.direction * (metric.dot(a.tangent, chord) + metric.psi2 * a.tangent_lam * (lam - a.lam)) <= 0.0:
                return None
        try:
            return self._point(problem, metric, a, state, lam, r, Kff, Kfp, it, history, time.perf_counter() - t0)
        except (np.linalg.LinAlgError, RuntimeError, ValueError):
            return None

    def rate(self, problem, state: State, lam: float):
        """The path's rate per unit load factor on all DOFs at ``(state, lam)`` (`_rate`), or None."""
        _, Kff, Kfp, _ = problem.evaluate(state, lam)
        return _rate(problem, state, lam, Kff, Kfp)

    def _point(self, problem, metric, a, state, lam, r, Kff, Kfp, iterations, history, seconds) -> PathPoint:
        t, tl = _unit_tangent(problem, metric, state, lam, Kff, Kfp)
        chord_u, chord_l = metric.difference(state, a.state), lam - a.lam
        # the path runs through the new point the way the chord from the last one points
        direction = 1.0 if metric.dot(t, chord_u) + metric.psi2 * tl * chord_l >= 0.0 else -1.0
        neg, near = inertia(problem.reduced_tangent(Kff))  # hinges: on the motions they allow
        arc = a.arc + metric.length(chord_u, chord_l)
        return PathPoint(state, lam, r, t, tl, direction, neg, near, direction * tl, arc, iterations,
                         tuple(history), seconds)

    def _converged(self, problem, metric, state, lam, r) -> bool | None:
        """True below the tolerance; None within 1e-5 of the force scales (where the round-off
        floor of a stiff model may sit: `step` then accepts a correction that moves nothing);
        False above."""
        free = problem.free
        if self.tol is not None:
            return float(np.linalg.norm(r[free])) <= self.tol
        f_ext = problem.external_force(state, lam)[0]
        f_int = r + f_ext
        is_tr = problem.model.force_dofs
        # forces and moments measure each other through the size: a mechanism loaded by moments
        # alone (a sprung hinge turned) has forces of round-off size, no scale of their own
        # the element end forces meeting at a node (and the hinges' constraint forces) set its
        # round-off floor: a mechanism that moves on hinges carries little net force but its
        # residual sums large end forces (a motor four-bar: 5e-9 N of 0.3 N, none applied)
        F0 = max(np.linalg.norm(f_int[is_tr]), np.linalg.norm(f_ext[is_tr]), getattr(problem, "force_scale", 0.0))
        M0 = max(np.linalg.norm(f_int[~is_tr]), np.linalg.norm(f_ext[~is_tr]))
        F, M = max(F0, M0 / metric.size), max(M0, F0 * metric.size)
        if F == 0.0 and M == 0.0:
            return float(np.linalg.norm(r[free])) == 0.0
        rf_tr = r[free][is_tr[free]]
        rf_rot = r[free][~is_tr[free]]
        a, b = np.linalg.norm(rf_tr) / F, np.linalg.norm(rf_rot) / M
        if a <= self.rtol and b <= self.rtol:
            return True
        if max(a, b) <= 1e-5 or float(np.linalg.norm(r[free])) <= _hinge_floor(problem.model, metric.size):
            return None
        return False

    def next_arc(self, ds: float, iterations: int, ds0: float) -> float:
        """The next step's arc length after a step that took ``iterations`` (Crisfield 1981)."""
        f = min(2.0, max(0.5, math.sqrt(self.desired_iterations / max(iterations, 1))))
        return min(self.max_arc * ds0, max(self.min_arc * ds0, ds * f))

    def follow(self, problem, metric, first: PathPoint, ds0: float, branch: str = "primary"):
        """Step along the path from ``first`` with first arc length ``ds0``: yields
        ``("point", PathPoint, ds)`` for every converged step (``ds`` its constraint radius),
        ``("critical", kind, PathPoint, multiplicity, modes, switched, asymmetric)`` before the
        point past a limit (``"limit"``) or bifurcation (``"bifurcation"``) point (``modes`` (m,
        n_dofs) the critical modes, `flexmb.solvers.branching.critical_modes`; ``switched``: the
        path leaves there for another branch, chosen by ``branch``,
        `flexmb.solvers.branching.BRANCHES`; ``asymmetric``: an asymmetric bifurcation,
        `flexmb.solvers.branching.is_asymmetric`, known where the branches were sought), and
        ``("stuck", message)`` once when the arc length falls below ``min_arc`` (then stops).
        Runs until the consumer stops asking."""
        a, ds, ref = first, ds0, ds0  # ref: the arc length the bounds min_arc, max_arc refer to
        while True:
            b = self.step(problem, metric, a, ds)
            if b is not None and ds > self.min_arc * ref and self._turn(metric, a, b) > self.max_turn:
                b = None  # the path turns too sharply for this step: it may have jumped to another branch
            if b is None:
                ds *= 0.5
                if ds < self.min_arc * ref:
                    yield ("stuck", f"the path cannot continue from load factor {a.lam:.6g}: no equilibrium "
                                    f"within arc length {2 * ds:.3g} (min_arc={self.min_arc:g} x the first step's "
                                    f"{ref:.3g})")
                    return
                continue
            following = b
            for kind, p, count, modes in self._critical(problem, metric, a, b, ds):
                q, asymmetric = None, False
                if kind == "bifurcation" and branch != "primary":
                    # a branch the path was not scaled for (a strut's bending under an axial
                    # load): its first step moves the mode by SWITCH_MOTION, and sets the bounds;
                    # the branches through p along which the load factor changes: the path's step
                    switch = max(ds, switch_arc(metric, modes))
                    own, others, asymmetric = branch_points(self, problem, metric, p, a, modes, ds, switch)
                    q = choose(p, own, others, branch)
                    q = None if q is own else q
                yield ("critical", kind, p, count, modes, q is not None, asymmetric)
                if q is not None:  # onto another branch: the critical points beyond p are not on it
                    ds = switch
                    following, ref = q, max(ref, ds)
                    break
            yield ("point", following, ds)
            a, ds = following, self.next_arc(ds, following.iterations, ref)

    @staticmethod
    def _turn(metric, a: PathPoint, b: PathPoint) -> float:
        """The angle [rad] between the oriented unit tangents at ``a`` and ``b``."""
        c = (metric.dot(a.tangent, b.tangent) + metric.psi2 * a.tangent_lam * b.tangent_lam) / (1.0 + metric.psi2)
        return math.acos(max(-1.0, min(1.0, a.direction * b.direction * c)))

    def _critical(self, problem, metric, a: PathPoint, b: PathPoint, ds: float) -> list:
        """The limit and bifurcation points between consecutive points ``a`` and ``b``, in path
        order: ``(kind, PathPoint, multiplicity, modes)``.

        Each eigenvalue (ascending order) that changes sign between them is located by its zero;
        the limit point, if ``dlam/ds`` changes sign, by that zero. The eigenvalue crossing
        nearest the limit point is the limit's own (the two zeros agree only to the equilibrium's
        accuracy: the eigenvalue is flat there), and so are the others located at it (within
        `SAME_CRITICAL` of the step: a double limit point, whose multiplicity is their number or
        `flexmb.solvers.branching.multiplicity`'s, the larger); the other crossings are
        bifurcation points, those located at the same point (within `SAME_CRITICAL` of the step)
        one point whose multiplicity is their number (a double eigenvalue: a symmetric two-leaf
        device). A load
        factor's extremum whose critical modes the load pattern does not work on is a bifurcation
        (`flexmb.solvers.branching.is_bifurcation`: a pitchfork met along its bifurcated branch)."""
        found = []
        if np.sign(a.dlam_ds) != np.sign(b.dlam_ds):
            p = self.locate(problem, metric, a, ds, a.dlam_ds, b.dlam_ds, lambda x: x.dlam_ds)
            if p is not None:
                found.append(("limit", p, 1))
        crossings = []
        for k in range(min(a.negative, b.negative), max(a.negative, b.negative)):
            def crossing(x, k=k):
                return _kth_eigenvalue(problem, x, k)

            ga, gb = crossing(a), crossing(b)
            if max(abs(ga), abs(gb)) <= ROUNDOFF_EIGENVALUE * max(np.max(np.abs(a.near)), np.max(np.abs(b.near))):
                continue  # an eigenvalue that only flickers about zero in round-off (a flat branch)
            p = self.locate(problem, metric, a, ds, ga, gb, crossing)
            if p is not None:
                crossings.append(p)
        if found and crossings:  # the crossing nearest the limit point is the limit's own eigenvalue, and
            # so are those located at it (a double limit: a decoupled two-half device's halves turn together)
            at = found[0][1].arc
            nearest = min(crossings, key=lambda p: abs(p.arc - at))
            own = [p for p in crossings if p is nearest or abs(p.arc - at) <= SAME_CRITICAL * ds]
            crossings = [p for p in crossings if all(p is not q for q in own)]
            found[0] = ("limit", found[0][1], len(own))
        groups = []
        for p in sorted(crossings, key=lambda p: p.arc):
            if groups and p.arc - groups[-1][0].arc <= SAME_CRITICAL * ds:
                groups[-1].append(p)
            else:
                groups.append([p])
        found += [("bifurcation", g[0], len(g)) for g in groups]
        out = []
        for kind, p, m in sorted(found, key=lambda f: f[1].arc):
            if kind == "limit":  # a pitchfork met along its bifurcated branch turns the load factor too
                m = max(m, multiplicity(p))
                modes = critical_modes(problem, metric, p, m)
                g = load_tangent(problem, p.state, p.lam)[0]
                kind = "bifurcation" if is_bifurcation(problem, metric, modes, g) else kind
            else:
                modes = critical_modes(problem, metric, p, m)
            out.append((kind, p, m, modes))
        return out

    def locate(self, problem, metric, a: PathPoint, b_arc: float, g_a: float, g_b: float, g):
        """The point between ``a`` (arc 0) and the step of arc ``b_arc`` where ``g(point)``
        (signs ``g_a``, ``g_b`` at the ends) vanishes: Illinois regula falsi on the arc length.
        Returns the point nearest the zero that converged, or None."""
        lo, hi, glo, ghi = 0.0, b_arc, g_a, g_b
        best, side = None, 0
        for _ in range(60):
            s = (lo * ghi - hi * glo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
            if not lo < s < hi:
                s = 0.5 * (lo + hi)
            p = self.step(problem, metric, a, s)
            if p is None:
                return best
            gs = g(p)
            best = p
            if gs == 0.0 or hi - lo <= self.locate_tol * b_arc:
                return p
            if np.sign(gs) == np.sign(glo):
                lo, glo = s, gs
                if side == -1:
                    ghi *= 0.5
                side = -1
            else:
                hi, ghi = s, gs
                if side == 1:
                    glo *= 0.5
                side = 1
        return best


def _kth_eigenvalue(problem, p: PathPoint, k: int) -> float:
    """The ``k``-th (0-based, ascending) eigenvalue of the symmetric free tangent at ``p``."""
    Kff = problem.reduced_tangent(problem.evaluate(p.state, p.lam)[1])
    n = Kff.shape[0]
    if n < DENSE_EIGEN_BELOW:
        A = Kff.toarray()
        return float(sla.eigvalsh(0.5 * (A + A.T), subset_by_index=[k, k])[0])
    # sparse: the negative count places the k-th eigenvalue among those nearest zero
    A = (0.5 * (Kff + Kff.T)).tocsc()
    neg, _ = inertia(A, 1)
    need = k - neg + 1 if neg <= k else neg - k  # how many on its side of zero, itself included
    try:
        ev = spla.eigsh(A, k=min(n - 1, 2 * need + 2), sigma=0.0, which="LM", return_eigenvectors=False)
        side = np.sort(ev[ev >= 0.0]) if neg <= k else np.sort(ev[ev < 0.0])[::-1]
        return float(side[need - 1])
    except (spla.ArpackNoConvergence, RuntimeError, ValueError, IndexError):
        return float(sla.eigvalsh(A.toarray(), subset_by_index=[k, k])[0])


def _split(problem, du: np.ndarray, dl: float, lam: float) -> np.ndarray:
    """The full increment with the prescribed DOFs moved exactly from ``lam`` to ``lam + dl``."""
    out = du.copy()
    out[problem.prescribed] = problem.prescribed_increment(dl, lam)
    return out


def _hinge_floor(model, size: float) -> float:
    """The round-off floor of the hinges' constraint rows [N]: their scale (the stiffest element's
    EA / L, `flexmb.fe.build._row_scales`) times 100 eps of the mechanism's size. A four-bar whose
    cross-flexure rocker is back at rest after a full crank turn carries forces of ~1e-6 N and its
    residual stalls at 1e-9 N; below this floor `ArcLength.step` accepts a correction that moves
    nothing."""
    hinges = getattr(model, "hinges", None)
    if hinges is None:
        return 0.0
    return 100.0 * np.finfo(float).eps * float(np.asarray(hinges.scale).ravel()[0]) * size  # a position row


def _negligible(model, du: np.ndarray, size: float) -> bool:
    """Whether an increment moves no node by more than 1e-12 of the mechanism's size (nor turns
    one by 1e-12 rad): round-off in the positions; measured on a strut with EA L^2 / EI = 1e7,
    whose residual stalls at 3.5e-8 of the applied load while the corrections reach 1e-16."""
    d = model.node_part(du)
    return bool(np.max(np.abs(d[:, : model.dim])) <= 1e-12 * size and np.max(np.abs(d[:, model.dim:])) <= 1e-12)


def _rate(problem, state, lam, Kff, Kfp):
    """The path's rate per unit load factor on all DOFs, ``K_ff t_f = -d r_f / d lam``,
    ``t_p = v_p``; None where ``K_ff`` is singular (a limit point)."""
    g, vp = load_tangent(problem, state, lam, Kfp)
    try:
        tf = problem.solve_linear(Kff, -g) if len(problem.free) else np.zeros(0)
    except (np.linalg.LinAlgError, RuntimeError):
        return None
    return problem.full_increment(tf, vp) if np.all(np.isfinite(tf)) else None


def _unit_tangent(problem, metric, state, lam, Kff, Kfp):
    """``(t, t_lam)``: the path's unit tangent in the arc-length metric (not oriented): the rate
    ``(t, 1)`` normalised, or at a singular ``K_ff`` (a limit point) its null vector with
    ``t_lam = 0``."""
    t = _rate(problem, state, lam, Kff, Kfp)
    if t is not None:
        n = metric.length(t, 1.0)
        if np.isfinite(n) and n > 0:
            return t / n, 1.0 / n
    K = Kff.toarray() if hasattr(Kff, "toarray") else np.asarray(Kff)
    null = sla.svd(K)[2][-1]
    phi = problem.full_increment(null, np.zeros(len(problem.prescribed)))
    return phi / metric.length(phi, 0.0), 0.0


@attrs.frozen
class _Metric:
    """The scaled metric of the arc-length constraint (module notes): translations over ``size``,
    rotations in rad, divided by ``scale`` (the initial tangent's size); multipliers weigh 0."""

    model: object
    size: float
    scale: float
    psi: float

    @property
    def psi2(self) -> float:
        return self.psi * self.psi

    def _weights(self) -> np.ndarray:
        w = np.ones(self.model.ndof)
        w[: self.model.dim] = 1.0 / self.size
        w = np.tile(w, self.model.n_nodes) / self.scale
        if self.model.hinges is not None:  # the hinges' multipliers follow the motion: no weight
            w = np.concatenate([w, np.zeros(self.model.hinges.n_rows)])
        return w

    def weights(self) -> np.ndarray:
        """The metric's weight of every DOF (n_dofs,)."""
        return self._weights()

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        w = self._weights()
        return float(np.dot(w * a, w * b))

    def norm(self, a: np.ndarray) -> float:
        return math.sqrt(self.dot(a, a))

    def length(self, du: np.ndarray, dlam: float) -> float:
        """The arc length of an increment ``(du, dlam)``."""
        return math.sqrt((self.dot(du, du) + self.psi2 * dlam * dlam) / (1.0 + self.psi2))

    def difference(self, state: State, start: State) -> np.ndarray:
        """The increment from ``start`` to ``state`` on all DOFs (`FEModel.increment`)."""
        return self.model.increment(start, state)

    def root(self, Du, Dl, dr, dt, ds) -> float:
        """``dlam`` of the corrector on the constraint ``|(Du + dr + dlam dt, Dl + dlam)| = ds``
        (Crisfield 1981, Eq. 17): of the two roots the one whose increment makes the smaller
        angle with the step's increment so far ``(Du, Dl)`` (no doubling back); complex roots:
        the constraint's closest point."""
        p2 = self.psi2
        v = Du + dr
        a = self.dot(dt, dt) + p2
        b = 2.0 * (self.dot(v, dt) + p2 * Dl)
        c = self.dot(v, v) + p2 * Dl * Dl - (1.0 + p2) * ds * ds
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            return -b / (2.0 * a)
        qq = -0.5 * (b + math.copysign(math.sqrt(disc), b))  # no cancellation (Numerical Recipes 5.6)
        roots = (qq / a, c / qq) if qq != 0.0 else (0.0, 0.0)
        return max(roots, key=lambda x: self.dot(Du, v + x * dt) + p2 * Dl * (Dl + x))
