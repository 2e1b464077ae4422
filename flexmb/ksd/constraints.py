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

import numpy as np

from ..errors import ModelError
from ..rotations import cross

__all__ = ["NAMES", "check_names", "ConstraintSet", "evaluate"]

NAMES = ("x", "y", "z", "tilt_x", "tilt_y", "symmetric", "length")
_FUNCTION = {"x": "x/D0", "y": "y/D0", "length": "D/D0-1"}


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


class ConstraintSet:
    """The constraints ``names`` of J joints sharing one database ``data``: ``D0`` (J,) and
    ``b0`` (J, 3), the undeformed position of node B. Everything that does not depend on the
    configuration is prepared once, so `evaluate` is a handful of array operations."""

    def __init__(self, names, data, D0, b0):
        self.names = tuple(names)
        J, m = len(D0), len(self.names)
        self.inv = inv = 1.0 / np.asarray(D0, dtype=float)
        # rows linear in p (x, y, z): constant gradient
        self.lin = [(k, "xyz".index(n)) for k, n in enumerate(self.names) if n in ("x", "y", "z")]
        self.tilt = [(k, n) for k, n in enumerate(self.names) if n in ("tilt_x", "tilt_y")]
        self.sym = self.names.index("symmetric") if "symmetric" in self.names else None
        self.len = self.names.index("length") if "length" in self.names else None
        self.n0 = cross([0.0, 0.0, 1.0], np.asarray(b0, dtype=float) * inv[:, None])
        self.fun = [(k, data.function(_FUNCTION[n])) for k, n in enumerate(self.names) if n in _FUNCTION]
        # offsets at rest of the rows linear in p: only z is held at its undeformed value
        self.rest = np.zeros((J, m))
        for k, c in self.lin:
            if c == 2:
                self.rest[:, k] = np.asarray(b0, dtype=float)[:, 2] * inv
        self.grad0 = np.zeros((J, m, 6))
        for k, c in self.lin:
            self.grad0[:, k, c] = inv

    def evaluate(self, p, R, theta, dtheta):
        """Values (J, m) and gradients (J, m, 6) with respect to ``(dp, omega)``; ``theta`` (J,)
        and ``dtheta`` (J, 3) from `intended_angle`."""
        inv = self.inv
        val = -self.rest
        grad = self.grad0.copy()
        for k, c in self.lin:
            val[:, k] += p[:, c] * inv
        for k, name in self.tilt:
            ez = R[:, :, 2]
            # d(R e_z) = omega x (R e_z): gradient of component c is (R e_z) x e_c
            if name == "tilt_x":
                val[:, k] = ez[:, 0]
                grad[:, k, 4], grad[:, k, 5] = ez[:, 2], -ez[:, 1]
            else:
                val[:, k] = ez[:, 1]
                grad[:, k, 3], grad[:, k, 5] = -ez[:, 2], ez[:, 0]
        if self.sym is not None:
            k, n0 = self.sym, self.n0
            h = 0.5 * theta
            c, s = np.cos(h), np.sin(h)
            n = np.empty_like(n0)
            n[:, 0], n[:, 1], n[:, 2] = c * n0[:, 0] - s * n0[:, 1], s * n0[:, 0] + c * n0[:, 1], n0[:, 2]
            val[:, k] = np.einsum("ji,ji->j", p, n) * inv
            grad[:, k, :3] = n * inv[:, None]
            # d n / d theta = (-n_y, n_x, 0) / 2
            grad[:, k, 3:] = (0.5 * (p[:, 1] * n[:, 0] - p[:, 0] * n[:, 1]) * inv)[:, None] * dtheta
        if self.len is not None:
            k = self.len
            d = np.sqrt(np.einsum("ji,ji->j", p, p))
            val[:, k] = d * inv - 1.0
            grad[:, k, :3] = p * (inv / d)[:, None]
        for k, f in self.fun:
            val[:, k] -= f(theta)
            grad[:, k, 3:] -= f.derivative(theta)[:, None] * dtheta
        return val, grad


def evaluate(names, data, p, R, theta, dtheta, D0, b0):
    """Values (J, m) and gradients (J, m, 6) with respect to ``(dp, omega)`` of the constraints
    ``names`` for J joints sharing one database ``data``; ``theta`` (J,) and ``dtheta`` (J, 3)
    from `intended_angle`, ``D0`` (J,), ``b0`` (J, 3) undeformed position of B."""
    return ConstraintSet(names, data, D0, b0).evaluate(p, R, theta, dtheta)
