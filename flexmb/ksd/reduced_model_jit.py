"""Numba kernel of `flexmb.ksd.reduced_model.reduced_modal_model`'s assembly: the joints'
condensed mass carried to the links (``G^T M_b G``) and their fixed-interface modes' coupling
``C G``, joint by joint into the reduced mechanism's mass, as the numpy path does with (J, 2 nd,
6 n_links) arrays (many small numpy operations). Held equal to the numpy
path to 1e-12 in tests/test_ksd_properties.py.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .reduced_jit import deboor_basis, near_offset

__all__ = ["interface_maps", "joint_maps", "assemble_mass", "bspline_rows", "eob_axial", "interface_b"]


@njit
def interface_maps(F, arm, a, b, emb, pos6, G, pos):
    """Per joint j the map ``G[j]`` (2 nd, 12) from the twists of its links a and b (the 12
    columns: link a's 6 components, then link b's) to its interface DOFs A, B in the joint
    frame: rows ``emb`` of ``[[F^T, -F^T skew(r)], [0, F^T]]`` with the arms ``arm[j]`` (2, 3) of
    node A (from link a) and B (from link b); ``pos[j]`` (12,) the columns' places on the links'
    FE DOFs (``pos6``, -1 where not a DOF: the planar model's out-of-plane components; their
    columns are zeroed)."""
    nd = len(emb)
    T = np.zeros((6, 6))
    for j in range(F.shape[0]):
        for side in range(2):
            r = arm[j, side]
            for i in range(3):
                for k in range(3):
                    T[i, k] = F[j, k, i]
                    T[3 + i, 3 + k] = F[j, k, i]
                # -F^T skew(r): column k of skew(r) is e_k x ... : skew(r)[m, k] = -eps_mkl r_l
                T[i, 3] = -(F[j, 1, i] * r[2] - F[j, 2, i] * r[1])
                T[i, 4] = -(F[j, 2, i] * r[0] - F[j, 0, i] * r[2])
                T[i, 5] = -(F[j, 0, i] * r[1] - F[j, 1, i] * r[0])
            link = a[j] if side == 0 else b[j]
            for c in range(6):
                p = pos6[6 * link + c]
                pos[j, 6 * side + c] = p if p >= 0 else 0
                for i in range(nd):
                    G[j, nd * side + i, 6 * side + c] = T[emb[i], c] if p >= 0 else 0.0
                for i in range(nd):
                    G[j, nd * (1 - side) + i, 6 * side + c] = 0.0


@njit
def joint_maps(R, a, b, s_a, s_b, P, emb, pos6, F, G, pos):
    """`interface_maps` from the links' rotations ``R`` (n_links, 3, 3) directly: the joint
    frames' axes ``F = R_a P`` (filled, (J, 3, 3)) and the arms of node A from link a (``R_a
    s_a``) and of node B from link b (``R_b s_b``), as `flexmb.ksd.geometry.JointFrames.frame_a`
    and ``relative`` give them (instead of their three numpy calls and the stacking)."""
    arm = np.empty((F.shape[0], 2, 3))
    for j in range(F.shape[0]):
        ia, ib = a[j], b[j]
        for i in range(3):
            arm[j, 0, i] = R[ia, i, 0] * s_a[j, 0] + R[ia, i, 1] * s_a[j, 1] + R[ia, i, 2] * s_a[j, 2]
            arm[j, 1, i] = R[ib, i, 0] * s_b[j, 0] + R[ib, i, 1] * s_b[j, 1] + R[ib, i, 2] * s_b[j, 2]
            for k in range(3):
                F[j, i, k] = R[ia, i, 0] * P[j, 0, k] + R[ia, i, 1] * P[j, 1, k] + R[ia, i, 2] * P[j, 2, k]
    interface_maps(F, arm, a, b, emb, pos6, G, pos)


@njit
def assemble_mass(G, pos, idx, Mb, C, at, M):
    """Add joints ``idx`` (one template: ``Mb`` (Jg, 2 nd, 2 nd), coupling ``C`` (Jg, m, 2 nd))
    to the reduced mass ``M`` (n, n): ``G^T M_b G`` on their links' DOFs, the coupling ``C G``
    in rows and columns ``at[j] ..`` of joint j's modal coordinates (set, as each joint has its
    own) and their unit modal mass."""
    nb = G.shape[1]
    H = np.empty((12, nb))
    for k in range(len(idx)):
        j = idx[k]
        g, mb = G[j], Mb[k]
        for p in range(12):  # H = G^T Mb
            for q in range(nb):
                s = 0.0
                for t in range(nb):
                    s += g[t, p] * mb[t, q]
                H[p, q] = s
        for p in range(12):
            for q in range(12):
                s = 0.0
                for t in range(nb):
                    s += H[p, t] * g[t, q]
                M[pos[j, p], pos[j, q]] += s
        m0 = at[j]
        for r in range(C.shape[1]):
            for q in range(12):
                s = 0.0
                for t in range(nb):
                    s += C[k, r, t] * g[t, q]
                M[m0 + r, pos[j, q]] += s
                M[pos[j, q], m0 + r] += s
            M[m0 + r, m0 + r] = 1.0


@njit
def bspline_rows(t, c, k, x, out):
    """``out[i] = sum_a c[l - k + a] B_a(x[i])`` (``out`` (S, m)): scipy's `BSpline` of degree
    ``k`` with knots ``t`` and coefficients ``c`` (n, m) at ``x`` (S,), the basis by the same de
    Boor recursion (`flexmb.ksd.reduced_jit.deboor_basis`, as `scipy.interpolate._bspl`), outside
    the base interval the end pieces; the coefficient rows summed outermost, so each row is one contiguous pass (scipy sums per
    column, most of a table call)."""
    n = c.shape[0]
    h, hh = np.empty(k + 1), np.empty(k + 1)
    for i in range(len(x)):
        ell = deboor_basis(t, k, n, x[i], h, hh)
        row = out[i]
        row[:] = 0.0
        for a in range(k + 1):
            ca = c[ell - k + a]
            ha = h[a]
            for m in range(c.shape[1]):
                row[m] += ca[m] * ha


@njit
def eob_axial(recover, xi_b, idx, element_dofs, A, c0, G, b_position, out):
    """Joints ``idx`` of one template (Jg): the elements' axial forces ``out`` (Jg, E) from the
    tabulated coefficients (`flexmb.ksd.eob_forces`: ``A`` (Jg, E, 2 nd), ``c0`` (Jg, E), ``G``
    (Jg, E, dim)) and the node displacements `flexmb.ksd.reduced_model.node_displacements` gives
    (node A 0, node B ``xi_b[j]`` (nd,), internal nodes ``-(recover[:, :nd] xi_b + recover[:,
    nd])``), built per joint in place of the (Jg, N nd) array: ``N = A . q[element_dofs] + c0 +
    G p`` in numpy's order of the sums."""
    Jg, ni, nd1 = recover.shape
    nd = nd1 - 1
    E, w = element_dofs.shape
    dim = G.shape[2]
    q = np.empty(2 * nd + ni)
    for k in range(Jg):
        j = idx[k]
        for c in range(nd):
            q[c] = 0.0
            q[nd + c] = xi_b[j, c]
        for r in range(ni):
            s = 0.0
            for c in range(nd):
                s += recover[k, r, c] * xi_b[j, c]
            q[2 * nd + r] = -(s + recover[k, r, nd])
        for e in range(E):
            s = 0.0
            for m in range(w):
                s += A[k, e, m] * q[element_dofs[e, m]]
            g = 0.0
            for d in range(dim):
                g += G[k, e, d] * b_position[j, d]
            out[k, e] = s + c0[k, e] + g


@njit
def interface_b(p, Rrel, p_hat, R_hat, emb, out):
    """Node B's displacement from its near pose in the joint frames into ``out`` (J, nd): the
    translation ``p - p_hat`` and the axial vector of ``Rrel R_hat^T`` (`flexmb.rotations.
    unskew`), components ``emb`` (`flexmb.ksd.reduced_model.node_displacements`' numpy steps)."""
    v = np.empty(6)
    W = np.empty((3, 3))
    for j in range(p.shape[0]):
        near_offset(p, Rrel, p_hat, R_hat, j, W, v)
        for c in range(len(emb)):
            out[j, c] = v[emb[c]]
