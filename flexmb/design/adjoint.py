"""Gradients of responses at a converged equilibrium: adjoint and direct sensitivities.

The equilibrium ``r_f(u_f, u_p, N) = 0`` on the free DOFs, with the prescribed DOFs
``u_p = g(N)`` and the model numbers ``N(p)``: for a response ``J(u, N)``

    dJ/dp = dJ/dN N' + dJ/du_p g' + dJ/du_f u_f',    K_ff u_f' = -(dr_f/dN N' + K_fp g') = -b.

*Adjoint* (one solve per response, any number of parameters): ``K_ff^T lam = (dJ/du_f)^T``, then
``dJ/dp = dJ/dN N' + dJ/du_p g' - lam^T b``. *Direct* (one solve per parameter, any number of
responses): ``u_f' = -K_ff^-1 b``. Both reuse one factorisation of the converged ``K_ff`` per
configuration (the solution's own linearisation, `flexmb.Solution.linearisation`); the tangent
is not symmetric (dead loads at offsets, dead moments in 3D, prescribed rotations), so the
adjoint solves with its transpose, never a symmetrised matrix. Rotation DOFs are increments: 2D angles, 3D spatial spins.
"""

from __future__ import annotations

import functools

import numpy as np

from .. import jit
from ..errors import ConvergenceError, ModelError, UnsupportedStrategyError
from ..linearisation import full_tangent
from ..rotations import expm_so3, skew
from .partials import contract, mass_blocks, mass_forms, residual_rates, tangent_blocks

__all__ = ["Sensitivity", "left_jacobian", "full_model", "DENSE_BELOW", "STRATEGIES"]

#: Model DOFs below which the full tangent's blocks and rows are read from a dense copy (`Sensitivity.block`).
DENSE_BELOW = 800

#: The strategies whose solutions are the full finite-element equilibrium (KSD-full converges to
#: the conventional equations from its KSD start, so it shares their gradient).
STRATEGIES = ("conventional", "ksd-full")


def full_model(solution) -> bool:
    """Whether ``solution`` is an equilibrium of the full finite-element model (its solution kind says
    so, `flexmb.Solution.full_equilibrium`, and its model has beam elements): what `Sensitivity`
    differentiates."""
    return bool(getattr(solution, "full_equilibrium", False)) and hasattr(solution.compiled.problem.model, "elements")


def left_jacobian(w: np.ndarray) -> np.ndarray:
    """SO(3)'s left Jacobian (3, 3) at rotation vector ``w``: ``d exp(w) = skew(J dw) exp(w)``
    (Chirikjian 2011, Vol. 2, Eq. 10.86): ``I + (1 - cos t)/t^2 W + (t - sin t)/t^3 W^2``."""
    w = np.asarray(w, dtype=float)
    t = float(np.sqrt(w @ w))
    W = skew(w)
    if t < 1e-6:  # series: 1/2 - t^2/24, 1/6 - t^2/120
        return np.eye(3) + (0.5 - t * t / 24.0) * W + (1.0 / 6.0 - t * t / 120.0) * W @ W
    return np.eye(3) + (1.0 - np.cos(t)) / t**2 * W + (t - np.sin(t)) / t**3 * W @ W


class Sensitivity:
    """A converged solution's linearisation with respect to the design: the full tangent, one
    factorisation of ``K_ff`` reused by every adjoint and direct solve, and the rates of the
    residual and of the prescribed DOFs with the parameters (`flexmb.design.parameters.ModelRates`).
    """

    def __init__(self, solution, rates):
        method = getattr(solution, "method", None)
        if not full_model(solution):
            kinds = ", ".join(f"{name!r} ({rates.kind(k)})" for k, name in enumerate(rates.names))
            raise UnsupportedStrategyError(
                f"design gradients with method {method!r} are not available for the parameters {kinds}: the "
                f"gradients differentiate the full finite-element equilibrium (methods {', '.join(STRATEGIES)}; "
                "'ksd-full' converges to it from the KSD start and shares its gradient)")
        if not solution.converged:
            raise ConvergenceError(f"design gradient of an unconverged solution ({solution.message})", solution)
        self.solution, self.rates = solution, rates
        self.problem = solution.compiled.problem
        self.model, self.state = self.problem.model, solution.state
        self.lam = float(solution.load_factor)
        self.names = rates.names
        self.free, self.prescribed = self.problem.free, self.problem.prescribed
        self._blocks = {}  # the tangents' and the mass's element blocks of dA/dp (tangent_forms, mass_forms)
        #: the residual rates' element rows (`flexmb.design.partials.residual_rates`' ``keep``): their
        #: directions, elements and complex deformations, stresses and lengths, read by the stress response
        self.element_rows = {}

    @functools.cached_property
    def K(self):
        """The full tangent (n_dofs, n_dofs), CSR (`flexmb.linearisation.full_tangent`, the one the
        solution's linearisation assembled)."""
        full = getattr(self.linearisation, "full", None)
        return (full if full is not None else full_tangent(self.solution)).tocsr()

    @functools.cached_property
    def _dense(self) -> np.ndarray | None:
        """The full tangent as a dense array for small models (`DENSE_BELOW`: blocks and rows are
        read from it faster than sliced from the CSR matrix), else None."""
        return self.K.toarray() if self.model.n_dofs < DENSE_BELOW else None

    def block(self, rows: np.ndarray, cols: np.ndarray):
        """The tangent's block ``K[rows][:, cols]``: dense for small models, else CSR."""
        if self._dense is not None:
            return self._dense[np.ix_(rows, cols)]
        return self.K[rows][:, cols]

    def row(self, dof: int) -> np.ndarray:
        """Row ``dof`` of the tangent, dense (n_dofs,)."""
        return self._dense[dof].copy() if self._dense is not None else self.K[[dof]].toarray()[0]

    @functools.cached_property
    def linearisation(self):
        """The solution's own linearisation (`flexmb.Solution.linearisation`, held: the prescribed
        DOFs): ``K_ff`` and one kept factorisation for every adjoint and direct solve."""
        lin = self.solution.linearisation("prescribed", owner="design gradients")
        if lin.Z is not None or not np.array_equal(lin.free, self.free):
            raise ModelError("design gradients: the solution's linearisation is not on the free DOFs of its problem")
        return lin

    def solve(self, rhs: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``K_ff^-1 rhs`` or ``K_ff^-T rhs`` (rhs (n_free,) or (n_free, m)) with the linearisation's
        kept factorisation (`flexmb.protocols.Linearisation.solve`)."""
        try:
            return self.linearisation.solve(np.asarray(rhs, dtype=float), transpose)
        except (np.linalg.LinAlgError, RuntimeError) as exc:
            raise ModelError("design gradient: the tangent on the free DOFs is singular (a critical equilibrium)") \
                from exc

    @functools.cached_property
    def residual_rates(self) -> np.ndarray:
        """``dr/dN N'`` (n_dofs, K) at the converged state held fixed."""
        return residual_rates(self.problem, self.state, self.rates, lam=self.lam, keep=self.element_rows)

    @functools.cached_property
    def prescribed_rates(self) -> np.ndarray:
        """``g'`` (n_p, K): the prescribed DOFs' motion per parameter (translations: the reference
        position's and the prescribed value's rates; 3D rotations: the spin of ``exp(lam w)``)."""
        m, lam = self.model, self.lam
        node, comp = np.divmod(self.prescribed, m.ndof)
        dvalues = self.rates.rate("values")  # (K, n_p)
        dx0 = self.rates.rate("x0")  # (K, N, dim)
        out = lam * dvalues.T.copy()
        tr = comp < m.dim
        out[tr] += dx0[:, node[tr], comp[tr]].T
        if m.dim == 3:  # the prescribed rotation vectors' totals from the undeformed state (the rates' own
            values = self.rates.compiled_numbers("values")  # compile: a warm-started problem holds increments)
            for i in np.flatnonzero(comp == 3):
                out[i:i + 3] = left_jacobian(lam * values[i:i + 3]) @ out[i:i + 3]
            self._chain_rates(out)
        return out

    def _chain_rates(self, out: np.ndarray) -> None:
        """The spins of prescribed chains of rotations ``R = exp(w_1) ... exp(w_k)`` (at load factor
        ``lam``: ``exp(lam w_i)``) into ``out``: ``sum_i P_(i-1) J_l(w_i) w_i'``, ``P_(i-1)`` the
        product of the rotations before ``w_i`` (``d exp(w) = skew(J_l(w) dw) exp(w)``)."""
        paths = self.rates.compiled.problem.rotation_paths  # a warm-started problem drops its chains
        if not paths:
            return
        dchain, at, lam = self.rates.rate("chains"), 0, self.lam
        for dofs, w in paths:
            w = np.asarray(w, dtype=float)
            dw = lam * dchain[:, at:at + w.size].reshape(-1, len(w), 3)  # (K, k, 3)
            at += w.size
            spin, P = np.zeros((len(self.names), 3)), np.eye(3)
            for i, wi in enumerate(w):
                spin += dw[:, i] @ (P @ left_jacobian(lam * wi)).T
                P = P @ expm_so3(lam * wi)
            out[np.searchsorted(self.prescribed, dofs)] = spin.T

    @functools.cached_property
    def _b(self) -> np.ndarray:
        """``b = dr_f/dN N' + K_fp g'`` (n_free, K)."""
        return self.residual_rates[self.free] + self.block(self.free, self.prescribed) @ self.prescribed_rates

    @functools.cached_property
    def state_rates(self) -> np.ndarray:
        """``du/dp`` (n_dofs, K) on all DOFs (direct method: one solve per parameter)."""
        du = np.zeros((self.model.n_dofs, len(self.names)))
        du[self.free] = -self.solve(self._b)
        du[self.prescribed] = self.prescribed_rates
        return du

    def tangent_forms(self, V: np.ndarray, W: np.ndarray | None = None, material: bool = False) -> np.ndarray:
        """``V^T (dK/dp_k) W`` (K, a, b): the tangent's total change with each parameter, along the
        model numbers' rates and the state's (`state_rates`), ``dK/dN N' + dK/du u'``
        (`flexmb.design.partials.tangent_blocks`, evaluated once per configuration and kept;
        ``material``: the material tangent's)."""
        key = "material" if material else "tangent"
        if key not in self._blocks:
            self._blocks[key] = tangent_blocks(self.problem, self.state, self.rates, self.state_rates, lam=self.lam,
                                               material=material)
        return contract(self._blocks[key], len(self.names), V, V if W is None else W)

    def mass_forms(self, V: np.ndarray, W: np.ndarray | None = None) -> np.ndarray:
        """``V^T (dM/dp_k) W`` (K, a, b): the consistent mass's total change with each parameter (the
        compiled kernels contract each row as they go, `flexmb.design.partials.mass_forms`; the numpy
        path keeps the blocks)."""
        if jit.enabled():
            return mass_forms(self.problem, self.state, self.rates, self.state_rates, V, V if W is None else W)
        if "mass" not in self._blocks:
            self._blocks["mass"] = mass_blocks(self.problem, self.state, self.rates, self.state_rates)
        return contract(self._blocks["mass"], len(self.names), V, V if W is None else W)

    def gradient(self, dJ_du: np.ndarray, dJ_dN: np.ndarray, method: str = "auto") -> np.ndarray:
        """``dJ/dp`` (K,) of a response with partials ``dJ/du`` (n_dofs,; rotations per spin) and
        ``dJ/dN N'`` (K,). ``method``: ``"adjoint"``, ``"direct"`` or ``"auto"`` (direct when the
        state's rates are already known, else adjoint)."""
        dJ_du = np.asarray(dJ_du, dtype=float)
        if method == "direct" or (method == "auto" and "state_rates" in self.__dict__):
            return dJ_dN + dJ_du @ self.state_rates
        lam_adj = self.solve(dJ_du[self.free], transpose=True)
        return dJ_dN + dJ_du[self.prescribed] @ self.prescribed_rates - lam_adj @ self._b
