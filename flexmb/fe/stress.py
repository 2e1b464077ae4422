"""Peak normal stress in beam elements from their generalised stresses (Appendix A).

The generalised stresses ``sigma = S e`` conjugate to the deformations of Eq. (A.4) (lengths
[m]) are forces [N]: ``sigma_1`` the axial force and, for the bending deformations
``e = +-L0 asin(...)``, ``L0 sigma`` the end moments [N m]. The peak normal stress of an element
is the largest over its two ends of ``|N|/A + |M_y| z_max/I_y + |M_z| y_max/I_z`` (3D; in 2D
bending about z only); shear from torsion and transverse forces is not included.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..sections import properties

__all__ = ["peak_normal_stress"]


def peak_normal_stress(model, state) -> np.ndarray:
    """Peak normal stress [Pa] of every element of ``model`` (an `FEModel`) in ``state``, shape (E,)."""
    el = model.elements
    fibre = [(s.ymax, s.zmax) for s in el.sections]
    if any(y is None or (model.dim == 3 and z is None) for y, z in fibre):
        raise ModelError("peak stress needs the extreme-fibre distances ymax, zmax of every section "
                         "(flexmb.sections.rectangle sets them)")
    ymax, A, Iz, *zy = properties(el.sections, ("ymax", "A", "Iz") + (("zmax", "Iy") if model.dim == 3 else ()))
    sig = model.element_response(state, tangent=False)[3]
    axial = np.abs(sig[:, 0]) / A
    L0 = el.L0[:, None]
    if model.dim == 2:
        return axial + np.abs(L0 * sig[:, 1:3]).max(axis=1) * ymax / Iz
    My, Mz = L0 * sig[:, 2:4], L0 * sig[:, 4:6]  # ends p, q
    zmax, Iy = zy
    bend = np.abs(My) * (zmax / Iy)[:, None] + np.abs(Mz) * (ymax / Iz)[:, None]
    return axial + bend.max(axis=1)
