"""`Solution`: what every solver strategy returns."""

from __future__ import annotations

import attrs
import numpy as np

from typing import ClassVar

from ._validate import frozen
from .errors import ModelError, UnsupportedStrategyError
from .fe.model import State
from .rotations import cross, logm_so3

__all__ = ["Solution"]


@attrs.frozen(eq=False)
class Solution:
    """The result of `flexmb.solve`.

    Attributes
    ----------
    converged
        True when the residual norm fell below the tolerance at load factor 1.
    iterations
        Total Newton iterations (all steps).
    residual_history
        Residual norm [N, N m mixed, as in the paper] after every iteration, shape (iterations,).
    load_factor
        The load factor reached (1.0 when converged); prescribed motions and loads scale with it.
    steps
        Accepted load steps; ``rejected_steps`` were halved away.
    wall_time
        Seconds per phase, e.g. ``{"assemble": ..., "solve": ..., "total": ...}``.
    message
        Why the solver stopped.
    stable
        True when the converged equilibrium is stable (free tangent positive definite), False when
        not, None when not checked (not converged, KSD-reduced, or the closed-form
        models of ``method="newton"``, whose tangent is not the Hessian of an energy).
    stages
        Per-step details of multi-step strategies (KSD: ``"kinematics"``, ``"reduced"``,
        ``"full"`` with their iterations, residuals and times; ``"eob"``, ``"internal"`` times).
    state
        Nodal configuration (internal use; see `pose`, `node_positions`).
    """

    method: str
    converged: bool
    iterations: int
    residual_history: np.ndarray = attrs.field(converter=frozen)  # read-only copies
    load_factor: float
    steps: int
    rejected_steps: int
    wall_time: dict
    message: str
    state: State = attrs.field(repr=False)
    residual: np.ndarray = attrs.field(repr=False, converter=frozen)
    compiled: object = attrs.field(repr=False)
    tolerance: float = 5e-7
    stable: bool | None = None
    stages: dict = attrs.field(factory=dict, repr=False)
    #: whether the state is the full model's equilibrium (its tangent and mass on every DOF are
    #: the linearisation); a reduced solution kind says False and why in ``full_equilibrium_note``
    full_equilibrium: ClassVar[bool] = True
    full_equilibrium_note: ClassVar[str] = ""

    def linearisation(self, held="prescribed", *, modal: bool = False, owner: str = "linearisation"):
        """The converged equilibrium linearised on its free coordinates (a
        `flexmb.protocols.Linearisation`): tangent ``K`` and mass ``M`` on them, the map back to
        the mechanism's DOFs, the held DOFs and a solve with a kept factorisation. ``held`` as in
        `flexmb.modes`; ``modal``: coordinates that carry the mass (a reduced solution kind adds
        its joints' interior modes; the full model's are the same either way); ``owner``: the
        property named in error messages. This is the full finite-element model's
        (`flexmb.linearisation.FELinearisation`); a solution kind with another model overrides
        it (KSD-reduced: `flexmb.ksd.reduced_model.ReducedSolution`). Raises `ConvergenceError` for
        an unconverged solution, `UnsupportedStrategyError` where the model has no beam elements."""
        from .linearisation import FELinearisation

        return FELinearisation(self, held, modal=modal, owner=owner)

    def _element_axial_forces(self):
        """``(elements, N)``: axial forces [N] that replace those the state's positions imply in
        `stresses` and `peak_stress` (a reduced solution kind's, from its own model), or None."""
        return None

    @classmethod
    def failed(cls, method: str, compiled, message: str, wall_time: dict | None = None, stages: dict | None = None):
        """A solve that produced no configuration (a strategy refused or broke down): not
        converged, ``message`` says why; its positions, rotations and reactions are NaN, so no
        table or plot can mistake it for an answer."""
        model = compiled.problem.model
        s0 = model.initial_state()
        return cls(method=method, converged=False, iterations=0, residual_history=np.empty(0), load_factor=0.0,
                   steps=0, rejected_steps=0, wall_time=dict(wall_time or {}), message=message,
                   state=State(np.full_like(s0.positions, np.nan), np.full_like(s0.rotations, np.nan)),
                   residual=np.full(model.n_dofs, np.nan), compiled=compiled, stages=dict(stages or {}))

    @property
    def dim(self) -> int:
        """2 (planar) or 3 (spatial)."""
        return self.compiled.problem.model.dim

    def _node(self, link: str) -> int:
        try:
            return self.compiled.link_node[link]
        except (KeyError, TypeError):
            if link in getattr(self.compiled, "joint_points", {}):  # a point inside a joint (Mechanism.add_joint_point)
                return self.compiled.joint_points[link]
            raise ModelError(f"no link named {link!r}; links: {', '.join(self.compiled.link_node)}") from None

    def pose(self, link: str):
        """``(position [m], rotation)`` of a link's reference point; rotation is an angle [rad] in 2D,
        a rotation matrix (3, 3) in 3D, both relative to the undeformed configuration."""
        n = self._node(link)
        return self.state.positions[n].copy(), (float(self.state.rotations[n]) if self.dim == 2
                                                else self.state.rotations[n].copy())

    def rotation_vector(self, link: str) -> np.ndarray:
        """Rotation of a link as a rotation vector [rad] (3D) or angle array (1,) (2D)."""
        n = self._node(link)
        if self.dim == 2:
            return np.array([self.state.rotations[n]])
        return logm_so3(self.state.rotations[n])

    def displacement(self, link: str) -> np.ndarray:
        """Displacement of a link's reference point [m]."""
        n = self._node(link)
        return self.state.positions[n] - self.compiled.problem.model.x0[n]

    def reaction(self, link: str) -> np.ndarray:
        """Wrench that holds a fixed or prescribed link: forces [N] then moments [N m], global axes,
        moments about the link's reference point. Components that are free are ~0 (the residual)."""
        model = self.compiled.problem.model
        return self.residual[model.node_dofs[self._node(link)]].copy()

    def joint_wrench(self, joint: str) -> np.ndarray:
        """The wrench an ideal joint (`flexmb.Hinge`: its constraint forces, motor and spring)
        applies on its side-B link: force [N] then moment [N m] about the joint's origin, global
        axes. About the hinge axis the moment is the motor's torque plus the spring's ``-k theta``;
        its other components (3D) are the moments the bearing carries."""
        model = self.compiled.problem.model
        names = () if getattr(model, "hinges", None) is None else model.hinges.names
        if joint not in names:
            raise ModelError(f"no ideal joint named {joint!r}; ideal joints: {', '.join(names) or 'none'}")
        st = self.state
        return model.hinges.wrench_on_b(names.index(joint), st.positions, st.rotations, st.multipliers, st.hinge_angles)

    def point(self, link: str, name: str) -> np.ndarray:
        """Current position [m] of a named point of a link (see `Mechanism.add_point`)."""
        try:
            owner, offset = self.compiled.points[name]
        except KeyError:
            raise ModelError(f"no point named {name!r}; points: {', '.join(self.compiled.points) or 'none'}") from None
        if owner != link:
            raise ModelError(f"point {name!r} belongs to link {owner!r}, not {link!r}")
        n = self._node(link)
        return self.state.positions[n] + self.compiled.problem.model.offsets(self.state, np.array([n]), offset[None])[0]

    def node_positions(self) -> np.ndarray:
        """Positions [m] of all finite-element nodes, (n, dim): link reference points first (in
        the order links were added), then each joint's points in the order joints were added."""
        return self.compiled.problem.model.point_positions(self.state)

    def imbalance(self) -> np.ndarray:
        """Net wrench of all joint forces on all links, about the origin: ``[F (dim), M]`` [N, N m].

        The internal forces of a model that balances globally (every flexure in equilibrium
        between its two links) sum to zero; this returns that sum, computed as residual plus
        applied loads over every link (fixed ones included). flexmb's finite-element model
        balances to roundoff; see `flexmb.CurvedBeam` for the closed-form models.
        """
        problem, state = self.compiled.problem, self.state
        n = len(state.positions) * problem.model.ndof  # the link and node rows (hinge multipliers follow)
        f = (self.residual + problem.external_load(state, self.load_factor))[:n].reshape(len(state.positions), -1)
        d = self.dim
        force = f[:, :d].sum(axis=0)
        x = state.positions
        if d == 2:
            moment = np.array([np.sum(f[:, 2] + x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0])])
        else:
            moment = np.sum(f[:, 3:] + cross(x, f[:, :3]), axis=0)
        return np.concatenate([force, moment])

    def peak_stress(self, joint: str | None = None) -> np.ndarray:
        """Peak normal stress [Pa] of every beam element (of ``joint`` only if given), axial plus
        bending at the worse end (`flexmb.fe.stress.peak_normal_stress`)."""
        from .fe.stress import peak_normal_stress

        model = self.compiled.problem.model
        if not hasattr(model, "elements"):
            raise UnsupportedStrategyError(
                f"peak_stress needs beam elements: this solution comes from method {self.method!r}, whose "
                "closed-form model has none; solve with method='conventional' for stresses")
        sigma = peak_normal_stress(model, self.state, self._element_axial_forces())
        if joint is None:
            return sigma
        try:
            return sigma[self.compiled.joint_elements[joint]]
        except KeyError:
            raise ModelError(f"no joint named {joint!r}; joints: {', '.join(self.compiled.joint_elements)}") from None

    def stresses(self, concentration=None, limit=None):
        """Peak normal, shear (torsion and transverse) and von Mises stresses [Pa] of every beam
        element at its section's perimeter (`flexmb.fe.stress.element_stresses`), times a
        stress-concentration factor ``concentration`` (a number for all joints or ``{joint:
        factor}``, >= 1; e.g. a notch hinge's K_t), and with a material ``limit`` [Pa] (yield or
        fatigue strength) the safety factors ``limit / von_mises`` (without it, from the sections'
        ``yield_stress`` where given: the joints' ``yield_stress``). Returns a
        `flexmb.fe.stress.Stresses`: per element arrays, ``.joint(name)`` and ``.summary()``.
        A solution kind may give its joint elements' axial forces from its own model
        (`_element_axial_forces`: a converged KSD-reduced solution's from the EOBs,
        `flexmb.ksd.reduced_model.eob_axial_forces`), the moments from the state's positions."""
        from .fe.stress import element_stresses

        model = self.compiled.problem.model
        if not hasattr(model, "elements"):
            raise UnsupportedStrategyError(
                f"stresses need beam elements: this solution comes from method {self.method!r}, whose "
                "closed-form model has none; solve with method='conventional' for stresses")
        return element_stresses(model, self.state, self.compiled.joint_elements, concentration, limit,
                                self._element_axial_forces())

    def strain_energy(self) -> float:
        """Elastic energy stored in all beam elements [J]."""
        return self.compiled.problem.model.strain_energy(self.state)
