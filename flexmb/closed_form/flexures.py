"""Constant-stiffness planar flexures between rigid links: deformation, wrenches and tangent terms.

Cammarata et al. (2022), Secs. 3.1-3.3 and Appendix A, vectorised over a batch of flexures.
Flexure f is clamped in link i (its first section S_if, joint side A) and its end section S_fj
sits on link j (side B). Links do not rotate in the undeformed configuration (theta_hat = 0),
so A_i = rot(theta_i) is also the rotation from rest. Per flexure, with ``q_ij = [r_i, theta_i,
r_j, theta_j]``:

* chord ``p = r_j + A_j s_j - r_i - A_i s_i`` (Eq. 4), its pull-back ``A_i^T p - p_hat`` (Eq. 5)
  in the undeformed end frame ``x' = B_j^T (A_i^T p - p_hat)`` (Eq. 6), ``phi = theta_j - theta_i``
  (Eq. 7); ``psi = [x', phi]`` (Eq. 8) and the end wrench ``w = K psi`` (Eq. 1);
* on link j: ``N_fj w`` (Eq. 22), on link i: ``N_if T w`` with ``T`` of Eq. 15 (linear model)
  or ``T'`` of Eq. 17 (partial non-linear: the arm is ``A_f^T d_f + x'``);
* tangent ``K_T = K^I + K^II + K^III`` (Eqs. 26-28): ``K^I = N T K J`` (Eq. A2), ``K^II`` the
  turning of N with the link (Eq. A8), ``K^III`` the moving arm of T' (Eq. A13).

Wrenches on links are global forces and moments about the link reference points.
"""

from __future__ import annotations

import attrs
import numpy as np

__all__ = ["FlexureSet", "FlexureResponse", "rot", "ONE_TILDE"]

#: The planar cross-product matrix of Eq. (14).
ONE_TILDE = np.array([[0.0, -1.0], [1.0, 0.0]])


def rot(theta) -> np.ndarray:
    """Rotation matrices (..., 2, 2) of angles ``theta`` [rad]."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _perp(v: np.ndarray) -> np.ndarray:
    """``1~ v`` for a batch of 2-vectors (..., 2)."""
    return np.stack([-v[..., 1], v[..., 0]], -1)


@attrs.frozen(eq=False)
class FlexureSet:
    """A batch of F flexures (geometry and stiffness, all constant).

    ``i``, ``j`` (F,) link indices of the first (clamped, side A) and end (side B) sections;
    ``s_i``, ``s_j`` (F, 2) their attachment points relative to the link reference points [m];
    ``B_i``, ``B_j`` (F, 2, 2) undeformed orientations of S_if and S_fj in global axes;
    ``A_f`` (F, 2, 2) rotation of S_fj relative to S_if, ``arm`` (F, 2) the chord
    ``A_f^T d_f`` in S_fj (Eq. 16), ``p_hat`` (F, 2) the undeformed chord in global axes (Eq. 3);
    ``K`` (F, 3, 3) end stiffness in S_fj; ``nonlinear`` (F,) True for the partial non-linear
    model (Eq. 17), False for the linear model (Eq. 15).
    """

    i: np.ndarray
    j: np.ndarray
    s_i: np.ndarray
    s_j: np.ndarray
    B_i: np.ndarray
    B_j: np.ndarray
    A_f: np.ndarray
    arm: np.ndarray
    p_hat: np.ndarray
    K: np.ndarray
    nonlinear: np.ndarray

    def __len__(self) -> int:
        return len(self.i)

    def evaluate(self, positions: np.ndarray, angles: np.ndarray, tangent: bool = True) -> FlexureResponse:
        """Wrenches on both links and (if ``tangent``) the tangent terms, for links at
        ``positions`` (N, 2) [m] and ``angles`` (N,) [rad]."""
        Ri, Rj = rot(angles[self.i]), rot(angles[self.j])
        ai = np.einsum("fab,fb->fa", Ri, self.s_i)  # current attachment offsets
        aj = np.einsum("fab,fb->fa", Rj, self.s_j)
        p = positions[self.j] + aj - positions[self.i] - ai  # Eq. (4)
        u = np.einsum("fba,fb->fa", Ri, p)  # A_i^T p
        x = np.einsum("fba,fb->fa", self.B_j, u - self.p_hat)  # Eqs. (5)-(6)
        phi = angles[self.j] - angles[self.i]  # Eq. (7)
        psi = np.concatenate([x, phi[:, None]], axis=1)  # Eq. (8)
        w = np.einsum("fab,fb->fa", self.K, psi)  # Eq. (1)
        F_t, M_t = w[:, :2], w[:, 2]
        arm = self.arm + np.where(self.nonlinear[:, None], x, 0.0)  # Eq. (15) or (17)
        # link j: N_fj w; force in global axes, moment about r_j (Eq. 22)
        Qj = Rj @ self.B_j
        f_j = np.einsum("fab,fb->fa", Qj, F_t)
        m_j = M_t + _cross(aj, f_j)
        # link i: N_if T w; the clamp wrench in S_if is [-A_f F, -(M + arm x F)]
        Qi = Ri @ self.B_i
        F_c = -np.einsum("fab,fb->fa", self.A_f, F_t)
        M_c = -(M_t + _cross(arm, F_t))
        f_i = np.einsum("fab,fb->fa", Qi, F_c)
        m_i = M_c + _cross(ai, f_i)
        wrench = np.stack([np.concatenate([f_i, m_i[:, None]], 1), np.concatenate([f_j, m_j[:, None]], 1)], 1)
        out = FlexureResponse(psi=psi, wrench=wrench)
        if not tangent:
            return out
        # Jacobian J (F, 3, 6) of psi on [r_i, theta_i, r_j, theta_j] (Eqs. 12-13, 37)
        nF = len(self)
        J = np.zeros((nF, 3, 6))
        BRi = np.einsum("fba,fcb->fac", self.B_j, Ri)  # B_j^T A_i^T
        J[:, :2, 0:2] = -BRi
        J[:, :2, 3:5] = BRi
        J[:, :2, 2] = -np.einsum("fba,fb->fa", self.B_j, _perp(u + self.s_i))
        J[:, :2, 5] = np.einsum("fab,fb->fa", BRi, _perp(aj))
        J[:, 2, 2], J[:, 2, 5] = -1.0, 1.0
        # N (F, 2, 3, 3): wrench in the section frame -> link wrench (Eq. 22)
        N = np.zeros((nF, 2, 3, 3))
        N[:, 0, :2, :2], N[:, 1, :2, :2] = Qi, Qj
        N[:, 0, 2, :2] = np.einsum("fa,fab->fb", _perp(ai), Qi)
        N[:, 1, 2, :2] = np.einsum("fa,fab->fb", _perp(aj), Qj)
        N[:, :, 2, 2] = 1.0
        T = np.zeros((nF, 3, 3))  # Eq. (15) / (17)
        T[:, :2, :2] = -self.A_f
        T[:, 2, :2] = -_perp(arm)
        T[:, 2, 2] = -1.0
        KJ = self.K @ J
        k1 = np.stack([N[:, 0] @ T @ KJ, N[:, 1] @ KJ], 1)  # (F, 2, 3, 6), Eq. (A2)
        k2 = np.zeros_like(k1)  # Eq. (A8): dN/dtheta w, in the column of the link's own angle
        k2[:, 0, :2, 2] = _perp(f_i)
        k2[:, 1, :2, 5] = _perp(f_j)
        k3 = np.zeros_like(k1)  # Eq. (A13): only the clamp-side moment row (N has [0, 0, 1] there)
        v = np.einsum("fa,fab->fb", _perp(F_t), J[:, :2, :])  # Eq. (A11)
        k3[:, 0, 2, :] = np.where(self.nonlinear[:, None], v, 0.0)
        return attrs.evolve(out, terms=(k1, k2, k3))

    def strain_energy(self, positions: np.ndarray, angles: np.ndarray) -> float:
        """``sum 1/2 psi^T K psi`` over the flexures [J]."""
        psi = self.evaluate(positions, angles, tangent=False).psi
        return 0.5 * float(np.einsum("fa,fab,fb->", psi, self.K, psi))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@attrs.frozen(eq=False)
class FlexureResponse:
    """``psi`` (F, 3) deformations (Eq. 8); ``wrench`` (F, 2, 3) on links i and j (global force,
    moment about the link reference); ``terms`` three arrays (F, 2, 3, 6): the rows of K^I, K^II,
    K^III for links i and j over ``[r_i, theta_i, r_j, theta_j]``."""

    psi: np.ndarray
    wrench: np.ndarray
    terms: tuple | None = None
