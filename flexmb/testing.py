"""Checks for plugin authors and the test suite: finite-difference tangents, perturbed states."""

from __future__ import annotations

import numpy as np

from .fe.model import State
from .problem import StaticProblem

__all__ = ["finite_difference_tangent", "perturbed_state", "scaled_error"]


def scaled_error(K: np.ndarray, Kfd: np.ndarray, diag_rows: np.ndarray, diag_cols: np.ndarray) -> float:
    """max |K - Kfd|_ij / sqrt(|d_i d_j|): translations and rotations weigh alike, so a wrong
    rotation-rotation entry of a thin leaf is not hidden by a large axial stiffness."""
    scale = np.sqrt(np.outer(np.abs(diag_rows), np.abs(diag_cols)))
    return float(np.max(np.abs(K - Kfd) / scale))


def finite_difference_tangent(problem: StaticProblem, state: State, lam: float = 1.0, step: float | None = None):
    """Analytic ``[K_ff | K_fp]`` and its central finite-difference counterpart at ``state``.

    Columns are ``(r(u + h e_j) - r(u - h e_j)) / 2h`` with the increment applied exactly as the
    solver does (positions add, rotations compose by the exponential map), so the comparison
    checks the tangent Newton actually uses. ``step`` defaults to ``1e-6`` times the model size
    for positions and ``1e-6`` rad for rotations. Returns ``(K_analytic, K_fd)`` as dense arrays of
    shape (n_free, n_free + n_prescribed): the free DOFs' columns first, then the prescribed ones.
    """
    model = problem.model
    size = float(np.ptp(model.x0, axis=0).max()) or 1.0
    _, Kff, Kfp, _ = problem.evaluate(state, lam)
    K = np.hstack([Kff.toarray(), Kfp.toarray()])
    Kfd = np.empty_like(K)
    for col, dof in enumerate(np.concatenate([problem.free, problem.prescribed])):
        h = step if step is not None else (1e-6 * size if dof % model.ndof < model.dim else 1e-6)
        du = np.zeros(model.n_dofs)
        du[dof] = h
        rp = problem.residual(model.apply_increment(state, du), lam)[problem.free]
        rm = problem.residual(model.apply_increment(state, -du), lam)[problem.free]
        Kfd[:, col] = (rp - rm) / (2.0 * h)
    return K, Kfd


def perturbed_state(problem: StaticProblem, state: State, rng: np.random.Generator, *, displacement: float,
                    rotation: float) -> State:
    """``state`` with random free-DOF increments: positions ~ ``displacement`` [m], rotations ~ ``rotation`` [rad]."""
    model = problem.model
    du = np.zeros(model.n_dofs)
    is_pos = (problem.free % model.ndof) < model.dim
    du[problem.free] = np.where(is_pos, displacement, rotation) * rng.standard_normal(len(problem.free))
    return model.apply_increment(state, du)
