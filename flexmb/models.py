"""Ready-made mechanisms from the papers."""

from __future__ import annotations

from . import _validate as v
from .joints.cross_flexure import CrossFlexure
from .joints.leaf_spring import LeafSpring
from .mechanism import Mechanism
from .registry import joint_from_params

__all__ = ["cantilever", "cross_flexure_pivot"]


def cross_flexure_pivot(elements_per_leaf: int = 3, dim: int = 3, rotation: float = 0.0, **joint_params) -> Mechanism:
    """A single cross flexure (Dwarshuis et al. 2020, Sec. 4.1-4.2, Table 1 defaults).

    Link ``"A"`` (the lower connector block, interface node A at the origin) is fixed; link
    ``"B"`` (the upper block, node B) is rotated by ``rotation`` [rad] about the joint axis z and
    free in x and y (in 3D, its z displacement and tilts are held at zero). The reaction on B
    about z is the moment of Fig. 7. ``joint_params`` go to `CrossFlexure`.
    """
    v.finite("cross_flexure_pivot", "rotation", rotation)
    joint = joint_from_params(CrossFlexure, elements_per_leaf=elements_per_leaf, **joint_params)
    m = Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim))
    m.add_joint("A", "B", joint, name="cross_flexure")
    if dim == 2:
        m.prescribe("B", rotation=rotation)
    else:
        m.prescribe("B", z=0.0, rotation=(0.0, 0.0, rotation))
    return m


def cantilever(elements: int = 8, dim: int = 2, **leaf_params) -> Mechanism:
    """A straight leaf spring clamped in link ``"ground"`` (fixed) with a free link ``"tip"``.

    The beam runs along +x from the origin; load the tip with `Mechanism.apply_force` /
    `apply_moment`. ``leaf_params`` go to `LeafSpring` (defaults: 0.1 x 0.02 x 0.001 m steel).
    """
    leaf = joint_from_params(LeafSpring, elements=elements, **leaf_params)
    m = Mechanism(dim=dim)
    m.add_link("ground", fixed=True)
    m.add_link("tip", position=leaf.interface_b(dim))
    m.add_joint("ground", "tip", leaf, name="leaf")
    return m
