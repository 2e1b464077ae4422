"""The plausibility check's strains in one compiled call (`flexmb.plausibility`): the elements'
generalised stresses (`flexmb.fe.model_jit.assemble3d` / ``assemble2d`` without a tangent, the
kernels `flexmb.fe.model.FEModel.stresses` runs), their peak normal stress
(`flexmb.fe.stress_jit.peak_normal_stress`) and the elements of the largest strain and of the
largest stress over the yield stress (numpy's argmax: the first NaN, else the first largest).
The same kernels in the same order as the numpy-level calls, so the same floating-point results
(tests/test_solve_fused.py holds them equal). The manipulator's 81 elements: the check
~41 -> ~20 us of a KSD-reduced solve (16 us of it the element kernel), ~68 -> ~56 us after
gc.collect.
"""

from __future__ import annotations

import numpy as np

from .fe.model_jit import assemble2d, assemble3d
from .fe.stress_jit import peak_normal_stress
from .jit import njit

__all__ = ["strains3d", "strains2d"]


@njit
def _largest(sigma, E, ys):
    """numpy's argmax of ``sigma / E`` and of ``sigma / ys``, and those two ratios there."""
    best_s, best_y = 0, 0
    cur_s, cur_y = sigma[0] / E[0], sigma[0] / ys[0]
    nan_s, nan_y = cur_s != cur_s, cur_y != cur_y
    for k in range(1, len(sigma)):
        s, y = sigma[k] / E[k], sigma[k] / ys[k]
        if not nan_s:
            if s != s:
                best_s, nan_s = k, True
            elif s > cur_s:
                best_s, cur_s = k, s
        if not nan_y:
            if y != y:
                best_y, nan_y = k, True
            elif y > cur_y:
                best_y, cur_y = k, y
    return best_s, best_y, sigma[best_s] / E[best_s], sigma[best_y] / ys[best_y]


@njit
def strains3d(pos, rot, master, offset, moved, ny0, nz0, L0, S, dofs, n_dofs, A, ymax, Iz, zmax_Iy, ymax_Iz, circle,
              E, ys, sigma):
    """3D: fills ``sigma`` (E,) with the elements' peak normal stress in the state ``pos`` (N, 3),
    ``rot`` (N, 3, 3); returns the elements of the largest strain and stress over yield stress and
    those ratios (`_largest`); model arrays as `assemble3d`, section factors as `peak_normal_stress`."""
    nE, nm = len(L0), S.shape[2]
    sig, e, Fm = np.empty((nE, nm)), np.empty((nE, nm)), np.empty((nE, 12))
    assemble3d(pos, rot, master, offset, moved, ny0, nz0, L0, S, False, False, np.zeros((1, nm)), dofs,
               np.zeros((1, 1), dtype=np.int64), np.zeros(n_dofs), np.zeros(0), np.zeros(0), Fm, e, sig, np.empty(2))
    peak_normal_stress(sig, L0, A, ymax, Iz, zmax_Iy, ymax_Iz, circle, 3, sigma)
    return _largest(sigma, E, ys)


@njit
def strains2d(pos, rot, master, offset, moved, alpha0, L0, S, dofs, n_dofs, A, ymax, Iz, zmax_Iy, ymax_Iz, circle,
              E, ys, sigma):
    """2D: as `strains3d` with ``rot`` (N,) angles and `assemble2d`'s element data."""
    nE, nm = len(L0), S.shape[2]
    sig, e, Fm = np.empty((nE, nm)), np.empty((nE, nm)), np.empty((nE, 6))
    assemble2d(pos, rot, master, offset, moved, alpha0, L0, S, False, False, np.zeros((1, nm)), dofs,
               np.zeros((1, 1), dtype=np.int64), np.zeros(n_dofs), np.zeros(0), np.zeros(0), Fm, e, sig, np.empty(2))
    peak_normal_stress(sig, L0, A, ymax, Iz, zmax_Iy, ymax_Iz, circle, 2, sigma)
    return _largest(sigma, E, ys)
