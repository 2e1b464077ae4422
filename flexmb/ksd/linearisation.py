"""A KSD-reduced solution and its linearisation: the reduced mechanism's tangent and mass.

`ReducedSolution` is the `flexmb.Solution` KSD-reduced returns: its state is step 4's (the links
in the reduced mechanism's equilibrium, the joints' internal nodes from the EOBs to first order),
so it is not the full model's equilibrium and linearises on the reduced mechanism instead
(`ReducedLinearisation`, `flexmb.ksd.reduced_model`): the links' DOFs with KSD step 3's tangent and,
for vibration, each joint's `KSD_FIXED_INTERFACE_MODES` fixed-interface modal coordinates with its
mass condensed by its EOB's Craig-Bampton transformation. Its stresses take the joint elements'
axial forces from the EOBs (`flexmb.ksd.reduced_model.eob_axial_forces`).
"""

from __future__ import annotations

import attrs
import numpy as np

from ..errors import UnsupportedStrategyError
from ..linearisation import DenseFactor, LinearisationBase, converged_problem, held_and_free
from ..results import Solution
from . import reduced_model

__all__ = ["ReducedSolution", "ReducedLinearisation", "KSD_FIXED_INTERFACE_MODES"]

#: Fixed-interface modes per joint in a KSD-reduced solution's modal coordinates (with the joints'
#: Craig-Bampton constraint modes, `flexmb.ksd.reduced_model.reduced_modal_model`). Measured on the
#: manipulator at 30 deg, first three frequencies against the full model: 0 modes +5.0/+21/+24 %,
#: 1: +0.96/+0.06/-0.27 %, 2: -0.10/-0.24/-0.28 %, 6: -0.17/-0.25/-0.28 %, 10: -0.18/-0.26/-0.28 %
#: (at -45 deg 6: -0.39/-0.35/-0.55 %, 10: -0.41/-0.36/-0.57 %): 6 is converged (10 moves the first
#: three by at most 0.02 %); what is left is the EOB stiffness's (no stress stiffening).
#: Ties at the cut are kept whole (`flexmb.ksd.joint_mass.condensed_subspace`): the four-bar's
#: cross flexures keep 7.
KSD_FIXED_INTERFACE_MODES = 6

_NO_GEOMETRIC = ("KSD-reduced has no honest geometric stiffness of its joints' leaves: the EOBs are stress-free "
                 "and step 4's positions first-order (a cross flexure pushed along its axis, turned 20 deg: -23 % "
                 "from them)")


@attrs.frozen(eq=False)
class ReducedSolution(Solution):
    """A KSD-reduced `flexmb.Solution` (see the module notes): linearised on the reduced mechanism."""

    full_equilibrium = False
    full_equilibrium_note = "KSD-reduced's internal nodes are first-order only"

    def linearisation(self, held="prescribed", *, modal: bool = False, owner: str = "linearisation"):
        """The reduced mechanism's linearisation (`ReducedLinearisation`)."""
        return ReducedLinearisation(self, held, modal=modal, owner=owner)

    def _element_axial_forces(self):
        """The joint elements' axial forces from the EOBs when converged (step 4's positions give
        them 15x off on the four-bar at d = 0.3 m, its peak von Mises stress +2.8 %; the EOBs' +0.6 %)."""
        return reduced_model.eob_axial_forces(self) if self.converged else None


class ReducedLinearisation(LinearisationBase):
    """KSD-reduced's `flexmb.protocols.Linearisation`: dense, on the reduced mechanism.

    The generalised DOFs are the links' FE DOFs (n_links ndof, leading, as in the full model) and,
    with ``modal``, each joint's `KSD_FIXED_INTERFACE_MODES` fixed-interface modal coordinates
    (`flexmb.ksd.reduced_model.reduced_modal_model`); ``free`` the links' DOFs not held and every
    modal coordinate; ``Z`` None. Without ``modal`` ``K`` is step 3's tangent on the links
    (`flexmb.ksd.reduced_model.reduced_tangent`: the modal coordinates do not couple to the links'
    DOFs in it, so a static response is the same without them) and ``M`` the links' condensed
    mass. ``expand`` recovers the joints' interior nodes by the Craig-Bampton transformation.
    Hinges are refused (`UnsupportedStrategyError`: the reduced model has no hinge rows)."""

    dense = True

    def __init__(self, solution, held="prescribed", *, modal: bool = False, owner: str = "linearisation"):
        self.problem = problem = converged_problem(solution, owner)
        self.solution, self.compiled, self.state = solution, solution.compiled, solution.state
        self.model = model = problem.model
        self.owner = owner
        if model.hinges is not None:
            raise UnsupportedStrategyError(f"{owner} of a KSD-reduced solution with hinges are not available: solve "
                                           "with method='ksd-full' or 'conventional'")
        self.held, free = held_and_free(solution, held, owner)
        nl = len(solution.compiled.link_node) * model.ndof
        self._to_full = self._factor = None
        if modal:  # small and dense: no sparse bookkeeping (a third of a call)
            K, M, self._to_full = reduced_model.reduced_modal_model(solution, KSD_FIXED_INTERFACE_MODES)
            self.size = K.shape[0]
            self.free = np.concatenate([free[free < nl], np.arange(nl, self.size)])
            self._M = M.take(self.free, 0).take(self.free, 1)
        else:
            K = reduced_model.reduced_tangent(solution)[0]
            self.size = K.shape[0]
            self.free = free[free < self.size]
        self._K = K.take(self.free, 0).take(self.free, 1)

    def _mass(self) -> np.ndarray:
        """The links' condensed mass on the coordinates (`flexmb.ksd.reduced_model.reduced_mass`)."""
        return reduced_model.reduced_mass(self.solution).take(self.free, 0).take(self.free, 1)

    def material_tangent(self, base=None):
        """None to give: `UnsupportedStrategyError` (see the message)."""
        raise UnsupportedStrategyError(
            f"{self.owner}: the full FE equilibrium is needed: solve with method='ksd-full' (the conventional equilibrium, "
            f"from the KSD start) or 'conventional'. {_NO_GEOMETRIC}")

    def expand(self, v: np.ndarray) -> np.ndarray:
        """Generalised DOF vectors (size, k) on the full model's DOFs (n_dofs, k): the links' as
        they are, the joints' interiors by the Craig-Bampton transformation."""
        if self._to_full is None:
            self._to_full = reduced_model.reduced_modal_model(self.solution, 0)[2]
        return self._to_full(v)

    def solve(self, b: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``x`` with ``K x = b`` (``K^T x = b``), one `flexmb.linearisation.DenseFactor` kept."""
        if self._factor is None:
            self._factor = DenseFactor(self._K, ill_conditioned="raise")
        return self._factor.solve(b, transpose)
