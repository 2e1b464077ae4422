"""Limits of the EOB on a single 3D cross flexure, Dwarshuis et al. (2020), Sec. 4.2: wider outer
leaves (Fig. 7b) and a large force along z on node B (Fig. 8). Each point is solved with the full
model (``conventional``) and with KSD-reduced (the EOB's linearised equilibrium, Eq. 3.11)."""

from __future__ import annotations

import numpy as np

from ..joints.cross_flexure import CrossFlexure
from ..mechanism import Mechanism
from ..solvers import solve

__all__ = ["pivot", "outer_width_study", "z_force_study"]


def pivot(joint: CrossFlexure, rotation: float, force_z: float = 0.0) -> Mechanism:
    """Node A fixed, node B turned by ``rotation`` [rad] about z (tilts held), free in x, y, z,
    with a force ``force_z`` [N] along z on B."""
    m = Mechanism(3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3))
    m.add_joint("A", "B", joint, name="cross_flexure")
    m.prescribe("B", rotation=(0.0, 0.0, rotation))
    if force_z:
        m.apply_force("B", (0.0, 0.0, force_z))
    return m


def _both(m: Mechanism):
    return solve(m, raise_on_failure=True), solve(m, method="ksd-reduced", raise_on_failure=True)


def outer_width_study(elements_per_leaf: int = 2, widths=(0.02, 0.08), degrees=(15, 30, 45, 60, 75)) -> dict:
    """Fig. 7b: M / M_lin (Eq. 4.3 with I of Eq. 4.4) of the full model and of the EOB for outer
    leaf widths ``widths`` [m]; the database is the default joint's (w2 = 0.02 m)."""
    out = {"degrees": np.asarray(degrees, float)}
    for w2 in widths:
        j = CrossFlexure(elements_per_leaf=elements_per_leaf, width_outer=w2)
        fe, eob = [], []
        for deg in degrees:
            th = np.radians(deg)
            M_lin = 2.0 * j.E * j.second_moment * th / j.length
            c, r = _both(pivot(j, th))
            fe.append(c.reaction("B")[5] / M_lin)
            eob.append(r.reaction("B")[5] / M_lin)
        out[w2] = {"fe": np.array(fe), "eob": np.array(eob)}
    return out


def z_force_study(elements_per_leaf: int = 4, degrees=(15, 45, 75), forces=(0.0, 1.0, 2.0, 4.0)) -> dict:
    """Fig. 8: z/L of node B and the scaled moment L M / (2 E I) (Eq. 4.6) against the scaled force
    F = L^2 F_z / (2 E I) (Eq. 4.5), full model and EOB, at the intended rotations ``degrees``."""
    j = CrossFlexure(elements_per_leaf=elements_per_leaf)
    EI, L = j.E * j.second_moment, j.length
    out = {"forces": np.asarray(forces, float), "degrees": np.asarray(degrees, float)}
    for deg in degrees:
        rows = []
        for F in forces:
            c, r = _both(pivot(j, np.radians(deg), F * 2.0 * EI / L**2))
            rows.append([c.displacement("B")[2] / L, r.displacement("B")[2] / L,
                         L * c.reaction("B")[5] / (2 * EI), L * r.reaction("B")[5] / (2 * EI)])
        out[deg] = dict(zip(("z_fe", "z_eob", "M_fe", "M_eob"), np.array(rows).T))
    return out
