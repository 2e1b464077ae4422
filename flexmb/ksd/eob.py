"""Element Orientation based Body (EOB), Dwarshuis et al. (2020), Section 3.

Everything is in the joint's own frame, relative to interface node A (the origin, held fixed):
the joint's large rigid motion in a mechanism is the pose of that frame (`geometry.JointFrames`).

1. Element orientations from the database, Eq. (3.1): in 2D the chord rotations ``beta_k(theta)``;
   in 3D rotation vectors (Sec. 3.1: elements of a spatial joint turn about several axes), as
   are the orientations of the internal nodes and rigid intermediate bodies.
2. Near configuration, Eq. (3.2): every element rigidly rotated and undeformed, its two *markers*
   placed along chains of elements that start at node A (breadth-first tree over the nodes):
   ``x_q = x_p + R_k d_pq``. Where chains close a loop (at node B of a cross flexure) the markers
   of coupled elements do not coincide.
3. Stiffness in the near configuration, Eqs. (3.3)-(3.11): ``K_k`` the element's material
   stiffness rotated by ``R_k`` (stress-free, so no geometric part), ``K_all`` block-diagonal,
   ``F_all = K_all (L q - q_hat)`` and ``F_nodes = K_nodes q + F_hat_nodes``,
   ``K_nodes = L^T K_all L``, ``F_hat_nodes = L^T F_hat_all``.

Node displacements ``q`` are measured from each node's near pose (node A: rest; node B: the
pose found by the kinematic step; internal nodes: the chains and the trained node rotations),
rotations as small spins about it. Then ``L`` maps node increments to marker increments; it is
Boolean for elements attached directly to a node (the paper's case) and carries the lever arm
``R_n s`` of the connector block for elements attached to a block at offset ``s`` (linearised
about the near pose, exact to first order for any block rotation). ``q_hat_all`` is the rigid
displacement of each marker from where the nodes' near poses put it, so
``F_hat_all = -K_all q_hat_all`` (Eq. 3.8).
"""

from __future__ import annotations

from collections import deque

import attrs
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import ModelError
from ..fe import beam2d, beam3d
from ..rotations import logm_so3, rot2, skew
from .geometry import expm, rz

__all__ = ["EOBTemplate", "EOB", "NearPoses", "lever", "block_diagonal"]

_EYE = np.eye(3)


def lever(r: np.ndarray, dim: int) -> np.ndarray:
    """Blocks ``(..., ndof, ndof)`` mapping a node increment to that of a point at arm ``r``."""
    nd = 3 if dim == 2 else 6
    T = np.zeros(r.shape[:-1] + (nd, nd))
    T[..., range(nd), range(nd)] = 1.0
    if dim == 2:
        T[..., 0, 2], T[..., 1, 2] = -r[..., 1], r[..., 0]
    else:  # dx_point = dx - r x dphi
        T[..., :3, 3:] = -skew(r)
    return T


def block_diagonal(blocks: np.ndarray) -> np.ndarray:
    """``(..., 2, nd, nd)`` -> ``(..., 2 nd, 2 nd)``: the two blocks on the diagonal."""
    nd = blocks.shape[-1]
    out = np.zeros(blocks.shape[:-3] + (2 * nd, 2 * nd))
    out[..., :nd, :nd], out[..., nd:, nd:] = blocks[..., 0, :, :], blocks[..., 1, :, :]
    return out


@attrs.frozen(eq=False)
class NearPoses:
    """The near poses of J EOBs without their stiffness (`EOBTemplate.near_poses`): ``rotation``
    (J, E, nd, nd), ``q_hat`` (J, E, 2nd) and ``lever`` (J, E, 2, nd, nd), as `EOB`'s."""

    rotation: np.ndarray
    q_hat: np.ndarray
    lever: np.ndarray


@attrs.frozen(eq=False)
class EOB:
    """Result of `EOBTemplate.evaluate` for J joints (leading axis J everywhere).

    ``K_all`` (J, E, 2nd, 2nd), ``F_hat_all`` (J, E, 2nd) in marker DOFs (markers p, q of each
    element); ``L`` (J, E, 2nd, 2nd) node-to-marker blocks; ``K_nodes`` (J, n, n) and
    ``F_hat_nodes`` (J, n) on the node DOFs (node A, node B, internal nodes); ``K_T``
    (J, 2nd, 2nd) and ``F_hat_T`` (J, 2nd) condensed on A and B (Eq. 2.5), or on B alone
    ((J, nd, nd), (J, nd)) when evaluated with node A held; ``recover``
    (J, n_i, nd + 1): ``q_i = -recover @ [q_B, 1]`` with node A held (Eq. 2.6).
    Near configuration: ``node_position`` (J, N, dim), ``node_rotation`` (J, N, dim, dim),
    ``node_angle`` (J, N) [rad] (2D; ``None`` in 3D), ``marker_position`` (J, E, 2, dim).
    ``K_all``, ``F_hat_all`` and ``L`` are formed when read (the nodes' terms need only their
    products, Eq. 3.11).
    """

    rotation: np.ndarray  # (J, E, nd, nd): element rotation of one marker's DOFs
    K0: np.ndarray  # (E, 2nd, 2nd): material stiffness in the undeformed orientation
    q_hat: np.ndarray  # (J, E, 2nd): Eq. (3.8)
    lever: np.ndarray  # (J, E, 2, nd, nd): node-to-marker blocks
    K_nodes: np.ndarray
    F_hat_nodes: np.ndarray
    K_T: np.ndarray
    F_hat_T: np.ndarray
    recover: np.ndarray
    node_position: np.ndarray
    node_angle: np.ndarray | None
    node_rotation: np.ndarray
    marker_position: np.ndarray

    @property
    def K_all(self) -> np.ndarray:
        """Element stiffness in the near configuration, ``T K0 T^T`` (Eqs. 3.3-3.4)."""
        T = block_diagonal(np.stack([self.rotation, self.rotation], axis=2))
        return T @ self.K0 @ np.swapaxes(T, -1, -2)

    @property
    def F_hat_all(self) -> np.ndarray:
        """``-K_all q_hat_all`` (Eq. 3.8)."""
        return -(self.K_all @ self.q_hat[..., None])[..., 0]

    @property
    def L(self) -> np.ndarray:
        """Node-to-marker increments per element (Eq. 3.9)."""
        return block_diagonal(self.lever)


class EOBTemplate:
    """What an EOB needs from one joint, prepared once: its mesh in the joint frame (node A = 0,
    B = 1, internal nodes 2.. in mesh order, as in training), the chains from node A and every
    element's material stiffness at rest."""

    def __init__(self, joint, dim: int, data):
        from ..mechanism import Mechanism

        m = Mechanism(dim=dim)
        m.add_link("A", fixed=True)
        m.add_link("B", position=joint.interface_b(dim))
        m.add_joint("A", "B", joint, name="joint")
        model = m.compile().problem.model
        self.dim, self.data = dim, data
        self.nd = model.ndof
        self.n_nodes = model.n_nodes
        self.n_elements = len(model.elements.L0)
        self.node_x0 = model.x0
        parent, flip = self._chains(joint, model)
        self._markers(model, flip, self._stiffness_at_rest(model))
        self._internal_paths(parent)
        self._assembly_layout()
        self._orientation_polynomial(data)
        self.lookup = None  # the tabulated condensation (`flexmb.ksd.eob_table.lookup_for`), when it applies

    def _stiffness_at_rest(self, model) -> np.ndarray:
        """Every element's material stiffness at rest (E, 2 nd, 2 nd), marker order (end 0, end 1)."""
        el, E = model.elements, self.n_elements
        x = model.point_x0[el.ends]
        if self.dim == 2:
            return beam2d.internal_force_and_tangent(x[:, 0], x[:, 1], np.zeros(E), np.zeros(E), el.alpha0, el.L0,
                                                     el.S)[1]
        I = np.tile(np.eye(3), (E, 1, 1))
        return beam3d.internal_force_and_tangent(x[:, 0], x[:, 1], I, I, el.ny0, el.nz0, el.L0, el.S)[1]

    def _chains(self, joint, model):
        """A breadth-first tree over the nodes from node A: each node's parent element (N,) and
        which elements run q -> p (E,) so that every element runs p -> q away from A."""
        N, E = self.n_nodes, self.n_elements
        ends, master = model.elements.ends, model.point_master
        incident = [[] for _ in range(N)]
        for k, (i, j) in enumerate(master[ends]):
            incident[i].append(k)
            incident[j].append(k)
        order = np.full(N, -1)
        order[0] = 0
        parent = np.full(N, -1)
        oriented = np.zeros(E, dtype=bool)
        flip = np.zeros(E, dtype=bool)
        queue, seen = deque([0]), 1
        while queue:
            u = queue.popleft()
            for k in incident[u]:
                if oriented[k]:
                    continue
                oriented[k] = True
                flip[k] = master[ends[k, 0]] != u
                v = master[ends[k, 1 - int(flip[k])]]
                if order[v] < 0:
                    order[v], seen = seen, seen + 1
                    parent[v] = k
                    queue.append(v)
        if seen < N:
            raise ModelError(f"joint {joint.kind!r}: nodes {np.flatnonzero(order < 0).tolist()} are not connected "
                             "to node A by elements")
        return parent, flip

    def _markers(self, model, flip, K0) -> None:
        """Each element's markers p, q (points, nodes, offsets), its step ``d`` from p to q, its
        stiffness at rest in (p, q) order and its axial force row."""
        nd, dim = self.nd, self.dim
        ends, master, offset = model.elements.ends, model.point_master, model.point_offset
        pq = np.where(flip[:, None], ends[:, ::-1], ends)
        self.p_point, self.q_point = pq[:, 0], pq[:, 1]
        self.p_node, self.q_node = master[self.p_point], master[self.q_point]
        self.s_p, self.s_q = offset[self.p_point], offset[self.q_point]
        self.pq_node, self.s_pq = np.stack([self.p_node, self.q_node], axis=1), np.stack([self.s_p, self.s_q], axis=1)
        self.d = model.point_x0[self.q_point] - model.point_x0[self.p_point]
        perm = np.r_[nd:2 * nd, 0:nd]
        self.K0 = np.where(flip[:, None, None], K0[:, perm][:, :, perm], K0)
        # d . (force on marker q) of K0: an element's axial force from its local displacements
        self._axial_row = np.einsum("ea,eab->eb", self.d / np.linalg.norm(self.d, axis=1)[:, None],
                                    self.K0[:, nd:nd + dim])

    def _internal_paths(self, parent) -> None:
        """Internal nodes: x_n = x_root + sum over the path from the root (A or B) of the element
        steps R_p s_p + R_k d_k - R_q s_q (node to node through the element's markers)."""
        N = self.n_nodes
        n_int = N - 2
        self.path = np.zeros((n_int, self.n_elements))
        self.root = np.zeros(n_int, dtype=np.int64)
        for n in range(2, N):
            v = n
            while v > 1:
                k = parent[v]
                self.path[n - 2, k] = 1.0
                v = self.p_node[k]
            self.root[n - 2] = v

    def _assembly_layout(self) -> None:
        """Node DOFs of every element's (p, q) markers, flattened for assembly into K_nodes; the
        internal nodes' chains (a cross flexure: one per leaf) that only the interface nodes
        couple: the Craig-Bampton solve is block diagonal, done per block size."""
        nd, N = self.nd, self.n_nodes
        n_int = N - 2
        dofs = np.concatenate([self.p_node[:, None] * nd + np.arange(nd), self.q_node[:, None] * nd + np.arange(nd)],
                              axis=1)
        self.element_dofs = dofs
        self._kidx = (dofs[:, :, None] * (N * nd) + dofs[:, None, :]).ravel()
        inner = (self.p_node >= 2) & (self.q_node >= 2)
        graph = sp.coo_array((np.ones(inner.sum()), (self.p_node[inner] - 2, self.q_node[inner] - 2)),
                             shape=(n_int, n_int))
        _, label = connected_components(graph, directed=False)
        blocks = {}
        for c in range(label.max() + 1 if n_int else 0):
            nodes = np.flatnonzero(label == c)
            blocks.setdefault(len(nodes), []).append((nodes[:, None] * nd + np.arange(nd)).ravel())
        self._blocks = [np.array(v) for v in blocks.values()]  # (c, s) interior DOF indices
        n, b = N * nd, 2 * nd
        self._block_at = [((b + i)[:, :, None] * n + (b + i)[:, None, :]) for i in self._blocks]  # in K_nodes (n * n)
        self._scatter_at = {}

    def _orientation_polynomial(self, data) -> None:
        """The element and internal-node orientation fits as one polynomial over the union of their powers."""
        polys = (data.elements, data.nodes) if self.n_nodes > 2 else (data.elements,)
        powers = np.unique(np.concatenate([f.powers for f in polys]))
        coef = [np.zeros((np.atleast_2d(f.coefficients).shape[0], len(powers))) for f in polys]
        for c, f in zip(coef, polys):
            c[:, np.searchsorted(powers, f.powers)] = np.atleast_2d(f.coefficients)
        self._powers, self._coef = powers, np.concatenate(coef).T  # (P,), (P, n_orient)

    def evaluate(self, theta: np.ndarray, b_position: np.ndarray, *, held_a: bool = False) -> EOB:
        """EOBs of J joints at intended rotations ``theta`` (J,) [rad] with node B's near position
        ``b_position`` (J, dim) [m] in the joint frame (from the kinematic step).

        ``held_a=True`` condenses with node A held (its displacement zero, as in KSD step 3,
        Eq. 2.4): ``K_T`` (J, nd, nd) and ``F_hat_T`` (J, nd) are then node B's blocks only, and
        the Craig-Bampton solve has nd + 1 right-hand sides instead of 2 nd + 1."""
        nd, N, E = self.nd, self.n_nodes, self.n_elements
        theta = np.asarray(theta, dtype=float)
        J = len(theta)
        Tb, q_hat, lv, arm, x, node_angle, Rn, markers = self._near_poses(theta, b_position)
        # with T = diag(Tb, Tb): K_all = T K0 T^T, F_hat_all = -K_all q_hat (Eq. 3.8); the nodes see
        # L^T K_all L = M K0 M^T and L^T F_hat_all = -M K0 T^T q_hat, M = L^T T (Eq. 3.11)
        M = block_diagonal(np.swapaxes(lv, -1, -2) @ Tb[:, :, None])
        Ke = M @ self.K0 @ np.swapaxes(M, 2, 3)
        local_q = np.swapaxes(Tb, 2, 3)[:, :, None] @ q_hat.reshape(J, E, 2, nd, 1)
        Fe = -(M @ (self.K0 @ local_q.reshape(J, E, 2 * nd, 1)))[..., 0]

        n = N * nd
        flat, fidx = self._scatter(J)
        K_nodes = np.bincount(flat, weights=Ke.ravel(), minlength=J * n * n).reshape(J, n, n)
        F_nodes = np.bincount(fidx, weights=Fe.ravel(), minlength=J * n).reshape(J, n)

        b = 2 * nd
        cols = slice(nd, b) if held_a else slice(0, b)  # the boundary DOFs condensed on
        if n > b:  # Craig-Bampton boundary modes, Eq. (2.5); node B's columns and F last
            rhs = np.concatenate([K_nodes[:, b:, cols], F_nodes[:, b:, None]], axis=2)
            X = np.empty_like(rhs)
            K_flat = K_nodes.reshape(J, n * n)
            for idx, at in zip(self._blocks, self._block_at):
                X[:, idx] = np.linalg.solve(K_flat[:, at], rhs[:, idx])
            K_Tb = K_nodes[:, cols, b:]
            K_T = K_nodes[:, cols, cols] - K_Tb @ X[:, :, :-1]
            F_T = F_nodes[:, cols] - (K_Tb @ X[:, :, -1:])[..., 0]
            recover = X[:, :, -(nd + 1):]
        else:
            K_T, F_T = K_nodes[:, cols, cols].copy(), F_nodes[:, cols].copy()
            recover = np.zeros((J, 0, nd + 1))
        return EOB(Tb, self.K0, q_hat, lv, K_nodes, F_nodes, K_T, F_T, recover, x, node_angle, Rn, markers)

    def near_poses(self, theta: np.ndarray, b_position: np.ndarray) -> NearPoses:
        """The EOBs' near poses at intended rotations ``theta`` (J,) [rad] with node B at
        ``b_position`` (J, dim) [m] (`evaluate`'s geometry, without the condensation's stiffness):
        what `axial_force` reads."""
        Tb, q_hat, lv = self._near_poses(np.asarray(theta, dtype=float), b_position)[:3]
        return NearPoses(Tb, q_hat, lv)

    def _near_poses(self, theta: np.ndarray, b_position: np.ndarray):
        """``(Tb, q_hat, lever, arm, x, node_angle, Rn, markers)`` of `evaluate` (Eqs. 3.1-3.8)."""
        dim, nd, N, E = self.dim, self.nd, self.n_nodes, self.n_elements
        J = len(theta)
        beta, Re, node_angle, Rn = self.orientations(theta)
        Rd = (Re @ self.d[..., None])[..., 0]
        Rpq = Rn[:, self.pq_node]  # (J, E, 2, dim, dim): near rotations of each element's nodes p, q
        arm = (Rpq @ self.s_pq[..., None])[..., 0]
        arm_p, arm_q = arm[:, :, 0], arm[:, :, 1]
        x = np.zeros((J, N, dim))
        x[:, 1] = b_position
        if N > 2:
            x[:, 2:] = x[:, self.root] + np.einsum("ne,jea->jna", self.path, arm_p + Rd - arm_q)
        markers = np.empty((J, E, 2, dim))
        markers[:, :, 0] = mp = x[:, self.p_node] + arm_p
        markers[:, :, 1] = mq = mp + Rd
        # q_hat: marker near pose minus where the nodes' near poses put the marker
        q_hat = np.zeros((J, E, 2, nd))
        q_hat[:, :, 1, :dim] = mq - (x[:, self.q_node] + arm_q)
        if dim == 2:
            q_hat[..., nd - 1] = beta[:, :, None] - node_angle[:, self.pq_node]
        else:  # spins from the node's near orientation to the element's
            q_hat[..., 3:] = -logm_so3(Rpq @ np.swapaxes(Re, 2, 3)[:, :, None])
        q_hat = q_hat.reshape(J, E, 2 * nd)

        Tb = np.zeros((J, E, nd, nd))  # element rotation of one marker's (translation, rotation) DOFs
        Tb[..., :dim, :dim] = Re
        if dim == 2:
            Tb[..., 2, 2] = 1.0
        else:
            Tb[..., 3:, 3:] = Re
        lv = lever(arm, dim)  # (J, E, 2, nd, nd)
        return Tb, q_hat, lv, arm, x, node_angle, Rn, markers

    def orientations(self, theta: np.ndarray, elements: bool = True):
        """Near orientations at intended rotations ``theta`` (J,) from the database (Eq. 3.1):
        ``beta`` (J, E) element angles (2D; None in 3D), ``Re`` (J, E, dim, dim) element rotations,
        ``node_angle`` (J, N) (2D; None in 3D) and ``Rn`` (J, N, dim, dim) of all nodes (A, B,
        internal); ``elements=False`` skips the elements (``beta`` and ``Re`` None)."""
        dim, N, E = self.dim, self.n_nodes, self.n_elements
        J = len(theta)
        c = 1 if dim == 2 else 3  # orientation components per element or node
        first = 0 if elements else c * E
        orient = (theta[:, None] ** self._powers) @ self._coef[:, first:]  # elements, then internal nodes
        e = E if elements else 0
        beta = Re = node_angle = None
        if dim == 2:
            node_angle = np.concatenate([np.zeros((J, 1)), theta[:, None], orient[:, e:]], axis=1)
            Rn = rot2(node_angle)  # (J, N, 2, 2)
            if elements:
                beta = orient[:, :E]
                Re = rot2(beta)  # (J, E, 2, 2)
        else:  # rotation vectors (Sec. 3.1: elements turning about several axes)
            R = expm(orient.reshape(J, e + N - 2, 3))
            Rn = np.empty((J, N, 3, 3))
            Rn[:, 0], Rn[:, 1], Rn[:, 2:] = _EYE, rz(theta), R[:, e:]
            if elements:
                Re = R[:, :E]
        return beta, Re, node_angle, Rn

    def axial_force(self, eob: EOB, q: np.ndarray) -> np.ndarray:
        """Axial force [N] (J, E) of every element of the EOBs' linear model, tension positive, at
        node displacements ``q`` (J, N nd) from the near poses (node A first; spins): the element
        forces ``F_all = K_all (L q - q_hat_all)`` (Eqs. 3.8-3.11) along each element's axis."""
        J, E, nd = len(q), self.n_elements, self.nd
        marker = eob.lever @ q[:, self.element_dofs].reshape(J, E, 2, nd, 1) - eob.q_hat.reshape(J, E, 2, nd, 1)
        local = np.swapaxes(eob.rotation, 2, 3)[:, :, None] @ marker  # element axes at rest (K0's)
        return np.einsum("eb,jeb->je", self._axial_row, local.reshape(J, E, 2 * nd))

    def _scatter(self, J: int):
        """Flat indices of J joints' element blocks in K_nodes (J, n, n) and F_nodes (J, n)."""
        try:
            return self._scatter_at[J]
        except KeyError:
            n = self.n_nodes * self.nd
            out = ((self._kidx[None, :] + (np.arange(J) * n * n)[:, None]).ravel(),
                   (self.element_dofs.ravel()[None, :] + (np.arange(J) * n)[:, None]).ravel())
            return self._scatter_at.setdefault(J, out)
