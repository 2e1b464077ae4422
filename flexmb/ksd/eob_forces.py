"""The EOB's element axial forces (Eqs. 3.8-3.11) of KSD-reduced stresses, tabulated against the
intended rotation.

An element's axial force in the EOB's linear model, ``N = a . T^T (L q - q_hat)`` (``a`` the
axial row of its rest stiffness ``K0``, `EOBTemplate.axial_force`), is linear in the node
displacements ``q`` with coefficients that depend on the element's rotation and levers, i.e. on
the intended rotation alone, plus ``-a . T^T q_hat``, which is linear in node B's near position
``p`` (the markers' gaps move with the nodes' near positions). `axial_forces` splines the
coefficients, the constant and its ``p`` gradient (`flexmb.ksd.splined`, one table per joint
template), so no EOB need be assembled per configuration (`EOBTemplate.evaluate` costs ten times the
tabulated forces); with the numba kernels `flexmb.ksd.reduced_model_jit.eob_axial` builds the node
displacements and sums the forces in one pass.
"""

from __future__ import annotations

import weakref

import numpy as np

from .splined import SplinedTable

__all__ = ["axial_forces", "force_table"]


def _coefficients(tpl, eob) -> np.ndarray:
    """(J, E, 2 nd): each element's axial force per unit displacement of its two nodes' DOFs."""
    E, nd = tpl.n_elements, tpl.nd
    row = tpl._axial_row.reshape(E, 2, nd)
    return np.einsum("esa,jeba,jesbc->jesc", row, eob.rotation, eob.lever).reshape(len(eob.lever), E, 2 * nd)


def _sample(tpl, theta: np.ndarray) -> dict:
    S, dim, n = len(theta), tpl.dim, tpl.n_nodes * tpl.nd
    zero = tpl.near_poses(theta, np.zeros((S, dim)))  # the axial forces read the near poses only
    c0 = tpl.axial_force(zero, np.zeros((S, n)))
    grad = np.stack([tpl.axial_force(tpl.near_poses(theta, np.tile(np.eye(dim)[k], (S, 1))),
                                     np.zeros((S, n))) - c0 for k in range(dim)], axis=-1)
    return {"A": _coefficients(tpl, zero), "c0": c0, "G": grad}


_TABLES = weakref.WeakKeyDictionary()


def force_table(tpl) -> SplinedTable:
    """The template's table of ``A`` (J, E, 2 nd), ``c0`` (J, E) and ``G`` (J, E, dim), built once."""
    table = _TABLES.get(tpl)
    return table if table is not None else _TABLES.setdefault(tpl, SplinedTable(lambda th: _sample(tpl, th),
                                                                                *tpl.data.range))


def axial_forces(tpl, theta: np.ndarray, b_position: np.ndarray, q: np.ndarray, eob=None) -> np.ndarray:
    """Axial forces [N] (J, E), tension positive, of J joints of template ``tpl`` at intended
    rotations ``theta`` (J,) [rad] with node B's near position ``b_position`` (J, dim) [m] and
    node displacements ``q`` (J, N nd) from the near poses: from the table inside the trained
    range, else from ``eob`` (a full `EOB` at that configuration; evaluated when None)."""
    table = force_table(tpl)
    if not table.covers(theta):
        eob = eob if eob is not None else tpl.evaluate(theta, b_position, held_a=True)
        return tpl.axial_force(eob, q)
    p = table(theta)
    return (np.einsum("jek,jek->je", p["A"], q[:, tpl.element_dofs]) + p["c0"]
            + (p["G"] @ np.asarray(b_position, dtype=float)[:, :, None])[..., 0])
