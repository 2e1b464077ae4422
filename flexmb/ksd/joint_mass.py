"""A joint's mass condensed on its interface nodes for KSD-reduced free vibration (issue 22
item 6): the Craig-Bampton reduction (Craig & Bampton 1968) of the joint's consistent mass with
its EOB's stiffness, tabulated against the intended rotation.

At an EOB near configuration every element is rigidly rotated (Eq. 3.2), so the joint's mass is
assembled exactly as the EOB's stiffness: each element's consistent mass at rest on its markers
(`flexmb.fe.mass`), turned by the element's rotation and moved to the nodes by the levers,
``M_nodes = L^T T M0 T^T L`` (Eqs. 3.3-3.11 with the mass for the stiffness). Both depend on the
intended rotation alone (node B's near position moves the nodes, not their orientations). With
the interior DOFs ``i`` and the interface nodes A, B ``b``:

* static constraint modes ``X = -K_ii^-1 K_ib``, ``T = [I; X]``: ``M_b = T^T M T``; they carry the
  joint's rigid motions exactly, so its mass and inertia are kept;
* fixed-interface modes ``K_ii Phi = M_ii Phi diag(omega^2)``, mass-normalised: the lowest
  ``n_fixed`` over the interior chains, as Ritz vectors of a basis per chain fixed over the range
  (`RITZ_SAMPLES`), so every projected matrix is smooth in the rotation and can be splined;
  coupling ``Phi^T M T``.

`condensed` interpolates ``M_b``, ``X`` and the Ritz projections over the trained range
(`flexmb.ksd.splined`, built once per joint template on first use) and solves the small Ritz
eigenproblems per configuration.
"""

from __future__ import annotations

import weakref

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack as _lapack

from ..fe.mass import element_mass, rigid_mass
from ..fe.model import State
from .eob import lever
from .splined import SplinedTable

__all__ = ["condensed", "joint_mass", "RITZ_SAMPLES"]

#: Intended rotations at which a joint's fixed-interface modes are sampled for its Ritz basis,
#: evenly over the trained range. Measured on three_x_infinity (3D, 3 el./leaf, one interior
#: chain of 120 DOFs, +-45 deg) at 40 random rotations, the lowest six fixed-interface eigenvalues
#: against `scipy.linalg.eigh` on the whole interior: 5 samples (basis of 30) 1.6e-2, 9 (54)
#: 8.5e-7, 13 (73) 8.2e-11 largest relative error (the 2D cross flexure's chains of 12 DOFs:
#: complete with any, 2e-12).
RITZ_SAMPLES = 9


def _block_diagonal(blocks):
    """``(..., 2, nd, nd)`` -> ``(..., 2 nd, 2 nd)``."""
    nd = blocks.shape[-1]
    out = np.zeros(blocks.shape[:-3] + (2 * nd, 2 * nd))
    out[..., :nd, :nd], out[..., nd:, nd:] = blocks[..., 0, :, :], blocks[..., 1, :, :]
    return out


class _JointMass:
    """A joint template's mass, prepared once: the elements' consistent mass at rest on their
    markers in the joint frame (``M0``, (E, 2 nd, 2 nd), marker order as the EOB's ``K0``), the
    Ritz bases and the tables."""

    def __init__(self, tpl, joint):
        from ..mechanism import Mechanism

        m = Mechanism(dim=tpl.dim)  # the joint alone, nodes numbered as the EOB's (A, B, internal)
        m.add_link("A", fixed=True)
        m.add_link("B", position=joint.interface_b(tpl.dim))
        m.add_joint("A", "B", joint, name="joint")
        self.model = model = m.compile().problem.model
        dim, nd, N = tpl.dim, tpl.nd, tpl.n_nodes
        el = model.elements
        rest = State(model.x0.copy(), np.zeros(N) if dim == 2 else np.tile(np.eye(3), (N, 1, 1)))
        Mm = element_mass(model, rest)  # on the master nodes: T^T M_points T, T the rest levers
        Tinv = _block_diagonal(lever(-model.point_offset[el.ends], dim))
        M0 = np.swapaxes(Tinv, 1, 2) @ Mm @ Tinv
        flip = tpl.p_point != el.ends[:, 0]
        perm = np.r_[nd:2 * nd, 0:nd]
        self.M0 = np.where(flip[:, None, None], M0[:, perm][:, :, perm], M0)
        self.tpl = tpl
        self.n = n = N * nd
        dofs = tpl.element_dofs
        self._kidx = (dofs[:, :, None] * n + dofs[:, None, :]).ravel()
        blocks = tpl._blocks  # one chain on all interior DOFs in order (three_x_infinity): no scatter
        self.whole = len(blocks) == 1 and blocks[0].shape[0] == 1 and np.array_equal(blocks[0][0],
                                                                                      np.arange(n - 2 * nd))
        self._basis, self._tables = {}, {}

    def nodes(self, eob) -> np.ndarray:
        """The joints' mass (J, n, n) on the EOB's node DOFs at its near configuration (``eob``
        a full `EOB`): beams from ``M0`` through the EOB's element rotations and levers,
        intermediate bodies (`flexmb.fe.mass.rigid_mass`) at the nodes' near poses."""
        J, n = len(eob.K_T), self.n
        Mmap = _block_diagonal(np.swapaxes(eob.lever, -1, -2) @ eob.rotation[:, :, None])
        Me = Mmap @ self.M0 @ np.swapaxes(Mmap, 2, 3)
        flat = (self._kidx[None, :] + (np.arange(J) * n * n)[:, None]).ravel()
        M = np.bincount(flat, weights=Me.ravel(), minlength=J * n * n).reshape(J, n, n)
        model = self.model
        if model.rigid_masses is not None:
            dofs = model.node_dofs[model.rigid_masses.node]
            for j in range(J):
                rot = eob.node_angle[j] if self.tpl.dim == 2 else eob.node_rotation[j]
                blocks = rigid_mass(model, State(eob.node_position[j].copy(), rot.copy()), model.rigid_masses)
                for d, blk in zip(dofs, blocks):
                    M[j][np.ix_(d, d)] += blk
        return 0.5 * (M + np.swapaxes(M, 1, 2))

    def basis(self, n_fixed: int) -> list:
        """Per block of equal interior chains (`EOBTemplate._blocks`, (c, s) DOFs) a Ritz basis
        (c, s, r): the span of each chain's lowest ``n_fixed`` fixed-interface modes at
        `RITZ_SAMPLES` intended rotations over the trained range (orthonormal, from an SVD)."""
        if n_fixed not in self._basis:
            tpl = self.tpl
            theta = np.linspace(*tpl.data.range, RITZ_SAMPLES)
            eob = tpl.evaluate(theta, np.zeros((len(theta), tpl.dim)))
            K, M, b = eob.K_nodes, self.nodes(eob), 2 * tpl.nd
            out = []
            for idx in tpl._blocks:
                k = min(n_fixed, idx.shape[1])
                U, rank = [], []
                for chain in idx:
                    at = np.ix_(b + chain, b + chain)
                    modes = np.concatenate([sla.eigh(0.5 * (Kj[at] + Kj[at].T), Mj[at], subset_by_index=[0, k - 1])[1]
                                            for Kj, Mj in zip(K, M)], axis=1)
                    u, sv, _ = np.linalg.svd(modes, full_matrices=False)
                    U.append(u)
                    rank.append(int((sv > 1e-10 * sv[0]).sum()))
                out.append(np.stack([u[:, :max(rank)] for u in U]))  # equal widths: extra vectors do no harm
            self._basis[n_fixed] = out
        return self._basis[n_fixed]

    def project(self, eob, n_fixed: int) -> dict:
        """At the EOBs' near configurations (J joints): ``Mb`` (J, b, b), ``X`` (J, n_i, b) and per
        block of chains, with the Ritz basis's stiffness ``K_r`` and mass ``M_r = L L^T``: ``S<k>`` =
        ``L^-1 K_r L^-T``, ``L<k>`` = ``L^-T`` (J, c, r, r) and the coupling ``C<k>`` = ``P^T M_i T``
        (J, c, r, b)."""
        K, M = eob.K_nodes, self.nodes(eob)
        J, n = K.shape[:2]
        b = 2 * self.tpl.nd
        X = np.zeros((J, n - b, b))
        out = {}
        for k, idx in enumerate(self.tpl._blocks):
            at = (slice(None), b + idx[:, :, None], b + idx[:, None, :])
            X[:, idx] = -np.linalg.solve(K[at], K[:, b + idx, :b])
            if n_fixed:
                P = self.basis(n_fixed)[k]
                Pt = np.swapaxes(P, 1, 2)
                Mr = Pt @ M[at] @ P
                Li = np.linalg.inv(np.linalg.cholesky(0.5 * (Mr + np.swapaxes(Mr, -1, -2))))
                S = Li @ (Pt @ K[at] @ P) @ np.swapaxes(Li, -1, -2)
                # the Ritz problem in standard form, S = L^-1 K_r L^-T (M_r = L L^T), and L^-T
                out[f"S{k}"], out[f"L{k}"] = 0.5 * (S + np.swapaxes(S, -1, -2)), np.swapaxes(Li, -1, -2)
        T = np.concatenate([np.broadcast_to(np.eye(b), (J, b, b)), X], axis=1)
        MT = M[:, b:] @ T  # (J, n_i, b)
        for k, idx in enumerate(self.tpl._blocks):
            if n_fixed:
                out[f"C{k}"] = np.swapaxes(self.basis(n_fixed)[k], 1, 2) @ MT[:, idx]
        Mb = np.swapaxes(T, 1, 2) @ M @ T
        out["Mb"], out["X"] = 0.5 * (Mb + np.swapaxes(Mb, 1, 2)), X
        return out

    def table(self, n_fixed: int) -> SplinedTable:
        """`project` splined over the trained range (`flexmb.ksd.splined.SplinedTable`)."""
        if n_fixed not in self._tables:
            tpl = self.tpl
            self._tables[n_fixed] = SplinedTable(
                lambda theta: self.project(tpl.evaluate(theta, np.zeros((len(theta), tpl.dim))), n_fixed),
                *tpl.data.range)
        return self._tables[n_fixed]


_JOINT_MASS = weakref.WeakKeyDictionary()


def _lowest(S: np.ndarray, m: int):
    """The lowest ``m`` eigenpairs of symmetric matrices ``S`` (..., r, r): eigenvalues (..., m),
    vectors (..., r, m). LAPACK ``dsyevr`` for the wanted ones only: on the manipulator's three
    54 x 54 Ritz problems 0.47 ms against numpy's batched ``eigh`` (all pairs) 0.65 ms (eigenvalues
    equal to 5e-14 relative)."""
    r = S.shape[-1]
    m = min(m, r)
    flat = S.reshape(-1, r, r)
    w, V = np.empty((len(flat), m)), np.empty((len(flat), r, m))
    lwork, liwork, _ = _lapack.dsyevr_lwork(r)
    lwork = int(lwork)
    for i, s in enumerate(flat):
        w_i, V_i, _, _, info = _lapack.dsyevr(s, compute_v=1, range="I", il=1, iu=m, lwork=lwork, liwork=liwork)
        if info != 0:  # not converged (never seen): the batched driver, all pairs
            w_i, V_i = np.linalg.eigh(s)
        w[i], V[i] = w_i[:m], V_i[:, :m]
    return w.reshape(S.shape[:-2] + (m,)), V.reshape(S.shape[:-2] + (r, m))


def joint_mass(tpl, joint) -> _JointMass:
    """The template's `_JointMass`, built once per template (``joint``: the joint it belongs to)."""
    data = _JOINT_MASS.get(tpl)
    return data if data is not None else _JOINT_MASS.setdefault(tpl, _JointMass(tpl, joint))


def condensed(tpl, joint, theta: np.ndarray, n_fixed: int = 0, table: bool = True):
    """Condensed mass of J joints of one template at intended rotations ``theta`` (J,) [rad], in
    their joint frames (module notes): ``M_b`` (J, 2 nd, 2 nd) on nodes A and B, the lowest
    ``n_fixed`` fixed-interface modes' coupling ``Phi^T M T`` (J, n_fixed, 2 nd) and ``omega^2``
    (J, n_fixed), and the interior transformation ``(X, Phi)``: interior DOFs ``X q_b + Phi eta``.
    ``table``: interpolate the tabulated projections (rotations inside the trained range), else
    assemble and condense at ``theta`` directly."""
    data = joint_mass(tpl, joint)
    theta = np.asarray(theta, dtype=float)
    J = len(theta)
    if table and data.table(n_fixed).covers(theta):
        parts = data.table(n_fixed)(theta)
    else:
        parts = data.project(tpl.evaluate(theta, np.zeros((J, tpl.dim))), n_fixed)
    Mb, X = parts["Mb"], parts["X"]
    b, ni = Mb.shape[-1], X.shape[1]
    n_fixed = max(0, min(n_fixed, ni))
    if not n_fixed:
        return Mb, np.zeros((J, 0, b)), np.zeros((J, 0)), (X, np.zeros((J, ni, 0)))
    blocks = tpl._blocks
    whole = data.whole
    w_all, v_all, c_all = [], [], []  # per chain its lowest Ritz fixed-interface modes
    for k, idx in enumerate(blocks):
        P = data.basis(n_fixed)[k]  # (c, s, r)
        w, V = _lowest(parts[f"S{k}"], n_fixed)
        m = w.shape[-1]
        a = parts[f"L{k}"] @ V  # (J, c, r, m): Ritz coefficients, M_ii-normalised
        Cr = parts[f"C{k}"]
        if whole:  # one chain on all interior DOFs in order (three_x_infinity): no scatter
            v_all.append((P @ a)[:, 0])
        else:
            full = np.zeros((J, idx.shape[0], ni, m))  # each chain's modes on all interior DOFs
            full[:, np.arange(idx.shape[0])[:, None], idx] = P @ a
            v_all.append(np.moveaxis(full, 2, 1).reshape(J, ni, -1))
        w_all.append(w[..., :m].reshape(J, -1))
        c_all.append((np.swapaxes(a, -1, -2) @ Cr).reshape(J, -1, b))
    if len(blocks) == 1:
        w, v, C = w_all[0], v_all[0], c_all[0]
    else:
        w, v, C = np.concatenate(w_all, axis=1), np.concatenate(v_all, axis=2), np.concatenate(c_all, axis=1)
    if whole and w.shape[1] == n_fixed:  # one chain: LAPACK's eigenvalues come ascending
        return Mb, C, w, (X, v)
    pick = np.argsort(w, axis=1)[:, :n_fixed]
    return (Mb, np.take_along_axis(C, pick[:, :, None], axis=1), np.take_along_axis(w, pick, axis=1),
            (X, np.take_along_axis(v, pick[:, None, :], axis=2)))
