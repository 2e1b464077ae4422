"""A joint's mass condensed on its interface nodes for KSD-reduced free vibration: the
Craig-Bampton reduction (Craig & Bampton 1968) of the joint's consistent mass with
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

`condensed_subspace` (what `flexmb.modes` uses; ``X`` and the interior shapes read only when
the mode shapes are, ``recovery=False``) interpolates ``M_b``, ``X`` and, per chain,
the kept fixed-interface modes' span in an aligned basis (`_JointMass.modal_parts`: its
stiffness ``Q^T K Q``, coupling and interior shapes) over the trained range
(`flexmb.ksd.splined`, built once per joint template on first use): no eigenproblem per
configuration (the three 54 x 54 Ritz problems were a third of the manipulator's ``modes``). The frequencies depend on the span alone; measured against the Ritz
eigenproblems solved at the configuration (``table=False``) between grid points: manipulator
f1-f6 5.8e-11, four-bar 2.5e-13 relative. Over three_x_infinity's +-45 deg the gap above the
6th mode stays open but narrow (``omega_7^2 / omega_6^2`` >= 1.00085, at 0 deg, an avoided
crossing in a cluster of the leaves' modes 3-9): the span turns quickly there, and the table
takes the finest grid (0.125 deg; interior shapes 5e-7, coupling 9e-8, stiffness 2e-10 of their
largest entries), sampled from the smooth Ritz projections' table (`_JointMass.ritz_table`,
1 deg), which builds in a third of the time. The 2D cross
flexure's (three chains, +-75 deg): >= 1.099, 0.5 deg grid. A template whose kept span is not
smooth over the range (a crossing at the cut: `span_check`, thresholds `GAP_MIN`, `ALIGN_MIN`,
`NEIGHBOUR_MIN` with the measured margins) gets no table: its Ritz eigenproblems are solved per
configuration, the reason kept in `_JointMass.refused`.
"""

from __future__ import annotations

import weakref

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack as _lapack

from ..fe.mass import element_mass, rigid_mass
from ..fe.model import State
from .eob import block_diagonal, lever
from .splined import SplinedTable

__all__ = ["condensed", "condensed_subspace", "joint_mass", "span_check", "span_margins", "RITZ_SAMPLES", "TIE",
           "GAP_MIN", "ALIGN_MIN", "NEIGHBOUR_MIN"]

#: Intended rotations at which a joint's fixed-interface modes are sampled for its Ritz basis,
#: evenly over the trained range. Measured on three_x_infinity (3D, 3 el./leaf, one interior
#: chain of 120 DOFs, +-45 deg) at 40 random rotations, the lowest six fixed-interface eigenvalues
#: against `scipy.linalg.eigh` on the whole interior: 5 samples (basis of 30) 1.6e-2, 9 (54)
#: 8.5e-7, 13 (73) 8.2e-11 largest relative error (the 2D cross flexure's chains of 12 DOFs:
#: complete with any, 2e-12).
RITZ_SAMPLES = 9

#: Relative distance under which two fixed-interface eigenvalues count as tied at the cut
#: (`condensed_subspace`): far above roundoff (equal chains tie to ~1e-13), far below the
#: distinct eigenvalues of a joint's chains.
TIE = 1e-6


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
        Tinv = block_diagonal(lever(-model.point_offset[el.ends], dim))
        M0 = np.swapaxes(Tinv, 1, 2) @ Mm @ Tinv
        flip = tpl.p_point != el.ends[:, 0]
        perm = np.r_[nd:2 * nd, 0:nd]
        self.M0 = np.where(flip[:, None, None], M0[:, perm][:, :, perm], M0)
        self.tpl = tpl
        self.n = n = N * nd
        dofs = tpl.element_dofs
        self._kidx = (dofs[:, :, None] * n + dofs[:, None, :]).ravel()
        self._basis, self._tables, self._cut, self._ref = {}, {}, {}, {}
        self.margins, self.refused = {}, {}  # per n_fixed: `span_margins`, `span_check`'s reason

    def nodes(self, eob) -> np.ndarray:
        """The joints' mass (J, n, n) on the EOB's node DOFs at its near configuration (``eob``
        a full `EOB`): beams from ``M0`` through the EOB's element rotations and levers,
        intermediate bodies (`flexmb.fe.mass.rigid_mass`) at the nodes' near poses."""
        J, n = len(eob.K_T), self.n
        Mmap = block_diagonal(np.swapaxes(eob.lever, -1, -2) @ eob.rotation[:, :, None])
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
            counts = self.cut(n_fixed)
            for idx, kept in zip(tpl._blocks, counts):
                k = min(max(n_fixed, int(kept.max(initial=0))), idx.shape[1])
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

    def cut(self, n_fixed: int) -> list:
        """Per block of chains the fixed-interface modes each chain keeps (list of (c,) ints): the
        lowest ``n_fixed`` over all chains at the trained range's middle rotation (the interior's
        exact modes, `scipy.linalg.eigh`), completed by every eigenvalue within `TIE` of the
        last one kept (`condensed_subspace`'s tie rule)."""
        if n_fixed not in self._cut:
            tpl = self.tpl
            mid = np.array([0.5 * (tpl.data.range[0] + tpl.data.range[1])])
            eob = tpl.evaluate(mid, np.zeros((1, tpl.dim)))
            K, M, b = eob.K_nodes[0], self.nodes(eob)[0], 2 * tpl.nd
            pooled = []  # (eigenvalue, block, chain)
            for k, idx in enumerate(tpl._blocks):
                for i, chain in enumerate(idx):
                    at = np.ix_(b + chain, b + chain)
                    top = min(n_fixed + 1, len(chain))
                    w = sla.eigh(0.5 * (K[at] + K[at].T), M[at], eigvals_only=True, subset_by_index=[0, top - 1])
                    pooled += [(float(v), k, i) for v in w]
            pooled.sort()
            counts = [np.zeros(len(idx), dtype=np.int64) for idx in tpl._blocks]
            if n_fixed and pooled:
                last = pooled[min(n_fixed, len(pooled)) - 1][0]
                for v, k, i in pooled:
                    if v <= last + TIE * abs(last):
                        counts[k][i] += 1
            self._cut[n_fixed] = counts
        return self._cut[n_fixed]

    def modal_parts(self, parts: dict, n_fixed: int, align: bool, checks: list | None = None) -> dict:
        """From `project`'s arrays (J joints) the interior modal coordinates `cut` keeps, chain
        by chain in block order: their stiffness ``Kq`` (J, m, m), coupling ``C = Q^T M_i T``
        (J, m, b) and interior shapes ``Phi`` (J, n_i, m), mass-normalised (``Q^T M_ii Q = I``).
        ``align=False``: the chains' lowest Ritz modes themselves (``Kq = diag(omega^2)``);
        ``align=True``: the basis of their span nearest (orthogonal Procrustes in the mass inner
        product) to the one at the range's middle rotation, ``Q = Pi Q_0 (Q_0^T M Pi Q_0)^-1/2``
        with ``Pi`` the projector on the kept span: it depends on the rotation only through the
        span, so it is smooth where the span is (the gap above the cut open) and can be splined.
        ``checks`` (a list, with ``align``): appended per chain ``(gap, sv, a)``: the ratio
        ``omega^2_{k+1} / omega^2_k`` above the chain's cut (J,), the alignment's singular values
        (J, k) and the kept span's Ritz coefficients (J, r, k) (`table`'s crossing check)."""
        counts = self.cut(n_fixed)
        m = int(sum(c.sum() for c in counts))
        X = parts["X"]
        J, ni, b = X.shape[0], X.shape[1], X.shape[2]
        Kq, C, Phi = np.zeros((J, m, m)), np.zeros((J, m, b)), np.zeros((J, ni, m))
        at = 0
        for k, idx in enumerate(self.tpl._blocks):
            P = self.basis(n_fixed)[k]  # (c, s, r)
            for i, chain in enumerate(idx):
                kc = int(counts[k][i])
                if not kc:
                    continue
                r = parts[f"S{k}"].shape[-1]
                if checks is not None and kc < r:  # one eigenvalue above the cut: the gap
                    w, V = _lowest(parts[f"S{k}"][:, i], kc + 1)
                    gap, w, V = w[:, kc] / w[:, kc - 1], w[:, :kc], V[:, :, :kc]
                else:
                    w, V = _lowest(parts[f"S{k}"][:, i], kc)
                    gap = np.full(len(w), np.inf)
                Lt = parts[f"L{k}"][:, i]  # L^-T: Ritz coefficients a = L^-T V
                a = Lt @ V
                if align:
                    ref = self.reference(n_fixed)[(k, i)]
                    A = np.swapaxes(V, 1, 2) @ np.linalg.solve(Lt, np.broadcast_to(ref, (J,) + ref.shape))
                    U, sv, Wt = np.linalg.svd(A)
                    R = U @ Wt
                    a = a @ R
                    if checks is not None:
                        checks.append((gap, sv, a))
                    Kq[:, at:at + kc, at:at + kc] = np.swapaxes(R, 1, 2) @ (w[:, :, None] * R)
                else:
                    Kq[:, range(at, at + kc), range(at, at + kc)] = w
                C[:, at:at + kc] = np.swapaxes(a, 1, 2) @ parts[f"C{k}"][:, i]
                Phi[:, chain, at:at + kc] = P[i] @ a
                at += kc
        return {"Kq": 0.5 * (Kq + np.swapaxes(Kq, 1, 2)), "C": C, "Phi": Phi}

    def reference(self, n_fixed: int) -> dict:
        """Per chain ``(block, chain)`` the Ritz coefficients (r, k) of its kept modes at the
        trained range's middle rotation: the basis `modal_parts` aligns to."""
        if n_fixed not in self._ref:
            tpl = self.tpl
            mid = np.array([0.5 * (tpl.data.range[0] + tpl.data.range[1])])
            parts = self.project(tpl.evaluate(mid, np.zeros((1, tpl.dim))), n_fixed)
            ref, counts = {}, self.cut(n_fixed)
            for k, idx in enumerate(tpl._blocks):
                for i in range(len(idx)):
                    if counts[k][i]:
                        ref[(k, i)] = (parts[f"L{k}"][0, i] @ _lowest(parts[f"S{k}"][0, i], int(counts[k][i]))[1])
            self._ref[n_fixed] = ref
        return self._ref[n_fixed]

    def ritz_table(self, n_fixed: int) -> SplinedTable:
        """`project` splined over the trained range: smooth in the rotation (a fixed Ritz basis
        per chain), so a coarse grid serves (three_x_infinity: 1 deg)."""
        key = ("ritz", n_fixed)
        if key not in self._tables:
            tpl = self.tpl
            self._tables[key] = SplinedTable(
                lambda theta: self.project(tpl.evaluate(theta, np.zeros((len(theta), tpl.dim))), n_fixed),
                *tpl.data.range)
        return self._tables[key]

    def table(self, n_fixed: int) -> SplinedTable | None:
        """Over the trained range (`flexmb.ksd.splined.SplinedTable`): ``Mb``, ``X`` and, with
        kept modes, `modal_parts` aligned (``Kq``, ``C``, ``Phi``): no eigenproblem per
        configuration. Sampled from `ritz_table` (where the kept span turns quickly the grid
        is fine: assembling the joint at each of its points took seven times as long). None where `span_check` refuses it (the reason in ``refused``)."""
        if n_fixed not in self._tables:
            ritz = self.ritz_table(n_fixed)
            if not sum(c.sum() for c in self.cut(n_fixed)):
                self._tables[n_fixed] = ritz
            else:
                seen = []  # (theta, per chain (gap, sv, a)) of every sample

                def sample(theta):
                    parts, checks = ritz(theta), []
                    out = {"Mb": parts["Mb"], "X": parts["X"], **self.modal_parts(parts, n_fixed, True, checks)}
                    seen.append((theta, checks))
                    return out

                table = SplinedTable(sample, *self.tpl.data.range)
                self.margins[n_fixed] = margins = span_margins(seen, np.radians(table.step))
                reason = span_check(margins)
                if reason:
                    self.refused[n_fixed] = reason
                self._tables[n_fixed] = None if reason else table
        return self._tables[n_fixed]


#: `span_check`'s thresholds. The kept span of a chain's fixed-interface modes is splined only
#: where it is a smooth function of the rotation: a true eigenvalue crossing at the cut anywhere
#: in the trained range swaps a mode in and out between two samples, and the spline would
#: interpolate across the jump (a silently wrong mass model). On the table's finest grid, per
#: chain and sample: the gap above the cut ``omega^2_{k+1} / omega^2_k`` >= `GAP_MIN`, the
#: alignment's smallest singular value (the kept span against the range's middle one) >=
#: `ALIGN_MIN`, and the span's overlap with its neighbour's (the cosine of their largest
#: principal angle, Euclidean, in the fixed Ritz basis) >= `NEIGHBOUR_MIN`. Measured margins
#: (gap / alignment / neighbour overlap): the manipulator's three_x_infinity (+-45 deg, 0.125 deg
#: grid) 1.00086 (at 0 deg, an avoided crossing: its spline reproduces the shapes to 5e-7) / 0.58
#: (at -45 deg) / 0.982 (at 0 deg, 11 deg of turn per step); the four-bar's 2D cross flexure
#: (+-75 deg, 0.5 deg grid) 1.099 / 0.17 / 0.997; refused: the planar cross flexure pivot's
#: (`flexmb.models.cross_flexure_pivot`, two chains of 3 kept modes) 1.126 / 1.7e-4 (at 62.75
#: deg: the aligned basis flips there; splined across it, f3 at 62.6 deg was 3 % off the Ritz
#: eigensolve) / 0.9998. A crossing between two samples gives an overlap
#: near 0 (a whole mode swapped) whatever the gap at the samples; an avoided one sharper than the
#: finest grid resolves (26 deg of turn per step) is refused as well.
GAP_MIN = 1.0 + 1e-4
ALIGN_MIN = 0.05
NEIGHBOUR_MIN = 0.9


def span_margins(seen: list, step: float) -> dict:
    """From `_JointMass.table`'s samples ``[(theta, [(gap, sv, a) per chain])]`` those on the
    finest grid (spacing ``step`` [rad]): the smallest gap above the cut, alignment singular
    value and neighbouring samples' span overlap, over chains and samples, with the rotation
    [rad] of each."""
    out = {"gap": (np.inf, None), "align": (np.inf, None), "neighbour": (np.inf, None)}
    for theta, checks in seen:
        if len(theta) < 2 or not np.isclose(theta[1] - theta[0], step, rtol=1e-6):
            continue
        for gap, sv, a in checks:
            for key, v in (("gap", gap), ("align", sv.min(axis=-1))):
                i = int(np.argmin(v))
                if v[i] < out[key][0]:
                    out[key] = (float(v[i]), float(theta[i]))
            Q = np.linalg.qr(a)[0]
            cos = np.linalg.svd(np.swapaxes(Q[:-1], 1, 2) @ Q[1:], compute_uv=False).min(axis=-1)
            i = int(np.argmin(cos))
            if cos[i] < out["neighbour"][0]:
                out["neighbour"] = (float(cos[i]), float(0.5 * (theta[i] + theta[i + 1])))
    return out


def span_check(margins: dict) -> str:
    """Why the kept span may not be splined (`span_margins` below a threshold), or ''."""
    limits = {"gap": (GAP_MIN, "gap above the cut omega^2_k+1/omega^2_k"),
              "align": (ALIGN_MIN, "alignment's smallest singular value"),
              "neighbour": (NEIGHBOUR_MIN, "neighbouring samples' span overlap")}
    out = [f"{what} {margins[key][0]:.6g} < {lim:g} at {np.degrees(margins[key][1]):.3f} deg"
           for key, (lim, what) in limits.items() if margins[key][0] < lim]
    return ("fixed-interface span not tabulated (an eigenvalue crossing at the cut?): " + "; ".join(out)
            + "; the Ritz eigenproblems are solved per configuration") if out else ""


_JOINT_MASS = weakref.WeakKeyDictionary()


def _lowest(S: np.ndarray, m: int):
    """The lowest ``m`` eigenpairs of symmetric matrices ``S`` (..., r, r): eigenvalues (..., m),
    vectors (..., r, m). LAPACK ``dsyevr`` for the wanted ones only, faster than numpy's batched ``eigh`` (all pairs) on
    the manipulator's three 54 x 54 Ritz problems (eigenvalues equal to 5e-14 relative)."""
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


def condensed_subspace(tpl, joint, theta: np.ndarray, n_fixed: int = 0, table: bool = True, recovery: bool = True):
    """Condensed mass of J joints of one template at intended rotations ``theta`` (J,) [rad] in
    their joint frames, for free vibration: ``M_b`` (J, b, b) on nodes A and B, and of the kept
    fixed-interface modes' span (m coordinates, `_JointMass.cut`) the stiffness ``K_q`` (J, m,
    m), the coupling ``Q^T M T`` (J, m, b) and the interior transformation ``(X, Q)``: interior
    DOFs ``X q_b + Q eta``; the coordinates' mass is the identity. The frequencies of a model
    built with them depend on the span alone, not on the basis ``Q`` within it.

    ``table`` (rotations inside the trained range): ``K_q``, the coupling and ``Q`` splined in
    an aligned basis (`_JointMass.modal_parts`), no eigenproblem per configuration; else the
    Ritz eigenproblems solved at ``theta`` (``K_q = diag(omega^2)``: the reference path).

    Tie rule: each chain keeps a fixed number of its lowest modes, the lowest ``n_fixed`` over
    the joint's chains at the range's middle rotation plus every one within `TIE` of the last
    kept (all ties at the cut, so m may exceed ``n_fixed``: three equal chains keep whole
    triples). Chosen per configuration among tied chains, the kept modes depended on roundoff
    (the four-bar's frequencies moved 4.8e-4 with a 4e-11 change of its solution). Measured
    effect against that choice: the manipulator's joints (one chain) unchanged (3e-11); the
    four-bar's cross flexures keep 3 + 2 + 2 modes (a triple tied at the 6th), f1-f6 over its
    stroke moved by up to 1.3e-3 relative (f1-f3 1.2e-3), now smooth in the solution (1e-10 m
    of stroke at rest: 5e-10, before 1.7e-5).

    ``recovery=False``: the last item is a function returning ``(X, Q)`` when called, so a caller
    that needs no interior shapes reads no table columns of them (the manipulator's joint
    table: 2400 columns, of which ``M_b``, ``K_q`` and the coupling are 252; a ``modes`` call
    read ~460 KB of it, now ~48 KB)."""
    data = joint_mass(tpl, joint)
    theta = np.asarray(theta, dtype=float)
    J = len(theta)
    tab = data.table(n_fixed) if table else None
    if tab is not None and tab.covers(theta):
        if "Kq" in tab._shapes:
            parts = tab(theta, ("Mb", "C", "Kq"))
            if recovery:
                rec = tab(theta, ("X", "Phi"))
                return parts["Mb"], parts["C"], parts["Kq"], (rec["X"], rec["Phi"])
            return parts["Mb"], parts["C"], parts["Kq"], lambda: tuple(tab(theta, ("X", "Phi")).values())
        parts = tab(theta)
    else:
        parts = data.project(tpl.evaluate(theta, np.zeros((J, tpl.dim))), n_fixed)
    Mb, X = parts["Mb"], parts["X"]
    b, ni = Mb.shape[-1], X.shape[1]
    if not n_fixed or not sum(c.sum() for c in data.cut(n_fixed)):
        rec = (X, np.zeros((J, ni, 0)))
        return Mb, np.zeros((J, 0, b)), np.zeros((J, 0, 0)), rec if recovery else lambda: rec
    modal = data.modal_parts(parts, n_fixed, align=False)
    rec = (X, modal["Phi"])
    return Mb, modal["C"], modal["Kq"], rec if recovery else lambda: rec


def condensed(tpl, joint, theta: np.ndarray, n_fixed: int = 0, table: bool = True):
    """`condensed_subspace` as modes: ``M_b`` (J, b, b), the kept fixed-interface modes'
    coupling ``Phi^T M T`` (J, m, b) and ``omega^2`` (J, m), ascending, and ``(X, Phi)``
    (tabulated: the eigenpairs of the interpolated ``K_q``)."""
    Mb, C, Kq, (X, Q) = condensed_subspace(tpl, joint, theta, n_fixed, table)
    w, U = np.linalg.eigh(Kq)
    return Mb, np.swapaxes(U, 1, 2) @ C, w, (X, Q @ U)
