"""Kinematic constraints of a joint on its unintended motion (KSD step 1, Sec. 2.2).

A joint's constraints are named from this vocabulary (`flexmb.Joint.kinematic_constraints`);
each is a dimensionless function of the relative pose ``(p, R_rel)`` of node B seen from node A
(lengths over D0, the undeformed distance of the interface nodes) and of the intended rotation
``theta`` about the joint's z axis, with the trained functions of the joint database:

``x``, ``y``
    ``p_x / D0 - xbar(theta)``, ``p_y / D0 - ybar(theta)`` (Eq. 2.1).
``z``
    ``(p_z - b0_z) / D0``: no change of the offset along the axis (Sec. 4.1, first constraint;
    ``b0`` the undeformed position of B, in the plane of A for the cross flexure).
``tilt_x``, ``tilt_y``
    x and y components of ``R_rel e_z``: no rotation about x and y (Sec. 4.1).
``symmetric``
    ``p . n(theta/2) / D0`` with ``n = e_z x b0/|b0|`` turned by ``theta/2``: nodes A and B
    turn by equal and opposite angles with respect to the line AB (Sec. 4.1, fourth).
``length``
    ``|p| / D0 - 1 - g(theta)``, the even polynomial of Eq. (4.1) (Sec. 4.1, fifth).
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import ModelError
from ..rotations import cross

__all__ = ["NAMES", "check_names", "ConstraintSet", "evaluate"]

NAMES = ("x", "y", "z", "tilt_x", "tilt_y", "symmetric", "length")
_FUNCTION = {"x": "x/D0", "y": "y/D0", "length": "D/D0-1"}
#: (R e_z) @ _TILT[c] = (R e_z) x e_c, the gradient of tilt component c with respect to a spin
_TILT = -np.array([[[0, 0, 0], [0, 0, 1], [0, -1, 0]], [[0, 0, -1], [0, 0, 0], [1, 0, 0]]], dtype=float)


def check_names(where: str, names, dim: int) -> tuple[str, ...]:
    """Validate a joint's constraint names: known, distinct, one per unintended DOF."""
    names = tuple(names)
    need = 2 if dim == 2 else 5
    bad = [n for n in names if n not in NAMES]
    if bad or len(set(names)) != len(names) or len(names) != need:
        raise ModelError(f"{where}: kinematic constraints {names} must be {need} distinct names from {NAMES} "
                         f"(one per unintended direction of a {dim}D joint)")
    if dim == 2 and set(names) & {"z", "tilt_x", "tilt_y"}:
        raise ModelError(f"{where}: constraints z, tilt_x, tilt_y have no meaning in a planar mechanism")
    return names


@functools.lru_cache(maxsize=256)
def _stacked(data, functions: tuple[str, ...]):
    """The trained ``functions`` of ``data`` as one polynomial over the union of their powers:
    powers (P,), coefficients (P, n), and the same for the derivative."""
    polys = [data.function(f) for f in functions]
    powers = np.unique(np.concatenate([f.powers for f in polys]))
    coef = np.zeros((len(polys), len(powers)))
    for i, f in enumerate(polys):
        coef[i, np.searchsorted(powers, f.powers)] = np.asarray(f.coefficients, dtype=float).ravel()
    return powers, coef.T, np.maximum(powers - 1, 0), (coef * powers).T


class ConstraintSet:
    """The constraints ``names`` of J joints sharing one database ``data``: ``D0`` (J,) and
    ``b0`` (J, 3), the undeformed position of node B. Everything that does not depend on the
    configuration is prepared once, so `values` and `gradients` are a handful of array operations."""

    def __init__(self, names, data, D0, b0):
        self.names = names = tuple(names)
        J, m = len(D0), len(names)
        self.inv = inv = 1.0 / np.asarray(D0, dtype=float)
        b0 = np.asarray(b0, dtype=float)
        # rows linear in p (x, y, z): p_c / D0 minus their rest value (only z is held at its
        # undeformed value, Sec. 4.1), constant gradient
        lin = [(k, "xyz".index(n)) for k, n in enumerate(names) if n in ("x", "y", "z")]
        self.lin, self.lin_c = (np.array(v, dtype=np.int64) for v in zip(*lin)) if lin else (None, None)
        self.grad0 = np.zeros((J, m, 6))
        if lin:
            self.lin_rest = np.where(self.lin_c == 2, b0[:, 2:3], 0.0) * inv[:, None]
            self.grad0[:, self.lin, self.lin_c] = inv[:, None]
        # tilt rows: components c of R e_z; d(R e_z) = omega x (R e_z), so their gradient is
        # (R e_z) x e_c = e_z-column @ _TILT[c]
        tilt = [(k, n[-1] == "y") for k, n in enumerate(names) if n in ("tilt_x", "tilt_y")]
        self.tilt, self.tilt_c = (np.array(v, dtype=np.int64) for v in zip(*tilt)) if tilt else (None, None)
        if tilt:
            self.tilt_map = np.concatenate([_TILT[c] for c in self.tilt_c], axis=1)  # (3, 3 n_tilt)
        self.sym = names.index("symmetric") if "symmetric" in names else None
        self.len = names.index("length") if "length" in names else None
        self.n0 = n0 = cross([0.0, 0.0, 1.0], b0 * inv[:, None])
        self.m0 = cross([0.0, 0.0, 1.0], n0)  # d n0 / d angle about z
        fun = [k for k, n in enumerate(names) if n in _FUNCTION]
        self.fun = np.array(fun, dtype=np.int64)
        if fun:
            self.powers, self.coef, self.dpowers, self.dcoef = _stacked(data, tuple(_FUNCTION[names[k]] for k in fun))

    def _symmetric_normal(self, theta):
        """``n0`` turned by ``theta / 2`` about z, (J, 3)."""
        h = 0.5 * theta[:, None]
        return np.cos(h) * self.n0 + np.sin(h) * self.m0

    def values(self, p, R, theta):
        """Constraint values (J, m): ``p`` (J, 3) and ``R`` (J, 3, 3) the relative pose of node B,
        ``theta`` (J,) the intended rotation from `intended_angle`."""
        inv = self.inv
        val = np.empty((len(inv), len(self.names)))
        if self.lin is not None:
            val[:, self.lin] = p[:, self.lin_c] * inv[:, None] - self.lin_rest
        if self.tilt is not None:
            val[:, self.tilt] = R[:, self.tilt_c, 2]
        if self.sym is not None:
            val[:, self.sym] = np.einsum("ji,ji->j", p, self._symmetric_normal(theta)) * inv
        if self.len is not None:
            val[:, self.len] = np.sqrt(np.einsum("ji,ji->j", p, p)) * inv - 1.0
        if len(self.fun):
            val[:, self.fun] -= (theta[:, None] ** self.powers) @ self.coef
        return val

    def gradients(self, p, R, theta, dtheta):
        """Gradients (J, m, 6) of `values` with respect to ``(dp, omega)``; ``dtheta`` (J, 3) the
        gradient of ``theta`` from `intended_angle`."""
        inv = self.inv
        grad = self.grad0.copy()
        if self.tilt is not None:
            grad[:, self.tilt, 3:] = (R[:, :, 2] @ self.tilt_map).reshape(len(inv), -1, 3)
        if self.sym is not None:
            n = self._symmetric_normal(theta)
            grad[:, self.sym, :3] = n * inv[:, None]
            # d n / d theta = (-n_y, n_x, 0) / 2
            grad[:, self.sym, 3:] = (0.5 * (p[:, 1] * n[:, 0] - p[:, 0] * n[:, 1]) * inv)[:, None] * dtheta
        if self.len is not None:
            grad[:, self.len, :3] = p * (inv / np.sqrt(np.einsum("ji,ji->j", p, p)))[:, None]
        if len(self.fun):
            df = (theta[:, None] ** self.dpowers) @ self.dcoef  # (J, n_fun)
            grad[:, self.fun, 3:] -= df[:, :, None] * dtheta[:, None, :]
        return grad

    def evaluate(self, p, R, theta, dtheta):
        """Values (J, m) and gradients (J, m, 6) with respect to ``(dp, omega)``; ``theta`` (J,)
        and ``dtheta`` (J, 3) from `intended_angle`."""
        return self.values(p, R, theta), self.gradients(p, R, theta, dtheta)


def evaluate(names, data, p, R, theta, dtheta, D0, b0):
    """Values (J, m) and gradients (J, m, 6) with respect to ``(dp, omega)`` of the constraints
    ``names`` for J joints sharing one database ``data``; ``theta`` (J,) and ``dtheta`` (J, 3)
    from `intended_angle`, ``D0`` (J,), ``b0`` (J, 3) undeformed position of B."""
    return ConstraintSet(names, data, D0, b0).evaluate(p, R, theta, dtheta)
