"""Arrays of a joint that depend on its intended rotation alone, sampled once over the trained
range and splined (`SplinedTable`): the condensed mass (`flexmb.ksd.joint_mass`) and the EOB's
element axial forces (`flexmb.ksd.eob_forces`) of KSD-reduced properties. As
`flexmb.ksd.eob_table` does for the stiffness: degree-7 splines on a grid that starts at
`STEP_DEG` and is halved (to at most `FINEST_DEG`) until the spline reproduces the samples
half-way between to `TOL` relative to each array's largest entry.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from .. import jit

__all__ = ["SplinedTable", "STEP_DEG", "FINEST_DEG", "DEGREE", "TOL"]

STEP_DEG = 1.0  # first grid step [deg]
FINEST_DEG = 0.125  # finest grid step [deg]
DEGREE = 7  # spline degree
#: Interpolation error accepted, relative to each array's largest entry. Measured on the condensed
#: mass of three_x_infinity at 40 random rotations against direct condensation: 1 deg grid (built
#: once per joint template and process), M_b 1.8e-9, omega^2 2e-12; the 2D cross flexure
#: 0.5 deg, M_b 1.7e-8. 1e-9 would take a 0.5 deg grid and build times 2.6 times as long for
#: three_x_infinity, far below the reduction's own error (the frequencies' 0.2-0.6 %).
TOL = 1e-7


class SplinedTable:
    """``sample(theta (S,)) -> {name: (S, ...) array}`` splined over ``[lo, hi]`` [rad]; calling
    it at rotations (J,) gives ``{name: (J, ...)}`` (``names``: only those arrays, from their
    own copy of the coefficients: a call reads only what it returns). ``step``: the grid step
    used [deg]."""

    def __init__(self, sample, lo: float, hi: float):
        self.range = (lo, hi)
        step = STEP_DEG
        while True:
            theta = np.linspace(lo, hi, int(round((hi - lo) / np.radians(step))) + 1)
            parts = sample(theta)
            values = np.concatenate([v.reshape(len(theta), -1) for v in parts.values()], axis=1)
            spline = make_interp_spline(theta, values, k=DEGREE, axis=0)
            if step <= FINEST_DEG:
                break
            mid = 0.5 * (theta[1:] + theta[:-1])
            between, interpolated = sample(mid), spline(mid)
            worst = 0.0
            for name, v in parts.items():  # error relative to each array's largest entry
                at = slice(*self._at(parts, name))
                err = np.abs(interpolated[:, at] - between[name].reshape(len(mid), -1)).max(initial=0.0)
                worst = max(worst, float(err / max(np.abs(v).max(initial=0.0), 1e-300)))  # empty: a chain of no modes
            if worst <= TOL:
                break
            step /= 2
        self.step, self._spline = step, spline
        # knots, coefficients (contiguous) and degree as the numba evaluation reads them
        # (BSpline's ``c`` is a property, computed per read)
        self._tck = (spline.t, np.ascontiguousarray(spline.c), int(spline.k))
        self._shapes = {name: v.shape[1:] for name, v in parts.items()}
        self._slices, at = [], 0  # each array's columns among the spline's (not np.prod per call)
        for name, shape in self._shapes.items():
            size = int(np.prod(shape))
            self._slices.append((name, shape, at, at + size))
            at += size
        self._parts = {}  # names -> (BSpline, (t, c, k), slices) of those arrays' columns alone

    def _part(self, names: tuple):
        """The spline of the arrays ``names`` alone (their columns' coefficients contiguous)."""
        part = self._parts.get(names)
        if part is None:
            spans = {name: (shape, a, b) for name, shape, a, b in self._slices}
            cols = np.concatenate([np.arange(spans[n][1], spans[n][2]) for n in names])
            t, c, k = self._tck
            c = np.ascontiguousarray(c[:, cols])
            slices, at = [], 0
            for n in names:
                shape, a, b = spans[n]
                slices.append((n, shape, at, at + b - a))
                at += b - a
            part = self._parts[names] = (BSpline(t, c, k), (t, c, k), slices)
        return part

    @staticmethod
    def _at(parts, name):
        start = 0
        for key, v in parts.items():
            size = int(np.prod(v.shape[1:]))
            if key == name:
                return start, start + size
            start += size
        raise KeyError(name)

    def covers(self, theta: np.ndarray) -> bool:
        """Whether every ``theta`` [rad] lies on the table's range."""
        return bool(theta.min(initial=np.inf) >= self.range[0] and theta.max(initial=-np.inf) <= self.range[1])

    def __call__(self, theta: np.ndarray, names: tuple | None = None) -> dict:
        theta = np.asarray(theta, dtype=float)
        spline, tck, slices = (self._spline, self._tck, self._slices) if names is None else self._part(tuple(names))
        if jit.enabled() and theta.ndim == 1:  # compiled, row by row (flexmb.ksd.reduced_model_jit)
            from . import reduced_model_jit

            t, c, k = tck
            flat = np.empty((len(theta), c.shape[1]))
            reduced_model_jit.bspline_rows(t, c, k, theta, flat)
        else:
            flat = spline(theta)
        J = len(flat)
        return {name: flat[:, a:b].reshape((J,) + shape) for name, shape, a, b in slices}
