"""The finite-element model of a whole mechanism: nodes, rigidly attached points, beam elements.

Independent nodes carry the unknowns (``dim`` positions and one (2D) or three (3D) rotations
each). Every element end sits on a *point*; a point is rigidly attached to a master node with
a fixed offset (zero for the node itself), which makes rigid links and connector blocks exact
constraints (master-slave), never stiff springs::

    x_point = x_master + R_master s,      R_point = R_master.
"""

from __future__ import annotations

import functools

import attrs
import numpy as np

from ..rotations import cross, expm_so3, logm_so3, rot2, skew
from . import beam2d, beam3d
from .. import jit
from .assembly import PartitionedPattern, scatter_add

__all__ = ["State", "BeamElements", "FEModel", "continued_spins"]


@attrs.frozen(eq=False)
class State:
    """Configuration of the independent nodes.

    ``positions`` [m] (N, dim); ``rotations``: (N,) angles [rad] in 2D, (N, 3, 3) matrices in 3D,
    both measured from the undeformed configuration.
    """

    positions: np.ndarray
    rotations: np.ndarray
    #: scaled Lagrange multipliers of the ideal joints' constraint rows (`flexmb.fe.ideal`), or None
    multipliers: np.ndarray | None = None
    #: 3D hinges' relative angles [rad] (H,), counted past a half turn along the increments that
    #: led here (a rotation matrix has no turn count; `FEModel.apply_increment`), or None (2D: the
    #: nodes' angles count turns themselves; a state built without increments: within one turn)
    hinge_angles: np.ndarray | None = None

    def copy(self) -> State:
        """An independent copy (every array copied)."""
        return State(*(None if a is None else a.copy()
                       for a in (self.positions, self.rotations, self.multipliers, self.hinge_angles)))


@attrs.frozen(eq=False)
class BeamElements:
    """A batch of beam elements between points.

    ``ends`` (E, 2) point indices; ``L0`` [m] (E,); ``S`` local stiffness (E, 6, 6) or (E, 3, 3);
    ``ny0`` (E, 3) undeformed local y axis (3D only); ``alpha0`` [rad] undeformed angle (2D only);
    ``sections`` one `Section` per element; ``owner`` the joint index of each element;
    ``stress_sections`` the sections where stresses are recovered (`flexmb.JointMesh`; None: ``sections``).
    """

    ends: np.ndarray
    L0: np.ndarray
    S: np.ndarray
    sections: tuple
    owner: np.ndarray
    ny0: np.ndarray | None = None
    nz0: np.ndarray | None = None
    alpha0: np.ndarray | None = None
    stress_sections: tuple | None = None


class FEModel:
    """Nodes, points and beam elements; evaluates internal forces and the consistent tangent."""

    def __init__(self, dim: int, x0: np.ndarray, point_master: np.ndarray, point_x0: np.ndarray,
                 elements: BeamElements, rigid_masses=None, hinges=None):
        self.dim = dim
        #: `flexmb.fe.mass.RigidMasses` of the links (None: the links carry no mass of their own)
        self.rigid_masses = rigid_masses
        self.ndof = 3 if dim == 2 else 6
        self.nrot = 1 if dim == 2 else 3
        self.x0 = np.asarray(x0, dtype=float)
        self.n_nodes = len(self.x0)
        #: `flexmb.fe.ideal.Hinges` between link nodes, or None; their multipliers are the last DOFs
        self.hinges = hinges if hinges is not None and len(hinges.node) else None
        self.n_node_dofs = self.n_nodes * self.ndof
        self.n_dofs = self.n_node_dofs + (self.hinges.n_rows if self.hinges is not None else 0)
        self.point_master = np.asarray(point_master, dtype=np.int64)
        self.point_x0 = np.asarray(point_x0, dtype=float)
        self.point_offset = self.point_x0 - self.x0[self.point_master]
        self.elements = elements
        ends_master = self.point_master[elements.ends]  # (E, 2)
        k = np.arange(self.ndof)
        self.element_dofs = (ends_master[:, :, None] * self.ndof + k).reshape(len(elements.L0), 2 * self.ndof)
        self.node_dofs = np.arange(self.n_node_dofs).reshape(self.n_nodes, self.ndof)
        self.hinge_dofs = None if self.hinges is None else self.hinges.dofs(self.node_dofs, self.n_node_dofs)

    # -- configuration -------------------------------------------------------------------
    def initial_state(self) -> State:
        """The undeformed configuration: reference positions [m], zero rotations."""
        rot = np.zeros(self.n_nodes) if self.dim == 2 else np.tile(np.eye(3), (self.n_nodes, 1, 1))
        if self.hinges is None:
            return State(self.x0.copy(), rot)
        return State(self.x0.copy(), rot, np.zeros(self.hinges.n_rows),
                     None if self.dim == 2 else np.zeros(len(self.hinges.node)))

    def rotation_matrices(self, state: State) -> np.ndarray:
        """Nodal rotation matrices (N, 2, 2) in 2D or (N, 3, 3) in 3D."""
        return rot2(state.rotations) if self.dim == 2 else state.rotations

    def offsets(self, state: State, master: np.ndarray, offset0: np.ndarray) -> np.ndarray:
        """Current offsets ``R_master s`` [m] of points attached to ``master`` with undeformed offset ``s``."""
        return np.einsum("kij,kj->ki", self.rotation_matrices(state)[master], offset0)

    def point_positions(self, state: State) -> np.ndarray:
        """Current positions of all points [m], shape (P, dim)."""
        return state.positions[self.point_master] + self.offsets(state, self.point_master, self.point_offset)

    def largest_stretch(self, frm: State, to: State) -> float:
        """The largest change of an element's chord length from ``frm`` to ``to`` over its
        undeformed length: what a linear predictor's straight-line motion of turning elements
        adds to them (a chord turned by theta gains theta^2 / 2)."""
        if not len(self.elements.L0):
            return 0.0
        ends = self.elements.ends
        a, b = self.point_positions(frm)[ends], self.point_positions(to)[ends]  # (E, 2, dim)
        change = np.linalg.norm(b[:, 1] - b[:, 0], axis=1) - np.linalg.norm(a[:, 1] - a[:, 0], axis=1)
        return float(np.max(np.abs(change) / self.elements.L0))

    def node_part(self, du: np.ndarray) -> np.ndarray:
        """The nodes' rows (N, ndof) of a vector on all DOFs (the hinges' multipliers, last, left out)."""
        return np.asarray(du)[: self.n_node_dofs].reshape(self.n_nodes, self.ndof)

    def multiplier_change(self, frm: State, to: State) -> np.ndarray:
        """The multipliers' part of the increment from ``frm`` to ``to`` (empty without hinges)."""
        if self.hinges is None:
            return np.zeros(0)
        zero = np.zeros(self.hinges.n_rows)
        return (zero if to.multipliers is None else to.multipliers) - (zero if frm.multipliers is None
                                                                         else frm.multipliers)

    @property
    def force_dofs(self) -> np.ndarray:
        """Which DOFs (n_dofs,) are translations, whose residuals are forces (True), rather than
        rotations (moments); a hinge's position rows are forces, its axis and motor rows moments."""
        node = np.tile(np.arange(self.ndof) < self.dim, self.n_nodes)
        if self.hinges is None:
            return node
        return np.concatenate([node, np.nonzero(self.hinges.active)[1] < self.dim])

    def increment(self, frm: State, to: State) -> np.ndarray:
        """The increment ``du`` (n_dofs,) with ``apply_increment(frm, du) == to``: translations
        subtract, rotations as spatial spins ``log(R_to R_frm^T)`` (3D, Eq. A.8) or angles (2D),
        the hinges' multipliers subtract."""
        du = np.empty((self.n_nodes, self.ndof))
        du[:, : self.dim] = to.positions - frm.positions
        if self.dim == 2:
            du[:, 2] = to.rotations - frm.rotations
        elif jit.enabled():
            from . import model_jit

            spin = np.empty((self.n_nodes, 3))
            model_jit.spin3d(np.ascontiguousarray(to.rotations, dtype=float),
                             np.ascontiguousarray(frm.rotations, dtype=float), spin)
            du[:, 3:] = spin
        else:
            du[:, 3:] = logm_so3(to.rotations @ frm.rotations.transpose(0, 2, 1))
        if self.hinges is None:
            return du.ravel()
        return np.concatenate([du.ravel(), self.multiplier_change(frm, to)])

    def extrapolated_increment(self, path: list, target: float, rate: np.ndarray | None = None) -> np.ndarray:
        """The increment (n_dofs,) from the last state of ``path`` [(load factor, State), ...] to
        the Lagrange polynomial through all of them (degree len - 1) at load factor ``target``:
        positions in R^n, rotations as spins about the last state (3D: on SO(3), each spin
        continued from its neighbour's along the path, `continued_spins`, so a path that turns a
        node beyond pi is not wrapped), the hinges' multipliers in R^n. With ``rate`` (n_dofs,),
        the path's derivative in the load factor at the last state (the same coordinates), the
        polynomial one degree higher that also has that slope there (Hermite). The
        continuation's predictor (`flexmb.solvers.conventional.newton_steps`)."""
        lams = np.array([lam for lam, _ in path])
        last = path[-1][1]
        du = np.zeros(self.n_dofs)
        near = np.zeros((self.n_nodes, 3))
        lam_n = lams[-1]
        # p(t) = sum_i l_i(t) d_i + w(t) / w'(lam_n) (rate - sum_i l_i'(lam_n) d_i), w(t) = prod_j (t - lam_j)
        hermite = 0.0 if rate is None else np.prod(target - lams) / np.prod(lam_n - lams[:-1])
        for i in range(len(path) - 2, -1, -1):  # from the last state back
            lam_i, s_i = path[i]
            others = np.delete(lams, i)
            weight = np.prod((target - others) / (lam_i - others))
            if rate is not None:  # l_i'(lam_n): the factor (t - lam_n) differentiated
                weight -= hermite * np.prod(lam_n - others[:-1]) / np.prod(lam_i - others)
            d = self.increment(last, s_i)
            if self.dim == 3:
                nodes = d[:self.n_node_dofs].reshape(self.n_nodes, self.ndof)  # a view: hinge multipliers last
                nodes[:, 3:] = near = continued_spins(nodes[:, 3:], near)
            du += weight * d
        if rate is not None:
            du += hermite * rate
        return du

    def apply_increment(self, state: State, du: np.ndarray) -> State:
        """New state after increments ``du`` (n_dofs,): positions add, rotations compose (Eq. A.8),
        the hinges' multipliers (the last DOFs) add; a 3D hinge's relative angle moves by the
        increment's spin about its axis, to the turn of the new rotations nearest to that
        (`flexmb.fe.ideal.Hinges.advance`: a spring turned past pi keeps its turn count)."""
        du = np.asarray(du)
        mult = state.multipliers
        if self.hinges is not None:
            du = du.ravel()
            mult = (np.zeros(self.hinges.n_rows) if mult is None else mult) + du[self.n_node_dofs:]
            du = du[:self.n_node_dofs]
        du = du.reshape(self.n_nodes, self.ndof)
        pos = state.positions + du[:, : self.dim]
        if self.dim == 2:
            return State(pos, state.rotations + du[:, 2], mult)
        if jit.enabled():  # the same formula compiled (tests/test_kernels.py: equal to 1e-14)
            from . import model_jit

            rot = np.empty((self.n_nodes, 3, 3))
            model_jit.compose3d(np.ascontiguousarray(state.rotations, dtype=float),
                                np.ascontiguousarray(du[:, 3:6], dtype=float), rot)
        else:
            rot = expm_so3(du[:, 3:6]) @ state.rotations
        if self.hinges is None:
            return State(pos, rot, mult)
        return State(pos, rot, mult, self.hinges.advance(state.rotations, state.hinge_angles, du[:, 3:6], rot))

    # -- forces ----------------------------------------------------------------------------
    def transfer(self, wrench: np.ndarray, d: np.ndarray):
        """Move point wrenches (K, ndof) to their masters through current offsets ``d`` (K, dim).

        Returns the master wrench ``[f, m + d x f]`` and the offset's geometric stiffness block
        ``d(d x f)/dphi`` on the master rotation: ``d f^T - (d.f) I`` in 3D, ``-(d.f)`` in 2D.
        """
        f = wrench[:, : self.dim]
        out = wrench.copy()
        dot = np.einsum("ki,ki->k", d, f)
        if self.dim == 2:
            out[:, 2] += d[:, 0] * f[:, 1] - d[:, 1] * f[:, 0]
            return out, -dot[:, None, None]
        out[:, 3:6] += cross(d, f)
        return out, d[:, :, None] * f[:, None, :] - dot[:, None, None] * np.eye(3)

    def _lever(self, d: np.ndarray) -> np.ndarray:
        """Blocks T (K, ndof, ndof) with ``dq_point = T dq_master`` for rigid offsets ``d``."""
        T = np.tile(np.eye(self.ndof), (len(d), 1, 1))
        if self.dim == 2:
            T[:, 0, 2], T[:, 1, 2] = -d[:, 1], d[:, 0]
        else:
            T[:, 0:3, 3:6] = -skew(d)
        return T

    def element_response(self, state: State, tangent: bool = True, geometric_stress=None):
        """Element forces and tangents in master-node DOFs.

        Returns ``F`` (E, 2 ndof), ``K`` (E, 2 ndof, 2 ndof) or None, deformations ``e`` and
        generalised stresses ``sigma`` of every element. ``geometric_stress``: a function of
        ``sigma`` returning the stresses of the beams' geometric stiffness, if not their own.
        """
        el = self.elements
        if len(el.L0) == 0:  # links joined by ideal joints only
            n2, nm = 2 * self.ndof, el.S.shape[-1] if el.S.ndim == 3 else 3 * self.nrot
            return np.zeros((0, n2)), (np.zeros((0, n2, n2)) if tangent else None), np.zeros((0, nm)), np.zeros((0, nm))
        m = self.point_master[el.ends]  # (E, 2)
        d = self.offsets(state, m.ravel(), self.point_offset[el.ends].ravel().reshape(-1, self.dim))
        x = state.positions[m.ravel()] + d
        x = x.reshape(-1, 2, self.dim)
        if self.dim == 2:
            th = state.rotations[m]
            F, K, e, sig = beam2d.internal_force_and_tangent(
                x[:, 0], x[:, 1], th[:, 0], th[:, 1], el.alpha0, el.L0, el.S, tangent=tangent,
                geometric_stress=geometric_stress)
        else:
            R = state.rotations[m]
            F, K, e, sig = beam3d.internal_force_and_tangent(
                x[:, 0], x[:, 1], R[:, 0], R[:, 1], el.ny0, el.nz0, el.L0, el.S, tangent=tangent,
                geometric_stress=geometric_stress)
        nE, nd, nr = len(el.L0), self.ndof, self.nrot
        Fm, G = self.transfer(F.reshape(2 * nE, nd), d)
        Fm = Fm.reshape(nE, 2 * nd)
        if not tangent:
            return Fm, None, e, sig
        Tb = self._lever(d).reshape(nE, 2, nd, nd)
        T = np.zeros((nE, 2 * nd, 2 * nd))
        T[:, :nd, :nd], T[:, nd:, nd:] = Tb[:, 0], Tb[:, 1]
        K = np.swapaxes(T, 1, 2) @ K @ T
        G = G.reshape(nE, 2, nr, nr)
        K[:, self.dim:nd, self.dim:nd] += G[:, 0]
        K[:, nd + self.dim:, nd + self.dim:] += G[:, 1]
        return Fm, K, e, sig

    @functools.cached_property
    def _ends(self):
        """The elements' end masters (E, 2), undeformed offsets (E, 2, dim) and which are non-zero."""
        el = self.elements
        offset = np.ascontiguousarray(self.point_offset[el.ends], dtype=float)
        return (np.ascontiguousarray(self.point_master[el.ends], dtype=np.int64), offset,
                np.ascontiguousarray(np.any(offset != 0.0, axis=2)))

    def largest_motion(self, du: np.ndarray) -> tuple[float, float]:
        """The largest nodal translation [m] and rotation [rad] (Euclidean norms per node) of an
        increment on all DOFs (the hinges' multipliers, last, left out)."""
        if jit.enabled():
            from . import model_jit

            out = np.empty(2)
            model_jit.largest_motion(np.ascontiguousarray(du, dtype=float), self.n_nodes, self.ndof, self.dim, out)
            return float(out[0]), float(out[1])
        d = self.node_part(du)
        if not len(d):
            return 0.0, 0.0
        return (float(np.sqrt(np.max(np.sum(d[:, : self.dim] ** 2, axis=1)))),
                float(np.sqrt(np.max(np.sum(d[:, self.dim:] ** 2, axis=1)))))

    def largest_by_kind(self, v: np.ndarray) -> tuple[float, float]:
        """The largest magnitude of the translation and of the rotation entries of ``v`` (rows of
        ``ndof``: element end forces (E, 2 ndof), or node vectors): forces [N] and moments [N m]."""
        v = np.ravel(v)
        if jit.enabled():
            from . import model_jit

            out = np.empty(2)
            model_jit.largest_by_kind(np.ascontiguousarray(v, dtype=float), self.ndof, self.dim, out)
            return float(out[0]), float(out[1])
        a = np.abs(v).reshape(-1, self.ndof).max(axis=0, initial=0.0)
        return float(a[: self.dim].max()), float(a[self.dim:].max())

    @functools.cached_property
    def _element_data(self):
        """The element arrays the numba kernels take, contiguous: 3D ``ny0, nz0, L0, S``; 2D
        ``alpha0, L0, S``."""
        el = self.elements
        data = (el.ny0, el.nz0) if self.dim == 3 else (el.alpha0,)
        return tuple(np.ascontiguousarray(a, dtype=float) for a in data + (el.L0, el.S))

    def assemble(self, state: State, pattern: PartitionedPattern | None = None, geometric_stress=None):
        """The elements' internal forces summed on all DOFs and, given the ``pattern`` of the tangent
        (`flexmb.fe.assembly.PartitionedPattern`, whose first entries are the elements' blocks in
        the layout of `element_response`), their tangents summed into its two CSR data arrays.

        Returns ``(f, data_ff, data_fp, F, e, sigma, largest)``: ``f`` (n_dofs,), the data arrays
        (None without ``pattern``), ``F`` (E, 2 ndof) master end forces, deformations, stresses and
        `largest_by_kind` of ``F``. ``geometric_stress``: the stresses (E, modes) of the geometric
        stiffness, or a function of the elements' own returning them (None: their own). One
        numba pass (`flexmb.fe.model_jit`) when `flexmb.jit.enabled`, else `element_response`
        and ``np.bincount``: equal to 1e-12 (tests/test_kernels.py)."""
        el = self.elements
        nE, n2 = len(el.L0), 2 * self.ndof
        tangent = pattern is not None
        if nE == 0 or not jit.enabled():
            held = geometric_stress
            if geometric_stress is not None and not callable(geometric_stress):
                held = lambda _: np.asarray(geometric_stress, dtype=float)  # noqa: E731
            F, K, e, sig = self.element_response(state, tangent=tangent, geometric_stress=held)
            f = scatter_add(self.element_dofs, F, self.n_dofs)
            data = pattern.split(K) if tangent else (None, None)
            return (f,) + data + (F, e, sig, self.largest_by_kind(F))
        from . import model_jit  # imports numba: on first use, not with flexmb

        master, offset, moved = self._ends
        nm = el.S.shape[-1]
        given = tangent and geometric_stress is not None
        sg = np.zeros((1, nm))
        if given:
            sg = geometric_stress(self.stresses(state)[1]) if callable(geometric_stress) else geometric_stress
            sg = np.ascontiguousarray(sg, dtype=float)
        f = np.zeros(self.n_dofs)
        data = (np.zeros(pattern.nnz[0]), np.zeros(pattern.nnz[1])) if tangent else (np.zeros(0), np.zeros(0))
        slots = pattern.slots[:nE * n2 * n2].reshape(nE, n2 * n2) if tangent else np.zeros((1, 1), dtype=np.int64)
        F, e, sig, largest = np.empty((nE, n2)), np.empty((nE, nm)), np.empty((nE, nm)), np.empty(2)
        kernel = model_jit.assemble3d if self.dim == 3 else model_jit.assemble2d
        kernel(np.ascontiguousarray(state.positions, dtype=float), np.ascontiguousarray(state.rotations, dtype=float),
               master, offset, moved, *self._element_data, tangent, given, sg,
               self.element_dofs, slots, f, *data, F, e, sig, largest)
        return (f,) + (data if tangent else (None, None)) + (F, e, sig, (float(largest[0]), float(largest[1])))

    def stresses(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """The elements' deformations ``e`` and generalised stresses ``sigma = S e`` (E, modes) in
        ``state`` (`assemble` without a tangent: compiled when `flexmb.jit.enabled`)."""
        return self.assemble(state)[4:6]

    def hinge_response(self, state: State, motor: float = 1.0, tangent: bool = True, material: bool = False):
        """The hinges' block forces and tangents on `hinge_dofs` (`flexmb.fe.ideal.Hinges.response`);
        ``motor``: the fraction of the hinges' motor angles reached."""
        mult = np.zeros(self.hinges.n_rows) if state.multipliers is None else state.multipliers
        return self.hinges.response(state.positions, state.rotations, mult, motor, tangent=tangent, material=material,
                                    angles=state.hinge_angles)

    def internal_force(self, state: State, motor: float = 1.0) -> np.ndarray:
        """Assembled internal force vector (n_dofs,): the elements', and the hinges' (their
        constraint forces and springs on the link rows, their scaled constraint values on the
        multiplier rows; ``motor``: the fraction of the motor angles reached)."""
        f = self.assemble(state)[0]
        if self.hinges is not None:
            f = f + scatter_add(self.hinge_dofs, self.hinge_response(state, motor, tangent=False)[0], self.n_dofs)
        return f

    def strain_energy(self, state: State) -> float:
        """Total strain energy [J], ``sum 1/2 e^T S e`` and the hinges' springs ``k theta^2 / 2``."""
        e, sig = self.stresses(state)
        energy = 0.5 * float(np.sum(e * sig))
        if self.hinges is not None:
            energy += 0.5 * float(np.sum(self.hinges.k * self.hinges.relative_angle(state.rotations, state.hinge_angles) ** 2))
        return energy


def continued_spins(spin: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The rotation vectors ``spin + 2 pi k spin / |spin|`` (k = -1, 0, 1) nearest to ``near``
    (N, 3): the same rotations, continued along a path instead of wrapped to angles in [0, pi]."""
    angle = np.linalg.norm(spin, axis=1, keepdims=True)
    axis = np.divide(spin, angle, out=np.zeros_like(spin), where=angle > 0.0)
    cands = spin[None] + (2.0 * np.pi * np.array([-1.0, 0.0, 1.0]))[:, None, None] * axis[None]
    best = np.argmin(np.sum((cands - near[None]) ** 2, axis=2), axis=0)
    return cands[best, np.arange(len(spin))]
