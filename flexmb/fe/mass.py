"""Consistent mass of the co-rotational beam elements and of rigid bodies, at a configuration.

Formulation: the *Timoshenko-consistent* mass of Friedman & Kosmatka (1993, Comput. Struct. 47,
473-481): the kinetic energy ``1/2 int rho (A |v|^2 + I |psi'|^2) dx`` with the displacement
``v`` and section rotation ``psi`` interpolated by the same interdependent (IIE) shape functions
that give flexmb's Timoshenko stiffness exactly (Eq. A.16 with the shear factor
``phi = 12 EI / (k G A L0^2)``), so mass and stiffness belong to one element. For ``phi = 0``
it reduces to the Euler-Bernoulli consistent mass with rotary inertia of Przemieniecki (1968,
*Theory of Matrix Structural Analysis*, Sec. 11.3, Eqs. 11.29-11.31; Cook et al. 2002, Sec.
11.3): the translational ``rho A L/420 [156, 22L, 54, -13L; ...]`` plus ``rho I/(30 L)
[36, 3L, -36, 3L; ...]``. Axial and torsional motion take the linear-interpolation consistent
mass ``rho A L/6 [2 1; 1 2]`` and ``rho (Iy + Iz) L/6 [2 1; 1 2]``. The integrals are evaluated
by 4-point Gauss quadrature, exact for these degree-6 polynomials.

The local matrices are turned to global axes at the element's *current* co-rotated frame
(chord direction, mean cross-section axes of its two nodes; Crisfield 1997, Vol. 2, Sec. 17.8),
and moved from the element's end points to their master nodes with the rigid lever of
`FEModel` (``M_master = T^T M T``, exact for rigid offsets). At an equilibrium (zero velocities)
the co-rotational mass's configuration derivatives do not enter the linearised free vibration.

Rotation DOFs are the node's spins (spatial angular velocity components, 3D; the angle rate, 2D).
`element_mass` and `rigid_mass` carry complex numbers (the complex step of `flexmb.design`: its
model and state complex); float ones take the float path unchanged.
"""

from __future__ import annotations

import attrs
import numpy as np
import scipy.sparse as sp

from ..rotations import cross, rot2
from ..sections import section_values, shear_factor
from .assembly import SparsePattern
from .beam2d import hypot_atan2
from .beam3d import length as _length

__all__ = ["local_mass", "RigidMasses", "element_mass", "rigid_mass", "mass_matrix"]

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)
_XI, _W = 0.5 * (_GAUSS_X + 1.0), 0.5 * _GAUSS_W  # on [0, 1]


def _bending(rhoA, rhoI, L, phi):
    """Plane-bending mass (E, 4, 4) for DOFs ``[v1, theta1, v2, theta2]`` with ``theta = dv/dx``
    (Friedman & Kosmatka 1993, Eqs. 12-13 interpolation; ``phi`` the shear factor)."""
    x = _XI[None, :]
    c = 1.0 / (1.0 + phi)[:, None]
    Lc, p = L[:, None], phi[:, None]
    # displacement shape functions (E, 4 gauss, 4 dofs)
    Nv = np.stack([
        c * (1 - 3 * x**2 + 2 * x**3 + p * (1 - x)),
        c * Lc * (x - 2 * x**2 + x**3 + 0.5 * p * (x - x**2)),
        c * (3 * x**2 - 2 * x**3 + p * x),
        c * Lc * (-x**2 + x**3 - 0.5 * p * (x - x**2)),
    ], axis=-1)
    # section-rotation shape functions
    Np = np.stack([
        c * 6.0 * (x**2 - x) / Lc,
        c * (1 - 4 * x + 3 * x**2 + p * (1 - x)),
        -c * 6.0 * (x**2 - x) / Lc,
        c * (-2 * x + 3 * x**2 + p * x),
    ], axis=-1)
    w = _W[None, :, None, None] * L[:, None, None, None]
    Mv = np.sum(w * Nv[:, :, :, None] * Nv[:, :, None, :], axis=1)
    Mp = np.sum(w * Np[:, :, :, None] * Np[:, :, None, :], axis=1)
    return rhoA[:, None, None] * Mv + rhoI[:, None, None] * Mp


def _bar(coef, L):
    """Linear-interpolation consistent mass ``coef L/6 [2 1; 1 2]``, (E, 2, 2)."""
    return (coef * L / 6.0)[:, None, None] * np.array([[2.0, 1.0], [1.0, 2.0]])


def local_mass(sections, L0: np.ndarray, dim: int) -> np.ndarray:
    """Consistent mass matrices in the element's local axes (x along the chord, y and z its
    cross-section's principal axes), shape (E, 6, 6) in 2D (``[u, v, theta]`` per node) or
    (E, 12, 12) in 3D (``[u, v, w, theta_x, theta_y, theta_z]`` per node) [kg, kg m, kg m^2]."""
    L0 = np.asarray(L0, dtype=complex if np.iscomplexobj(L0) else float)  # complex: the complex step
    rho, E, G, A, Iy, Iz, ky, kz = section_values(sections, ("density", "E", "G", "A", "Iy", "Iz", "ky", "kz"))
    nE = len(L0)
    nd = 3 if dim == 2 else 6
    M = np.zeros((nE, 2 * nd, 2 * nd), dtype=np.result_type(L0, rho, E, G, A, Iy, Iz, ky, kz))
    ax = np.array([0, nd])
    M[:, ax[:, None], ax] = _bar(rho * A, L0)
    # bending in the x-y plane (v, theta_z = dv/dx): E Iz with shear coefficient ky, as the stiffness
    rz = 2 if dim == 2 else 5
    idx = np.array([1, rz, nd + 1, nd + rz])
    cplx = np.iscomplexobj(M)  # the complex step: k = inf kept (`flexmb.sections.shear_factor`)
    phi = shear_factor(12.0 * E * Iz, ky, G * A * L0**2) if cplx else 12.0 * E * Iz / (ky * G * A * L0**2)
    M[:, idx[:, None], idx] = _bending(rho * A, rho * Iz, L0, phi)
    if dim == 3:
        tw = np.array([3, 9])
        M[:, tw[:, None], tw] = _bar(rho * (Iy + Iz), L0)
        # bending in the x-z plane (w, theta_y = -dw/dx): E Iy with kz
        idx = np.array([2, 4, 8, 10])
        sign = np.array([1.0, -1.0, 1.0, -1.0])
        phi = shear_factor(12.0 * E * Iy, kz, G * A * L0**2) if cplx else 12.0 * E * Iy / (kz * G * A * L0**2)
        Mb = _bending(rho * A, rho * Iy, L0, phi)
        M[:, idx[:, None], idx] = sign[:, None] * Mb * sign
    return M


@attrs.frozen(eq=False)
class RigidMasses:
    """Rigid bodies attached to nodes (the links' own mass).

    ``node`` (K,) master node; ``offset`` (K, dim) undeformed offset of the centre of mass from
    the node [m]; ``mass`` (K,) [kg]; ``inertia`` about the centre of mass in the undeformed
    orientation: (K,) [kg m^2] in 2D (about z), (K, 3, 3) in 3D.
    """

    node: np.ndarray
    offset: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray

    @classmethod
    def of_bodies(cls, bodies, dim: int) -> RigidMasses | None:
        """From ``(node, mass, inertia, center)`` rows (checked values, e.g. `flexmb.Link` s);
        bodies without mass and inertia are left out; None when none is left."""
        rows = [b for b in bodies if np.real(b[1]) > 0 or np.any(np.asarray(b[2]) != 0)]
        if not rows:
            return None
        nrot = (len(rows), 3, 3) if dim == 3 else (len(rows),)
        centers = [np.zeros(dim) if r[3] is None else r[3] for r in rows]
        masses, inertias = [r[1] for r in rows], [r[2] for r in rows]
        dt = complex if any(np.iscomplexobj(x) for x in centers + masses + inertias) else float  # the complex step
        return cls(np.array([r[0] for r in rows], dtype=np.int64), np.array(centers, dtype=dt).reshape(-1, dim),
                   np.array(masses, dtype=dt), np.array(inertias, dtype=dt).reshape(nrot))


def _frames_3d(model, state, x, R):
    """Rows: the current co-rotated element axes (E, 3, 3): chord, mean section y, their cross."""
    el = model.elements
    ex = x[:, 1] - x[:, 0]
    ex = ex / _length(ex)[:, None]
    y = np.einsum("eij,ej->ei", R[:, 0] + R[:, 1], el.ny0)
    y = y - np.einsum("ei,ei->e", y, ex)[:, None] * ex
    y = y / _length(y)[:, None]
    return np.stack([ex, y, cross(ex, y)], axis=1)


def element_mass(model, state, local: np.ndarray | None = None) -> np.ndarray:
    """Element mass matrices (E, 2 ndof, 2 ndof) in global axes and master-node DOFs at ``state``
    (the layout of `FEModel.element_response`'s tangent). ``local``: `local_mass` if precomputed."""
    el, dim, nd = model.elements, model.dim, model.ndof
    if local is None:
        local = local_mass(el.sections, el.L0, dim)
    m = model.point_master[el.ends]
    d = model.offsets(state, m.ravel(), model.point_offset[el.ends].reshape(-1, dim))
    x = (state.positions[m.ravel()] + d).reshape(-1, 2, dim)
    nE = len(el.L0)
    if dim == 2:
        chord = x[:, 1] - x[:, 0]
        lam = rot2(hypot_atan2(chord)[1]).transpose(0, 2, 1)  # rows: local axes
        blk = np.zeros((nE, 3, 3), dtype=lam.dtype)
        blk[:, :2, :2], blk[:, 2, 2] = lam, 1.0
    else:
        lam = _frames_3d(model, state, x, state.rotations[m])
        blk = np.zeros((nE, 6, 6), dtype=lam.dtype)
        blk[:, :3, :3] = blk[:, 3:, 3:] = lam
    T = np.zeros((nE, 2 * nd, 2 * nd), dtype=np.result_type(blk, d))
    lever = model._lever(d).reshape(nE, 2, nd, nd)
    T[:, :nd, :nd] = blk @ lever[:, 0]
    T[:, nd:, nd:] = blk @ lever[:, 1]
    return np.swapaxes(T, 1, 2) @ local @ T


def rigid_mass(model, state, rigid: RigidMasses) -> np.ndarray:
    """Mass blocks (K, ndof, ndof) of the rigid bodies at their master nodes at ``state``:
    ``T^T diag(m I, J) T`` with ``J = R J0 R^T`` and the lever ``T`` of the current offset ``R s``."""
    dim, nd = model.dim, model.ndof
    K = len(rigid.node)
    d = model.offsets(state, rigid.node, rigid.offset)
    Mc = np.zeros((K, nd, nd), dtype=np.result_type(d, rigid.mass, rigid.inertia))
    Mc[:, range(dim), range(dim)] = rigid.mass[:, None]
    if dim == 2:
        Mc[:, 2, 2] = rigid.inertia
    else:
        R = state.rotations[rigid.node]
        Mc[:, 3:, 3:] = R @ rigid.inertia @ R.transpose(0, 2, 1)
    T = model._lever(d)
    return np.swapaxes(T, 1, 2) @ Mc @ T


def mass_matrix(model, state, rigid: RigidMasses | None = None) -> sp.csr_array:
    """The assembled mass matrix (N ndof, N ndof) [kg, kg m, kg m^2] of beams and rigid bodies at
    ``state`` (symmetric positive semi-definite; definite on DOFs that carry mass)."""
    Me = element_mass(model, state)
    rows_e = model.element_dofs
    parts_r, parts_v = [rows_e], [Me]
    if rigid is not None and len(rigid.node):
        parts_r.append(model.node_dofs[rigid.node])
        parts_v.append(rigid_mass(model, state, rigid))
    rows = np.concatenate([np.broadcast_to(r[:, :, None], r.shape + r.shape[1:]).ravel() for r in parts_r])
    cols = np.concatenate([np.broadcast_to(r[:, None, :], r.shape + r.shape[1:]).ravel() for r in parts_r])
    vals = np.concatenate([v.ravel() for v in parts_v])
    M = SparsePattern(rows, cols, (model.n_dofs, model.n_dofs)).matrix(vals)
    return (M + M.T) * 0.5  # exact symmetry (the products above are symmetric to roundoff)
