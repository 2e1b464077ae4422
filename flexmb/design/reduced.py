"""Design gradients of a KSD-reduced solution with respect to placements, loads and prescribed motion.

KSD-reduced (Dwarshuis et al. 2020, steps 1-4) solves the reduced mechanism's equilibrium
``r(z, p) = 0`` on the links' coordinates ``z`` (step 3) with each joint's condensed EOB stiffness
``K``, preload ``F_hat`` about its near configuration (node B's position ``p_hat`` and the intended
rotation ``theta`` of step 1's kinematics, ``R_hat = Rz(theta)``). A *placement* (where a joint
sits on its links: the links' reference positions, the joints' origins and rotations), a load or a
prescribed motion leaves every joint and so its database valid; it changes

1. step 1's kinematic solution: the kept constraint equations ``c(z_1, p) = 0`` through the joints'
   relative poses (`flexmb.ksd.kinematics.kinematics_rates`, the implicit function theorem with the
   constraints' exact gradients), hence ``theta`` and ``p_hat``;
2. step 2's condensation through ``theta`` and ``p_hat``: the joint's tabulated condensation
   (`flexmb.ksd.eob_table`: ``K_T(theta)``, ``F_hat = F0(theta) + G(theta) p_hat``, a spline in
   ``theta``) differentiated exactly (the spline's derivative);
3. step 3's residual at fixed link poses through the joints' frames, the near configuration and the
   loads: the complex step through `flexmb.ksd.reduced_model.step3` (the residual's own terms in
   complex arithmetic), and the prescribed coordinates' motion.

Then ``K_red,ff dz_f/dp = -(dr_f/dp + K_red,fp g')`` with the reduced tangent
(`flexmb.ksd.reduced_model.reduced_tangent`) — the `flexmb.design.adjoint.Sensitivity` equations on
the links' DOFs. The derivative is the exact derivative of the KSD-reduced solution as it is
computed (to the steps' convergence), wherever every joint's rotation lies on its table's range;
a joint whose condensation is evaluated directly (no table, or outside it) is refused by name.
The compliance (`flexmb.compliance` on the reduced tangent) differentiates the tangent too: its
total rate ``dK/dp + dK/dz z'`` is the complex step of step 3's tangent along the parameters' and
the state's rates. Refused by name (`flexmb.UnsupportedStrategyError`, pointing to ksd-full):
parameters that change a joint (its database entry) or a mass, and the responses of the joints'
condensed EOB models (frequencies, buckling, stresses).
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.linalg as sla

from ..errors import ConvergenceError, ModelError, UnsupportedStrategyError
from ..ksd.geometry import ACTIVE
from ..ksd.kinematics import kinematics_rates, solve_kinematics
from ..ksd.reduced_model import link_poses, near, reduced_tangent, relative_pose, step3, step3_inputs
from ..rotations import skew
from .adjoint import Sensitivity

__all__ = ["ReducedSensitivity", "RESPONSES", "KINDS"]

#: The responses a KSD-reduced gradient serves: those read from the links' DOFs and the compliance
#: of the reduced tangent (a support stiffness is its reciprocal).
RESPONSES = ("_Reaction", "_Position", "_Rotation", "_Mass", "_Compliance")

#: The parameter kinds (`flexmb.design.parameters.ModelRates.kind`) a KSD-reduced gradient follows.
KINDS = ("placement", "load", "prescribed motion")

#: The complex step through step 3 (rates of order one or more: far below round-off, above underflow).
_H = 1e-30

_EZ = skew(np.array([0.0, 0.0, 1.0]))


#: The model fields of the kinds KSD-reduced does not follow (a joint's dimensions or material, masses).
REFUSED_FIELDS = ("S", "L0", "rho_A", "rigid_mass", "rigid_inertia", "rigid_offset")


def _refuse_kinds(solution, rates) -> None:
    """Refuse parameters that change a joint or a mass, naming each with its kind (`KINDS` pass)."""
    bad = [k for k in range(len(rates.names)) if any(np.any(rates.rate(f)[k] != 0.0) for f in REFUSED_FIELDS)]
    if bad:
        listed = ", ".join(f"{rates.names[k]!r} ({rates.kind(k)})" for k in bad)
        raise UnsupportedStrategyError(
            f"design gradients with KSD-reduced (method {solution.method!r}) follow placements, loads and prescribed "
            f"motion (the joints' databases stay valid); the parameters {listed} change a joint's database entry or "
            "the masses: solve with method='ksd-full' (the full equilibrium from the KSD start, with every "
            "parameter's gradient)")


class ReducedSensitivity(Sensitivity):
    """`flexmb.design.adjoint.Sensitivity` for a converged KSD-reduced solution: the reduced tangent
    on the links' DOFs, the residual's and the tangent's rates through steps 1-3 (module notes);
    vectors over the full model's DOFs, nonzero on the links' DOFs only."""

    def __init__(self, solution, rates):
        if not solution.converged:
            raise ConvergenceError(f"design gradient of an unconverged solution ({solution.message})", solution)
        _refuse_kinds(solution, rates)
        self.solution, self.rates = solution, rates
        self.problem = solution.compiled.problem
        self.model, self.state = self.problem.model, solution.state
        self.lam = 1.0
        self.names = rates.names
        self._K_links, self.red = reduced_tangent(solution)
        n = self._K_links.shape[0]  # the links' DOFs lead the full model's (link k's: k ndof ...)
        self.links = np.arange(n)
        self.prescribed = self.problem.prescribed
        if np.any(self.prescribed >= n):
            raise ModelError("KSD-reduced design gradients: a prescribed DOF is not a link's")
        self.free = np.setdiff1d(self.links, self.prescribed)
        self._blocks = {}

    def check_response(self, response) -> None:
        """Refuse a response whose KSD-reduced value is not a function of the links' DOFs and the
        reduced tangent (a support stiffness: its compliance's)."""
        inner = getattr(response, "response", response)
        if type(inner).__name__ not in RESPONSES:
            method = self.solution.method
            raise UnsupportedStrategyError(
                f"{response.name} cannot be differentiated with KSD-reduced (method {method!r}: its value comes from the "
                "joints' condensed EOB models, which the design parameters' gradient does not follow): solve with "
                "method='ksd-full'; with KSD-reduced: reactions, displacements, positions, rotations, the mass and "
                "compliances (support stiffnesses)")

    # -- the reduced tangent ------------------------------------------------------------------
    def block(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The reduced tangent's block ``K[rows][:, cols]`` (link DOFs)."""
        return self._K_links[np.ix_(rows, cols)]

    def row(self, dof: int) -> np.ndarray:
        """Row ``dof`` of the reduced tangent on the full model's DOFs (zero outside the links')."""
        out = np.zeros(self.model.n_dofs)
        if dof < len(self.links):
            out[self.links] = self._K_links[dof]
        return out

    @functools.cached_property
    def _lu(self):
        lu = sla.lu_factor(self.block(self.free, self.free))
        if np.any(np.diag(lu[0]) == 0.0):
            raise ModelError("design gradient: the reduced tangent on the free DOFs is singular")
        return lu

    def solve(self, rhs: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``K_red,ff^-1 rhs`` (or its transpose's) on the free link DOFs, one LU kept. ``rhs`` may
        also be given on all the full model's free DOFs (a link's load, `flexmb.responses.compliance`):
        zero on the joints' internal nodes (else refused), the answer then on those rows too."""
        rhs = np.asarray(rhs, dtype=float)
        if len(rhs) == len(self.free) or len(rhs) != self.model.n_dofs - len(self.prescribed):
            return sla.lu_solve(self._lu, rhs, trans=1 if transpose else 0)
        on_links = self._on_links
        if np.any(rhs[~on_links] != 0.0):
            raise UnsupportedStrategyError("a load on the joints' internal nodes: KSD-reduced recovers them from the "
                                           "EOBs (step 4), not differentiable with KSD-reduced")
        out = np.zeros_like(rhs)
        out[on_links] = sla.lu_solve(self._lu, rhs[on_links], trans=1 if transpose else 0)
        return out

    @functools.cached_property
    def _on_links(self) -> np.ndarray:
        """Which of the full model's free DOFs are the links' (they lead)."""
        return np.setdiff1d(np.arange(self.model.n_dofs), self.prescribed) < len(self.links)

    # -- the rates through steps 1-3 -----------------------------------------------------------
    @functools.cached_property
    def _inputs(self) -> dict:
        """`flexmb.ksd.reduced_model.STEP3_INPUTS` at the solution (float)."""
        return step3_inputs(self.solution)

    @functools.cached_property
    def _frame_rates(self) -> dict:
        """The joints' frames' rates ``{"s_a", "s_b", "P"}`` (K, J, ...) per parameter, from each
        parameter's build (`flexmb.design.builds.ParameterBuild.combine`: its complex step), kept
        with the design's rates (they do not depend on the configuration)."""
        key = ("ksd-reduced frames", tuple(self.red.joint_names))
        shared = self.rates.shared
        if key not in shared:
            red, link_node = self.red, self.solution.compiled.link_node
            J = len(red.joint_names)
            flat = np.array([self.rates.build(k).combine(lambda mech, _: _frame_numbers(red, link_node, mech))
                             for k in range(len(self.names))]).reshape(len(self.names), -1)
            s_a, s_b, P = np.split(flat, [3 * J, 6 * J], axis=1)
            shared[key] = {"s_a": s_a.reshape(-1, J, 3), "s_b": s_b.reshape(-1, J, 3), "P": P.reshape(-1, J, 3, 3)}
        return shared[key]

    def _complex(self, state=None) -> dict:
        """`STEP3_INPUTS` stacked over the parameters (K, ...), each parameter's rates as imaginary
        parts (`_H`); ``state``: the links' rates (K, 6 n_links) too (translations, spins)."""
        g = self._inputs
        rates = {**self._frame_rates, **self._near_rates, **self._load_rates}
        if state is not None:
            dz = state.reshape(len(state), -1, 6)
            rates["x"], rates["R"] = dz[..., :3], skew(dz[..., 3:]) @ g["R"]
        K = len(self.names)
        return {f: g[f] + 1j * _H * rates[f] if f in rates else np.broadcast_to(g[f], (K,) + g[f].shape) + 0j
                for f in g}

    @functools.cached_property
    def _load_rates(self) -> dict:
        """The dead loads' rates in 3D form (K, L, 3)."""
        dim, K, L = self.model.dim, len(self.names), len(self.red.load_node)
        out = {}
        for f, field in (("force", "load_force"), ("moment", "load_moment"), ("offset", "load_offset")):
            out[f] = np.zeros((K, L, 3))
            if L == 0:
                continue
            rate = np.asarray(self.rates.rate(field), dtype=float).reshape(K, L, -1)
            if f == "moment" and dim == 2:
                out[f][..., 2] = rate[..., 0]
            else:
                out[f][..., :dim] = rate
        return out

    @functools.cached_property
    def _near_rates(self) -> dict:
        """The near configuration's rates ``{"K", "Fh", "p_hat", "R_hat"}`` (K, J, ...): step 1's
        kinematic solution (`kinematics_rates`) and step 2's tabulated condensation's derivative."""
        red, (_, K0, _, p_hat, R_hat, theta) = near(self.solution)
        nK, J = len(self.names), len(red.joint_names)
        out = {"K": np.zeros((nK,) + K0.shape), "Fh": np.zeros((nK, J, 6)), "p_hat": np.zeros((nK, J, 3)),
               "R_hat": np.zeros((nK, J, 3, 3))}
        pres = self.prescribed_rates
        if not (np.any(pres) or any(np.any(r) for r in self._frame_rates.values())):
            return out  # loads only: steps 1-2 do not read them
        poses, theta1 = solve_kinematics(red, tol=1e-10)[:2]  # step 1's poses (the solve keeps the angles only)
        if np.abs(theta1 - theta).max() > 1e-8:
            raise ModelError("KSD-reduced design gradients: step 1 solved again does not reach the solution's near "
                             f"configuration (intended rotations {theta1} against {theta} rad)")
        fr = {f: self._inputs[f] + 1j * _H * r for f, r in self._frame_rates.items()}  # (K, J, ...)
        p, Rrel, _ = relative_pose(red, poses.x, poses.R, fr["s_a"], fr["s_b"], fr["P"])
        # the relative poses' rates at step 1's poses held fixed: the frames' (J, 6, K)
        rel = np.concatenate([p.imag / _H, _unskew(Rrel.imag / _H @ np.swapaxes(Rrel.real, -1, -2))], axis=-1)
        rel = np.moveaxis(rel, 0, -1)
        dtheta, dp = kinematics_rates(red, poses, rel, pres)
        out["p_hat"], out["R_hat"] = np.moveaxis(dp, -1, 0), np.einsum("ab,jbc,jk->kjac", _EZ, R_hat, dtheta)
        _condensation_rates(red, theta, p_hat, dtheta, dp, out)
        return out

    @functools.cached_property
    def residual_rates(self) -> np.ndarray:
        """``dr/dp`` (n_dofs, K) at the solution's link poses held fixed: through the frames, the near
        configuration and the loads (the complex step through step 3)."""
        red = self.red
        out = np.zeros((self.model.n_dofs, len(self.names)))
        r, _ = step3(red, self._complex(), tangent=False)
        out[red.fe_dofs] = r.imag[:, red.emb_dofs].T / _H
        return out

    def tangent_forms(self, V: np.ndarray, W: np.ndarray | None = None, material: bool = False) -> np.ndarray:
        """``V^T (dK_red/dp_k) W`` (K, a, b): the reduced tangent's total change with each parameter,
        along the parameters' and the state's rates (`state_rates`), by the complex step through
        step 3's tangent; ``material``: refused (KSD-reduced has no material/geometric split)."""
        if material:
            raise UnsupportedStrategyError("the material tangent of a KSD-reduced solution: solve with "
                                           "method='ksd-full'")
        if "tangent" not in self._blocks:
            red, du = self.red, self.state_rates
            dz = np.zeros((len(self.names), 6 * red.n_links))
            dz[:, red.emb_dofs] = du[red.fe_dofs].T
            T = step3(red, self._complex(dz))[1].imag / _H
            self._blocks["tangent"] = T[:, red.emb_dofs][:, :, red.emb_dofs]
        W = V if W is None else W
        n = len(self.links)
        return np.einsum("ia,kij,jb->kab", V[:n], self._blocks["tangent"], W[:n])

    def mass_forms(self, V, W=None):
        """Refused: KSD-reduced's mass follows the joints' condensed EOB models."""
        raise UnsupportedStrategyError("the mass of a KSD-reduced solution has no design derivative: solve with "
                                       "method='ksd-full'")

    def gradient(self, dJ_du: np.ndarray, dJ_dN: np.ndarray, method: str = "auto") -> np.ndarray:
        """``dJ/dp`` (K,) from a response's partials (`Sensitivity.gradient`); a response reading
        the joints' internal nodes is refused."""
        dJ_du = np.asarray(dJ_du, dtype=float)
        if np.any(dJ_du[len(self.links):] != 0.0):
            raise UnsupportedStrategyError("this response reads the joints' internal nodes, which KSD-reduced recovers "
                                           "from the EOBs (step 4): not differentiable with KSD-reduced")
        return super().gradient(dJ_du, dJ_dN, method)


def _unskew(S: np.ndarray) -> np.ndarray:
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]],
                          axis=-1)


def _frame_numbers(red, link_node: dict, mech) -> np.ndarray:
    """The joints' frames ``s_a``, ``s_b`` (J, 3), ``P`` (J, 3, 3) of a mechanism (a design's build,
    complex in a complex step), flattened, as `flexmb.ksd.reduced.ReducedMechanism` sets them up."""
    dim, J = red.dim, len(red.joint_names)
    X = np.zeros((red.n_links, 3), dtype=complex)
    for name, link in mech.links.items():
        if name in link_node:
            X[link_node[name], :dim] = link.position
    places = {k: d["placement"] for _, _, k, d in mech.graph.edges(keys=True, data=True)}
    P = np.repeat(np.eye(3, dtype=complex)[None], J, axis=0)
    origin = np.zeros((J, 3), dtype=complex)
    for j, name in enumerate(red.joint_names):
        P[j, :dim, :dim] = places[name].rotation
        origin[j, :dim] = places[name].origin
    fr = red.frames
    s_a = origin - X[fr.a]
    s_b = origin + (P @ red.b0[..., None])[..., 0] - X[fr.b]
    return np.concatenate([s_a.ravel(), s_b.ravel(), P.ravel()])


def _condensation_rates(red, theta, p_hat, dtheta, dp, out: dict) -> None:
    """Step 2's rates into ``out["K"]``, ``out["Fh"]`` (K, J, ...): per group of joints its tabulated
    condensation ``K_T(theta)``, ``F_hat = F0(theta) + G(theta) p_hat`` differentiated (the spline's
    derivative); a joint whose condensation was evaluated directly is refused by name."""
    dim = red.dim
    emb = ACTIVE[dim]
    for tpl, _, idx in red.groups:
        lookup = tpl.lookup
        if not (np.any(dtheta[idx]) or np.any(dp[idx])):
            continue  # their near configuration does not move
        if lookup is None or not lookup.covers(theta[idx]):
            names = ", ".join(repr(red.joint_names[j]) for j in idx)
            raise UnsupportedStrategyError(
                f"KSD-reduced design gradients: the joints {names} have their EOB condensation evaluated directly "
                f"(no tabulated condensation over their rotations {np.round(theta[idx], 4)} rad), whose rate with "
                "the near configuration is not differentiated: solve with method='ksd-full'")
        val, der = (lookup.table.split(lookup._spline(theta[idx], nu=nu)) for nu in (0, 1))
        b = p_hat[idx, :dim]
        dth = dtheta[idx].T  # (K, Jg)
        dK = der["K_T"][None] * dth[..., None, None]
        dF = (der["F0"][..., 0] + (der["G"] @ b[..., None])[..., 0])[None] * dth[..., None] \
            + np.einsum("jab,jbk->kja", val["G"], dp[idx, :dim])
        out["K"][:, idx[:, None, None], emb[:, None], emb] = dK
        out["Fh"][:, idx[:, None], emb] = dF
