"""Linearised properties of a KSD-reduced solution (issue 22 item 6): the reduced mechanism's
tangent on the links' DOFs, from which `flexmb.compliance` takes a link point's compliance.

The tangent is the Jacobian of the equilibrium KSD step 3 solves (`ReducedMechanism.equilibrium`):
each joint's Craig-Bampton stiffness ``K_T`` (node A held, Eq. 2.5) at its EOB near configuration
(the intended rotation and node B's position from step 1), carried to the links through the
joints' current frames (the moments of the joint wrenches about the links' reference points:
their geometric part), and the dead loads at offset points. The EOBs are rebuilt from step 1 as
the solve built them (the tabulated condensation where the solve used it), so the tangent is the
one the solve converged with. Rotation DOFs are spins (3D) or the angle (2D), as in the full model.
"""

from __future__ import annotations

import weakref

import numpy as np

from .geometry import ACTIVE, LinkPoses, rz
from .kinematics import solve_kinematics
from .reduced import ReducedMechanism

__all__ = ["reduced_tangent", "link_poses"]


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


def near_configuration(red: ReducedMechanism, table: bool = True):
    """KSD steps 1-2 as the KSD-reduced solve does them: per group of joints its EOB, and the
    stiffness ``K`` (J, 6, 6), preload ``F_hat`` (J, 6), node B's near position ``p_hat`` (J, 3)
    and rotation ``R_hat`` (J, 3, 3) in the joint frames, and the intended rotations (J,)."""
    _, theta, p_hat, _ = solve_kinematics(red, tol=1e-10)
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


_NEAR = weakref.WeakKeyDictionary()


def near(solution, database=None):
    """The solution's `ReducedMechanism` and `near_configuration`, built once per solution and
    database (measured on the manipulator: 7 ms of a 10 ms compliance; a second property of the
    same solution skips it)."""
    per = _NEAR.setdefault(solution, {})
    if database not in per:
        red = ReducedMechanism(solution.compiled, database)
        per[database] = red, near_configuration(red)
    return per[database]


def reduced_tangent(solution, database=None):
    """The KSD-reduced solution's tangent (n_links ndof, n_links ndof) on the links' FE DOFs
    (link k's DOFs ``k ndof ..``, as in the full model), symmetric up to the dead loads' part,
    and the `ReducedMechanism`. ``database``: the folder the solve used (default: shipped data)."""
    red, (_, K, Fh, p_hat, R_hat, _) = near(solution, database)
    poses = link_poses(red, solution.state)
    _, Kr = red.equilibrium(poses, K, Fh, p_hat, R_hat, tangent=True)
    return Kr[np.ix_(red.emb_dofs, red.emb_dofs)], red
