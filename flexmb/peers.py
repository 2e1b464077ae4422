"""Peer codes on flexmb's own mesh: `ExudynModel` rebuilds a compiled 3D mechanism in Exudyn.

Exudyn (Gerstmayr, https://github.com/jgerstmayr/EXUDYN; the ``peers`` extra) is an open-source
multibody code with geometrically exact (shear-deformable, SE(3)-interpolated) beams. The
Exudyn model is made of flexmb's compiled model, nothing else:

- every beam element becomes one ``ObjectBeamGeometricallyExact`` (``refine`` > 1 splits it into
  that many) between two rigid-body nodes whose reference frames are the element's axes
  ``[e_x, n_y0, n_z0]`` (Exudyn's local x is the beam axis); element ends on one point with one
  frame share a node; the section stiffness is ``diag(EA, k_y GA, k_z GA, G I_t, E I_y, E I_z)``
  (Exudyn's order; ``k = inf``, no shear deformation, becomes ``1e6 GA``);
- every flexmb node (link or internal rigid body) is an Exudyn rigid-body node (mass zero); a
  point rigidly attached to it with an offset is a beam node tied to it by a ``GenericJoint``
  with all six axes locked (exact constraints, Lagrange multipliers); an internal node that is
  itself an element end is that beam node; fixed links are Exudyn ground;
- prescribed translations are ``CoordinateConstraint``s on the link node, prescribed rotations
  a ``GenericJoint`` to ground locking the three rotations to the prescribed orientation (rotation
  chains followed as flexmb does); both scale with Exudyn's load factor ``t`` in [0, 1];
- dead point loads are Exudyn force and torque vectors at markers on the link's body, scaled by
  the load factor.

The converged Exudyn state maps back to a flexmb `flexmb.fe.model.State` (node positions and
rotations), so positions compare point by point with a flexmb `Solution`. The two beams differ:
flexmb's element is the co-rotational Timoshenko beam with the exact two-node stiffness (a
cantilever's tip load is exact with one element), Exudyn's interpolates linearly with one-point
integration (one element: tip deflection ``F L^3 / (4 EI) + F L / GA`` instead of
``F L^3 / (3 EI) + F L / GA``), which converges as ``h^2``: agreement is to that modelling
difference, shrinking by ~4x per doubling of ``refine``.
"""

from __future__ import annotations

import time

import attrs
import numpy as np

from .errors import ModelError, UnsupportedStrategyError, require
from .fe.model import State
from .rotations import chain_rotation
from .sections import section_values

__all__ = ["ExudynModel", "ExudynSolution", "NODE_TYPES", "LINEAR_SOLVERS"]

#: Exudyn rigid-body node types for the beam and link nodes (rotation parameters: Euler parameters
#: with their norm constraint, Tait-Bryan xyz angles, rotation vector for Lie-group integrators).
#: Measured: Exudyn's static solver converges with EP and Rxyz on all benchmark cases; with
#: RotVecLG only on the four-bar (it diverges on the manipulator and on a turned cross flexure).
NODE_TYPES = ("EP", "Rxyz", "RotVecLG")
#: Exudyn linear solvers for the Newton systems
LINEAR_SOLVERS = ("EigenSparse", "EXUdense")
_NO_SHEAR = 1e6  # k = inf (no shear deformation): shear stiffness 1e6 GA
# Exudyn's GenericJoint reports the multipliers of its locked rotations in the link's axes, those
# about y and z with the opposite sign of the moment on the link (measured: a cantilever's end
# turned about x, y and z in turn, against flexmb's reactions)
_TORQUE_SIGN = np.array([1.0, -1.0, -1.0])


@attrs.frozen(eq=False)
class ExudynSolution:
    """An Exudyn static solve of a flexmb model.

    ``state``: the converged configuration as a flexmb `State` of the compiled model's nodes;
    ``positions``: every point of the compiled model [m] (as `flexmb.Solution.node_positions`);
    ``reactions``: link name -> (6,) wrench [N, N m] the prescriptions exert on the link (global
    axes, moments about the link's reference point; zero for components left free);
    ``iterations``: Newton iterations (Exudyn's ``newtonStepsCount``), ``jacobians`` tangent
    evaluations, ``steps`` load steps taken; ``residual``: 2-norm [N, N m] of Exudyn's equilibrium
    residual at the end (the ODE2 rows; rotation rows are generalised moments);
    ``constraint_error``: largest violation of the constraint equations; ``wall_time`` and
    ``cpu_time`` [s] of the solve (Exudyn's ``SolveSystem`` from the undeformed state; the CPU
    time of this process, robust on a busy machine)."""

    converged: bool
    state: State
    positions: np.ndarray
    reactions: dict
    iterations: int
    jacobians: int
    steps: int
    residual: float
    constraint_error: float
    wall_time: float
    cpu_time: float


def _exudyn():
    exu = require("exudyn", "peers", "flexmb.peers.ExudynModel")
    from exudyn import itemInterface, rigidBodyUtilities

    return exu, itemInterface, rigidBodyUtilities


class ExudynModel:
    """The Exudyn model of a compiled flexmb mechanism (`flexmb.Mechanism.compile`), 3D only.

    Parameters
    ----------
    compiled
        A `flexmb.compiled.Compiled` of the full finite-element model (``mechanism.compile()``).
    node_type
        Exudyn rigid-body node type, one of `NODE_TYPES`.
    refine
        Exudyn beam elements per flexmb element (1: the same mesh).
    """

    def __init__(self, compiled, node_type: str = "EP", refine: int = 1):
        exu, ii, rbu = _exudyn()
        problem = compiled.problem
        model = getattr(problem, "model", None)
        if model is None or not hasattr(model, "elements"):
            raise UnsupportedStrategyError("ExudynModel needs the full finite-element model (mechanism.compile())")
        if model.dim != 3:
            raise UnsupportedStrategyError(f"ExudynModel builds 3D models; this one is {model.dim}D "
                                           "(build the mechanism with dim=3)")
        if getattr(model, "hinges", None) is not None:
            raise UnsupportedStrategyError("ExudynModel builds flexure joints (beam elements); this mechanism has "
                                           "ideal joints (hinges), which it does not translate")
        if node_type not in NODE_TYPES:
            raise ModelError(f"ExudynModel: node_type={node_type!r}; valid: {', '.join(NODE_TYPES)}")
        if not (isinstance(refine, (int, np.integer)) and refine >= 1):
            raise ModelError(f"ExudynModel: refine={refine!r} must be an integer >= 1")
        self.compiled, self.node_type, self.refine = compiled, node_type, int(refine)
        self._exu, self._ii = exu, ii
        self.system = exu.SystemContainer()
        mbs = self.mbs = self.system.AddSystem()
        self._rot_ref = {"RotVecLG": rbu.RotationMatrix2RotationVector, "EP": rbu.RotationMatrix2EulerParameters,
                         "Rxyz": rbu.RotationMatrix2RotXYZ}[node_type]
        self._node_class = {"RotVecLG": ii.NodeRigidBodyRotVecLG, "EP": ii.NodeRigidBodyEP,
                            "Rxyz": ii.NodeRigidBodyRxyz}[node_type]
        self._xyz = rbu.RotationMatrix2RotXYZ
        self._ground = mbs.AddObject(ii.ObjectGround())
        self._ground_coordinate = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(ii.NodePointGround()),
                                                                        coordinate=0))
        self._build(model, problem, compiled)
        mbs.Assemble()

    # -- building ---------------------------------------------------------------------------
    def _add_node(self, x, F) -> int:
        return self.mbs.AddNode(self._node_class(referenceCoordinates=list(x) + list(self._rot_ref(F))))

    def _build(self, model, problem, compiled):
        mbs, ii, exu = self.mbs, self._ii, self._exu
        el = model.elements
        ends = el.ends
        px0 = model.point_x0
        chord = px0[ends[:, 1]] - px0[ends[:, 0]]
        frames = np.stack([chord / el.L0[:, None], el.ny0, el.nz0], axis=2)  # (E, 3, 3), columns: local axes
        fixed_nodes = {compiled.link_node[n] for n in compiled.fixed}
        link_nodes = set(compiled.link_node.values())
        # beam nodes: one per (point, frame) of the element ends
        groups, end_group = {}, np.empty(ends.shape, dtype=np.int64)
        for e in range(len(ends)):
            key_f = tuple(np.round(frames[e], 12).ravel())
            for k in range(2):
                end_group[e, k] = groups.setdefault((int(ends[e, k]), key_f), len(groups))
        group_point = np.array([p for p, _ in groups], dtype=np.int64)
        group_frame = [frames[np.argwhere(end_group == g)[0][0]] for g in range(len(groups))]
        # masters: flexmb node -> (Exudyn node or None for ground, reference frame F_m, body or None)
        self._master = {}
        rep = {}
        for g, p in enumerate(group_point):
            m = int(model.point_master[p])
            if (m not in link_nodes and m not in rep and not np.any(model.point_offset[p])):
                rep[m] = g
        group_node = np.full(len(groups), -1, dtype=np.int64)
        for m in range(model.n_nodes):
            if m in fixed_nodes:
                self._master[m] = (None, np.eye(3))
            elif m in rep:
                F = group_frame[rep[m]]
                node = group_node[rep[m]] = self._add_node(model.x0[m], F)
                self._master[m] = (node, F)
            else:
                self._master[m] = (self._add_node(model.x0[m], np.eye(3)), np.eye(3))
        self._bodies = {}
        self.n_ties = 0
        for g, p in enumerate(group_point):
            if group_node[g] >= 0:
                continue
            F = group_frame[g]
            node = group_node[g] = self._add_node(px0[p], F)
            m = int(model.point_master[p])
            marker0 = self._marker(m, model.point_offset[p], F)
            marker1 = mbs.AddMarker(ii.MarkerNodeRigid(nodeNumber=int(node)))
            mbs.AddObject(ii.ObjectJointGeneric(markerNumbers=[marker0, marker1], constrainedAxes=[1] * 6))
            self.n_ties += 1
        # beams
        E, G, A, Iy, Iz, It, ky, kz = section_values(el.sections, ("E", "G", "A", "Iy", "Iz", "It", "ky", "kz"))
        shear = lambda k: np.where(np.isinf(k), _NO_SHEAR, k) * G * A  # noqa: E731
        C = np.zeros((len(ends), 6, 6))
        for i, v in enumerate((E * A, shear(ky), shear(kz), G * It, E * Iy, E * Iz)):
            C[:, i, i] = v
        sections = {}
        n = self.refine
        for e in range(len(ends)):
            key = C[e].diagonal().tobytes()
            if key not in sections:
                sections[key] = exu.BeamSection()
                sections[key].stiffnessMatrix = C[e]
            a, b = group_node[end_group[e]]
            chain = [a]
            for k in range(1, n):
                chain.append(self._add_node(px0[ends[e, 0]] + chord[e] * k / n, frames[e]))
            chain.append(b)
            for k in range(n):
                mbs.AddObject(ii.ObjectBeamGeometricallyExact(nodeNumbers=[int(chain[k]), int(chain[k + 1])],
                                                              length=float(el.L0[e]) / n, sectionData=sections[key]))
        self.n_beams = len(ends) * n
        self._loads(problem)
        self._prescriptions(model, problem, compiled, fixed_nodes)

    def _marker(self, m: int, offset, F) -> int:
        """A rigid marker on flexmb node ``m`` at global undeformed ``offset`` [m] whose frame is ``F``
        in the undeformed configuration (ground for a fixed node)."""
        mbs, ii, exu = self.mbs, self._ii, self._exu
        node, Fm = self._master[m]
        if node is None:
            ht = exu.HT(rotation=F, translation=self.compiled.problem.model.x0[m] + offset)
            return mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=self._ground, localHT=ht))
        if not np.any(offset):
            return mbs.AddMarker(ii.MarkerNodeRigid(nodeNumber=node, localHT=exu.HT(rotation=Fm.T @ F)))
        if m not in self._bodies:  # a massless body carries the offset markers (statics: no mass needed)
            self._bodies[m] = mbs.AddObject(ii.ObjectRigidBody(nodeNumber=node, mass=0.0, inertia=[0.0] * 6))
        ht = exu.HT(rotation=Fm.T @ F, translation=Fm.T @ offset)
        return mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=self._bodies[m], localHT=ht))

    def _loads(self, problem):
        mbs, ii = self.mbs, self._ii
        loads = problem.loads
        for m, s, f, mo in zip(loads.node, loads.offset, loads.force, loads.moment):
            if self._master[int(m)][0] is None:
                continue  # on the ground: taken by the support
            marker = self._marker(int(m), s, np.eye(3))
            if np.any(f):
                mbs.AddLoad(ii.LoadForceVector(markerNumber=marker, loadVector=list(f)))
            if np.any(mo):
                mbs.AddLoad(ii.LoadTorqueVector(markerNumber=marker, loadVector=list(mo)))

    def _prescriptions(self, model, problem, compiled, fixed_nodes):
        mbs, ii = self.mbs, self._ii
        paths = {int(dofs[0]) // model.ndof: w for dofs, w in problem.rotation_paths}
        node_of = {v: k for k, v in compiled.link_node.items()}
        self._translations, self._rotations = [], []  # (link, component, object) / (link, object)
        nodes, comps = np.divmod(problem.prescribed, model.ndof)
        for m in sorted(set(nodes.tolist()) - fixed_nodes):
            if m not in node_of:
                raise ModelError(f"ExudynModel: prescribed DOFs on node {m}, which is not a link's node")
            node = self._master[m][0]
            values = dict(zip(comps[nodes == m].tolist(), problem.values[nodes == m]))
            for c in range(3):
                if c in values:
                    obj = mbs.AddObject(ii.ObjectConnectorCoordinate(
                        markerNumbers=[self._ground_coordinate, mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=node,
                                                                                                      coordinate=c))],
                        offset=float(values[c]), offsetUserFunction=_scaled_offset))
                    self._translations.append((node_of[m], c, obj))
            if 3 in values:
                w = paths.get(m, np.array([[values[3], values[4], values[5]]]))
                uf = _RotationOffset(w, self._xyz)
                marker1 = self._marker(m, np.zeros(3), np.eye(3))  # the link's axes
                ground = mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=self._ground, localHT=self._exu.HT()))
                obj = mbs.AddObject(ii.ObjectJointGeneric(markerNumbers=[ground, marker1],
                                                          constrainedAxes=[0, 0, 0, 1, 1, 1],
                                                          offsetUserFunction=uf))
                self._rotations.append((node_of[m], obj))

    # -- solving ----------------------------------------------------------------------------
    def settings(self, *, load_steps: int = 1, adaptive: bool = True, max_iterations: int = 25,
                 modified_newton: bool = False, linear_solver: str = "EigenSparse",
                 relative_tolerance: float = 0.0, absolute_tolerance: float = 5e-7):
        """Exudyn ``SimulationSettings`` of a quiet static solve (no files, no output): Exudyn's
        static solver with ``load_steps`` equal load steps (``adaptive``: cut by 4 on a failed
        step, doubled after recovery), ``max_iterations`` Newton iterations per step, full or
        modified Newton, the linear solver (`LINEAR_SOLVERS`) and Exudyn's Newton tolerances."""
        if linear_solver not in LINEAR_SOLVERS:
            raise ModelError(f"ExudynModel: linear_solver={linear_solver!r}; valid: {', '.join(LINEAR_SOLVERS)}")
        exu = self._exu
        s = exu.SimulationSettings()
        s.solution.file.write = False
        s.solution.file.writeInitialValues = False
        s.solution.sensors.writePeriod = 1e30
        s.show.computationTime = False
        s.show.statistics = False
        s.linearSolver.solverType = getattr(exu.LinearSolverType, linear_solver)
        s.linearSolver.reuseAnalyzedPattern = linear_solver == "EigenSparse"
        st = s.staticSolver
        st.verboseMode = 0
        st.numberOfLoadSteps = int(load_steps)
        st.adaptiveStep = bool(adaptive)
        st.loadStepDuration = 1.0
        st.useLoadFactor = True
        st.newton.maxIterations = int(max_iterations)
        st.newton.useModifiedNewton = bool(modified_newton)
        st.newton.relativeTolerance = float(relative_tolerance)
        st.newton.absoluteTolerance = float(absolute_tolerance)
        return s

    def solve(self, settings=None, **options) -> ExudynSolution:
        """Solve from the undeformed state with ``settings`` (an Exudyn ``SimulationSettings``) or
        `settings` made of ``options``; returns an `ExudynSolution` (``converged`` False rather
        than an exception when Exudyn's solver stops)."""
        exu = self._exu
        s = self.settings(**options) if settings is None else settings
        solver = exu.MainSolverStatic()
        t, c = time.perf_counter(), time.process_time()
        try:
            ok = bool(solver.SolveSystem(self.mbs, s))
        except (RuntimeError, ValueError, exu.ExudynError):
            ok = False
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        return self._solution(solver, s, ok, wall, cpu)

    def _solution(self, solver, s, ok, wall, cpu) -> ExudynSolution:
        exu, mbs = self._exu, self.mbs
        model = self.compiled.problem.model
        out = exu.OutputVariableType
        pos, rot = model.x0.copy(), np.tile(np.eye(3), (model.n_nodes, 1, 1))
        for m, (node, F) in self._master.items():
            if node is not None:
                pos[m] = mbs.GetNodeOutput(node, out.Position)
                rot[m] = mbs.GetNodeOutput(node, out.RotationMatrix).reshape(3, 3) @ F.T
        state = State(pos, rot)
        reactions = {}
        for link, c, obj in self._translations:
            reactions.setdefault(link, np.zeros(6))[c] = float(np.ravel(mbs.GetObjectOutput(obj, out.Force))[0])
        for link, obj in self._rotations:
            torque = np.asarray(mbs.GetObjectOutput(obj, out.TorqueLocal), dtype=float) * _TORQUE_SIGN
            reactions.setdefault(link, np.zeros(6))[3:] = rot[self.compiled.link_node[link]] @ torque
        try:
            solver.ComputeNewtonResidual(mbs, s)
            r = np.asarray(solver.GetSystemResidual())
            n2 = solver.GetODE2size()
            residual, cerr = float(np.linalg.norm(r[:n2])), float(np.abs(r[n2:]).max(initial=0.0))
        except (RuntimeError, ValueError, exu.ExudynError):
            residual = cerr = float("nan")
        it = solver.it
        return ExudynSolution(ok, state, model.point_positions(state), reactions, int(it.newtonStepsCount),
                              int(it.newtonJacobiCount), int(it.currentStepIndex), residual, cerr, wall, cpu)


class _RotationOffset:
    """Exudyn's offset user function of a prescribed orientation: the Tait-Bryan xyz angles of the
    rotation chain ``w`` at load factor ``t``, cached per ``t`` (Exudyn asks again at every
    residual and tangent of a step: 1047 calls on the manipulator at 45 deg)."""

    def __init__(self, w, xyz):
        self.w, self.xyz, self.t, self.value = np.asarray(w, dtype=float), xyz, None, None

    def __call__(self, mbs, t, item, parameters):
        if t != self.t:
            self.t, self.value = t, [0.0, 0.0, 0.0] + [float(a) for a in self.xyz(chain_rotation(self.w, t))]
        return self.value


def _scaled_offset(mbs, t, item, offset):
    """A prescribed coordinate at Exudyn's load factor ``t``: ``t * offset``."""
    return t * offset

