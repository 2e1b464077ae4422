"""Co-rotational 3D Timoshenko beam element of Dwarshuis et al. (2020), Appendix A (batched).

Nodal displacement vector per element (Eq. A.6): ``q = [dr_p, dphi_p, dr_q, dphi_q]`` (12,),
with spatial spins ``dphi`` (``dR = skew(dphi) R``, Eq. A.8). Deformations (Eq. A.4)::

    e1 = |L| - L0                                              elongation
    e2 = L0/2 (asin(nz_p . ny_q) - asin(ny_p . nz_q))          torsion
    e3 = -L0 asin(nz_p . nl),   e4 = L0 asin(nz_q . nl)        bending about local y
    e5 =  L0 asin(ny_p . nl),   e6 = -L0 asin(ny_q . nl)       bending about local z

``F = D^T sigma`` with ``sigma = S e`` (Eqs. A.13-A.18). The tangent is the exact derivative of
``F`` along the spin update: ``K = D^T S D + sum_i sigma_i dD_i/dq`` (material + geometric
part); ``D`` is derived from Eq. (A.4) with (A.9)-(A.10) since the paper's A.11c is damaged.
"""

from __future__ import annotations

import numpy as np

from .. import jit
from ..rotations import cross, skew
from ..sections import section_values, shear_factor

__all__ = ["local_stiffness", "deformations", "internal_force", "internal_force_and_tangent",
           "numpy_internal_force_and_tangent", "numpy_deformation_gradient", "length"]

_RP, _PP, _RQ, _PQ = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
_EYE = np.eye(3)


def local_stiffness(sections, L0: np.ndarray) -> np.ndarray:
    """Local stiffness matrices ``S`` (Eqs. A.14-A.16), shape (E, 6, 6).

    ``sections`` is a sequence of `flexmb.sections.Section`, one per element; ``L0`` [m] (E,).
    """
    L0 = np.asarray(L0, dtype=complex if np.iscomplexobj(L0) else float)  # complex: the complex step
    E, G, A, Iy, Iz, It, ky, kz = section_values(sections, ("E", "G", "A", "Iy", "Iz", "It", "ky", "kz"))
    S = np.zeros((len(L0), 6, 6), dtype=np.result_type(L0, E, G, A, Iy, Iz, It, ky, kz))
    S[:, 0, 0] = E * A / L0
    S[:, 1, 1] = G * It / L0**3
    for (i, j), EI, k in (((2, 3), E * Iy, kz), ((4, 5), E * Iz, ky)):
        if np.iscomplexobj(S):  # the complex step
            phi = shear_factor(12.0 * EI, k, G * A * L0**2)
        else:
            phi = 12.0 * EI / (k * G * A * L0**2)  # shear factor, Eq. (A.16); k = inf -> Euler-Bernoulli
        c = EI / ((1.0 + phi) * L0**3)
        S[:, i, i] = S[:, j, j] = c * (4.0 + phi)
        S[:, i, j] = S[:, j, i] = c * (-2.0 + phi)
    return S


def length(L):
    """``|L|`` of vectors (E, 3); for a complex step (`flexmb.design`) the analytic continuation
    ``sqrt(L . L)`` (``np.linalg.norm`` would take the modulus)."""
    return np.sqrt(np.einsum("ei,ei->e", L, L)) if np.iscomplexobj(L) else np.linalg.norm(L, axis=-1)


def _vectors(xp, xq, Rp, Rq, ny0, nz0):
    L = xq - xp
    l = length(L)
    nl = L / l[:, None]
    return (
        l,
        nl,
        np.einsum("eij,ej->ei", Rp, ny0),
        np.einsum("eij,ej->ei", Rp, nz0),
        np.einsum("eij,ej->ei", Rq, ny0),
        np.einsum("eij,ej->ei", Rq, nz0),
    )


def _dot(a, b):
    return np.einsum("ei,ei->e", a, b)


def deformations(xp, xq, Rp, Rq, ny0, nz0, L0) -> np.ndarray:
    """Deformations ``e`` of Eq. (A.4) [m], shape (E, 6); NaN where an arcsine leaves its domain."""
    l, nl, pyv, pzv, qyv, qzv = _vectors(xp, xq, Rp, Rq, ny0, nz0)
    with np.errstate(invalid="ignore"):
        return np.stack(
            [
                l - L0,
                0.5 * L0 * (np.arcsin(_dot(pzv, qyv)) - np.arcsin(_dot(pyv, qzv))),
                -L0 * np.arcsin(_dot(pzv, nl)),
                L0 * np.arcsin(_dot(qzv, nl)),
                L0 * np.arcsin(_dot(pyv, nl)),
                -L0 * np.arcsin(_dot(qyv, nl)),
            ],
            axis=-1,
        )


def _outer(a, b):
    return a[:, :, None] * b[:, None, :]


def internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, *, tangent: bool = True, geometric_stress=None):
    """Internal forces, tangent, deformations and stresses of a batch of elements: the compiled
    kernel (`flexmb.fe.beam3d_jit`) when `flexmb.jit.enabled`, else
    `numpy_internal_force_and_tangent` (its docstring has the arguments); equal to 1e-12."""
    if jit.enabled():
        from . import beam3d_jit  # imports numba: on first use, not with flexmb

        return beam3d_jit.internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent, geometric_stress)
    return numpy_internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent=tangent, geometric_stress=geometric_stress)


def numpy_internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, *, tangent: bool = True, geometric_stress=None):
    """Internal nodal forces ``F`` (E, 12) and tangent ``K`` (E, 12, 12) of a batch of elements.

    Parameters
    ----------
    xp, xq
        Node positions [m], shape (E, 3).
    Rp, Rq
        Node rotation matrices (rotation since the undeformed state), shape (E, 3, 3).
    ny0, nz0
        Undeformed local y and z unit vectors of each element (global axes), shape (E, 3).
    L0
        Undeformed length [m], shape (E,).
    S
        Local stiffness from `local_stiffness`, shape (E, 6, 6).
    geometric_stress
        A function of the elements' generalised stresses ``sigma`` (E, 6) returning those of the
        geometric part of ``K`` (``K = D^T S D + sum_i sigma_g,i dD_i/dq``); None: ``sigma``.

    Returns
    -------
    F, K, e, sigma
        ``K`` is None when ``tangent`` is False. ``e`` (E, 6) deformations, ``sigma = S e``.
        Rows of elements outside the formulation's validity (a node's axis 90 degrees or more
        from the chord, or the end sections twisted 90 degrees or more apart) are NaN. Complex
        arguments (a complex step, `flexmb.design`) give complex results, validity judged on the
        real parts; float ones the float path unchanged.
    """
    with np.errstate(divide="ignore", invalid="ignore"):  # invalid states come out as NaN rows
        return _internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent, geometric_stress)


def numpy_deformation_gradient(xp, xq, Rp, Rq, ny0, nz0, L0):
    """Deformations ``e`` (E, 6) of Eq. (A.4) and their gradient ``D = de/dq`` (E, 6, 12) with respect
    to the nodal displacements and spins (Eq. A.6; the ``D`` of `numpy_internal_force_and_tangent`,
    ``F = D^T sigma``); rows of invalid elements NaN in ``e``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return _internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, np.zeros((len(L0), 6, 6)), False,
                                           gradient=True)


def _elongation_hessian(Pl: np.ndarray, dt) -> np.ndarray:
    """Second derivative (E, 12, 12) of the elongation ``|L|`` in the element's DOFs, from ``(I - nl nl^T) / l``."""
    H1 = np.zeros((len(Pl), 12, 12), dtype=dt)
    H1[:, _RP, _RP] = H1[:, _RQ, _RQ] = Pl
    H1[:, _RP, _RQ] = H1[:, _RQ, _RP] = -Pl
    return H1


def _valid(Rp, Rq, ny0, nz0, nl, pyv, pzv, qyv, qzv) -> np.ndarray:
    """Which elements (E,) are within Eq. (A.4)'s validity: asin(c) cannot tell a rotation x from
    pi - x, so beyond 90 degrees between a node's axis and the chord (or between the two nodes'
    cross-sections) it has spurious equilibria; such states are marked invalid (NaN) and the
    solver cuts its step instead of landing there (complex arguments: judged on the real parts)."""
    nx0 = cross(ny0, nz0)
    return ((_dot(np.einsum("eij,ej->ei", Rp, nx0), nl).real > 0.0)
            & (_dot(np.einsum("eij,ej->ei", Rq, nx0), nl).real > 0.0)
            & ((_dot(pyv, qyv) + _dot(pzv, qzv)).real > 0.0))


def _internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent, geometric_stress=None, gradient=False):
    nE = len(L0)
    l, nl, pyv, pzv, qyv, qzv = _vectors(xp, xq, Rp, Rq, ny0, nz0)
    dt = np.result_type(l, pyv, qyv, L0, S)  # float64, or complex for a complex step (`flexmb.design`)
    P = _EYE - _outer(nl, nl)
    Dm = np.zeros((nE, 6, 12), dtype=dt)
    H = [None] * 6  # per-mode second-derivative matrices, (E, 12, 12) each, built lazily
    e = np.empty((nE, 6), dtype=dt)

    # -- mode 1: elongation
    e[:, 0] = l - L0
    Dm[:, 0, _RP], Dm[:, 0, _RQ] = -nl, nl
    Pl = P / l[:, None, None]
    if tangent:
        H[0] = _elongation_hessian(Pl, dt)

    def asin_rot_rot(row, coef, a, ia, b, ib):
        """Add coef * L0 * asin(a . b), a rotating with node block ia, b with block ib."""
        c = _dot(a, b)
        with np.errstate(invalid="ignore"):
            B = np.sqrt(1.0 - c * c)
            e[:, row] += coef * L0 * np.arcsin(c)
        g = np.zeros((nE, 12), dtype=dt)
        g[:, ia], g[:, ib] = cross(a, b), cross(b, a)
        s = coef * L0 / B
        Dm[:, row] += s[:, None] * g
        if tangent:
            Hc = np.zeros((nE, 12, 12), dtype=dt)
            cI = c[:, None, None] * _EYE
            Hc[:, ia, ia] = _outer(a, b) - cI
            Hc[:, ib, ib] = _outer(b, a) - cI
            Hc[:, ia, ib] = cI - _outer(b, a)
            Hc[:, ib, ia] = cI - _outer(a, b)
            Hr = s[:, None, None] * Hc + (s * c / B**2)[:, None, None] * _outer(g, g)
            H[row] = Hr if H[row] is None else H[row] + Hr

    def asin_rot_chord(row, coef, a, ia):
        """Add coef * L0 * asin(a . nl), a rotating with node block ia."""
        c = _dot(a, nl)
        with np.errstate(invalid="ignore"):
            B = np.sqrt(1.0 - c * c)
            e[:, row] = coef * L0 * np.arcsin(c)
        Pa = np.einsum("eij,ej->ei", P, a) / l[:, None]
        g = np.zeros((nE, 12), dtype=dt)
        g[:, ia], g[:, _RP], g[:, _RQ] = cross(a, nl), -Pa, Pa
        s = coef * L0 / B
        Dm[:, row] = s[:, None] * g
        if tangent:
            Hc = np.zeros((nE, 12, 12), dtype=dt)
            Hc[:, ia, ia] = _outer(a, nl) - c[:, None, None] * _EYE
            aP = skew(a) @ P / l[:, None, None]  # d(a x nl)/d r_q
            Hc[:, ia, _RQ], Hc[:, ia, _RP] = aP, -aP
            Pa_phi = np.swapaxes(aP, 1, 2)  # d(P a / l)/d phi = -P skew(a) / l = aP^T
            Hc[:, _RQ, ia], Hc[:, _RP, ia] = Pa_phi, -Pa_phi
            Hn = -(c[:, None, None] * Pl + _outer(nl, Pa) + _outer(Pa, nl)) / l[:, None, None]
            Hc[:, _RP, _RP] = Hc[:, _RQ, _RQ] = Hn
            Hc[:, _RP, _RQ] = Hc[:, _RQ, _RP] = -Hn
            H[row] = s[:, None, None] * Hc + (s * c / B**2)[:, None, None] * _outer(g, g)

    e[:, 1] = 0.0
    asin_rot_rot(1, 0.5, pzv, _PP, qyv, _PQ)
    asin_rot_rot(1, -0.5, pyv, _PP, qzv, _PQ)
    asin_rot_chord(2, -1.0, pzv, _PP)
    asin_rot_chord(3, 1.0, qzv, _PQ)
    asin_rot_chord(4, 1.0, pyv, _PP)
    asin_rot_chord(5, -1.0, qyv, _PQ)

    e[~_valid(Rp, Rq, ny0, nz0, nl, pyv, pzv, qyv, qzv)] = np.nan
    if gradient:
        return e, Dm
    sigma = np.einsum("eij,ej->ei", S, e)
    F = np.einsum("eij,ei->ej", Dm, sigma)
    if not tangent:
        return F, None, e, sigma
    K = np.swapaxes(Dm, 1, 2) @ (S @ Dm)
    sg = sigma if geometric_stress is None else geometric_stress(sigma)
    for i in range(6):
        K += sg[:, i, None, None] * H[i]
    return F, K, e, sigma


def internal_force(xp, xq, Rp, Rq, ny0, nz0, L0, S):
    """Internal nodal forces only, shape (E, 12); see `internal_force_and_tangent`."""
    return internal_force_and_tangent(xp, xq, Rp, Rq, ny0, nz0, L0, S, tangent=False)[0]
