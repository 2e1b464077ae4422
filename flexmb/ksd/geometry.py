"""Link poses and joint frames of the reduced mechanism (KSD steps 1 and 3).

The reduced mechanism has one node per rigid link. Its poses are kept in 3D form whatever the
mechanism's dimension: positions (n, 3) and rotation matrices (n, 3, 3) relative to the
undeformed configuration, updated with increments ``[dx, dphi]`` (6 per link, spatial spin
``R <- exp(skew(dphi)) R``). A planar mechanism uses only x, y and the spin about z
(`ACTIVE`), so one code path serves both.

A joint's frame sits on its side-A link: origin ``o_A = x_a + R_a s_a`` and axes ``F = R_a P``
(``P`` the placement rotation); interface node B is ``o_B = x_b + R_b s_b`` with axes
``R_b P``. The relative pose of B seen from A is ``p = F^T (o_B - o_A)`` and
``R_rel = F^T R_b P``; its variation is ``(dp, omega)`` with ``dR_rel = skew(omega) R_rel``.
"""

from __future__ import annotations

import attrs
import numpy as np

from .. import jit
from ..rotations import expm_so3, skew

__all__ = ["ACTIVE", "LinkPoses", "JointFrames", "rz", "intended_angle", "compose", "expm"]

_EYE = np.eye(3)

#: Increment components a link uses: planar (x, y, spin z) or spatial (all six).
ACTIVE = {2: np.array([0, 1, 5]), 3: np.arange(6)}


def _angle_map() -> np.ndarray:
    """(9, 8): flattened ``R @ map`` = (s, c, ds_x, ds_y, ds_z, dc_x, dc_y, dc_z) of `intended_angle`."""
    terms = [{3: 1, 1: -1}, {0: 1, 4: 1}, {6: -1}, {7: -1}, {0: 1, 4: 1}, {7: -1}, {6: 1}, {1: 1, 3: -1}]
    out = np.zeros((9, 8))
    for col, entries in enumerate(terms):
        for k, v in entries.items():
            out[k, col] = v
    return out


_ANGLE = _angle_map()


def _relative_maps():
    """``[ra, rb] @ arms + const`` (flattened (6, 12)) = ``[[-I, skew(ra), I, -skew(rb)], [0, -I, 0, I]]``."""
    const = np.zeros((6, 12))
    const[:3, 0:3] = const[3:, 3:6] = -_EYE
    const[:3, 6:9] = const[3:, 9:12] = _EYE
    arms = np.zeros((6, 6, 12))
    arms[:3, :3, 3:6] = skew(_EYE)
    arms[3:, :3, 9:12] = -skew(_EYE)
    return arms.reshape(6, 72), const.ravel()


_ARMS, _JREL0 = _relative_maps()


_compose3d = None  # flexmb.fe.model_jit.compose3d, bound on first use


def compose(w: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``exp(skew(w)) R`` for stacks of spins [rad] (..., 3) and rotations (..., 3, 3) of the same
    leading shape (Eq. A.8). With the numba kernels `flexmb.fe.model_jit.compose3d` (the same
    Rodrigues terms as `flexmb.rotations.expm_so3`, equal to 1e-15): numpy's calls on a few 3x3
    matrices cost several times the numba update."""
    global _compose3d
    if not jit.enabled():
        return expm_so3(w) @ R
    if _compose3d is None:  # numba is imported with the first kernel module only (flexmb.jit)
        from ..fe.model_jit import compose3d as _compose3d
    w = np.ascontiguousarray(w, dtype=float)
    out = np.empty(w.shape[:-1] + (3, 3))
    if R.shape != out.shape or not R.flags.c_contiguous or R.dtype != float:
        Rb = np.empty(out.shape)  # a copy costs less than np.broadcast_to
        Rb[...] = R
        R = Rb
    _compose3d(R.reshape(-1, 3, 3), w.reshape(-1, 3), out.reshape(-1, 3, 3))
    return out


def expm(w: np.ndarray) -> np.ndarray:
    """``exp(skew(w))`` of spins [rad] (..., 3): `compose` with identities."""
    return compose(w, _EYE) if jit.enabled() else expm_so3(w)


def rz(angle: np.ndarray) -> np.ndarray:
    """Rotation matrices about z, angles [rad] (...) -> (..., 3, 3)."""
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    return R


def intended_angle(R: np.ndarray):
    """Rotation about z of ``R`` (..., 3, 3) [rad] and its gradient with respect to a spin
    ``omega`` (``dR = skew(omega) R``), shape (..., 3). Exact for any tilt (atan2 of the
    in-plane block). A stack (J, 3, 3) with the numba kernels: `flexmb.ksd.reduced_jit.intended_angle`."""
    if R.ndim == 3 and jit.enabled():
        from . import reduced_jit

        theta, dtheta = np.empty(len(R)), np.empty((len(R), 3))
        reduced_jit.intended_angle(np.ascontiguousarray(R, dtype=float), theta, dtheta)
        return theta, dtheta
    # s = R10 - R01, c = R00 + R11 and their variations along skew(e_k) R, k = x, y, z
    sc = (R.reshape(R.shape[:-2] + (9,)) @ _ANGLE).swapaxes(-1, 0)
    s, c, ds, dc = sc[0], sc[1], sc[2:5].swapaxes(-1, 0), sc[5:8].swapaxes(-1, 0)
    n = s * s + c * c
    return np.arctan2(s, c), (c[..., None] * ds - s[..., None] * dc) / n[..., None]


@attrs.frozen(eq=False)
class LinkPoses:
    """Positions [m] (n, 3) and rotations (n, 3, 3) of the links, from the undeformed state, and
    the accumulated spin about z [rad] (n,): a planar link's angle, not wrapped to (-pi, pi]."""

    x: np.ndarray
    R: np.ndarray
    angle: np.ndarray

    def moved(self, dz: np.ndarray) -> LinkPoses:
        """Poses after increments ``dz`` (n, 6)."""
        dz = dz.reshape(-1, 6)
        return LinkPoses(self.x + dz[:, :3], compose(dz[:, 3:], self.R), self.angle + dz[:, 5])


@attrs.frozen(eq=False)
class JointFrames:
    """Where J joints attach: link indices ``a``, ``b`` (J,), offsets ``s_a``, ``s_b`` (J, 3) of
    the joint origin and of node B from the links' reference points (undeformed), placement
    rotations ``P`` (J, 3, 3)."""

    a: np.ndarray
    b: np.ndarray
    s_a: np.ndarray
    s_b: np.ndarray
    P: np.ndarray
    _ab: np.ndarray = attrs.field(init=False, repr=False)
    _s_ab: np.ndarray = attrs.field(init=False, repr=False)
    _P2: np.ndarray = attrs.field(init=False, repr=False)

    def __attrs_post_init__(self):
        object.__setattr__(self, "_ab", np.concatenate([self.a, self.b]))
        object.__setattr__(self, "_s_ab", np.concatenate([self.s_a, self.s_b])[..., None])
        object.__setattr__(self, "_P2", np.concatenate([self.P, self.P]))

    def frame_a(self, poses: LinkPoses):
        """Current joint frames: origins ``o_A`` (J, 3) and axes ``F`` (J, 3, 3)."""
        Ra = poses.R[self.a]
        return poses.x[self.a] + np.einsum("jik,jk->ji", Ra, self.s_a), Ra @ self.P

    def relative(self, poses: LinkPoses):
        """``p`` (J, 3), ``R_rel`` (J, 3, 3) and ``dict`` of intermediate vectors: the frame axes
        ``F`` and ``Ft = F^T`` (J, 3, 3), node B's arms ``rb`` from link b and ``ra`` from link a (J, 3).
        With the numba kernels `flexmb.ksd.reduced_jit.relative`."""
        if jit.enabled():
            from . import reduced_jit

            n = len(self.a)
            p, Rrel, F, rb, ra = np.empty((n, 3)), np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3))
            reduced_jit.relative(np.ascontiguousarray(poses.x, dtype=float), np.ascontiguousarray(poses.R, dtype=float),
                                 self.a, self.b, self.s_a, self.s_b, self.P, p, Rrel, F, rb, ra)
            return p, Rrel, {"F": F, "Ft": F.swapaxes(1, 2), "rb": rb, "ra": ra}
        Rab = poses.R.take(self._ab, axis=0)  # (2J, 3, 3): links a, then links b (take: cheaper than [])
        xab = poses.x.take(self._ab, axis=0)
        arm = (Rab @ self._s_ab)[..., 0]
        n = len(self.a)
        o = xab + arm
        RP = Rab @ self._P2  # F = R_a P, then R_b P
        F = RP[:n]
        Ft = F.swapaxes(1, 2)
        oB = o[n:]
        p = ((oB - o[:n])[:, None, :] @ F)[:, 0]
        return p, Ft @ RP[n:], {"F": F, "Ft": Ft, "rb": arm[n:], "ra": oB - xab[:n]}

    def relative_jacobian(self, geo: dict) -> np.ndarray:
        """``d(p, omega) / d(dx_a, dphi_a, dx_b, dphi_b)``, shape (J, 6, 12): ``diag(F^T, F^T)`` times
        ``[[-I, skew(ra), I, -skew(rb)], [0, -I, 0, I]]``."""
        Ft = geo["Ft"]
        C = np.concatenate([geo["ra"], geo["rb"]], axis=1) @ _ARMS + _JREL0
        return (Ft[:, None] @ C.reshape(-1, 2, 3, 12)).reshape(-1, 6, 12)
