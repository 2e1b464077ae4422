"""Design gradients of a KSD-reduced solution with respect to loads.

KSD-reduced (Dwarshuis et al. 2020, steps 1-4) solves the reduced mechanism's equilibrium
``r(q, loads) = 0`` on the links' DOFs with each joint's condensed EOB stiffness about its near
configuration (steps 1-2: kinematics and database, which do not read the loads). A load parameter
moves only ``r``'s applied-load part, so ``dq/dp = -K_red^-1 dr/dp`` with the reduced tangent
(`flexmb.ksd.reduced_model.reduced_tangent`: the exact Jacobian of step 3's residual, dead loads'
stiffness included) and the loads' rates. Parameters that change a joint, a placement, a mass or a
prescribed motion also change steps 1-2 (the joint's database entry, its frame, its near
configuration): refused by name (`flexmb.UnsupportedStrategyError`), as are the responses of the
linearisation and the stresses (their KSD-reduced values come from the EOBs' condensed models).
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.linalg as sla

from ..errors import ConvergenceError, ModelError, UnsupportedStrategyError
from ..ksd.reduced_model import reduced_tangent
from .partials import residual_rates

__all__ = ["ReducedSensitivity", "RESPONSES"]

#: The responses a KSD-reduced gradient serves: those read from the links' DOFs.
RESPONSES = ("_Reaction", "_Position", "_Rotation", "_Mass")


class ReducedSensitivity:
    """`flexmb.design.adjoint.Sensitivity`'s interface for a converged KSD-reduced solution and load
    parameters: vectors over the full model's DOFs, nonzero on the links' DOFs only."""

    def __init__(self, solution, rates):
        if not solution.converged:
            raise ConvergenceError(f"design gradient of an unconverged solution ({solution.message})", solution)
        bad = [(name, rates.kind(k)) for k, name in enumerate(rates.names) if rates.kind(k) != "load"]
        if bad:
            listed = ", ".join(f"{name!r} ({kind})" for name, kind in bad)
            raise UnsupportedStrategyError(
                f"design gradients with KSD-reduced (method {solution.method!r}) are available with respect to loads only; "
                "the parameters "
                f"{listed} change the joints' database entries, frames or near configurations (KSD steps 1-2): solve "
                "with method='ksd-full' (the full equilibrium from the KSD start, with every parameter's gradient)")
        self.solution, self.rates = solution, rates
        self.problem = solution.compiled.problem
        self.model, self.state = self.problem.model, solution.state
        self.lam = 1.0
        self.names = rates.names
        K_links, _ = reduced_tangent(solution)
        self._K_links = K_links
        n = K_links.shape[0]  # the links' DOFs lead the full model's (link k's: k ndof ...)
        self.links = np.arange(n)
        pres = self.problem.prescribed
        self.prescribed = pres[pres < n]
        self.free = np.setdiff1d(self.links, self.prescribed)

    def check_response(self, response) -> None:
        """Refuse a response whose KSD-reduced value is not a function of the links' DOFs alone."""
        if type(response).__name__ not in RESPONSES:
            method = self.solution.method
            raise UnsupportedStrategyError(
                f"{response.name} cannot be differentiated with KSD-reduced (method {method!r}: its value comes from the "
                "joints' condensed EOB models, which the design parameters' gradient does not follow): solve with "
                "method='ksd-full'; with KSD-reduced: reactions, displacements, positions, rotations and the mass")

    def row(self, dof: int) -> np.ndarray:
        """Row ``dof`` of the reduced tangent on the full model's DOFs (zero outside the links')."""
        out = np.zeros(self.model.n_dofs)
        if dof < len(self.links):
            out[self.links] = self._K_links[dof]
        return out

    @functools.cached_property
    def residual_rates(self) -> np.ndarray:
        """``dr/dp`` (n_dofs, K): the applied loads' part at the solution's link poses."""
        out = residual_rates(self.problem, self.state, self.rates, lam=1.0)
        out[len(self.links):] = 0.0
        return out

    @functools.cached_property
    def prescribed_rates(self) -> np.ndarray:
        """``g'``: zero (a load moves no prescribed DOF)."""
        return np.zeros((len(self.prescribed), len(self.names)))

    @functools.cached_property
    def _lu(self):
        K_ff = self._K_links[np.ix_(self.free, self.free)]
        lu = sla.lu_factor(K_ff)
        if np.any(np.diag(lu[0]) == 0.0):
            raise ModelError("design gradient: the reduced tangent on the free DOFs is singular")
        return lu

    def solve(self, rhs: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``K_red,ff^-1 rhs`` (or its transpose's) on the free link DOFs, one LU kept."""
        return sla.lu_solve(self._lu, rhs, trans=1 if transpose else 0)

    @functools.cached_property
    def state_rates(self) -> np.ndarray:
        """``du/dp`` (n_dofs, K): the links' free DOFs' motion per load parameter (direct method)."""
        du = np.zeros((self.model.n_dofs, len(self.names)))
        du[self.free] = -self.solve(self.residual_rates[self.free])
        return du

    def gradient(self, dJ_du: np.ndarray, dJ_dN: np.ndarray, method: str = "auto") -> np.ndarray:
        """``dJ/dp`` (K,) from a response's partials, adjoint or direct (`Sensitivity.gradient`);
        a response reading the joints' internal nodes is refused."""
        dJ_du = np.asarray(dJ_du, dtype=float)
        if np.any(dJ_du[len(self.links):] != 0.0):
            raise UnsupportedStrategyError("this response reads the joints' internal nodes, which KSD-reduced recovers "
                                           "from the EOBs (step 4): not differentiable with KSD-reduced")
        if method == "direct" or (method == "auto" and "state_rates" in self.__dict__):
            return dJ_dN + dJ_du @ self.state_rates
        lam_adj = self.solve(dJ_du[self.free], transpose=True)
        return dJ_dN - lam_adj @ self.residual_rates[self.free]
