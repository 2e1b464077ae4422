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

    _c: dict = attrs.field(init=False, repr=False)

    def __attrs_post_init__(self):
        # 2D vectors as complex numbers and rotations as unit complex numbers: far fewer numpy
        # calls per evaluation than (F, 2, 2) matrices, which is what costs at this size
        def z(v):
            return v[:, 0] + 1j * v[:, 1]

        object.__setattr__(self, "_c", {
            "s_i": z(self.s_i), "s_j": z(self.s_j), "b_i": z(self.B_i[:, :, 0]), "b_j": z(self.B_j[:, :, 0]),
            "a_f": z(self.A_f[:, :, 0]), "arm": z(self.arm), "p_hat": z(self.p_hat),
            "nl": self.nonlinear.astype(float), "b_j*": z(self.B_j[:, :, 0]).conj(),
            "b_ia_f": -z(self.B_i[:, :, 0]) * z(self.A_f[:, :, 0]),
        })

    def compiled_arrays(self) -> tuple:
        """The constants in the argument order of `flexmb.closed_form.linkage_jit` (fi ... nl),
        contiguous and typed for the numba loops."""
        c = self._c
        if "jit" not in c:  # built once: the flexures never change
            c["jit"] = (np.ascontiguousarray(self.i, dtype=np.int64), np.ascontiguousarray(self.j, dtype=np.int64),
                        *(np.ascontiguousarray(c[k], dtype=complex) for k in ("s_i", "s_j", "b_j", "b_j*", "b_ia_f",
                                                                             "arm", "p_hat")),
                        np.ascontiguousarray(self.K, dtype=float), np.ascontiguousarray(c["nl"], dtype=float))
        return c["jit"]

    def __len__(self) -> int:
        return len(self.i)

    def evaluate(self, positions: np.ndarray, angles: np.ndarray, tangent: bool = True) -> FlexureResponse:
        """Wrenches on both links and (if ``tangent``) the tangent terms, for links at
        ``positions`` (N, 2) [m] and ``angles`` (N,) [rad]."""
        c = self._c
        e = np.exp(1j * angles)
        P = positions[:, 0] + 1j * positions[:, 1]
        ei, ej = e[self.i], e[self.j]
        ai, aj = ei * c["s_i"], ej * c["s_j"]  # current attachment offsets
        ai_, aj_ = ai.conj(), aj.conj()
        p = P[self.j] + aj - P[self.i] - ai  # Eq. (4)
        u = ei.conj() * p  # A_i^T p
        x = c["b_j*"] * (u - c["p_hat"])  # Eqs. (5)-(6)
        nF = len(self.i)
        psi = np.empty((nF, 3))
        psi[:, 0], psi[:, 1] = x.real, x.imag
        psi[:, 2] = angles[self.j] - angles[self.i]  # Eqs. (7)-(8)
        w = (self.K @ psi[:, :, None])[:, :, 0]  # Eq. (1)
        Ft, Mt = w[:, 0] + 1j * w[:, 1], w[:, 2]
        arm_ = (c["arm"] + c["nl"] * x).conj()  # Eq. (15) or (17)
        Qj, Qi = ej * c["b_j"], ei * c["b_ia_f"]  # Qi includes the -A_f of T
        f_j = Qj * Ft  # link j: N_fj w (Eq. 22), global force and moment about r_j
        f_i = Qi * Ft  # link i: N_if T w; the clamp wrench in S_if is [-A_f F, -(M + arm x F)]
        wrench = np.empty((nF, 2, 3))
        wrench[:, 0, 0], wrench[:, 0, 1] = f_i.real, f_i.imag
        wrench[:, 0, 2] = (ai_ * f_i).imag - Mt - (arm_ * Ft).imag
        wrench[:, 1, 0], wrench[:, 1, 1] = f_j.real, f_j.imag
        wrench[:, 1, 2] = Mt + (aj_ * f_j).imag
        if not tangent:
            return FlexureResponse(psi, wrench)
        # Jacobian J (F, 3, 6) of psi on [r_i, theta_i, r_j, theta_j] (Eqs. 12-13, 37)
        g = c["b_j*"] * ei.conj()  # B_j^T A_i^T as a complex factor
        J = np.zeros((nF, 3, 6))
        J[:, 0, 0], J[:, 1, 0] = -g.real, -g.imag
        J[:, 0, 1], J[:, 1, 1] = g.imag, -g.real
        J[:, :2, 3:5] = -J[:, :2, 0:2]
        dti = -1j * c["b_j*"] * (u + c["s_i"])
        dtj = 1j * g * aj
        J[:, 0, 2], J[:, 1, 2] = dti.real, dti.imag
        J[:, 0, 5], J[:, 1, 5] = dtj.real, dtj.imag
        J[:, 2, 2], J[:, 2, 5] = -1.0, 1.0
        KJ = self.K @ J
        kf = KJ[:, 0] + 1j * KJ[:, 1]  # force rows of K J as complex numbers (F, 6)
        terms = np.zeros((3, nF, 2, 3, 6))
        # K^I (Eq. A2): link j rows N_fj K J, link i rows N_if T K J
        fj = Qj[:, None] * kf
        terms[0, :, 1, 0], terms[0, :, 1, 1] = fj.real, fj.imag
        terms[0, :, 1, 2] = KJ[:, 2] + (aj_[:, None] * fj).imag
        fi = Qi[:, None] * kf
        terms[0, :, 0, 0], terms[0, :, 0, 1] = fi.real, fi.imag
        terms[0, :, 0, 2] = (ai_[:, None] * fi).imag - KJ[:, 2] - (arm_[:, None] * kf).imag
        # K^II (Eq. A8): dN/dtheta w, in the column of the link's own angle
        terms[1, :, 0, 0, 2], terms[1, :, 0, 1, 2] = -f_i.imag, f_i.real
        terms[1, :, 1, 0, 5], terms[1, :, 1, 1, 5] = -f_j.imag, f_j.real
        # K^III (Eq. A13): only the clamp-side moment row, (1~ F)^T J_x (Eq. A11)
        terms[2, :, 0, 2] = c["nl"][:, None] * (Ft.real[:, None] * J[:, 1] - Ft.imag[:, None] * J[:, 0])
        return FlexureResponse(psi, wrench, terms)

    def strain_energy(self, positions: np.ndarray, angles: np.ndarray) -> float:
        """``sum 1/2 psi^T K psi`` over the flexures [J]."""
        psi = self.evaluate(positions, angles, tangent=False).psi
        return 0.5 * float(np.einsum("fa,fab,fb->", psi, self.K, psi))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@attrs.frozen(eq=False)
class FlexureResponse:
    """``psi`` (F, 3) deformations (Eq. 8); ``wrench`` (F, 2, 3) on links i and j (global force,
    moment about the link reference); ``terms`` (3, F, 2, 3, 6): the rows of K^I, K^II, K^III for
    links i and j over ``[r_i, theta_i, r_j, theta_j]``."""

    psi: np.ndarray
    wrench: np.ndarray
    terms: tuple | None = None
