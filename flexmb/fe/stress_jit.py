"""Compiled peak normal stress of every element (`flexmb.fe.stress.peak_normal_stress`'s terms),
for the plausibility check every solve runs (`flexmb.plausibility`): numpy's ~12 calls on the
manipulator's 81 elements cost ~17 us of a ~0.3 ms KSD-reduced solve, this loop ~1 us (issue 21).
Held equal to the numpy function in tests/test_kernels.py.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit

__all__ = ["peak_normal_stress"]


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
