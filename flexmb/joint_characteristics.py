"""Characteristics of a single joint from its finite-element model: stiffness of node B relative
to node A in every direction at a given intended rotation, and how well it supports the
unintended directions."""

from __future__ import annotations

import numpy as np

from ._warnings import renamed
from .errors import ConvergenceError, ConvergenceWarning
from .ksd.geometry import rz

__all__ = ["joint_stiffness", "support_ratios", "joint_characteristics"]

_DIRECTIONS = ("x", "y", "z", "tilt_x", "tilt_y", "rotation")


def joint_stiffness(joint, rotation: float = 0.0):
    """Tangent stiffness (6, 6) of a spatial joint's node B with node A clamped, in B's turned
    frame (units N/m, N, N m/rad), at the intended rotation ``rotation`` [rad] about the joint's
    z axis reached with the rest of B free (the FE model condensed onto B: internal nodes
    eliminated). Returns ``(K, solution)``."""
    from .solvers import solve
    from .testing import joint_mechanism

    sol = solve(joint_mechanism(joint, 3, motion=rotation))
    if not sol.converged:
        raise ConvergenceError(f"{joint.kind}: the FE model did not converge at {np.degrees(rotation):.1f} deg: "
                               f"{sol.message}", sol)
    problem = joint_mechanism(joint, 3).compile().problem  # same nodes, only link A held
    K = problem.evaluate(sol.state, 0.0)[1].toarray()
    b = np.searchsorted(problem.free, problem.model.node_dofs[sol.compiled.link_node["B"]])
    i = np.setdiff1d(np.arange(len(problem.free)), b)
    KB = K[np.ix_(b, b)] - K[np.ix_(b, i)] @ np.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, b)])
    T = np.zeros((6, 6))
    T[:3, :3] = T[3:, 3:] = rz(rotation)
    return T.T @ KB @ T, sol


def support_ratios(joint, rotation: float = 0.0) -> dict:
    """Support stiffness of every unintended direction over the rotational stiffness at
    ``rotation`` [rad]: a special case of `flexmb.compliance`.

    Each direction's stiffness is ``1 / C_ii`` with ``C`` the compliance of node B
    (``flexmb.compliance(solution, "B", held="fixed")``: link A held, every direction of B free,
    the intended rotation included) turned into B's frame ``rz(rotation)``. Translations are
    compared as ``k D0^2`` [N m] with D0 the distance of the interface nodes (the joint's own
    length), tilts directly [N m/rad]. Returns the five ratios, ``"k_rotation"`` [N m/rad] and
    the peak normal stress ``"stress"`` [Pa] of the solution."""
    from .linearised import compliance
    from .solvers import solve
    from .testing import joint_mechanism

    sol = solve(joint_mechanism(joint, 3, motion=rotation))
    if not sol.converged:
        raise ConvergenceError(f"{joint.kind}: the FE model did not converge at {np.degrees(rotation):.1f} deg: "
                               f"{sol.message}", sol)
    T = np.zeros((6, 6))
    T[:3, :3] = T[3:, 3:] = rz(rotation)
    k = 1.0 / np.diag(T.T @ compliance(sol, "B", held="fixed") @ T)
    D0 = float(np.linalg.norm(joint.interface_b(3)))
    out = {name: float(k[i] * (D0 ** 2 if i < 3 else 1.0) / k[5]) for i, name in enumerate(_DIRECTIONS[:5])}
    out["k_rotation"] = float(k[5])
    out["stress"] = float(sol.peak_stress().max())
    return out


def joint_characteristics(kind: str, rotation: float = 0.0, **params) -> dict:
    """`support_ratios` of the registered joint ``kind`` built with shape ``params`` (SI units),
    at the intended rotation ``rotation`` [rad]: one design of a parameter study
    (`flexmb.study.parameter_study`), picklable as ``functools.partial(joint_characteristics, kind)``.

    Also ``"converged"`` (False: the joint's model did not converge at that rotation; the ratios,
    stiffness and stress are then NaN) and ``"warnings"``: the warnings the solve raised (e.g. a
    `flexmb.PlausibilityWarning` of a strain beyond the elastic range), ``"Category: message"``
    joined by ``" | "``, ``""`` for none; they are raised again here as well, so a direct call
    still shows them (a study records them in its own ``warnings`` column)."""
    import warnings

    from . import _warnings
    from .registry import joint

    j = joint(kind, **params)
    with _warnings.recording() as caught:  # per thread: two designs in one dask worker keep their own
        try:
            out = support_ratios(j, rotation)
            out["converged"] = True
        except ConvergenceError:
            out = {**{name: float("nan") for name in _DIRECTIONS[:5]}, "k_rotation": float("nan"),
                   "stress": float("nan"), "converged": False}
            warnings.warn(f"{kind}: the finite-element model did not converge at {np.degrees(rotation):.1f} deg",
                          ConvergenceWarning, stacklevel=2)
    _warnings.raise_again(caught)
    out["warnings"] = _warnings.as_text(caught)
    return out


#: ``joint_properties``, this function's name until flexmb 0.2 (module ``flexmb.analysis``): warns, kept one release
__getattr__ = renamed("flexmb.joint_characteristics", {"joint_properties": "flexmb.joint_characteristics.joint_characteristics"})
