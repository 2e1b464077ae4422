"""Joint plugins. The shipped ones register themselves in the ``flexmb.joints`` entry-point group."""

from ._base import INTERNAL, SIDE_A, SIDE_B, Joint, JointMesh
from .cross_flexure import CrossFlexure

__all__ = ["Joint", "JointMesh", "CrossFlexure", "INTERNAL", "SIDE_A", "SIDE_B"]
