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


def _basic(idx):
    """Indices (ascending ints) as a slice when evenly spaced: basic indexing is much cheaper than
    fancy indexing on these small arrays."""
    idx = np.array(idx, dtype=np.int64)
    step = idx[1] - idx[0] if len(idx) > 1 else 1
    if step > 0 and np.all(np.diff(idx) == step):
        return slice(int(idx[0]), int(idx[-1]) + 1, int(step))
    return idx


@functools.lru_cache(maxsize=256)
def _stacked(data, functions: tuple[str, ...]):
    """The trained ``functions`` of ``data`` and their derivatives as one polynomial: powers (2 P,)
    and coefficients (2 P, 2 n), the functions' terms over the union of their powers, then the
    derivatives' terms; functions in the first n columns, derivatives in the last n."""
    polys = [data.function(f) for f in functions]
    powers = np.unique(np.concatenate([f.powers for f in polys]))
    coef = np.zeros((len(polys), len(powers)))
    for i, f in enumerate(polys):
        coef[i, np.searchsorted(powers, f.powers)] = np.asarray(f.coefficients, dtype=float).ravel()
    P, n = len(powers), len(polys)
    out = np.zeros((2 * P, 2 * n))
    out[:P, :n], out[P:, n:] = coef.T, (coef * powers).T
    return np.concatenate([powers, np.maximum(powers - 1, 0)]), out


class ConstraintSet:
    """The constraints ``names`` of J joints sharing one database ``data``: ``D0`` (J,) and
    ``b0`` (J, 3), the undeformed position of node B. Everything that does not depend on the
    configuration is prepared once, so `values` and `gradients` are a handful of array operations."""

    def __init__(self, names, data, D0, b0):
        self.names = names = tuple(names)
        J, m = len(D0), len(names)
        self.inv = inv = 1.0 / np.asarray(D0, dtype=float)
        self._inv_col = inv[:, None]
        b0 = np.asarray(b0, dtype=float)
        # rows linear in p (x, y, z): p_c / D0 minus their rest value (only z is held at its
        # undeformed value, Sec. 4.1), constant gradient
        lin = [(k, "xyz".index(n)) for k, n in enumerate(names) if n in ("x", "y", "z")]
        self.lin, self.lin_c = (_basic(v) for v in zip(*lin)) if lin else (None, None)
        self.grad0 = np.zeros((J, m, 6))
        if lin:
            rows, comps = (list(v) for v in zip(*lin))
            self.lin_rest = np.where(np.array(comps) == 2, b0[:, 2:3], 0.0) * inv[:, None]
            self.grad0[:, rows, comps] = inv[:, None]
        # tilt rows: components c of R e_z; d(R e_z) = omega x (R e_z), so their gradient is
        # (R e_z) x e_c = e_z-column @ _TILT[c]
        tilt = [(k, int(n[-1] == "y")) for k, n in enumerate(names) if n in ("tilt_x", "tilt_y")]
        self.tilt, self.tilt_c = (_basic(v) for v in zip(*tilt)) if tilt else (None, None)
        if tilt:
            self.tilt_map = np.concatenate([_TILT[c] for _, c in tilt], axis=1)  # (3, 3 n_tilt)
        self.sym = names.index("symmetric") if "symmetric" in names else None
        self.len = names.index("length") if "length" in names else None
        n0 = cross([0.0, 0.0, 1.0], b0 * inv[:, None])
        m0 = cross([0.0, 0.0, 1.0], n0)  # d n0 / d angle about z
        self._nm = np.stack([n0, m0], axis=2) * inv[:, None, None]  # (J, 3, 2): (n0, m0) / D0
        fun = [k for k, n in enumerate(names) if n in _FUNCTION]
        self.fun = _basic(fun) if fun else None
        if fun:
            self.powers, self.coef = _stacked(data, tuple(_FUNCTION[names[k]] for k in fun))

    def values(self, p, R, theta):
        """Constraint values (J, m): ``p`` (J, 3) and ``R`` (J, 3, 3) the relative pose of node B,
        ``theta`` (J,) the intended rotation from `intended_angle`."""
        return self.evaluate(p, R, theta, None, deferred=True)[0]

    def gradients(self, p, R, theta, dtheta):
        """Gradients (J, m, 6) of `values` with respect to ``(dp, omega)``; ``dtheta`` (J, 3) the
        gradient of ``theta`` from `intended_angle`."""
        return self.evaluate(p, R, theta, dtheta, deferred=True)[1]()

    def evaluate(self, p, R, theta, dtheta, deferred: bool = False):
        """Values (J, m) and gradients (J, m, 6) with respect to ``(dp, omega)``; ``theta`` (J,)
        and ``dtheta`` (J, 3) from `intended_angle`. ``deferred=True`` returns a function that
        computes the gradients when called, from the work shared with the values."""
        inv = self.inv
        val = np.empty((len(inv), len(self.names)))
        if self.lin is not None:
            val[:, self.lin] = p[:, self.lin_c] * self._inv_col - self.lin_rest
        if self.tilt is not None:
            val[:, self.tilt] = R[:, self.tilt_c, 2]
        if self.sym is not None:  # p . n(theta/2) / D0, n = cos n0 + sin m0
            h = 0.5 * theta
            c, s = np.cos(h), np.sin(h)
            pq = (p[:, None] @ self._nm)[:, 0]  # p . (n0, m0) / D0
            val[:, self.sym] = c * pq[:, 0] + s * pq[:, 1]
        if self.len is not None:
            r = np.sqrt((p[:, None] @ p[..., None])[:, 0, 0])
            val[:, self.len] = r * inv - 1.0
        if self.fun is not None:
            poly = (theta[:, None] ** self.powers) @ self.coef  # (J, 2 n_fun): functions, derivatives
            nf = poly.shape[1] // 2
            val[:, self.fun] -= poly[:, :nf]

        def gradients():
            grad = self.grad0.copy()
            if self.tilt is not None:
                grad[:, self.tilt, 3:] = (R[:, :, 2] @ self.tilt_map).reshape(len(inv), -1, 3)
            if self.sym is not None:
                grad[:, self.sym, :3] = c[:, None] * self._nm[..., 0] + s[:, None] * self._nm[..., 1]
                # d n / d theta = (-sin n0 + cos m0) / 2
                grad[:, self.sym, 3:] = (0.5 * (c * pq[:, 1] - s * pq[:, 0]))[:, None] * dtheta
            if self.len is not None:
                grad[:, self.len, :3] = p * (inv / r)[:, None]
            if self.fun is not None:
                grad[:, self.fun, 3:] -= poly[:, nf:, None] * dtheta[:, None, :]
            return grad

        return (val, gradients) if deferred else (val, gradients())


def evaluate(names, data, p, R, theta, dtheta, D0, b0):
    """Values (J, m) and gradients (J, m, 6) with respect to ``(dp, omega)`` of the constraints
    ``names`` for J joints sharing one database ``data``; ``theta`` (J,) and ``dtheta`` (J, 3)
    from `intended_angle`, ``D0`` (J,), ``b0`` (J, 3) undeformed position of B."""
    return ConstraintSet(names, data, D0, b0).evaluate(p, R, theta, dtheta)
