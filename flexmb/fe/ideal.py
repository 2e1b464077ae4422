"""Ideal joints between link nodes: exact holonomic constraints with Lagrange multipliers.

A revolute joint (`flexmb.Hinge`) between links A and B with joint frame ``P`` (columns
``p_x, p_y, p_z``, global, undeformed) at origin ``o`` imposes, at any rotation::

    x_A + R_A s_A - x_B - R_B s_B = 0            the links share the joint origin (dim rows)
    (R_A p_x) . (R_B p_z) = 0,  (R_A p_y) . (R_B p_z) = 0     3D: they share the z axis
    motor (optional): theta - t = 0

with ``s = o - X`` the undeformed offsets and ``t`` the motor angle at the current load factor.
A torsional spring ``k`` adds the energy ``k theta^2 / 2`` of the relative angle ``theta``
(2D: ``theta_B - theta_A``, unbounded; 3D: ``atan2((R_A p_y).(R_B p_x), (R_A p_x).(R_B p_x))``
plus the whole turns the increments that led to the state took it past pi: the state carries
``theta`` (`flexmb.fe.model.State.hinge_angles`, `Hinges.advance`), since a rotation matrix has no
turn count; e.g. a spring k = 2 turned 4 rad held +4.57 N m, taken at 4 - 2 pi, for -8).

Each constraint row ``c_i`` enters the residual as ``s_i c_i`` on its multiplier's row and the
multiplier's force ``s_i g_i^T mu_i`` on the links' rows (``g_i`` its gradient in the solver's
increments: translations and spins), so the tangent is the symmetric saddle point
``[[K + sum mu_i s_i H_i, s G^T], [s G, 0]]``. ``s`` (N/m for positions, N m/rad for rotations)
puts the constraint rows in the units and the size of the model's own stiffest rows, so the
residual norm stays a force and the saddle point is balanced; ``s_i mu_i`` is the physical
multiplier [N, N m] (`flexmb.Solution.joint_wrench` turns them into the wrench on link B).
"""

from __future__ import annotations

import attrs
import numpy as np
import scipy.sparse as sp

from ..rotations import cross, skew

__all__ = ["Hinges", "ROWS", "row_names"]

#: Constraint rows per hinge (before dependent rows are dropped): positions, axis, motor.
ROWS = {2: 3, 3: 6}
_NAMES = {2: ("x", "y", "motor"), 3: ("x", "y", "z", "axis_x", "axis_y", "motor")}


def row_names(dim: int) -> tuple[str, ...]:
    """Names of a hinge's constraint rows, in order."""
    return _NAMES[dim]


def _ss(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``skew(a) @ skew(b) = b a^T - (a . b) I`` for batches of 3-vectors (H, 3) -> (H, 3, 3)."""
    return b[:, :, None] * a[:, None, :] - np.einsum("hi,hi->h", a, b)[:, None, None] * np.eye(3)


def _dot_row(a: np.ndarray, b: np.ndarray):
    """``f = a . b`` with ``a`` turning with link A and ``b`` with link B (3D): value (H,), gradient
    on the spins (H, 2, 3) ``[a x b, b x a]`` and the spin derivative of that gradient
    (H, 2, 2, 3, 3) (blocks d g_A/d w_A, d g_A/d w_B; d g_B/...)."""
    f = np.einsum("hi,hi->h", a, b)
    gA = cross(a, b)
    dAA, dAB = _ss(b, a), -_ss(a, b)
    H = np.stack([np.stack([dAA, dAB], 1), np.stack([-dAA, -dAB], 1)], 1)
    return f, np.stack([gA, -gA], 1), H


@attrs.frozen(eq=False)
class Hinges:
    """The hinges of a model, batched.

    ``names`` (H,) joint names; ``node`` (H, 2) link nodes of sides A and B; ``offset`` (H, 2, dim)
    undeformed offsets ``o - X`` [m] of the joint origin from the two nodes; ``frame`` (H, dim, dim)
    joint frames (global, undeformed); ``k`` (H,) torsional stiffness [N m/rad]; ``angle`` (H,)
    motor angle [rad] at load factor 1 (NaN: no motor); ``active`` (H, ROWS) constraint rows kept
    (`flexmb.fe.build` drops dependent ones); ``scale`` (ROWS,) row scales [N/m, N m/rad].
    """

    dim: int
    names: tuple
    node: np.ndarray
    offset: np.ndarray
    frame: np.ndarray
    k: np.ndarray
    angle: np.ndarray
    active: np.ndarray
    scale: np.ndarray
    #: dependent rows dropped at build time, as ``"joint.row"`` names (`row_names`), and their mask
    dropped: tuple = ()
    dropped_rows: np.ndarray | None = None

    def violated(self, positions, R, lam_angle: float, size: float, tol: float = 1e-8, angles=None) -> list[str]:
        """The dropped (dependent) rows that a state violates by more than ``tol`` (positions: times
        ``size`` [m]; rotations [rad]), as ``"joint.row (value)"``: an over-constrained mechanism
        whose prescribed motion contradicts its redundant constraints."""
        if self.dropped_rows is None or not self.dropped_rows.any():
            return []
        c = self.residual_rows(positions, R, lam_angle, angles=angles)[0]
        limit = np.where(np.arange(ROWS[self.dim]) < self.dim, tol * size, tol)
        bad = self.dropped_rows & (np.abs(c) > limit)
        return [f"{self.names[h]}.{row_names(self.dim)[r]} ({c[h, r]:+.3g})" for h, r in zip(*np.nonzero(bad))]

    @property
    def n_rows(self) -> int:
        """Number of multipliers (active constraint rows)."""
        return int(self.active.sum())

    def dofs(self, node_dofs: np.ndarray, first: int) -> np.ndarray:
        """(H, 2 ndof + ROWS) global DOFs of each hinge block: the two nodes, then its multipliers
        (numbered from ``first``); inactive rows point at the hinge's first DOF (their entries are 0)."""
        nodes = node_dofs[self.node].reshape(len(self.node), -1)
        mult = np.full(self.active.shape, -1, dtype=np.int64)
        mult[self.active] = first + np.arange(self.n_rows)
        mult = np.where(self.active, mult, nodes[:, :1])
        return np.concatenate([nodes, mult], axis=1)

    def residual_rows(self, positions, R, lam_angle: float, gradient: bool = True, angles=None):
        """Constraint values ``c`` (H, ROWS) [m, rad-like], gradients ``g`` (H, ROWS, 2 ndof) and
        the data of their second derivatives. ``R``: the links' rotations (2D angles (N,), 3D (N, 3, 3));
        ``lam_angle``: the fraction of the motor angle reached; ``angles``: the 3D relative angles
        counted past pi (`advance`; None: within one turn, the motor's distance wrapped)."""
        dim, H = self.dim, len(self.node)
        nd = 3 if dim == 2 else 6
        a, b = self.node[:, 0], self.node[:, 1]
        t = lam_angle * np.nan_to_num(self.angle)
        c = np.zeros((H, ROWS[dim]))
        g = np.zeros((H, ROWS[dim], 2 * nd))
        if dim == 2:
            ca, sa, cb, sb = np.cos(R[a]), np.sin(R[a]), np.cos(R[b]), np.sin(R[b])
            sA, sB = self.offset[:, 0], self.offset[:, 1]
            dA = np.stack([ca * sA[:, 0] - sa * sA[:, 1], sa * sA[:, 0] + ca * sA[:, 1]], 1)
            dB = np.stack([cb * sB[:, 0] - sb * sB[:, 1], sb * sB[:, 0] + cb * sB[:, 1]], 1)
            c[:, :2] = positions[a] + dA - positions[b] - dB
            c[:, 2] = R[b] - R[a] - t
            g[:, 0, 0] = g[:, 1, 1] = 1.0
            g[:, 0, 3] = g[:, 1, 4] = -1.0
            g[:, 0, 2], g[:, 1, 2] = -dA[:, 1], dA[:, 0]
            g[:, 0, 5], g[:, 1, 5] = dB[:, 1], -dB[:, 0]
            g[:, 2, 2], g[:, 2, 5] = -1.0, 1.0
            return c, g, (dA, dB)
        RA, RB = R[a] @ self.frame, R[b] @ self.frame  # current joint frames on A and B (columns)
        dA = np.einsum("hij,hj->hi", R[a], self.offset[:, 0])
        dB = np.einsum("hij,hj->hi", R[b], self.offset[:, 1])
        c[:, :3] = positions[a] + dA - positions[b] - dB
        g[:, :3, 0:3] = np.eye(3)
        g[:, :3, 6:9] = -np.eye(3)
        g[:, :3, 3:6] = -skew(dA)
        g[:, :3, 9:12] = skew(dB)
        second = []
        for i, (va, vb) in enumerate([(RA[:, :, 0], RB[:, :, 2]), (RA[:, :, 1], RB[:, :, 2])]):
            f, gr, Hr = _dot_row(va, vb)
            c[:, 3 + i] = f
            g[:, 3 + i, 3:6], g[:, 3 + i, 9:12] = gr[:, 0], gr[:, 1]
            second.append(Hr)
        # the motor: the relative angle's distance to t (without a turn count, wrapped to (-pi, pi])
        gt, Ht = self._angle_derivatives(R, gradient)
        c[:, 5] = (self.relative_angle(R, angles) - t if angles is not None
                   else np.angle(np.exp(1j * (self.relative_angle(R) - t))))
        g[:, 5] = gt
        return c, g, (dA, dB, np.stack(second, 1), Ht)

    def relative_angle(self, R, near=None) -> np.ndarray:
        """Relative rotation [rad] of B from A about each hinge's axis, (H,); 3D: in (-pi, pi], or
        with ``near`` (H,) [rad] the same rotation's angle nearest to it (whole turns added)."""
        a, b = self.node[:, 0], self.node[:, 1]
        if self.dim == 2:
            return R[b] - R[a]
        RA, RB = R[a] @ self.frame, R[b] @ self.frame
        theta = np.arctan2(np.einsum("hi,hi->h", RA[:, :, 1], RB[:, :, 0]),
                           np.einsum("hi,hi->h", RA[:, :, 0], RB[:, :, 0]))
        if near is None:
            return theta
        return theta + 2.0 * np.pi * np.round((near - theta) / (2.0 * np.pi))

    def advance(self, R, angles, spins, R_new) -> np.ndarray:
        """The 3D relative angles (H,) [rad] after the increment that turns the links from ``R`` by
        the spins ``spins`` (N, 3) to ``R_new``: the angle of ``R_new`` nearest to the angles at ``R``
        (``angles``; None: within one turn) plus the increment's first-order change of them, so a
        hinge turned past pi, in one increment or many, keeps its turn count."""
        old = self.relative_angle(R, angles)
        gt = self._angle_derivatives(R, tangent=False)[0]
        a, b = self.node[:, 0], self.node[:, 1]
        change = np.einsum("hi,hi->h", gt[:, 3:6], spins[a]) + np.einsum("hi,hi->h", gt[:, 9:12], spins[b])
        return self.relative_angle(R_new, old + change)

    def response(self, positions, R, multipliers, lam_angle: float, tangent: bool = True, material: bool = False,
                 angles=None):
        """Block forces ``F`` (H, 2 ndof + ROWS) and tangents ``K`` (H, n, n) on the DOFs of
        `dofs`: the multipliers' forces and the springs' moments on the link rows, the scaled
        constraint values on the multiplier rows. ``material``: the tangent without the parts
        proportional to the constraint forces and spring moments (their "geometric" stiffness:
        the multipliers times the constraints' second derivatives, ``k theta`` times the angle's).
        ``angles``: the 3D relative angles counted past pi (`advance`)."""
        dim, H = self.dim, len(self.node)
        nd, nr, rows = (3, 1, 3) if dim == 2 else (6, 3, 6)
        n = 2 * nd + rows
        c, g, extra = self.residual_rows(positions, R, lam_angle, angles=angles)
        mu = np.zeros((H, rows))
        mu[self.active] = multipliers
        sg = g * self.scale[None, :, None] * self.active[:, :, None]
        F = np.zeros((H, n))
        F[:, :2 * nd] = np.einsum("hr,hrj->hj", mu, sg)
        F[:, 2 * nd:] = np.where(self.active, c * self.scale, 0.0)
        theta = self.relative_angle(R, angles)
        gt, Ht = self._angle_derivatives(R, tangent)
        F[:, :2 * nd] += (self.k * theta)[:, None] * gt
        if not tangent:
            return F, None
        K = np.zeros((H, n, n))
        K[:, :2 * nd, 2 * nd:] = np.swapaxes(sg, 1, 2)
        K[:, 2 * nd:, :2 * nd] = sg
        K[:, :2 * nd, :2 * nd] = self.k[:, None, None] * (gt[:, :, None] * gt[:, None, :])
        if material:
            return F, K
        K[:, :2 * nd, :2 * nd] += (self.k * theta)[:, None, None] * Ht
        w = mu * self.scale  # physical multipliers
        ra, rb = slice(dim, nd), slice(nd + dim, 2 * nd)
        if dim == 2:
            dA, dB = extra
            K[:, 2, 2] -= np.einsum("hi,hi->h", dA, w[:, :2])
            K[:, 5, 5] += np.einsum("hi,hi->h", dB, w[:, :2])
            return F, K
        dA, dB, second, Hmotor = extra
        K[:, ra, ra] += _ss(w[:, :3], dA)
        K[:, rb, rb] -= _ss(w[:, :3], dB)
        K[:, :2 * nd, :2 * nd] += w[:, 5, None, None] * Hmotor
        Hsum = np.einsum("hr,hrabij->habij", w[:, 3:5], second)  # (H, 2, 2, 3, 3)
        K[:, ra, ra] += Hsum[:, 0, 0]
        K[:, ra, rb] += Hsum[:, 0, 1]
        K[:, rb, ra] += Hsum[:, 1, 0]
        K[:, rb, rb] += Hsum[:, 1, 1]
        return F, K

    def wrench_on_b(self, h: int, positions, R, multipliers, angles=None) -> np.ndarray:
        """The wrench hinge ``h`` (its constraints and spring) applies on its link B: force [N]
        and moment [N m] about the joint origin, global axes ((3,) in 2D, (6,) in 3D); ``angles``
        the 3D relative angles counted past pi (`advance`)."""
        dim = self.dim
        nd = 3 if dim == 2 else 6
        F = self.response(positions, R, multipliers, 1.0, tangent=False, angles=angles)[0][h, nd:2 * nd]
        f, m = -F[:dim], -F[dim:]  # the hinge's internal force on B's DOFs, reversed
        b = self.node[h, 1]
        if dim == 2:
            c, s = np.cos(R[b]), np.sin(R[b])
            d = np.array([c * self.offset[h, 1, 0] - s * self.offset[h, 1, 1], s * self.offset[h, 1, 0]
                          + c * self.offset[h, 1, 1]])
            return np.concatenate([f, m - (d[0] * f[1] - d[1] * f[0])])
        d = R[b] @ self.offset[h, 1]
        return np.concatenate([f, m - np.cross(d, f)])

    def _angle_derivatives(self, R, tangent: bool):
        """Gradient (H, 2 ndof) of the relative angle on the solver's increments and its spin
        derivative (H, 2 ndof, 2 ndof)."""
        H = len(self.node)
        if self.dim == 2:
            gt = np.zeros((H, 6))
            gt[:, 2], gt[:, 5] = -1.0, 1.0
            return gt, np.zeros((H, 6, 6))
        a, b = self.node[:, 0], self.node[:, 1]
        RA, RB = R[a] @ self.frame, R[b] @ self.frame
        s, gs, Hs = _dot_row(RA[:, :, 1], RB[:, :, 0])
        co, gc, Hc = _dot_row(RA[:, :, 0], RB[:, :, 0])
        rho2 = s * s + co * co
        gs, gc = gs.reshape(H, 6), gc.reshape(H, 6)
        gth = (co[:, None] * gs - s[:, None] * gc) / rho2[:, None]
        gt = np.zeros((H, 12))
        gt[:, 3:6], gt[:, 9:12] = gth[:, :3], gth[:, 3:]
        if not tangent:
            return gt, None
        Hs = np.transpose(Hs, (0, 1, 3, 2, 4)).reshape(H, 6, 6)
        Hc = np.transpose(Hc, (0, 1, 3, 2, 4)).reshape(H, 6, 6)
        Hth = ((co[:, None, None] * Hs - s[:, None, None] * Hc
                + gs[:, :, None] * gc[:, None, :] - gc[:, :, None] * gs[:, None, :]) / rho2[:, None, None]
               - 2.0 * gth[:, :, None] * (s[:, None] * gs + co[:, None] * gc)[:, None, :] / rho2[:, None, None])
        Ht = np.zeros((H, 12, 12))
        rot = np.r_[3:6, 9:12]
        Ht[:, rot[:, None], rot[None, :]] = Hth
        return gt, Ht


def lock_rows(dim: int, dA: np.ndarray, dB: np.ndarray) -> np.ndarray:
    """Rows (H, ndof, 2 ndof) that hold the relative motion of two links at a point (a weld):
    positions as a hinge's, then the relative rotation; ``dA``, ``dB`` (H, dim) the point's offsets."""
    H, nd = len(dA), 3 if dim == 2 else 6
    g = np.zeros((H, nd, 2 * nd))
    g[:, :dim, :dim] = np.eye(dim)
    g[:, :dim, nd:nd + dim] = -np.eye(dim)
    if dim == 2:
        g[:, 0, 2], g[:, 1, 2], g[:, 0, 5], g[:, 1, 5] = -dA[:, 1], dA[:, 0], dB[:, 1], -dB[:, 0]
    else:
        g[:, :3, 3:6], g[:, :3, 9:12] = -skew(dA), skew(dB)
    g[:, dim:, dim:nd] = np.eye(nd - dim)
    g[:, dim:, nd + dim:] = -np.eye(nd - dim)
    return g


def dense_rows(g: np.ndarray, node: np.ndarray, ndof: int, n_cols: int) -> np.ndarray:
    """Block rows ``g`` (H, r, 2 ndof) on nodes ``node`` (H, 2) as a dense (H r, n_cols) matrix."""
    H, r = g.shape[:2]
    out = np.zeros((H, r, n_cols))
    cols = (node[:, :, None] * ndof + np.arange(ndof)).reshape(H, 2 * ndof)
    for i in range(2 * ndof):  # two nodes of one block may be the same link only for a plugin's mistake
        np.add.at(out, (np.arange(H), slice(None), cols[:, i]), g[:, :, i])
    return out.reshape(H * r, n_cols)


def independent_rows(J: np.ndarray, candidate: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Which ``candidate`` rows of ``J`` (m, n) to keep, in order, so that the kept rows are
    linearly independent and span the candidates (incremental Gram-Schmidt, twice; a row whose
    part outside the kept rows' span is below ``tol`` of its norm is dependent)."""
    keep = np.zeros(len(J), dtype=bool)
    Q = np.zeros((0, J.shape[1]))
    for i in np.flatnonzero(candidate):
        row = J[i]
        norm = np.linalg.norm(row)
        if norm == 0.0:
            continue
        w = row - Q.T @ (Q @ row)
        w = w - Q.T @ (Q @ w)
        if np.linalg.norm(w) > tol * norm:
            keep[i] = True
            Q = np.vstack([Q, w / np.linalg.norm(w)])
    return keep


def free_motions(J: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Orthonormal basis (n, k) of the motions ``v`` with ``J v = 0`` (rows of ``J`` normalised)."""
    if J.shape[1] == 0:
        return np.zeros((0, 0))
    norms = np.linalg.norm(J, axis=1)
    A = J[norms > 0] / norms[norms > 0, None]
    if len(A) == 0:
        return np.eye(J.shape[1])
    _, s, vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(s > tol * max(s[0], 1.0)))
    return vt[rank:].T


def constrained_basis(G):
    """A sparse basis ``Z`` (n, n - rank) of the motions the constraint rows ``G`` (m, n) allow
    (``G Z = 0``): identity on the columns ``G`` does not touch, a dense orthonormal null-space
    basis (SVD) on the few link DOFs it does."""
    G = sp.csr_array(G)
    n = G.shape[1]
    touched = np.unique(G.indices)
    others = np.setdiff1d(np.arange(n), touched)
    Zt = free_motions(G[:, touched].toarray(), tol=1e-12) if len(touched) else np.zeros((0, 0))
    rows = np.concatenate([others, np.repeat(touched, Zt.shape[1])])
    cols = np.concatenate([np.arange(len(others)), len(others) + np.tile(np.arange(Zt.shape[1]), len(touched))])
    return sp.csr_array((np.concatenate([np.ones(len(others)), Zt.ravel()]), (rows, cols)),
                        shape=(n, len(others) + Zt.shape[1]))


def constrained(model, free: np.ndarray, K, state=None):
    """The free DOFs' split for an analysis on the motions the hinges allow: the free *node* DOFs
    ``fn`` and a basis ``Z`` (len(fn), m) of their motions that keep the hinges' constraints to
    first order (rows of ``K``'s multiplier-node block), or ``(free, None)`` without hinges.
    ``state``: the rows dropped at build time (`Hinges.dropped_rows`) hold too; dependent only
    while the prescribed DOFs are held, they keep a released link on its hinge's axis (without
    them a 3D pendulum whose turn was prescribed swung at 0 Hz with ``held="fixed"``)."""
    if model.hinges is None:
        return free, None
    fn, fm = free[free < model.n_node_dofs], free[free >= model.n_node_dofs]
    G = sp.csr_array(K[fm][:, fn])
    h = model.hinges
    if state is not None and h.dropped_rows is not None and h.dropped_rows.any():
        g = h.residual_rows(state.positions, state.rotations, 1.0, angles=state.hinge_angles)[1]
        rows = dense_rows(g, h.node, model.ndof, model.n_node_dofs)[h.dropped_rows.ravel()][:, fn]
        G = sp.vstack([G, sp.csr_array(rows)]).tocsr()
    return fn, constrained_basis(G)
