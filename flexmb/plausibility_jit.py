"""The plausibility check's strains by numba kernels (`flexmb.plausibility`): the elements'
generalised stresses (`flexmb.fe.model_jit.assemble3d` / ``assemble2d`` without a tangent, the
kernels `flexmb.fe.model.FEModel.stresses` runs), their peak normal stress
(`flexmb.fe.stress_jit.peak_normal_stress`) and the elements of the largest strain and of the
largest stress over the yield stress (numpy's argmax: the first NaN, else the first largest).
The same kernels in the same order as the numpy-level calls, so the same floating-point results
(tests/test_solve_fused.py holds them equal).
"""

from __future__ import annotations

import numpy as np

from .fe.stress_jit import peak_normal_stress
from .jit import njit

__all__ = ["strains"]


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


def strains(model, state, L0, A, ymax, Iz, zmax_Iy, ymax_Iz, circle, E, ys, sigma):
    """Fills ``sigma`` (E,) with the elements' peak normal stress in ``state`` and returns the
    elements of the largest strain and stress over yield stress and those ratios (`_largest`):
    the generalised stresses by ``model.stresses`` (`flexmb.fe.model_jit.assemble3d` /
    ``assemble2d`` without a tangent: the specialisation every solve compiles anyway), then
    `flexmb.fe.stress_jit.peak_normal_stress` with the section factors. Three calls instead of one
    fused kernel: a fused one compiled its own copy of the element kernel (a third of the
    first solve's compilation) to save microseconds per check."""
    sig = np.ascontiguousarray(model.stresses(state)[1], dtype=float)
    peak_normal_stress(sig, L0, A, ymax, Iz, zmax_Iy, ymax_Iz, circle, model.dim, sigma)
    return _largest(sigma, E, ys)
