"""Co-rotational planar Timoshenko beam: the in-plane restriction of Appendix A (batched).

Nodal displacements ``q = [dx_p, dy_p, dtheta_p, dx_q, dy_q, dtheta_q]``. Deformations::

    e1 = |L| - L0                 elongation
    e2 =  L0 psi_p                bending (Eq. A.4's e5: L0 asin(ny_p . nl) = L0 psi_p)
    e3 = -L0 psi_q                bending (Eq. A.4's e6)

where ``psi_k = beta - alpha0 - theta_k`` (wrapped to (-pi, pi]) is the angle from node k's
rotated axis to the chord at angle ``beta``. In the plane ``asin(ny . nl) = psi`` exactly while
``|psi| < 90 deg``; the angle form keeps the same element valid beyond that.
"""

from __future__ import annotations

import numpy as np

from .. import jit
from ..sections import section_values, shear_factor

__all__ = ["local_stiffness", "numpy_internal_force_and_tangent", "numpy_deformation_gradient",
           "internal_force_and_tangent", "hypot_atan2"]


def local_stiffness(sections, L0: np.ndarray) -> np.ndarray:
    """Local stiffness ``S`` (E, 3, 3): ``EA/L0`` and the in-plane bending block of Eq. (A.15) with ``Iz``."""
    L0 = np.asarray(L0, dtype=complex if np.iscomplexobj(L0) else float)  # complex: the complex step
    E, G, A, Iz, ky = section_values(sections, ("E", "G", "A", "Iz", "ky"))
    if np.iscomplexobj(L0) or np.iscomplexobj(E):  # the complex step (`section_values` is complex when any is)
        phi = shear_factor(12.0 * E * Iz, ky, G * A * L0**2)
    else:
        phi = 12.0 * E * Iz / (ky * G * A * L0**2)
    c = E * Iz / ((1.0 + phi) * L0**3)
    S = np.zeros((len(L0), 3, 3), dtype=np.result_type(L0, E, G, A, Iz, ky))
    S[:, 0, 0] = E * A / L0
    S[:, 1, 1] = S[:, 2, 2] = c * (4.0 + phi)
    S[:, 1, 2] = S[:, 2, 1] = c * (-2.0 + phi)
    return S


def _wrap(a):
    if np.iscomplexobj(a):  # complex step: the real part wrapped, the imaginary part carried
        return a - (a.real - _wrap(a.real))
    return np.arctan2(np.sin(a), np.cos(a))


def hypot_atan2(L):
    """``|L|`` and the angle of ``L`` (E, 2): ``np.hypot`` and ``np.arctan2`` for floats; for a complex
    step (`flexmb.design`) their analytic continuations, exact in the imaginary part to first order."""
    if not np.iscomplexobj(L):
        return np.hypot(L[:, 0], L[:, 1]), np.arctan2(L[:, 1], L[:, 0])
    x, y = L[:, 0], L[:, 1]
    r2 = x.real**2 + y.real**2
    return np.sqrt(x * x + y * y), np.arctan2(y.real, x.real) + 1j * (x.real * y.imag - y.real * x.imag) / r2


def internal_force_and_tangent(xp, xq, thp, thq, alpha0, L0, S, *, tangent: bool = True, geometric_stress=None):
    """Internal forces, tangent, deformations and stresses of a batch of elements: the compiled
    kernel (`flexmb.fe.beam2d_jit`) when `flexmb.jit.enabled`, else
    `numpy_internal_force_and_tangent` (its docstring has the arguments); equal to 1e-12."""
    if jit.enabled():
        from . import beam2d_jit  # imports numba: on first use, not with flexmb

        return beam2d_jit.internal_force_and_tangent(xp, xq, thp, thq, alpha0, L0, S, tangent, geometric_stress)
    return numpy_internal_force_and_tangent(xp, xq, thp, thq, alpha0, L0, S, tangent=tangent, geometric_stress=geometric_stress)


def numpy_deformation_gradient(xp, xq, thp, thq, alpha0, L0):
    """Deformations ``e`` (E, 3) and their gradient ``D = de/dq`` (E, 3, 6) with respect to the nodal
    displacements and rotations (the ``D`` of `numpy_internal_force_and_tangent`, ``F = D^T sigma``)."""
    return numpy_internal_force_and_tangent(xp, xq, thp, thq, alpha0, L0, np.zeros((len(L0), 3, 3)), tangent=False,
                                            gradient=True)


def numpy_internal_force_and_tangent(xp, xq, thp, thq, alpha0, L0, S, *, tangent: bool = True, geometric_stress=None,
                                     gradient: bool = False):
    """Internal forces ``F`` (E, 6) and tangent ``K`` (E, 6, 6) of planar co-rotational beams.

    ``xp, xq`` node positions [m] (E, 2); ``thp, thq`` node rotations since the undeformed state
    [rad] (E,); ``alpha0`` undeformed element angle [rad] (E,); ``L0`` [m]; ``S`` (E, 3, 3);
    ``geometric_stress``: a function of the elements' ``sigma`` (E, 3) returning the stresses of
    the geometric part of ``K`` (None: ``sigma``).
    Returns ``F, K, e, sigma`` (``K`` None when ``tangent`` is False). Complex arguments (a complex
    step, `flexmb.design`) give complex results; float ones the float path unchanged.
    """
    L = xq - xp
    l, beta = hypot_atan2(L)
    n = L / l[:, None]
    m = np.stack([-n[:, 1], n[:, 0]], axis=-1)  # n rotated by +90 degrees
    psi_p = _wrap(beta - alpha0 - thp)
    psi_q = _wrap(beta - alpha0 - thq)
    e = np.stack([l - L0, L0 * psi_p, -L0 * psi_q], axis=-1)

    nE = len(L0)
    dt = np.result_type(e, S)
    gb = np.zeros((nE, 6), dtype=dt)  # gradient of the chord angle beta
    gb[:, 0:2], gb[:, 3:5] = -m / l[:, None], m / l[:, None]
    D = np.zeros((nE, 3, 6), dtype=dt)
    D[:, 0, 0:2], D[:, 0, 3:5] = -n, n
    D[:, 1] = L0[:, None] * gb
    D[:, 1, 2] -= L0
    D[:, 2] = -L0[:, None] * gb
    D[:, 2, 5] += L0

    if gradient:  # numpy_deformation_gradient
        return e, D
    sigma = np.einsum("eij,ej->ei", S, e)
    F = np.einsum("eij,ei->ej", D, sigma)
    if not tangent:
        return F, None, e, sigma
    K = np.swapaxes(D, 1, 2) @ (S @ D)
    Hl = np.einsum("ei,ej->eij", m, m) / l[:, None, None]  # d2|L|/dL2
    Hb = -(np.einsum("ei,ej->eij", n, m) + np.einsum("ei,ej->eij", m, n)) / (l * l)[:, None, None]  # d2beta/dL2
    sg = sigma if geometric_stress is None else geometric_stress(sigma)
    Hr = sg[:, 0, None, None] * Hl + ((sg[:, 1] - sg[:, 2]) * L0)[:, None, None] * Hb
    K[:, 0:2, 0:2] += Hr
    K[:, 3:5, 3:5] += Hr
    K[:, 0:2, 3:5] -= Hr
    K[:, 3:5, 0:2] -= Hr
    return F, K, e, sigma
