"""The kinetostatic problem of rigid links joined by constant-stiffness flexures (planar).

Cammarata et al. (2022), Eqs. (18)-(25): per link ``R_i = -w_i + sum of flexure wrenches``
with three coordinates ``q_i = [x_i, y_i, theta_i]`` per link; the global residual is
``R(w, q)`` (Eq. 25) and its tangent ``K_T = K^I + K^II + K^III`` (Eq. 26), plus the load
stiffness of dead forces applied away from a link's reference point (zero for loads at the
reference points, as in the paper).
"""

from __future__ import annotations

import copy

import numpy as np

from .. import jit
from ..fe.model import State
from ..problem import BoundaryConditions, PointLoads
from .flexures import FlexureSet, rot

__all__ = ["LinkageModel", "LinkageProblem", "TERMS"]

#: Names of the tangent terms returned by `LinkageProblem.tangent_terms`.
TERMS = ("I", "II", "III", "load")


class LinkageModel:
    """Links (the nodes: 3 DOFs each) and the flexures between them; the `Solution` accessors'
    view of the closed-form model (the same interface as `flexmb.fe.model.FEModel`)."""

    dim = 2
    ndof = 3
    nrot = 1

    def __init__(self, x0: np.ndarray, flexures: FlexureSet):
        self.x0 = np.asarray(x0, dtype=float)
        self.n_nodes = len(self.x0)
        self.n_dofs = 3 * self.n_nodes
        self.node_dofs = np.arange(self.n_dofs).reshape(self.n_nodes, 3)
        self.flexures = flexures

    def initial_state(self) -> State:
        """The undeformed configuration: reference positions [m] of the links, zero rotations."""
        return State(self.x0.copy(), np.zeros(self.n_nodes))

    def offsets(self, state: State, master: np.ndarray, offset0: np.ndarray) -> np.ndarray:
        """Current offsets ``A_i s`` [m] of points attached to links ``master``."""
        return np.einsum("kij,kj->ki", rot(state.rotations[master]), offset0)

    def point_positions(self, state: State) -> np.ndarray:
        """Link reference points, then each flexure's two attachment points (first, end) [m]."""
        fl = self.flexures
        ends = np.stack([state.positions[fl.i] + self.offsets(state, fl.i, fl.s_i),
                         state.positions[fl.j] + self.offsets(state, fl.j, fl.s_j)], 1).reshape(-1, 2)
        return np.concatenate([state.positions, ends])

    def apply_increment(self, state: State, du: np.ndarray) -> State:
        """New state after link increments ``du`` (3 per link: x, y [m], theta [rad]; planar, so they add)."""
        du = du.reshape(self.n_nodes, 3)
        return State(state.positions + du[:, :2], state.rotations + du[:, 2])

    def strain_energy(self, state: State) -> float:
        """``sum 1/2 psi^T K_f psi`` [J] (the flexures' linear stiffness, Eq. 1)."""
        return self.flexures.strain_energy(state.positions, state.rotations)


class LinkageProblem(BoundaryConditions):
    """Residual and tangent terms of a closed-form linkage under dead loads and prescribed DOFs.

    ``prescribed`` global DOF indices and their ``values`` (displacements [m], rotations [rad]
    from the undeformed configuration; fixed links have zeros); ``loads`` dead point loads.
    """

    def __init__(self, model: LinkageModel, prescribed: np.ndarray, values: np.ndarray, loads: PointLoads):
        self.model = model
        super().__init__(model.n_dofs, prescribed, values)
        n = model.n_dofs
        fl = model.flexures
        dofs = np.concatenate([model.node_dofs[fl.i], model.node_dofs[fl.j]], axis=1)  # (F, 6)
        rows = np.stack([model.node_dofs[fl.i], model.node_dofs[fl.j]], 1)  # (F, 2, 3)
        self._rows = rows
        flat = rows[:, :, :, None] * n + dofs[:, None, None, :]  # (F, 2, 3, 6) -> n x n
        self._flat = (flat[None] + n * n * np.arange(3)[:, None, None, None, None]).ravel()  # three terms
        self.set_loads(loads)

    def set_loads(self, loads: PointLoads) -> None:
        """Replace the dead loads (a sweep varies them) and the DOF maps that scatter them."""
        self.loads = loads
        nd = self.model.node_dofs
        self._load_dofs = nd[loads.node].ravel()
        self._load_flat = nd[loads.node, 2] * (self.model.n_dofs + 1)  # (theta, theta) entries
        self._load_offset = loads.offset[:, 0] + 1j * loads.offset[:, 1]
        self._load_force = loads.force[:, 0] + 1j * loads.force[:, 1]
        self._jit_loads = (np.ascontiguousarray(loads.node, dtype=np.int64), np.ascontiguousarray(self._load_offset),
                           np.ascontiguousarray(self._load_force), np.ascontiguousarray(loads.moment[:, 0], dtype=float))

    def compiled_arrays(self) -> tuple:
        """Flexure and load constants in the argument order of `flexmb.closed_form.linkage_jit`."""
        return self.model.flexures.compiled_arrays() + self._jit_loads

    def with_loads(self, loads: PointLoads, start: PointLoads | None = None) -> LinkageProblem:
        """A copy of this problem under other loads (patterns shared). ``start`` is accepted for the
        interface of `flexmb.problem.StaticProblem.with_loads` and not needed: the closed-form
        residual always carries the whole load (no load factor)."""
        out = copy.copy(self)
        out.set_loads(loads)
        return out

    def with_motion(self, values: np.ndarray, start: State | None = None) -> LinkageProblem:
        """A copy with other prescribed ``values``; ``start`` is accepted for the interface of
        `flexmb.problem.StaticProblem.with_motion` and not needed (`prescribed_state` sets them)."""
        out = copy.copy(self)
        out.values = np.asarray(values, dtype=float)
        return out

    def prescribed_state(self, state: State) -> State:
        """``state`` with the prescribed DOFs set to their values."""
        q = np.concatenate([state.positions - self.model.x0, state.rotations[:, None]], axis=1).ravel()
        q[self.prescribed] = self.values
        q = q.reshape(-1, 3)
        return State(self.model.x0 + q[:, :2], q[:, 2].copy())

    def _external(self, state: State):
        """Load vector and ``(A s).F`` per load (the load stiffness on its link's angle)."""
        ld = self.loads
        dF = np.exp(-1j * state.rotations[ld.node]) * self._load_offset.conj() * self._load_force  # conj(d) F
        w = np.concatenate([ld.force, ld.moment[:, :1] + dF.imag[:, None]], axis=1)
        return np.bincount(self._load_dofs, w.ravel(), minlength=self.model.n_dofs), dF.real

    def external_load(self, state: State, lam: float = 1.0) -> np.ndarray:
        """Assembled applied loads on all DOFs (forces, moments about the link reference points).
        The closed-form residual always carries the whole load, so ``lam`` is not used."""
        return self._external(state)[0]

    def evaluate(self, state: State, tangent: bool = True):
        """Residual ``R`` (n_dofs,) on all DOFs (Eq. 25; the reactions on prescribed DOFs) and, if
        asked, the tangent terms as a dict of dense (n_dofs, n_dofs) arrays keyed by `TERMS`."""
        m, n = self.model, self.model.n_dofs
        if jit.enabled():
            from . import linkage_jit

            r, T = np.empty(n), np.empty((4, n, n) if tangent else (1, 1, 1))
            linkage_jit.evaluate(np.ascontiguousarray(state.positions, dtype=float),
                                 np.ascontiguousarray(state.rotations, dtype=float), *self.compiled_arrays(),
                                 tangent, r, T)
            return r, (dict(zip(TERMS, T)) if tangent else None)
        resp = m.flexures.evaluate(state.positions, state.rotations, tangent=tangent)
        f_ext, dF = self._external(state)
        r = np.bincount(self._rows.ravel(), resp.wrench.ravel(), minlength=n) - f_ext
        if not tangent:
            return r, None
        K = np.bincount(self._flat, resp.terms.ravel(), minlength=3 * n * n).reshape(3, n, n)
        terms = dict(zip(TERMS, K))
        # d(-(A s) x F)/dtheta = (A s).F
        terms["load"] = np.bincount(self._load_flat, dF, minlength=n * n).reshape(n, n)
        return r, terms
