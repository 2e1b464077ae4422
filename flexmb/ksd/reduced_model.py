"""The model a KSD-reduced solution's properties read: the reduced mechanism's tangent on the
links' DOFs, from which `flexmb.compliance` takes a link point's compliance; with the joints'
condensed mass (`flexmb.ksd.joint_mass`) the model `flexmb.modes` solves; and the joint
elements' axial forces from the EOBs' element forces, which `Solution.stresses` uses.

The tangent is the Jacobian of the equilibrium KSD step 3 solves (`ReducedMechanism.equilibrium`):
each joint's Craig-Bampton stiffness ``K_T`` (node A held, Eq. 2.5) at its EOB near configuration
(the intended rotation and node B's position from step 1), carried to the links through the
joints' current frames (the moments of the joint wrenches about the links' reference points:
their geometric part), and the dead loads at offset points. The EOBs are rebuilt from step 1 as
the solve built them (the tabulated condensation where the solve used it), so the tangent is the
one the solve converged with. Rotation DOFs are spins (3D) or the angle (2D), as in the full model.
"""

from __future__ import annotations

import os
import weakref

import numpy as np

from .. import jit
from ..errors import ParameterError
from ..fe.mass import RigidMasses, rigid_mass
from .eob import lever
from .eob_forces import axial_forces, force_table
from .joint_mass import condensed_subspace
from ..rotations import skew, unskew
from .geometry import ACTIVE, LinkPoses, rz
from .kinematics import solve_kinematics
from . import reduced_model_jit
from .reduced import ReducedMechanism, reduced_mechanism

__all__ = ["reduced_tangent", "reduced_mass", "link_poses", "near", "full_eobs",
           "node_displacements", "eob_axial_forces"]


def link_poses(red: ReducedMechanism, state) -> LinkPoses:
    """The links' poses (3D form) of a full-model `State` whose first nodes are the links."""
    nL, dim = red.n_links, red.dim
    x = np.zeros((nL, 3))
    x[:, :dim] = state.positions[:nL]
    if dim == 2:
        angle = np.asarray(state.rotations[:nL], dtype=float)
        return LinkPoses(x, rz(angle), angle.copy())
    R = np.array(state.rotations[:nL], dtype=float)
    return LinkPoses(x, R, np.arctan2(R[:, 1, 0], R[:, 0, 0]))


def near_configuration(red: ReducedMechanism, table: bool = True, step1=None):
    """KSD steps 1-2 as the KSD-reduced solve does them: per group of joints its EOB, and the
    stiffness ``K`` (J, 6, 6), preload ``F_hat`` (J, 6), node B's near position ``p_hat`` (J, 3)
    and rotation ``R_hat`` (J, 3, 3) in the joint frames, and the intended rotations (J,).
    ``step1``: step 1's ``(theta, p_hat)`` as the solve found them (else step 1 is solved again)."""
    theta, p_hat = step1 if step1 is not None else solve_kinematics(red, tol=1e-10)[1:3]
    dim = red.dim
    emb = ACTIVE[dim]
    J = len(red.joint_names)
    K, Fh, eobs = np.zeros((J, 6, 6)), np.zeros((J, 6)), []
    for tpl, _, idx in red.groups:
        if table and tpl.lookup is not None and tpl.lookup.covers(theta[idx]):
            e = tpl.lookup(theta[idx], p_hat[idx, :dim])
        else:
            e = tpl.evaluate(theta[idx], p_hat[idx, :dim], held_a=True)
        K[idx[:, None, None], emb[:, None], emb] = e.K_T
        Fh[idx[:, None], emb] = e.F_hat_T
        eobs.append(e)
    return eobs, K, Fh, p_hat, rz(theta), theta


class _LookedUp:
    """A group's tabulated EOBs as the compiled solve keeps them (``[recover, node positions,
    node rotations]``, `flexmb.ksd.reduced_jit`): what the properties read of a tabulated `EOB`,
    the Craig-Bampton recovery ``recover`` (Jg, n_i, nd + 1); no element-level fields."""

    K_nodes = None

    def __init__(self, recover):
        self.recover = recover


_NEAR = weakref.WeakKeyDictionary()
def _database(solution, database):
    """``database``, or when None the folder the solve read (``solution.stages["setup"]``): the
    properties of a solve with ``database=FOLDER`` use that folder's fits, not the shipped ones."""
    if database is None:
        database = (solution.stages or {}).get("setup", {}).get("database")
    return None if database is None else os.fspath(database)


def near(solution, database=None):
    """The solution's `ReducedMechanism` and `near_configuration`, built once per solution and
    database (default: the one the solve used; a second property of the same solution skips it),
    from step 1's intended rotations and near positions that the solve keeps in
    ``solution.stages["kinematics"]`` (solving step 1 again took half of the manipulator's properties) and,
    with the solve's database, its `ReducedMechanism` and step 2's EOBs, stiffness and preload it
    keeps in ``solution.stages["eob"]["near"]`` (the same arrays `near_configuration` would
    rebuild; the set-up as the solve found it current)."""
    database = _database(solution, database)
    per = _NEAR.setdefault(solution, {})
    if database not in per:
        stages = solution.stages or {}
        step1 = stages.get("kinematics", {})
        step1 = (step1["theta"], step1["p_hat"]) if "theta" in step1 and "p_hat" in step1 else None
        step2 = stages.get("eob", {}).get("near")
        if step1 is not None and step2 is not None and database == _database(solution, None):
            red, eobs, K, Fh = step2  # the solve's own set-up and step 2, not computed again
            # the numba step 2 keeps a group's lookup as arrays [recover, positions, rotations]
            eobs = [_LookedUp(e[0]) if isinstance(e, (list, tuple)) else e for e in eobs]
            per[database] = red, (eobs, K, Fh, step1[1], rz(step1[0]), step1[0])
        else:
            if database is not None and not os.path.isdir(database):  # else the search passes it over silently
                raise ParameterError(f"the KSD properties of this {solution.method} solution read the database folder "
                                     f"{database!r}, which no longer exists (no such directory): the shipped or user "
                                     "data found instead need not be the fits the solve used. Restore the folder or "
                                     "solve again")
            red = reduced_mechanism(solution.compiled, database)  # the solve's own set-up, shared
            per[database] = red, near_configuration(red, step1=step1)
    return per[database]


def full_eobs(solution, database=None) -> list:
    """Per group of joints (`ReducedMechanism.groups`) the EOB at the solution's near
    configuration with its element-level fields (a tabulated one, `flexmb.ksd.eob_table`, has
    only the condensation), node A held; built once per solution."""
    red, (eobs, _, _, p_hat, _, theta) = near(solution, database)
    per = _NEAR[solution]
    key = ("full", _database(solution, database))
    if key not in per:
        per[key] = [e if getattr(e, "K_nodes", None) is not None else
                    tpl.evaluate(theta[idx], p_hat[idx, :red.dim], held_a=True)
                    for (tpl, _, idx), e in zip(red.groups, eobs)]
    return per[key]


def _interface_b(red, solution, p_hat, R_hat) -> np.ndarray:
    """Node B's displacement (J, nd) from its near pose at the solution, in the joint frames."""
    p, Rrel, _ = red.frames.relative(link_poses(red, solution.state))
    if jit.enabled():
        out = np.empty((len(p), len(ACTIVE[red.dim])))
        reduced_model_jit.interface_b(p, Rrel, np.ascontiguousarray(p_hat, dtype=float),
                                   np.ascontiguousarray(R_hat, dtype=float), ACTIVE[red.dim], out)
        return out
    return np.concatenate([p - p_hat, unskew(Rrel @ np.swapaxes(R_hat, 1, 2))], axis=1)[:, ACTIVE[red.dim]]


def node_displacements(solution, database=None) -> list:
    """Per group of joints the EOB node displacements (Jg, N nd) from the near poses at the
    solution (node A held: zero; node B from the links' poses; internal nodes by the
    Craig-Bampton recovery, Eq. 2.6), as KSD step 4 computes them."""
    red, (eobs, _, _, p_hat, R_hat, _) = near(solution, database)
    nd = len(ACTIVE[red.dim])
    xi_B = _interface_b(red, solution, p_hat, R_hat)
    out = []
    for (_, _, idx), e in zip(red.groups, eobs):
        xi = -(np.einsum("jab,jb->ja", e.recover[:, :, :nd], xi_B[idx]) + e.recover[:, :, nd])
        out.append(np.concatenate([np.zeros((len(idx), nd)), xi_B[idx], xi], axis=1))
    return out


def eob_axial_forces(solution, database=None):
    """The joint elements' axial forces [N] of a KSD-reduced solution from the EOBs' element
    forces ``F_all = K_all (L q - q_hat_all)`` (Eqs. 3.8-3.11, `EOBTemplate.axial_force`,
    tabulated: `flexmb.ksd.eob_forces`): ``(elements (k,), N (k,))``, tension positive. Step 4's
    positions are exact to first order only, and their second-order error along a leaf times
    its axial stiffness spoils the axial forces they imply (four-bar at d = 0.3 m, 5 el./leaf:
    2620 N against the converged 169 N; the EOB's within 1.4 N); the moments they imply are
    first-order accurate."""
    red, (eobs, _, _, p_hat, R_hat, theta) = near(solution, database)
    st = _static(red)
    if jit.enabled():  # the tabulated forces and the node displacements in one numba pass per group
        xi_B, values, q = _interface_b(red, solution, p_hat, R_hat), [], None
        b_position = np.ascontiguousarray(p_hat[:, :red.dim])
        for g, ((tpl, _, idx), e) in enumerate(zip(red.groups, eobs)):
            table = force_table(tpl)
            if table.covers(theta[idx]):
                p = table(theta[idx])
                out = np.empty((len(idx), tpl.n_elements))
                reduced_model_jit.eob_axial(np.ascontiguousarray(e.recover), xi_B, idx, tpl.element_dofs, p["A"],
                                         p["c0"], p["G"], b_position, out)
            else:
                q = node_displacements(solution, database) if q is None else q
                full = e if getattr(e, "K_nodes", None) is not None else None
                out = axial_forces(tpl, theta[idx], p_hat[idx, :red.dim], q[g], full)
            values.append(out.ravel())
        return st["elements"].copy(), np.concatenate(values)
    values = []
    for (tpl, _, idx), e, q in zip(red.groups, eobs, node_displacements(solution, database)):
        full = e if getattr(e, "K_nodes", None) is not None else None  # a tabulated one has no elements
        values.append(axial_forces(tpl, theta[idx], p_hat[idx, :red.dim], q, full).ravel())
    return st["elements"].copy(), np.concatenate(values)


def reduced_tangent(solution, database=None):
    """The KSD-reduced solution's tangent (n_links ndof, n_links ndof) on the links' FE DOFs
    (link k's DOFs ``k ndof ..``, as in the full model), symmetric up to the dead loads' part,
    and the `ReducedMechanism`; built once per solution (a copy each call). ``database``: a folder of joint data (default: the one the solve used)."""
    red, (_, K, Fh, p_hat, R_hat, _) = near(solution, database)
    key = ("tangent", _database(solution, database))
    per = _NEAR[solution]
    if key not in per:  # built once per solution: `flexmb.modes` and `flexmb.compliance` share it
        _, Kr = red.equilibrium(link_poses(red, solution.state), K, Fh, p_hat, R_hat, tangent=True)
        per[key] = Kr.copy() if _static(red)["whole"] else Kr[np.ix_(red.emb_dofs, red.emb_dofs)]  # 3D: all
    return per[key].copy(), red


def reduced_mass(solution, database=None) -> np.ndarray:
    """The KSD-reduced solution's mass (n_links ndof, n_links ndof) on the links' FE DOFs: each
    joint's condensed mass (`flexmb.ksd.joint_mass.condensed`), carried from its interface nodes to the links by the joint's
    current frame and the levers from the links' reference points, plus the links' rigid masses
    (`flexmb.fe.mass.rigid_mass`) at their current poses."""
    return reduced_modal_model(solution, 0, database)[1]


_STATIC = weakref.WeakKeyDictionary()


def _static(red: ReducedMechanism) -> dict:
    """What `reduced_modal_model` reads of a `ReducedMechanism` alone, gathered once: the joints
    by name, each group's joints' node DOFs (Jg, nodes ndof) and the links' 3D-form DOFs' places
    among their FE DOFs (``pos6`` (6 n_links,), -1: not a DOF of the planar model)."""
    out = _STATIC.get(red)
    if out is None:
        nd = len(red.active)
        pos6 = np.full(6 * red.n_links, -1, dtype=np.int64)
        pos6[red.emb_dofs] = np.arange(len(red.emb_dofs))
        dofs = [(np.array([red.joint_nodes[j] for j in idx])[:, :, None] * nd + np.arange(nd)).reshape(len(idx), -1)
                for _, _, idx in red.groups]
        elements = np.concatenate([np.concatenate([red.compiled.joint_elements[red.joint_names[j]] for j in idx])
                                   for _, _, idx in red.groups])
        out = _STATIC[red] = {"joints": {key: jt for key, jt, *_ in red.compiled.joints}, "pos6": pos6,
                              "elements": elements,
                              "dofs": dofs, "whole": bool(np.array_equal(red.emb_dofs, np.arange(6 * red.n_links)))}
    return out


def reduced_modal_model(solution, n_fixed: int, database=None, table: bool = True):
    """The KSD-reduced mechanism for free vibration: stiffness and mass (n, n) on the links' FE
    DOFs (n_links ndof) followed by ``n_fixed`` fixed-interface modal coordinates per joint (in
    joint order), and a function mapping a vector of those (n, k) to the full model's DOFs
    (n_dofs, k): links as they are, joint interiors from the Craig-Bampton transformation (the
    joints' ``X`` and fixed-interface shapes read from their tables on its first call).
    With the numba kernels the assembly is `flexmb.ksd.reduced_model_jit` (the same sums).
    ``table``: the joints' tabulated span of fixed-interface modes, else their Ritz eigenproblems
    at the configuration (`flexmb.ksd.joint_mass.condensed_subspace`: the same frequencies)."""
    red, (_, _, _, _, _, theta) = near(solution, database)
    st = _static(red)
    model = solution.compiled.problem.model
    nl = red.n_links * model.ndof
    compiled = jit.enabled()
    poses = link_poses(red, solution.state)
    G, pos, F = _joint_maps(red, poses, st, compiled)
    parts = [condensed_subspace(tpl, st["joints"][red.joint_names[idx[0]]], theta[idx], n_fixed, table,
                                recovery=False) for tpl, _, idx in red.groups]  # interior shapes: when to_full asks
    counts = tuple(ws.shape[1] for _, _, ws, _ in parts)  # modal coordinates per joint of each group
    if counts not in st:  # each joint's first modal coordinate, per kept counts
        nm = np.zeros(len(red.joint_names), dtype=np.int64)
        for (_, _, idx), c in zip(red.groups, counts):
            nm[idx] = c
        st[counts] = nm, nl + np.concatenate([[0], np.cumsum(nm)])
    nm, at = st[counts]
    n = int(at[-1])
    M = _modal_mass(red, st, parts, G, pos, nm, at, nl, compiled)
    K = np.zeros((n, n))
    K[:nl, :nl] = reduced_tangent(solution, database)[0]
    for (_, _, idx), (_, _, Kq, _) in zip(red.groups, parts):  # each joint's modal stiffness block
        for k, j in enumerate(idx):
            K[at[j]:at[j + 1], at[j]:at[j + 1]] = Kq[k]
    rigid = model.rigid_masses
    if rigid is not None and (rigid.node < red.n_links).any():
        on = rigid.node < red.n_links
        sub = RigidMasses(rigid.node[on], rigid.offset[on], rigid.mass[on], rigid.inertia[on])
        for d, blk in zip(model.node_dofs[sub.node], rigid_mass(model, solution.state, sub)):
            M[np.ix_(d, d)] += blk
    return K, 0.5 * (M + M.T), _recovery(red, st, parts, G, pos, F, at, n, model, compiled)


def _joint_maps(red, poses, st, compiled: bool):
    """Each joint's interface DOFs (A, B) in its frame from the links' twists: ``G`` (J, 2 nd, 12)
    on links a, b's twists placed by ``pos`` (J, 12) among the links' DOFs (compiled), or ``G``
    (J, 2 nd, 6 n_links) on all the links' twists (numpy, ``pos`` None); the joint frames ``F``."""
    fr = red.frames
    emb, nL, J = red.active, red.n_links, len(red.joint_names)
    nd = len(emb)
    if compiled:
        G, pos, F = np.empty((J, 2 * nd, 12)), np.empty((J, 12), dtype=np.int64), np.empty((J, 3, 3))
        reduced_model_jit.joint_maps(np.ascontiguousarray(poses.R, dtype=float), fr.a, fr.b, fr.s_a, fr.s_b, fr.P, emb,
                                  st["pos6"], F, G, pos)
        return G, pos, F
    oA, F = fr.frame_a(poses)
    arms = np.stack([oA - poses.x[fr.a], fr.relative(poses)[2]["rb"]], axis=1)  # (J, 2, 3): A, B from links a, b
    Ft = np.zeros((J, 6, 6))  # the joint frames' axes on both halves of a link twist
    Ft[:, :3, :3] = Ft[:, 3:, 3:] = np.swapaxes(F, 1, 2)
    levers = (Ft[:, None] @ lever(arms, 3))[..., emb, :]  # (J, 2, nd, 6)
    G = np.zeros((J, 2, nd, nL, 6))  # joint j's interface DOFs (A, B) from the links' twists
    ar = np.arange(J)
    G[ar, 0, :, fr.a] = levers[:, 0]
    G[ar, 1, :, fr.b] = levers[:, 1]
    return G.reshape(J, 2 * nd, 6 * nL), None, F


def _modal_mass(red, st, parts, G, pos, nm, at, nl: int, compiled: bool) -> np.ndarray:
    """The joints' condensed mass (n, n) on the links' DOFs and their modal coordinates (not yet
    symmetrised; the links' rigid masses not yet added)."""
    n = int(at[-1])
    M = np.zeros((n, n))
    if compiled:
        for (_, _, idx), (Mbs, Cs, _, _) in zip(red.groups, parts):
            reduced_model_jit.assemble_mass(G, pos, idx, Mbs, Cs, at, M)
        return M
    M6 = np.zeros((6 * red.n_links, 6 * red.n_links))
    for (_, _, idx), (Mbs, Cs, _, _) in zip(red.groups, parts):
        Gg = G[idx]
        M6 += (np.swapaxes(Gg, 1, 2) @ Mbs @ Gg).sum(axis=0)
        CG = (Cs @ Gg)[..., red.emb_dofs]
        for k, j in enumerate(idx):
            sl = slice(at[j], at[j + 1])
            M[sl, :nl], M[:nl, sl] = CG[k], CG[k].T
            M[sl, sl] = np.eye(nm[j])
    M[:nl, :nl] = M6 if st["whole"] else M6[np.ix_(red.emb_dofs, red.emb_dofs)]
    return M


def _recovery(red, st, parts, G, pos, F, at, n: int, model, compiled: bool):
    """The function mapping reduced vectors (n, k) to the full model's DOFs (n_dofs, k): links as
    they are, joint interiors by the Craig-Bampton transformation (read on its first call)."""
    nl = red.n_links * model.ndof
    nd = len(red.active)
    recovered = []

    def to_full(v):
        v = np.asarray(v, dtype=float).reshape(n, -1)
        k = v.shape[1]
        out = np.zeros((model.n_dofs, k))
        out[:nl] = v[:nl]
        dim = model.dim
        if not recovered:  # the joints' interior transformations (X, Phi), read once
            recovered.extend(rec() for *_, rec in parts)
        for (_, _, idx), (_, _, ws, _), (Xs, Phis), dofs in zip(red.groups, parts, recovered, st["dofs"]):
            if compiled:  # (a numba pass measured no faster on the manipulator)
                qb = G[idx] @ v[pos[idx]]  # (Jg, 2 nd, k): interface DOFs in the joint frames
            else:
                qb = G[idx][:, :, red.emb_dofs] @ v[:nl]
            eta = v[at[idx][:, None] + np.arange(ws.shape[1])]  # (Jg, m, k)
            q = (Xs @ qb + Phis @ eta).reshape(len(idx), -1, nd, k)  # interior DOFs in the joint frames
            Fg = F[idx]
            if dim == 3:  # both halves of each node's DOFs turned by the joint frame
                g = Fg[:, None, None] @ q.reshape(len(idx), -1, 2, 3, k)
            else:
                g = q.copy()
                g[:, :, :2] = Fg[:, None, :2, :2] @ q[:, :, :2]
            out[dofs.ravel()] = g.reshape(-1, k)
        return out

    return to_full


# -- step 3 in complex arithmetic (the design gradients' complex step) ---------------------------
#: ``Q.reshape(9) @ _DUNSKEW`` = ``0.5 (trace(Q) I - Q)`` flattened, d unskew(Q) / d omega (dQ = skew(omega) Q)
_DUNSKEW = 0.5 * (np.outer(np.eye(3).ravel(), np.eye(3).ravel()) - np.eye(9))

#: The numbers step 3's residual reads besides the fixed layout of a `ReducedMechanism`: the links'
#: positions ``x`` (n_links, 3) [m] and rotations ``R`` (n_links, 3, 3), the joints' frames ``s_a``,
#: ``s_b`` (J, 3) [m] and ``P`` (J, 3, 3), their near configuration ``K`` (J, 6, 6), ``Fh`` (J, 6),
#: ``p_hat`` (J, 3), ``R_hat`` (J, 3, 3), and the dead loads ``force``, ``moment``, ``offset`` (L, 3).
STEP3_INPUTS = ("x", "R", "s_a", "s_b", "P", "K", "Fh", "p_hat", "R_hat", "force", "moment", "offset")


def _unskew(S: np.ndarray) -> np.ndarray:
    """Axial vector of the skew part of ``S`` (..., 3, 3), complex-safe (`flexmb.rotations.unskew` is float)."""
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]],
                          axis=-1)


def relative_pose(red: ReducedMechanism, x, R, s_a, s_b, P):
    """The joints' relative poses ``p`` (..., J, 3), ``R_rel`` (..., J, 3, 3) and the frame axes and
    arms (``F``, ``Ft``, ``rb``, ``ra``) of `flexmb.ksd.geometry.JointFrames.relative`, from explicit
    frame numbers, stacked along leading axes and in complex arithmetic (a complex step through the
    placements): ``x`` (..., n_links, 3), ``R`` (..., n_links, 3, 3), ``s_a``, ``s_b`` (..., J, 3),
    ``P`` (..., J, 3, 3)."""
    a, b = red.frames.a, red.frames.b
    Ra, Rb = R[..., a, :, :], R[..., b, :, :]
    o_a = x[..., a, :] + (Ra @ s_a[..., None])[..., 0]
    rb = (Rb @ s_b[..., None])[..., 0]
    o_b = x[..., b, :] + rb
    F = Ra @ P
    Ft = np.swapaxes(F, -1, -2)
    p = (Ft @ (o_b - o_a)[..., None])[..., 0]
    return p, Ft @ Rb @ P, {"F": F, "Ft": Ft, "rb": rb, "ra": o_b - x[..., a, :]}


def step3(red: ReducedMechanism, inputs: dict, tangent: bool = True):
    """KSD step 3's residuals (B, 6 n_links) and tangents (B, 6 n_links, 6 n_links) of
    `ReducedMechanism.equilibrium` (the same terms, its numpy path) for B sets of the numbers
    `STEP3_INPUTS` stacked along a leading axis, in complex arithmetic: the complex step of the
    design gradients through the joints' frames, their near configuration and the loads, all
    parameters in one pass (`flexmb.design.reduced`). ``tangent`` False: None for it."""
    g = inputs
    B, J = len(g["K"]), len(red.joint_names)
    p, Rrel, geo = relative_pose(red, g["x"], g["R"], g["s_a"], g["s_b"], g["P"])
    Q = Rrel @ np.swapaxes(g["R_hat"], -1, -2)
    xi = np.concatenate([p - g["p_hat"], _unskew(Q)], axis=-1)
    w = (g["K"] @ xi[..., None])[..., 0] + g["Fh"]
    fm = (geo["F"][:, :, None] @ w.reshape(B, J, 2, 3, 1))[..., 0]  # force and moment on B, global axes
    S = skew(np.concatenate([fm, geo["rb"][:, :, None], geo["ra"][:, :, None]], axis=2))  # of f, mB, rb, ra
    f = fm[:, :, 0]
    m = fm[:, :, 1:] + (S[:, :, 2:] @ fm[:, :, :1, :, None])[..., 0]  # moments about b and a
    d = (g["R"][:, red.load_node] @ g["offset"][..., None])[..., 0]
    loads = np.concatenate([g["force"], g["moment"] + (skew(d) @ g["force"][..., None])[..., 0]], axis=-1)
    n = 6 * red.n_links
    r = _summed(red._r_at, np.concatenate([np.concatenate([f, m[:, :, 0], -f, -m[:, :, 1]], axis=-1).reshape(B, -1),
                                           -loads.reshape(B, -1)], axis=1), n)
    if not tangent:
        return r, None
    flat = {k: geo[k].reshape(B * J, *geo[k].shape[2:]) for k in ("Ft", "ra", "rb")}
    Jrel = red.frames.relative_jacobian(flat).reshape(B, J, 6, 12).astype(complex)
    Jrel[:, :, 3:] = (Q.reshape(B, J, 1, 9) @ _DUNSKEW).reshape(B, J, 3, 3) @ Jrel[:, :, 3:]
    D = geo["F"][:, :, None] @ (g["K"] @ Jrel).reshape(B, J, 2, 3, 12)  # d(f, mB)
    D[..., 3:6] -= S[:, :, :2]  # F turns with link a
    dm = D[:, :, 1:] + S[:, :, 2:] @ D[:, :, :1]
    dm[..., 9:12] += (S[:, :, 0] @ S[:, :, 2])[:, :, None]
    dm[:, :, 1, :, 0:3] += S[:, :, 0]
    dm[:, :, 1, :, 6:9] -= S[:, :, 0]
    blocks = np.concatenate([-D[:, :, 0], -dm[:, :, 1], D[:, :, 0], dm[:, :, 0]], axis=2)  # (B, J, 12, 12)
    entries = np.concatenate([blocks.reshape(B, -1), -(skew(g["force"]) @ skew(d)).reshape(B, -1)], axis=1)
    return r, _summed(red._K_at, entries, n * n).reshape(B, n, n)  # d(d x f)/dphi of loads at offsets last


def _summed(at: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """``out[b, at[i]] += values[b, i]`` (B, n), complex: `np.bincount` of the real and imaginary parts
    over the B rows at once (`np.add.at` is many times slower)."""
    B = len(values)
    flat = (np.arange(B)[:, None] * n + at[:values.shape[1]]).ravel()
    v = values.ravel()
    return (np.bincount(flat, v.real, minlength=B * n) + 1j * np.bincount(flat, v.imag, minlength=B * n)).reshape(B, n)


def step3_inputs(solution, database=None) -> dict:
    """`STEP3_INPUTS` of a KSD-reduced solution: its links' poses, the joints' frames, its near
    configuration (`near`) and the loads (3D form, float; `step3` takes them with a leading axis)."""
    red, (_, K, Fh, p_hat, R_hat, _) = near(solution, database)
    poses = link_poses(red, solution.state)
    fr = red.frames
    return {"x": poses.x, "R": poses.R, "s_a": fr.s_a, "s_b": fr.s_b, "P": fr.P, "K": K, "Fh": Fh, "p_hat": p_hat,
            "R_hat": R_hat, "force": red.load_force, "moment": red.load_moment, "offset": red.load_offset}
