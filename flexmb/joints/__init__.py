"""Joint plugins. The shipped ones register themselves in the ``flexmb.joints`` entry-point group."""

from ._base import FLEXURE_MODELS, INTERNAL, SIDE_A, SIDE_B, ClosedForm, Joint, JointMesh
from .cross_flexure import CrossFlexure
from .curved_beam import CurvedBeam
from .hinge import Hinge
from .leaf_spring import LeafSpring
from .three_x_infinity import ThreeXInfinity

__all__ = ["Joint", "JointMesh", "ClosedForm", "FLEXURE_MODELS", "CrossFlexure", "CurvedBeam", "Hinge", "LeafSpring", "ThreeXInfinity", "INTERNAL", "SIDE_A", "SIDE_B"]
