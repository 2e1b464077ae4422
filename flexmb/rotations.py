"""Rotations in 2D and 3D: skew matrices, exponential and logarithmic maps (batched).

3D rotations are updated multiplicatively with a spatial spin, ``R <- exp(skew(dphi)) R``,
the convention of Dwarshuis et al. (2020), Eq. (A.8): ``dR = skew(dphi) R``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["skew", "unskew", "cross", "expm_so3", "logm_so3", "rot2"]

_EYE = np.eye(3)
#: ``w @ _SKEW`` is ``skew(w)`` flattened row by row
_SKEW = np.zeros((3, 3, 3))
_SKEW[0, 2, 1] = _SKEW[1, 0, 2] = _SKEW[2, 1, 0] = 1.0
_SKEW[0, 1, 2] = _SKEW[1, 2, 0] = _SKEW[2, 0, 1] = -1.0
_SKEW = _SKEW.reshape(3, 9)
#: ``R.reshape(9) @ _TRACE_AXIAL`` = (trace R, twice the axial vector of R's skew part)
_TRACE_AXIAL = np.concatenate([_EYE.reshape(9, 1), _SKEW.T], axis=1)


def _real_or_complex(a) -> type:
    """``complex`` for a complex array (the complex step of `flexmb.design`), else ``float``."""
    return complex if np.iscomplexobj(a) else float


def skew(w: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix of vectors, shape (..., 3) -> (..., 3, 3): ``skew(a) @ b = a x b``
    (complex vectors stay complex: the complex step of `flexmb.design`)."""
    w = np.asarray(w, dtype=_real_or_complex(w))
    return (w @ _SKEW).reshape(w.shape + (3,))


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for arrays of 3-vectors (...,3), broadcast; np.cross's generic path is slower
    on the small batches of the Newton loop."""
    return (skew(a) @ np.asarray(b, dtype=_real_or_complex(b))[..., None])[..., 0]


def unskew(S: np.ndarray) -> np.ndarray:
    """Axial vector of the skew part of ``S``, shape (..., 3, 3) -> (..., 3)."""
    S = np.asarray(S, dtype=float)
    return 0.5 * (S.reshape(S.shape[:-2] + (9,)) @ _SKEW.T)


def expm_so3(w: np.ndarray) -> np.ndarray:
    """Rotation matrices ``exp(skew(w))``, rotation vectors [rad] shape (..., 3).

    Rodrigues, ``cos t I + (sin t / t) skew(w) + (1 - cos t) / t^2 w w^T`` with ``t = |w|``;
    ``(1 - cos t) / t^2 = (sin h / h)^2 / 2`` (``h = t / 2``) has no cancellation at small ``t``
    (complex ``w``, a complex step: ``t = sqrt(w . w)``, the even functions of ``t`` continued
    analytically)."""
    w = np.asarray(w, dtype=_real_or_complex(w))
    row = w[..., None, :]
    t = np.maximum(np.sqrt(row @ w[..., :, None])[..., 0], 1e-300)  # (..., 1); sin(t)/t = 1 at t = 1e-300
    h = 0.5 * t
    s = np.sin(h) / h
    R = ((0.5 * s * s) * w)[..., :, None] * row
    R += ((np.sin(t) / t) * w @ _SKEW).reshape(R.shape)
    R += np.cos(t)[..., None] * _EYE
    return R


def logm_so3(R: np.ndarray) -> np.ndarray:
    """Rotation vectors [rad] of rotation matrices, shape (..., 3, 3) -> (..., 3), angle in [0, pi]
    (complex ``R = R0 + i h dR``, a complex step: `_logm_complex`)."""
    if np.iscomplexobj(R):
        return _logm_complex(np.asarray(R))
    R = np.asarray(R, dtype=float)
    tv = R.reshape(R.shape[:-2] + (9,)) @ _TRACE_AXIAL
    c = 0.5 * (tv[..., 0] - 1.0)  # cos(t)
    v = 0.5 * tv[..., 1:]  # sin(t) * axis
    s = np.sqrt(np.einsum("...i,...i->...", v, v))
    t = np.arctan2(s, c)  # accurate at every angle, unlike arccos(c) near 0
    w = (t / np.where(s > 0.0, s, 1.0))[..., None] * v
    near_pi = t > np.pi - 1e-3
    if np.any(near_pi):
        # sin(t) -> 0 at pi: take the axis from the symmetric part, R + I = 2 n n^T (1 - cos t) + ...
        B = 0.5 * (R + np.swapaxes(R, -1, -2)) - c[..., None, None] * np.eye(3)
        k = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), axis=-1)
        col = np.take_along_axis(B, k[..., None, None], axis=-1)[..., 0]
        n = col / np.linalg.norm(col, axis=-1, keepdims=True)
        n = np.where((np.einsum("...i,...i->...", n, v) < 0)[..., None], -n, n)
        w = np.where(near_pi[..., None], t[..., None] * n, w)
    return w


def _logm_complex(R: np.ndarray) -> np.ndarray:
    """`logm_so3` of ``R0 + i h dR`` to first order in ``h``: ``w0 + i h J_l(w0)^-1 s`` with the
    spin ``skew(s) = dR R0^T`` (``d exp(w) = skew(J_l(w) dw) exp(w)``, Chirikjian 2011, Eq. 10.86;
    ``J_l^-1 = I - W/2 + (1/t^2 - (1 + cos t) / (2 t sin t)) W^2``)."""
    R0 = R.real.copy()
    w0 = logm_so3(R0)
    s = unskew(np.einsum("...ij,...kj->...ik", R.imag, R0))  # dR R0^T is skew for a rotation's dR
    W = skew(w0)
    t = np.sqrt(np.einsum("...i,...i->...", w0, w0))[..., None, None]
    small = t < 1e-4
    tt = np.where(small, 1.0, t)
    c = np.where(small, 1.0 / 12.0 + t * t / 720.0, 1.0 / tt**2 - (1.0 + np.cos(tt)) / (2.0 * tt * np.sin(tt)))
    Jinv = np.eye(3) - 0.5 * W + c * (W @ W)
    return w0 + 1j * np.einsum("...ij,...j->...i", Jinv, s)


def chain_rotation(w: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """``exp(scale w_1) exp(scale w_2) ... exp(scale w_k)`` of rotation vectors ``w`` (k, 3) [rad]
    (complex ones, a complex step: the product in complex arithmetic)."""
    R = np.eye(3)
    for Ri in expm_so3(scale * np.asarray(w, dtype=_real_or_complex(w))):
        R = R @ Ri
    return R


def rot2(theta: np.ndarray) -> np.ndarray:
    """Planar rotation matrices, angles [rad] shape (...) -> (..., 2, 2) (complex angles stay complex)."""
    theta = np.asarray(theta, dtype=_real_or_complex(theta))
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
