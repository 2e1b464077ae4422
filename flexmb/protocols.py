"""The contracts flexmb's parts keep with each other, written down as `typing.Protocol`s.

Nothing here is a base class to inherit: flexmb's own classes satisfy these by shape (duck
typing, as they did before this module existed), and so may a third party's. Each protocol
lists what a caller may rely on; ``runtime_checkable`` ones let a test (and a registry) check
that an object has the attributes, not their types or meaning.

- `Model`: nodes and their configuration (`flexmb.fe.model.FEModel`,
  `flexmb.closed_form.problem.LinkageModel`).
- `Problem`: a model with prescribed DOFs and dead loads that a strategy iterates on
  (`flexmb.problem.StaticProblem`, `flexmb.closed_form.problem.LinkageProblem`).
- `Strategy`: a solver configuration with one ``solve`` (`flexmb.solvers.Conventional`, ...).
- `Linearisation`: a converged equilibrium linearised on its free coordinates
  (`flexmb.linearisation.FELinearisation`, `flexmb.ksd.reduced_model.ReducedLinearisation`), the one
  thing `flexmb.modes`, `flexmb.buckling`, `flexmb.compliance` and the design gradients read.
- `Response`: a scalar of a solution with its derivative (the design layer, `flexmb.design`).
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

__all__ = ["Model", "Problem", "Strategy", "Linearisation", "Response"]


@runtime_checkable
class Model(Protocol):
    """Nodes and their configuration: what `flexmb.Solution` and the builders read of a model.

    ``dim`` is 2 or 3; ``x0`` the nodes' reference positions (N, dim) [m]; a state is the model's
    own configuration object (`flexmb.fe.model.State`: positions, rotations and, with hinges,
    multipliers). ``apply_increment`` moves a state by an increment on every DOF (rotations on
    the manifold in 3D: ``R <- exp(skew(dphi)) R``)."""

    dim: int
    x0: np.ndarray

    def initial_state(self) -> Any:
        """The undeformed configuration (a new state)."""

    def point_positions(self, state) -> np.ndarray:
        """Positions [m] of all the model's points at ``state``, (n, dim)."""

    def offsets(self, state, master: np.ndarray, offset0: np.ndarray) -> np.ndarray:
        """Current offsets [m] (k, dim) of points rigidly attached to nodes ``master`` (k,) at the
        undeformed offsets ``offset0`` (k, dim): turned with their nodes."""

    def apply_increment(self, state, du: np.ndarray) -> Any:
        """A new state moved by ``du`` on every DOF (rotations composed, never added, in 3D)."""

    def strain_energy(self, state) -> float:
        """Elastic energy stored at ``state`` [J]."""


@runtime_checkable
class Problem(Protocol):
    """A model under prescribed motions and dead loads, scaled together by a load factor.

    ``prescribed`` (sorted DOF indices), ``values`` (their values at load factor 1) and ``free``
    (the other DOFs, sorted) are the boundary conditions; ``with_loads`` and ``with_motion``
    return a copy with other loads or prescribed values that shares the original's analysis
    (sparsity pattern, symbolic factorisation): a sweep's problems. ``external_load(state, lam)``
    is the applied load vector on every DOF."""

    model: Model
    prescribed: np.ndarray
    values: np.ndarray
    free: np.ndarray

    def with_loads(self, loads, start=None) -> Problem:
        """A copy under other dead loads (`flexmb.problem.PointLoads`) sharing this one's analysis."""

    def with_motion(self, values: np.ndarray, start=None) -> Problem:
        """A copy with other prescribed values sharing this one's analysis."""

    def external_load(self, state, lam: float = 1.0) -> np.ndarray:
        """The applied loads on every DOF at ``state`` and load factor ``lam`` [N, N m]."""


@runtime_checkable
class Strategy(Protocol):
    """A solver configuration (frozen attrs: options set at construction, data at call time).

    ``name`` is the method name `flexmb.solve` knows it by; ``capability`` names the builder
    (``"fe_model"``, ``"closed_form"``) that turns a mechanism into the `Problem` it iterates on
    (`flexmb.Mechanism.compile`); ``needs`` the joint capabilities every joint must offer and
    ``dims`` the mechanism dimensions handled. ``solve(compiled)`` returns a `flexmb.Solution`
    (or a subclass: a solution kind with its own `Linearisation`, e.g. KSD-reduced's); it never
    raises for a failed solve unless ``raise_on_failure`` (``converged=False`` and a message)."""

    name: ClassVar[str]
    capability: ClassVar[str]
    needs: ClassVar[tuple[str, ...]]
    dims: ClassVar[tuple[int, ...]]

    def solve(self, compiled) -> Any:
        """The equilibrium of ``compiled`` (`flexmb.compiled.Compiled`): a `flexmb.Solution`."""


@runtime_checkable
class Linearisation(Protocol):
    """A converged equilibrium linearised on its free coordinates ``q`` (`flexmb.Solution.linearisation`).

    The *generalised DOFs* (``size`` of them) are the mechanism model's DOFs (the full FE model:
    ``size = n_dofs``), or a reduced model's (KSD-reduced: the links' DOFs, which lead and are the
    mechanism's own, then the joints' modal coordinates). ``free`` are the generalised DOFs not
    held (sorted; hinge multipliers excluded), and ``Z`` (len(free), n) maps the coordinates to
    them, ``u[free] = Z q`` (hinges: the motions they allow; None: ``q = u[free]``).

    ``K`` is the tangent and ``M`` the mass on ``q`` (n, n): scipy CSR, or dense ndarrays where
    ``dense`` (a small reduced model). ``K`` is the derivative of the free residual at the
    solution's load factor, dead loads included (not symmetric under a dead moment in 3D).
    ``material_tangent(base)`` is buckling's ``K_m`` on ``q`` (`flexmb.linearised.buckling`).
    ``solve(b, transpose=False)`` solves ``K x = b`` (or ``K^T x = b``), b (n,) or (n, k), with
    one factorisation kept for every later solve. ``place(q)`` puts coordinate vectors (n, k) on
    the generalised DOFs (size, k), held ones 0; ``expand(v)`` maps those to the mechanism model's
    DOFs (n_dofs, k) (a reduced model recovers the joints' interior nodes).
    ``solution``, ``state`` and ``compiled`` are the equilibrium's."""

    solution: Any
    held: np.ndarray
    free: np.ndarray
    Z: Any
    size: int
    dense: bool

    @property
    def K(self) -> Any:
        """The tangent on the coordinates (n, n): the free residual's derivative, dead loads in."""

    @property
    def M(self) -> Any:
        """The mass on the coordinates (n, n) at the deformed state."""

    def material_tangent(self, base=None) -> Any:
        """Buckling's ``K_m`` on the coordinates (``base``: the full tangent at a preloaded
        solution); `flexmb.UnsupportedStrategyError` where the kind has no geometric stiffness."""

    def solve(self, b: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``x`` with ``K x = b`` (``K^T x = b``), one factorisation kept for every solve."""

    def place(self, q: np.ndarray) -> np.ndarray:
        """Coordinate vectors (n, k) on the generalised DOFs (size, k), held ones 0."""

    def expand(self, v: np.ndarray) -> np.ndarray:
        """Generalised DOF vectors (size, k) on the mechanism model's DOFs (n_dofs, k)."""


@runtime_checkable
class Response(Protocol):
    """A scalar ``J(u, N)`` of a converged solution's state ``u`` and model numbers ``N`` with its
    derivative (the design layer, `flexmb.design.base.Response`): ``value(solution)``;
    ``partials(sens)``, the explicit ``(dJ/du (n_dofs,), dJ/dN N' (K,))`` at the state of a
    `flexmb.design.adjoint.Sensitivity`; ``gradient(sens, method)``, ``dJ/dp`` (K,) by the adjoint
    (``K^T lam = dJ/du`` with the factorisation the linearisation keeps) or the direct method."""

    name: str

    def value(self, solution) -> float:
        """The response's value at the converged ``solution``."""

    def partials(self, sens) -> tuple:
        """``(dJ/du, dJ/dN . dN/dp)`` at the state of ``sens``."""

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        """``dJ/dp`` (K,)."""
