"""The static problem: residual and tangent of a finite-element model under loads and prescribed motion.

``r(u, lam) = f_int(u) - lam f_ext(u)`` on every DOF; the solver drives its free part to zero
while the prescribed DOFs follow ``lam * value``. Dead loads at points offset from their node
give a load stiffness (their moment arm turns with the node), included in the tangent.
"""

from __future__ import annotations

import copy
import functools

import attrs
import numpy as np
import scipy.sparse as sp

from .fe.assembly import PartitionedPattern, node_pattern, scatter_add
from .fe.model import FEModel, State
from .linear import TangentSolver
from .rotations import chain_rotation, expm_so3, logm_so3

#: A model farther than this many times its size from the origin is said to be so when Newton stops
#: short (`StaticProblem.roundoff_hint`).
FAR_FROM_ORIGIN = 100.0

__all__ = ["PointLoads", "BoundaryConditions", "StaticProblem"]


@attrs.frozen(eq=False)
class PointLoads:
    """Dead loads at points rigidly attached to nodes.

    ``node`` (K,) master node; ``offset`` (K, dim) undeformed offset from the node [m];
    ``force`` (K, dim) [N] and ``moment`` (K, nrot) [N m] in global axes, at load factor 1.
    """

    node: np.ndarray
    offset: np.ndarray
    force: np.ndarray
    moment: np.ndarray


def path_load_factors(m: int) -> np.ndarray:
    """The load factors ``(1 - cos(k pi / m)) / 2``, k = 1..m, of a curved prescribed motion's
    waypoints (`motion_path`): Chebyshev-Lobatto points, where the interpolating polynomial of
    any degree stays close to a smooth curve."""
    return 0.5 * (1.0 - np.cos(np.pi * np.arange(1, m + 1) / m))


class _Curve:
    """The offset of a curved prescribed motion from its straight line (`motion_path`)."""

    def __init__(self, coef: np.ndarray):
        self.coef, self.rate = coef, np.polynomial.chebyshev.chebder(coef) * 2.0  # d/dlam = 2 d/ds

    def __call__(self, lam: float, nu: int = 0) -> np.ndarray:
        return np.polynomial.chebyshev.chebval(2.0 * lam - 1.0, self.rate if nu else self.coef)


def motion_path(points, end: np.ndarray) -> _Curve:
    """The offset ``p(lam) - lam * end`` of a curved prescribed motion from its straight line, as a
    function ``offset(lam, nu=0)`` (``nu=1``: its derivative in the load factor): ``p`` the
    polynomial through zero at 0 and ``points`` (m, k) at `path_load_factors` (the last at 1); with
    ``end`` (k,) the last point, the offset is zero at 0 and 1. Analytic in ``lam``: the
    continuation's extrapolation follows it (a cubic spline's jumps in the third derivative cost the
    manipulator's location case twice the iterations)."""
    points = np.asarray(points)
    m = len(points)
    lam = np.concatenate([[0.0], path_load_factors(m)])
    pts = np.concatenate([np.zeros((1, points.shape[1]), dtype=points.dtype), points]) - lam[:, None] * end
    return _Curve(np.polynomial.chebyshev.chebfit(2.0 * lam - 1.0, pts, m))


class BoundaryConditions:
    """Prescribed DOFs (sorted indices), their values at load factor 1 and the free DOFs."""

    def __init__(self, n_dofs: int, prescribed: np.ndarray, values: np.ndarray):
        self.prescribed = np.asarray(prescribed, dtype=np.int64)
        self.values = np.asarray(values, dtype=float)
        is_free = np.ones(n_dofs, dtype=bool)
        is_free[self.prescribed] = False
        self.free = np.flatnonzero(is_free)

    @property
    def n_free(self) -> int:
        """Number of free DOFs."""
        return len(self.free)


class StaticProblem(BoundaryConditions):
    """Residual and tangent, partitioned into free and prescribed DOFs with fixed sparsity patterns.

    Parameters
    ----------
    model
        The finite-element model.
    prescribed
        Global DOF indices (n_p,) whose values are prescribed.
    values
        Their values at load factor 1, shape (n_p,): displacements [m] for positions, rotation
        [rad] in 2D, rotation-vector components [rad] in 3D (a 3D node has all three rotation
        DOFs prescribed or none, so ``R = exp(lam * value)`` exactly).
    loads
        The applied point loads at load factor 1.
    rotation_paths
        (rotation DOFs (3,), rotation vectors (k, 3)) of nodes whose prescribed orientation is a
        chain ``exp(w_1) ... exp(w_k)``, followed as ``exp(lam w_1) ... exp(lam w_k)``.
    motion_paths
        (translation DOFs (k,), waypoints (m, k)) of prescribed displacements that follow a curve
        instead of the straight line ``lam * values``: the displacements at the load factors
        `path_load_factors` (the last, 1, equal to their ``values``), joined to zero at 0 by the
        polynomial through them (`motion_path`); the equilibrium at load factor 1 is the same, the
        steps between differ.
    """

    def __init__(self, model: FEModel, prescribed: np.ndarray, values: np.ndarray, loads: PointLoads,
                 rotation_paths=(), motion_paths=()):
        self.model = model
        self.rotation_paths = tuple(rotation_paths)
        self.motion_paths = tuple(motion_paths)
        super().__init__(model.n_dofs, prescribed, values)
        n = model.n_dofs
        nf, npres = len(self.free), len(self.prescribed)
        slot_f = np.full(n, -1)
        slot_f[self.free] = np.arange(nf)
        slot_p = np.full(n, -1)
        slot_p[self.prescribed] = np.arange(npres)

        self._slots = (slot_f, slot_p, nf, npres)
        self.loads = loads
        self._wrench = np.concatenate([loads.force, loads.moment], axis=1)
        self._wrench0 = np.zeros_like(self._wrench)
        self._motion_scale = 1.0
        self._offset = None
        #: (prescribed slots (3,), w_0, w_1) of 3D orientations followed as exp(w_0 + lam (w_1 - w_0))
        self._rotation_lines = ()
        #: (prescribed slots (k,), the curve's offset from the straight line (a function of lam))
        self._curves = tuple((np.searchsorted(self.prescribed, dofs), motion_path(points, self.values[
            np.searchsorted(self.prescribed, dofs)])) for dofs, points in self.motion_paths)

    @functools.cached_property
    def _pattern(self) -> PartitionedPattern:
        """Sparsity of K_ff and K_fp (element blocks, then the load-stiffness blocks, then the
        hinges'), built once on the first tangent evaluation and shared by `with_loads` copies
        made after it."""
        slot_f, slot_p = self._slots[:2]
        m = self.model
        if m.hinges is None:  # element blocks on whole nodes: the pattern from the connectivity, O(E)
            blocks = self._blocks
            fast = node_pattern(m.point_master[m.elements.ends], m.n_nodes, m.ndof, slot_f, slot_p, blocks[1:])
            if fast is not None:
                return fast
        rows, cols = zip(*[(np.broadcast_to(a[:, :, None], a.shape + a.shape[1:]).ravel(),
                            np.broadcast_to(a[:, None, :], a.shape + a.shape[1:]).ravel()) for a in self._blocks])
        return PartitionedPattern(np.concatenate(rows), np.concatenate(cols), slot_f, slot_p)

    @property
    def _blocks(self) -> tuple:
        """The DOFs of the tangent's blocks, in the order of `_pattern`: elements (E, 2 ndof), load
        points' rotations (K, nrot), hinges (H, 2 ndof + rows)."""
        m = self.model
        lr = m.node_dofs[self.loads.node][:, m.dim:]
        return (m.element_dofs, lr) if m.hinges is None else (m.element_dofs, lr, m.hinge_dofs)

    def with_loads(self, loads: PointLoads, start: PointLoads | None = None) -> StaticProblem:
        """A copy under other ``loads`` (same points, other values; patterns shared). With
        ``start``, the loads at load factor 0 are ``start`` instead of zero and the prescribed
        motion counts as already reached (a warm start from an equilibrium under ``start``)."""
        if len(loads.node) != len(self.loads.node) or (start is not None and len(start.node) != len(loads.node)):
            raise ValueError("with_loads: the loads must act on the same points")
        out = copy.copy(self)
        out.loads = loads
        out._wrench = np.concatenate([loads.force, loads.moment], axis=1)
        out._wrench0 = (np.zeros_like(out._wrench) if start is None
                        else np.concatenate([start.force, start.moment], axis=1))
        out._motion_scale = 1.0 if start is None else 0.0
        out._motor_reached = start is not None
        out._offset = None
        return out

    def continued_from(self, state: State) -> StaticProblem:
        """A copy whose load factor runs from ``state`` (any configuration satisfying the prescribed
        motion) to this problem: ``r_lam(u) = r(u) - (1 - lam) r(state)``, so ``state`` is the
        equilibrium at load factor 0 and the step control can halve towards it (homotopy)."""
        out = self.with_loads(self.loads, start=self.loads)
        out._offset = functools.partial(self.residual, state, 1.0)  # needed only if a step is cut
        return out

    def with_motion(self, values: np.ndarray, start: State | None = None,
                    start_values: np.ndarray | None = None) -> StaticProblem:
        """A copy with other prescribed ``values`` (same DOFs, totals from the undeformed state).

        With ``start`` (an equilibrium under these loads), the load factor moves the prescribed
        DOFs from ``start`` to ``values`` while the loads stay whole (a warm start along a motion
        sweep); 3D orientations turn about the one axis of ``R_target R_start^T`` or, given the
        prescribed ``start_values`` ``start`` was solved for, along ``exp(w_0 + lam (w_1 - w_0))``:
        the requested motion, however far (a turn of more than pi is not taken the short way;
        `max_load_step` splits it).
        """
        out = copy.copy(self)
        out.values = np.asarray(values, dtype=float)
        out._offset = None
        out._rotation_lines = ()
        out.motion_paths, out._curves = (), ()  # another motion: the straight line
        if start is None:
            return out
        m = self.model
        node, comp = np.divmod(self.prescribed, m.ndof)
        inc = out.values.copy()
        tr = comp < m.dim
        inc[tr] -= start.positions[node[tr], comp[tr]] - m.x0[node[tr], comp[tr]]
        if m.dim == 2:
            inc[~tr] -= start.rotations[node[~tr]]
        else:
            first = np.flatnonzero(comp == 3)  # a node's three rotation DOFs are prescribed together
            blocks = first[:, None] + np.arange(3)
            target = expm_so3(out.values[blocks])
            for dofs, w in self.rotation_paths:
                target[np.searchsorted(self.prescribed[first], dofs[0])] = chain_rotation(w, 1.0)
            inc[blocks] = logm_so3(target @ start.rotations[node[first]].transpose(0, 2, 1))
            if start_values is not None:
                chained = {int(d[0]) for d, _ in self.rotation_paths}
                w0 = np.asarray(start_values, dtype=float)
                out._rotation_lines = tuple((b, w0[b], out.values[b]) for b in blocks
                                            if int(self.prescribed[b[0]]) not in chained)
        out.values = inc
        out.rotation_paths = ()
        out._motor_reached = True
        out._wrench0 = out._wrench
        out._motion_scale = 1.0
        return out

    def external_force(self, state: State, lam: float = 1.0):
        """Assembled external load vector at load factor ``lam`` and the load-stiffness blocks."""
        m = self.model
        if len(self.loads.node):
            d = m.offsets(state, self.loads.node, self.loads.offset)
            w, G = m.transfer(self._wrench0 + lam * (self._wrench - self._wrench0), d)
            f = scatter_add(m.node_dofs[self.loads.node], w, m.n_dofs)
        else:  # prescribed motion only
            f, G = np.zeros(m.n_dofs), np.zeros((0, m.nrot, m.nrot))
        if self._offset is not None and lam != 1.0:
            if callable(self._offset):
                self._offset = self._offset()
            f = f + (1.0 - lam) * self._offset
        return f, G

    def external_load(self, state: State, lam: float = 1.0) -> np.ndarray:
        """Assembled applied loads at load factor ``lam`` on all DOFs (what `residual` subtracts)."""
        return self.external_force(state, lam)[0]

    def motor_fraction(self, lam: float) -> float:
        """How much of the hinges' motor angles is reached at load factor ``lam``: ``lam`` from the
        undeformed state; all of it in a warm-started copy (`with_loads`/`with_motion` with ``start``)."""
        return 1.0 if getattr(self, "_motor_reached", False) else lam

    def residual(self, state: State, lam: float) -> np.ndarray:
        """``f_int - f_ext(lam)`` on all DOFs (n_dofs,; the hinges' multiplier rows last)."""
        return self.model.internal_force(state, self.motor_fraction(lam)) - self.external_force(state, lam)[0]

    def evaluate(self, state: State, lam: float, tangent: bool = True, geometric_stress=None):
        """Residual on all DOFs and, if asked, the tangent blocks ``K_ff`` and ``K_fp`` (CSR).

        Returns ``(r, K_ff, K_fp, sigma)``; ``r`` contains NaN when an element left its valid
        range (a relative rotation of 90 degrees or more within one 3D element).
        ``geometric_stress``: the stresses of the geometric stiffness (E, modes), if not the
        elements' own, or a function of their own returning them (`FEModel.assemble`).
        """
        m = self.model
        pattern = self._pattern if tangent else None
        f_int, data_ff, data_fp, _, _, sig, largest = m.assemble(state, pattern, geometric_stress=geometric_stress)
        f_ext, G = self.external_force(state, lam)
        r = f_int - f_ext
        if tangent and len(G):
            pattern.split(-G, first=m.element_dofs.size * m.element_dofs.shape[1], out=(data_ff, data_fp))
        if m.hinges is not None:
            Fh, Kh = m.hinge_response(state, self.motor_fraction(lam), tangent=tangent)
            r += scatter_add(m.hinge_dofs, Fh, m.n_dofs)
            if tangent:
                pattern.split(Kh, first=len(pattern.slots) - Kh.size, out=(data_ff, data_fp))
        self.force_scale = self._force_scale(largest, f_ext)
        if not tangent:
            return r, None, None, sig
        return (r,) + pattern.matrices(data_ff, data_fp) + (sig,)

    def prescribed_increment(self, dlam: float, lam: float = 0.0) -> np.ndarray:
        """Increments of the prescribed DOFs for a load-factor step from ``lam`` to ``lam + dlam``
        (the spin between the two orientations of a rotation chain, `rotation_paths`)."""
        du = (dlam * self._motion_scale) * self.values
        if self._motion_scale and self.rotation_paths:
            for dofs, w in self.rotation_paths:
                step = chain_rotation(w, lam + dlam) @ chain_rotation(w, lam).T
                du[np.searchsorted(self.prescribed, dofs)] = logm_so3(step)
        for slots, w0, w1 in self._rotation_lines:
            du[slots] = logm_so3(expm_so3(w0 + (lam + dlam) * (w1 - w0)) @ expm_so3(w0 + lam * (w1 - w0)).T)
        if self._motion_scale:
            for slots, curve in self._curves:
                du[slots] += curve(lam + dlam) - curve(lam)
        return du

    def straight(self) -> StaticProblem:
        """This problem with its prescribed motion on straight lines (`motion_paths` dropped: the
        same equilibrium at load factor 1; Fig. 18's control steps along them, as published)."""
        if not self._curves:
            return self
        out = copy.copy(self)
        out.motion_paths, out._curves = (), ()
        return out

    def curve_rate(self, lam: float) -> np.ndarray:
        """The derivative in the load factor of the prescribed values' offset from the straight line
        ``lam * values`` (`motion_paths`; zero without them), (n_p,)."""
        out = np.zeros(len(self.prescribed), dtype=np.result_type(self.values, float))
        if self._motion_scale:
            for slots, curve in self._curves:
                out[slots] += curve(lam, 1)
        return out

    def path_rate(self, state: State, lam: float, r: np.ndarray, K_ff, K_fp, h: float) -> np.ndarray:
        """The equilibrium path's derivative in the load factor at ``state`` (n_dofs,; the
        increment's coordinates): ``K_ff du_f = -(dr_f/dlam + K_fp du_p)``, the prescribed rate
        ``du_p`` (central) and ``dr/dlam`` (the applied loads', linear in lam) as differences over ``h``;
        ``r``, ``K_ff``, ``K_fp`` the residual and tangent blocks at ``(state, lam)``
        (`evaluate`). The continuation's tangent predictor."""
        dp = (self.prescribed_increment(h, lam) - self.prescribed_increment(-h, lam)) / (2.0 * h)
        dr = (self.residual(state, lam + h) - r) / h
        return self.full_increment(self.solve_linear(K_ff, -(dr[self.free] + K_fp @ dp)), dp)

    @property
    def max_load_step(self) -> float:
        """Largest load-factor step whose prescribed rotation increments stay below 3 rad (< pi,
        so that each is the requested turn, not the short way round): the angle between
        ``exp(a)`` and ``exp(b)`` is at most ``|a - b|``, a chain's at most the sum of its links'."""
        turn = max([float(np.sum(np.linalg.norm(w, axis=1))) for _, w in self.rotation_paths if self._motion_scale]
                   + [float(np.linalg.norm(w1 - w0)) for _, w0, w1 in self._rotation_lines] + [0.0])
        return min(1.0, 3.0 / turn) if turn > 0.0 else 1.0

    def full_increment(self, du_free: np.ndarray, du_pres: np.ndarray) -> np.ndarray:
        """The increment of every DOF from its free and prescribed parts."""
        du = np.zeros(self.model.n_dofs)
        du[self.free] = du_free
        du[self.prescribed] = du_pres
        return du

    def broken_constraints(self, state: State, lam: float = 1.0) -> str:
        """Why ``state`` is not the equilibrium asked for although its residual vanishes, or "": an
        over-constrained mechanism whose prescribed motion violates the hinges' redundant rows
        (dropped at build time as dependent, `flexmb.fe.ideal.Hinges.violated`)."""
        m = self.model
        if m.hinges is None:
            return ""
        size = float(np.ptp(m.x0, axis=0).max()) or 1.0
        bad = m.hinges.violated(state.positions, state.rotations, self.motor_fraction(lam), size,
                               angles=state.hinge_angles)
        return ("" if not bad else "the prescribed motion contradicts the over-constrained hinges: their redundant "
                f"(dropped) constraint rows are violated: {', '.join(bad)} [m, rad]")

    def _force_scale(self, largest: tuple[float, float], f_ext: np.ndarray) -> float:
        """The problem's force scale [N]: the largest element end force (``largest``: force and
        moment, `FEModel.largest_by_kind` of the end forces), applied load or moment over
        `model_length` (reactions are sums of element forces)."""
        m, L = self.model, self.model_length
        F, M = largest
        f, moment = (m.largest_by_kind(f_ext[: m.n_node_dofs])  # the hinges' rows last
                     if len(self.loads.node) or self._offset is not None else (0.0, 0.0))
        return max(F, M / L, f, moment / L)

    def scaled_residual(self, r_free: np.ndarray) -> float:
        """``|| [r_F, r_M / L] || / F``: the free residual in units of the force scale of the last
        `evaluate` (`force_scale`), moments over `model_length`: the same in any consistent unit
        system."""
        w = self._free_weights
        F = getattr(self, "force_scale", 0.0)
        v = float(np.sqrt(np.sum((r_free * w) ** 2)))
        return v / F if F > 0.0 else (0.0 if v == 0.0 else np.inf)

    @functools.cached_property
    def _free_weights(self) -> np.ndarray:
        return np.where(self.model.force_dofs[self.free], 1.0, 1.0 / self.model_length)

    @functools.cached_property
    def model_length(self) -> float:
        """A length of the model [m]: the diagonal of its nodes' bounding box (the mean element
        length if the nodes coincide); moments over it compare with forces, rotations with
        translations over it."""
        x0 = self.model.x0
        d = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0))) if len(x0) else 0.0
        return d if d > 0.0 else float(np.mean(self.model.elements.L0)) if len(self.model.elements.L0) else 1.0

    def roundoff_hint(self) -> str:
        """Why Newton may stop short here, or "": the model lies more than `FAR_FROM_ORIGIN` times
        its own size (`model_length`) from the origin, so the round-off of its absolute coordinates
        (eps |x|) is a sizeable part of its elements' deformations (measured: a 0.1 m leaf 300 m
        away stopped with "step halved below min_step"; at 100 m it converged to 2.4e-5 of the
        force scale, at the origin to 1.8e-8)."""
        x0 = self.model.x0
        far = float(np.abs(x0).max()) if x0.size else 0.0
        L = self.model_length
        if not far > FAR_FROM_ORIGIN * L:
            return ""
        return (f"; the model lies {far:.3g} (length units) from the origin, {far / L:.3g} times its own size {L:.3g}: "
                f"the round-off of its absolute coordinates ({np.finfo(float).eps * far:.2g}) limits how far the residual "
                "can fall. Place the mechanism near the origin (its links' positions relative to its own centre)")

    def reduced_tangent(self, K_ff: sp.csr_array) -> sp.csr_array:
        """The free tangent on the motions the hinges allow, ``Z^T K Z`` with ``G Z = 0`` (``G`` the
        hinges' constraint rows): positive definite exactly when the constrained equilibrium is a
        strict minimum of the energy (second-order condition); ``K_ff`` itself without hinges."""
        m = self.model
        if m.hinges is None:
            return K_ff
        from .fe.ideal import constrained_basis

        n = len(self.free) - m.hinges.n_rows  # the multipliers are the last free DOFs
        K = sp.csr_array(K_ff)
        Z = constrained_basis(K[n:, :n])
        return (Z.T @ K[:n, :n] @ Z).tocsr()

    def positive_definite(self, K_ff: sp.csr_array) -> bool | None:
        """Whether the tangent ``K_ff`` (this problem's pattern) is positive definite, from the
        pivots of the linear solver's factorisation (`flexmb.linear.TangentSolver.positive_definite`,
        not a separate SuperLU); None where it cannot tell (hinges: their
        multipliers make a saddle point, judged on `reduced_tangent`; small dense systems)."""
        if self.model.hinges is not None:
            return None
        return self._tangent_solver.positive_definite(K_ff)

    def solve_linear(self, K: sp.csr_array, rhs: np.ndarray) -> np.ndarray:
        """Solve ``K x = rhs`` with `flexmb.linear.TangentSolver` (dense LAPACK below 220 unknowns;
        above, an LDL^T whose analysis is reused across the pattern's solves, refined to an exact
        solve, or SuperLU). Copies made by `with_loads` / `with_motion` share the analysis."""
        return self._tangent_solver.solve(K, rhs)

    @functools.cached_property
    def _tangent_solver(self) -> TangentSolver:
        return TangentSolver()
