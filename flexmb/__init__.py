"""flexmb: fast kinetostatics of flexure-based (compliant) mechanisms."""

from . import accuracy, export, models, plot, study, testing
from .errors import (
    AccuracyError,
    AccuracyWarning,
    ConvergenceError,
    ConvergenceWarning,
    DiscretisationWarning,
    ExtrapolationWarning,
    PlausibilityWarning,
    DatabaseError,
    FlexmbError,
    MissingExtraError,
    ModelError,
    ParameterError,
    TopologyError,
    UnknownJointError,
    UnsupportedStrategyError,
)
from .joints import CrossFlexure, CurvedBeam, Hinge, Joint, JointMesh, LeafSpring, ThreeXInfinity
from .mechanism import Link, Mechanism
from .materials import Material, material
from .files import MechanismFileError, load, save
from .statespace import StateSpace, state_space
from .linearised import buckling, compliance
from .design_properties import properties
from . import design
from .design import responses, value_and_grad
from .design.optimize import optimize
from .discretisation import DiscretisationEstimate, discretisation_error
from .modal import Modes, modes
from .registry import available_joints, joint, register_joint
from .results import Solution
from .sections import Section, circle, rectangle
from .solvers import solve
from .study import grid, parameter_study
from .sweeps import SweepResult, find_actuation, sweep, tangent_stiffness
from .path import Critical, EquilibriumPath, trace
from .imperfection import imperfect
from .table import Table, read_csv
from ._version import __version__  # noqa: F401 (flexmb.__version__)
from ._warnings import renamed as _renamed


__all__ = [
    "accuracy",
    "AccuracyError",
    "AccuracyWarning",
    "design",
    "responses",
    "value_and_grad",
    "optimize",
    "ConvergenceError",
    "ConvergenceWarning",
    "DiscretisationWarning",
    "ExtrapolationWarning",
    "PlausibilityWarning",
    "Critical",
    "DiscretisationEstimate",
    "EquilibriumPath",
    "trace",
    "imperfect",
    "CrossFlexure",
    "CurvedBeam",
    "FlexmbError",
    "Hinge",
    "Joint",
    "JointMesh",
    "LeafSpring",
    "ThreeXInfinity",
    "Link",
    "Mechanism",
    "Material",
    "material",
    "MechanismFileError",
    "StateSpace",
    "state_space",
    "load",
    "save",
    "Modes",
    "MissingExtraError",
    "ModelError",
    "ParameterError",
    "Section",
    "Solution",
    "SweepResult",
    "Table",
    "TopologyError",
    "UnknownJointError",
    "UnsupportedStrategyError",
    "DatabaseError",
    "available_joints",
    "buckling",
    "compliance",
    "discretisation_error",
    "export",
    "grid",
    "parameter_study",
    "plot",
    "properties",
    "read_csv",
    "study",
    "find_actuation",
    "joint",
    "models",
    "modes",
    "testing",
    "rectangle",
    "circle",
    "register_joint",
    "solve",
    "sweep",
    "tangent_stiffness",
]

#: ``flexmb.Path``, `EquilibriumPath`'s name until flexmb 0.2 (it shadowed ``pathlib.Path``): warns, kept one release
__getattr__ = _renamed("flexmb", {"Path": "flexmb.path.EquilibriumPath"})
