"""Compiled stress kernels: `flexmb.fe.stress.perimeter_peaks`'s search (`perimeter_search`) and
the peak normal stress of every element (`peak_normal_stress`).

`perimeter_search`: the same coarse-then-fine search over a section's perimeter points, row by
row, the same floating-point operations in the same order (the numpy path's results to the last
bit; tests/test_stress.py holds them equal to 1e-12). The numpy path builds (rows, points)
temporaries for the coarse points and gathers the fine windows, most of `Solution.stresses`;
the numba search keeps the fine windows contiguous, takes lane-wise maxima, searches NaN only
where a value could be NaN, lets an element's second end reuse its shear peak and inlines the
helpers (coarse points vectorised in `_coarse`). `element_peaks` goes from the elements'
generalised stresses to their peaks in one call (`flexmb.fe.stress.element_stresses`).

`peak_normal_stress`: `flexmb.fe.stress.peak_normal_stress`'s terms for the plausibility check
every solve runs (`flexmb.plausibility.peak_stress`): numpy's ~12 calls on the manipulator's 81
elements were a visible share of a KSD-reduced solve, this loop a small one; held equal to
the numpy function in tests/test_kernels.py.
"""

from __future__ import annotations

import numpy as np

from .. import jit
from ..jit import njit

def _inlined(fn):
    """`flexmb.jit.njit` with ``inline="always"``: the search's helpers inlined into their callers
    at numba's level (LLVM left them as calls)."""
    if not jit._AVAILABLE:  # pragma: no cover - the numpy path is used then
        return fn
    import numba

    return numba.njit(cache=True, error_model="numpy", fastmath=False, inline="always")(fn)


__all__ = ["perimeter_search", "element_peaks", "peaks_per_element", "peak_normal_stress"]


@_inlined
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


@_inlined
def _first_max(a, n):
    """numpy's argmax of ``a[:n]`` holding no NaN (the first largest): the largest value over
    eight independent running maxima (no loop-carried compare chain), then the first index holding it among the lanes that reach it."""
    if n < 16:
        b = 0
        for p in range(1, n):
            if a[p] > a[b]:
                b = p
        return b
    m0, m1, m2, m3, m4, m5, m6, m7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    n8 = n - n % 8
    for p in range(8, n8, 8):
        x = a[p]
        m0 = x if x > m0 else m0
        x = a[p + 1]
        m1 = x if x > m1 else m1
        x = a[p + 2]
        m2 = x if x > m2 else m2
        x = a[p + 3]
        m3 = x if x > m3 else m3
        x = a[p + 4]
        m4 = x if x > m4 else m4
        x = a[p + 5]
        m5 = x if x > m5 else m5
        x = a[p + 6]
        m6 = x if x > m6 else m6
        x = a[p + 7]
        m7 = x if x > m7 else m7
    m = max(max(max(m0, m1), max(m2, m3)), max(max(m4, m5), max(m6, m7)))
    tail = m
    for p in range(n8, n):
        tail = a[p] if a[p] > tail else tail
    b = n
    if tail == m:  # a lane holds the largest value: the first index among the lanes that reach it
        for lane, ml in enumerate((m0, m1, m2, m3, m4, m5, m6, m7)):
            if ml == m:
                for p in range(lane, min(b, n8), 8):
                    if a[p] == m:
                        b = p
                        break
        return b
    for p in range(n8, n):
        if a[p] == tail:
            return p
    return b


@_inlined
def _window_max(v, nw):
    """The largest of ``v[:nw]`` (each >= 0 or NaN) and whether one is NaN: four independent
    running maxima and NaN flags (no loop-carried chain of compares or sums)."""
    f0 = f1 = f2 = f3 = -np.inf
    nan = False
    n4 = nw - nw % 4
    for w in range(0, n4, 4):
        x0, x1, x2, x3 = v[w], v[w + 1], v[w + 2], v[w + 3]
        nan |= (x0 != x0) | (x1 != x1) | (x2 != x2) | (x3 != x3)
        f0 = x0 if x0 > f0 else f0
        f1 = x1 if x1 > f1 else f1
        f2 = x2 if x2 > f2 else f2
        f3 = x3 if x3 > f3 else f3
    for w in range(n4, nw):
        x0 = v[w]
        nan |= x0 != x0
        f0 = x0 if x0 > f0 else f0
    return max(max(f0, f1), max(f2, f3)), nan


@_inlined
def _search_row(units, u, umax, N, Vy, Vz, T, My, Mz, A, step, coarse, fine, best, reuse, out, i):
    """One row's three peaks into ``out[i]`` (`perimeter_search`); ``umax`` (8,): the largest
    ``|units|`` per field; ``reuse``: the previous row ``out[i - 1]`` has the same ``Vy, Vz, T``
    (its ``|tau|^2`` peak is this row's)."""
    nc = u.shape[1]
    nw = 2 * step + 1
    nA = N / A
    _coarse(u[0], u[1], u[2], u[3], u[4], u[5], u[6], u[7], nA, Vy, Vz, T, My, Mz,
            coarse[0], coarse[1], coarse[2])
    # a bound on every |sigma_x| and |tau| component: below 1e100 no value overflows, so none is NaN
    # (False for a NaN or an infinite section force: the values are searched for NaN)
    bound = max(abs(nA) + abs(My) * umax[0] + abs(Mz) * umax[1],
                abs(T) * max(umax[2], umax[3]) + abs(Vy) * max(umax[4], umax[5]) + abs(Vz) * max(umax[6], umax[7]))
    nan = False
    if not bound < 1e100:
        for k in range(3):
            for c in range(nc):
                nan |= coarse[k, c] != coarse[k, c]
    if nan:
        _argmax3(coarse, nc, best)
    else:
        best[0] = _first_max(coarse[0], nc)
        best[2] = _first_max(coarse[2], nc)
    same = reuse and Vy == out[i - 1, 3] and Vz == out[i - 1, 4] and T == out[i - 1, 5]
    if not nan and not same:
        best[1] = _first_max(coarse[1], nc)
    f0, f1, f2, f3, f4, f5, f6, f7 = units[0], units[1], units[2], units[3], units[4], units[5], units[6], units[7]
    for k in range(3):
        if k == 1 and same and not nan:
            out[i, 1] = out[i - 1, 1]  # the same shear field: the same numbers
            continue
        b = best[k]
        peak = coarse[k, b]
        s = b * step  # the window's first point, -step before point b step, in the padded columns
        if k == 0:
            for w in range(nw):
                fine[w] = abs(nA + My * f0[s + w] - Mz * f1[s + w])
        elif k == 1:
            for w in range(nw):
                t0 = T * f2[s + w] + Vy * f4[s + w] + Vz * f6[s + w]
                t1 = T * f3[s + w] + Vy * f5[s + w] + Vz * f7[s + w]
                fine[w] = t0 * t0 + t1 * t1
        else:
            for w in range(nw):
                t0 = T * f2[s + w] + Vy * f4[s + w] + Vz * f6[s + w]
                t1 = T * f3[s + w] + Vy * f5[s + w] + Vz * f7[s + w]
                t2 = t0 * t0 + t1 * t1
                sx = nA + My * f0[s + w] - Mz * f1[s + w]
                fine[w] = sx * sx + 3.0 * t2
        fmax, fnan = _window_max(fine, nw)
        if peak != peak or fnan:
            out[i, k] = np.nan
        else:
            out[i, k] = peak if peak >= fmax else fmax
    out[i, 3], out[i, 4], out[i, 5] = Vy, Vz, T


@_inlined
def _reduce_rows(out, r0, per, kt, normal, shear, vm, j):
    """``out[r0:r0 + per, :3]`` (`perimeter_search`'s rows of one element) reduced per column as
    numpy's ``max`` (a NaN gives NaN) into ``normal[j]``, ``shear[j]``, ``vm[j]``: the peak
    ``|sigma_x|`` and the square roots of the peak ``|tau|^2`` and von Mises squared, times ``kt``
    (1.0 leaves them bit for bit)."""
    for k in range(3):
        m = out[r0, k]
        for r in range(r0 + 1, r0 + per):
            v = out[r, k]
            if m == m and (v != v or v > m):
                m = v
        if k == 0:
            normal[j] = kt * m
        elif k == 1:
            shear[j] = kt * np.sqrt(m)
        else:
            vm[j] = kt * np.sqrt(m)


@njit
def perimeter_search(units, coarse_units, umax, rows, A, Iy, Iz, step, out):
    """Per row of ``rows`` (R, 6) ``[N, Vy, Vz, T, My, Mz]`` the peak ``|sigma_x|``, ``|tau|^2``
    and von Mises stress squared over the perimeter points into ``out[:, :3]`` (R, 6; the last
    three columns: the row's ``Vy, Vz, T``): each searched on every ``step``-th point
    (``coarse_units``, the same every ``step``-th column of ``units``), then on the points within
    one step of the best coarse one. ``units`` (8, P + 2 step): per point ``z/Iy``, ``y/Iz`` and
    the shear per unit torque, Vy, Vz (``tau_xy``, ``tau_xz`` each), padded by one step on each
    side with the points one period away (`flexmb.fe.stress._units`), so each fine window is
    contiguous; ``umax`` (8,) the largest ``|units|`` per field. The coarse maxima found after a
    NaN check (skipped where the section forces bound every value below overflow; `_argmax3` only
    with a NaN: numpy's first NaN), each fine window evaluated in one loop LLVM vectorises and then
    reduced (`_window_max`; a NaN anywhere gives NaN, as numpy); a row whose ``Vy, Vz, T`` equal
    the previous row's (an element's other end) reuses its ``|tau|^2`` peak, the same arithmetic
    on the same numbers, the same numbers to the last bit."""
    coarse = np.empty((3, coarse_units.shape[1]))
    fine = np.empty(2 * step + 1)
    best = np.empty(3, dtype=np.int64)
    for i in range(rows.shape[0]):
        _search_row(units, coarse_units, umax, rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4], rows[i, 5],
                    A, step, coarse, fine, best, i > 0, out, i)


@njit
def element_peaks(e, sig, L0, dim, group, units, coarse_units, umax, A, step, kt, out, normal, shear, vm):
    """`flexmb.fe.stress.element_stresses`'s peaks in one pass: per element its two ends' section
    forces from its deformations ``e`` and generalised stresses ``sig`` (E, modes) as
    `flexmb.fe.stress.section_resultants` forms them (the same operations; 2D: ``[N, Vy, 0, 0, 0,
    Mz]``), each end's `perimeter_search` with its group's ``units`` (G, 8, P + 2 step),
    ``coarse_units`` (G, 8, P / step), ``umax`` (G, 8) and area ``A`` (G,) (``group`` (E,)), the two ends reduced
    as `peaks_per_element` and times ``kt`` (E,) into ``normal``, ``shear``, ``vm`` (E,).
    ``out`` (2, 6): scratch."""
    coarse = np.empty((3, coarse_units.shape[2]))
    fine = np.empty(2 * step + 1)
    best = np.empty(3, dtype=np.int64)
    for j in range(len(L0)):
        g = group[j]
        U, C, M, a = units[g], coarse_units[g], umax[g], A[g]
        l = L0[j] + e[j, 0]
        N = sig[j, 0]
        if dim == 2:
            Vy = L0[j] * (sig[j, 1] - sig[j, 2]) / l
            _search_row(U, C, M, N, Vy, 0.0, 0.0, 0.0, L0[j] * sig[j, 1], a, step, coarse, fine, best, False, out, 0)
            _search_row(U, C, M, N, Vy, 0.0, 0.0, 0.0, L0[j] * sig[j, 2], a, step, coarse, fine, best, True, out, 1)
        else:
            Vy = L0[j] * (sig[j, 4] - sig[j, 5]) / l
            Vz = L0[j] * (sig[j, 3] - sig[j, 2]) / l
            T = L0[j] * sig[j, 1]
            _search_row(U, C, M, N, Vy, Vz, T, L0[j] * sig[j, 2], L0[j] * sig[j, 4], a, step, coarse, fine, best,
                        False, out, 0)
            _search_row(U, C, M, N, Vy, Vz, T, L0[j] * sig[j, 3], L0[j] * sig[j, 5], a, step, coarse, fine, best,
                        True, out, 1)
        _reduce_rows(out, 0, 2, kt[j], normal, shear, vm, j)


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
    (instead of numpy's reshape, max and two sqrt)."""
    for e in range(len(normal)):
        _reduce_rows(out, e * per, per, 1.0, normal, shear, vm, e)
