"""flexmb: fast kinetostatics of flexure-based (compliant) mechanisms."""

from . import models, testing
from .errors import (
    ConvergenceError,
    FlexmbError,
    ModelError,
    ParameterError,
    TopologyError,
    UnknownJointError,
    UnsupportedStrategyError,
)
from .joints import CrossFlexure, CurvedBeam, Joint, JointMesh, LeafSpring, ThreeXInfinity
from .mechanism import Link, Mechanism
from .registry import available_joints, joint, register_joint
from .results import Solution
from .sections import Section, rectangle
from .solvers import solve
from .sweeps import find_actuation, sweep, tangent_stiffness

__version__ = "0.1.0"

__all__ = [
    "ConvergenceError",
    "CrossFlexure",
    "CurvedBeam",
    "FlexmbError",
    "Joint",
    "JointMesh",
    "LeafSpring",
    "ThreeXInfinity",
    "Link",
    "Mechanism",
    "ModelError",
    "ParameterError",
    "Section",
    "Solution",
    "TopologyError",
    "UnknownJointError",
    "UnsupportedStrategyError",
    "available_joints",
    "find_actuation",
    "joint",
    "models",
    "testing",
    "rectangle",
    "register_joint",
    "solve",
    "sweep",
    "tangent_stiffness",
]
