"""Compiled stress kernels: `flexmb.fe.stress.perimeter_peaks`'s search (`perimeter_search`) and
the peak normal stress of every element (`peak_normal_stress`).

`perimeter_search`: the same coarse-then-fine search over a section's perimeter points, row by
row, the same floating-point operations in the same order (the numpy path's results to the last
bit; tests/test_stress.py holds them equal to 1e-12). The numpy path builds (rows, points)
temporaries for the coarse points and gathers the fine windows: 1.5 ms of the manipulator's 2 ms
`Solution.stresses` (162 element ends, two sections).

`peak_normal_stress`: `flexmb.fe.stress.peak_normal_stress`'s terms for the plausibility check
every solve runs (`flexmb.plausibility.peak_stress`): numpy's ~12 calls on the manipulator's 81
elements cost ~17 us of a ~0.3 ms KSD-reduced solve, this loop ~1 us (issue 21); held equal to
the numpy function in tests/test_kernels.py.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit

__all__ = ["perimeter_search", "peak_normal_stress"]


@njit
def _argmax(value, n):
    """numpy's argmax of ``value[:n]``: the first NaN if any, else the first largest."""
    best, cur = 0, value[0]
    if cur != cur:
        return 0
    for p in range(1, n):
        v = value[p]
        if v != v:
            return p
        if v > cur:
            best, cur = p, v
    return best


@njit
def perimeter_search(units, coarse_units, rows, A, Iy, Iz, step, out):
    """Per row of ``rows`` (R, 6) ``[N, Vy, Vz, T, My, Mz]`` the peak ``|sigma_x|``, ``|tau|^2``
    and von Mises stress squared over the perimeter points into ``out`` (R, 3): each searched on
    every ``step``-th point (``coarse_units``, the same every ``step``-th column of ``units``),
    then on the points within one step of the best coarse one. ``units`` (8, P): per point
    ``z/Iy``, ``y/Iz`` and the shear per unit torque, Vy, Vz (``tau_xy``, ``tau_xz`` each)."""
    P = units.shape[1]
    nc = coarse_units.shape[1]
    u = coarse_units
    coarse = np.empty((3, nc))
    nw = 2 * step + 1
    window = np.empty(nw)
    for i in range(rows.shape[0]):
        N, Vy, Vz, T, My, Mz = rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4], rows[i, 5]
        nA = N / A
        for c in range(nc):
            sx = nA + My * u[0, c] - Mz * u[1, c]
            t0 = T * u[2, c] + Vy * u[4, c] + Vz * u[6, c]
            t1 = T * u[3, c] + Vy * u[5, c] + Vz * u[7, c]
            t2 = t0 * t0 + t1 * t1
            coarse[0, c] = abs(sx)
            coarse[1, c] = t2
            coarse[2, c] = sx * sx + 3.0 * t2
        for k in range(3):
            best = _argmax(coarse[k], nc)
            peak = coarse[k, best]
            for w in range(nw):
                p = (best * step + w - step) % P
                if k != 1:
                    sx = nA + My * units[0, p] - Mz * units[1, p]
                if k != 0:
                    t0 = T * units[2, p] + Vy * units[4, p] + Vz * units[6, p]
                    t1 = T * units[3, p] + Vy * units[5, p] + Vz * units[7, p]
                    t2 = t0 * t0 + t1 * t1
                window[w] = abs(sx) if k == 0 else (t2 if k == 1 else sx * sx + 3.0 * t2)
            fine = window[_argmax(window, nw)]  # as np.max: NaN if any
            if peak != peak or fine != fine:
                out[i, k] = np.nan
            else:
                out[i, k] = peak if peak >= fine else fine


@njit
def peak_normal_stress(sig, L0, A, ymax, Iz, zmax_Iy, ymax_Iz, circle, dim, out):
    """Fills ``out`` (E,) with ``|N|/A`` plus the larger end's bending stress from the generalised
    stresses ``sig`` (E, modes): 2D ``|L0 sig_1,2| ymax / Iz``; 3D ``|My| zmax/Iy + |Mz| ymax/Iz``
    with ``My = L0 sig_2,3``, ``Mz = L0 sig_4,5`` (ends p, q), a circle ``hypot(My, Mz) ymax/Iz``
    (numpy's association order kept: the same floating-point result)."""
    for e in range(len(L0)):
        axial = abs(sig[e, 0]) / A[e]
        if dim == 2:
            bend = max(abs(L0[e] * sig[e, 1]), abs(L0[e] * sig[e, 2])) * ymax[e] / Iz[e]
        else:
            bend = -np.inf
            for end in range(2):
                My, Mz = L0[e] * sig[e, 2 + end], L0[e] * sig[e, 4 + end]
                if circle[e]:
                    b = np.hypot(My, Mz) * ymax_Iz[e]
                else:
                    b = abs(My) * zmax_Iy[e] + abs(Mz) * ymax_Iz[e]
                bend = max(bend, b)
        out[e] = axial + bend
