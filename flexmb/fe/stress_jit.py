"""Compiled stress kernels: `flexmb.fe.stress.perimeter_peaks`'s search (`perimeter_search`) and
the peak normal stress of every element (`peak_normal_stress`).

`perimeter_search`: the same coarse-then-fine search over a section's perimeter points, row by
row, the same floating-point operations in the same order (the numpy path's results to the last
bit; tests/test_stress.py holds them equal to 1e-12). The numpy path builds (rows, points)
temporaries for the coarse points and gathers the fine windows: 1.5 ms of the manipulator's 2 ms
`Solution.stresses` (162 element ends, two sections); compiled ~0.13 ms, of which the coarse
points (vectorised, `_coarse`) ~0.015 ms and the three running maxima per end most of the rest.

`peak_normal_stress`: `flexmb.fe.stress.peak_normal_stress`'s terms for the plausibility check
every solve runs (`flexmb.plausibility.peak_stress`): numpy's ~12 calls on the manipulator's 81
elements cost ~17 us of a ~0.3 ms KSD-reduced solve, this loop ~1 us (issue 21); held equal to
the numpy function in tests/test_kernels.py.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit

__all__ = ["perimeter_search", "peaks_per_element", "peak_normal_stress"]


@njit
def _wrap(p, P):
    """``p % P`` for ``-P <= p < 2 P`` (an integer division per fine point: 47 -> 39 us for the
    manipulator's 54 element ends of one section)."""
    if p < 0:
        return p + P
    if p >= P:
        return p - P
    return p


@njit
def _coarse(u0, u1, u2, u3, u4, u5, u6, u7, nA, Vy, Vz, T, My, Mz, a, t, v):
    """|sigma_x|, |tau|^2 and von Mises^2 at the coarse points (one loop LLVM vectorises)."""
    for c in range(len(a)):
        sx = nA + My * u0[c] - Mz * u1[c]
        t0 = T * u2[c] + Vy * u4[c] + Vz * u6[c]
        t1 = T * u3[c] + Vy * u5[c] + Vz * u7[c]
        t2 = t0 * t0 + t1 * t1
        a[c] = abs(sx)
        t[c] = t2
        v[c] = sx * sx + 3.0 * t2


@njit
def _argmax3(coarse, n, best):
    """numpy's argmax (the first NaN if any, else the first largest) of each row of ``coarse[:,
    :n]`` (3, n) in one pass, into ``best`` (3,)."""
    for k in range(3):
        best[k] = 0
    for p in range(1, n):
        for k in range(3):
            cur = coarse[k, best[k]]
            if cur != cur:  # a NaN found first: kept
                continue
            v = coarse[k, p]
            if v != v or v > cur:
                best[k] = p


@njit
def perimeter_search(units, coarse_units, rows, A, Iy, Iz, step, out):
    """Per row of ``rows`` (R, 6) ``[N, Vy, Vz, T, My, Mz]`` the peak ``|sigma_x|``, ``|tau|^2``
    and von Mises stress squared over the perimeter points into ``out`` (R, 3): each searched on
    every ``step``-th point (``coarse_units``, the same every ``step``-th column of ``units``),
    then on the points within one step of the best coarse one. ``units`` (8, P): per point
    ``z/Iy``, ``y/Iz`` and the shear per unit torque, Vy, Vz (``tau_xy``, ``tau_xz`` each).
    The three coarse maxima in one pass (`_argmax3`), each fine window's maximum as it is
    computed (the window's point index wrapped by one period; a NaN anywhere gives NaN, as before): the manipulator's two sections' 54 and 108
    element ends 47 -> 39 and 88 -> 75 us, the same numbers to the last bit."""
    P = units.shape[1]
    nc = coarse_units.shape[1]
    u = coarse_units
    coarse = np.empty((3, nc))
    nw = 2 * step + 1
    best = np.empty(3, dtype=np.int64)
    for i in range(rows.shape[0]):
        N, Vy, Vz, T, My, Mz = rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4], rows[i, 5]
        nA = N / A
        _coarse(u[0], u[1], u[2], u[3], u[4], u[5], u[6], u[7], nA, Vy, Vz, T, My, Mz,
                coarse[0], coarse[1], coarse[2])
        _argmax3(coarse, nc, best)
        for k in range(3):
            b = best[k]
            peak = coarse[k, b]
            start = b * step - step
            fine = -np.inf
            fnan = False
            if k == 0:
                for w in range(nw):
                    p = _wrap(start + w, P)
                    v = abs(nA + My * units[0, p] - Mz * units[1, p])
                    if v != v:
                        fnan = True
                    elif v > fine:
                        fine = v
            elif k == 1:
                for w in range(nw):
                    p = _wrap(start + w, P)
                    t0 = T * units[2, p] + Vy * units[4, p] + Vz * units[6, p]
                    t1 = T * units[3, p] + Vy * units[5, p] + Vz * units[7, p]
                    v = t0 * t0 + t1 * t1
                    if v != v:
                        fnan = True
                    elif v > fine:
                        fine = v
            else:
                for w in range(nw):
                    p = _wrap(start + w, P)
                    t0 = T * units[2, p] + Vy * units[4, p] + Vz * units[6, p]
                    t1 = T * units[3, p] + Vy * units[5, p] + Vz * units[7, p]
                    t2 = t0 * t0 + t1 * t1
                    sx = nA + My * units[0, p] - Mz * units[1, p]
                    v = sx * sx + 3.0 * t2
                    if v != v:
                        fnan = True
                    elif v > fine:
                        fine = v
            if peak != peak or fnan:
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


@njit
def peaks_per_element(out, per, normal, shear, vm):
    """`perimeter_search`'s rows (R, 3) reduced over each element's ``per`` consecutive rows
    (its ends) as numpy's ``max`` (a NaN gives NaN): the peak ``|sigma_x|`` into ``normal``, the
    square roots of the peak ``|tau|^2`` and von Mises squared into ``shear`` and ``vm`` (R / per,)
    (numpy's reshape, max and two sqrt: ~7 of ~50 us per section group)."""
    for e in range(len(normal)):
        for k in range(3):
            m = out[e * per, k]
            for r in range(1, per):
                v = out[e * per + r, k]
                if m != m:
                    break
                if v != v or v > m:
                    m = v
            if k == 0:
                normal[e] = m
            elif k == 1:
                shear[e] = np.sqrt(m)
            else:
                vm[e] = np.sqrt(m)
