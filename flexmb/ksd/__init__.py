"""The Kinematically Started Deformation method's building blocks (Dwarshuis et al. 2020):
reduced-mechanism geometry and kinematic constraints (step 1), Element Orientation based Bodies
(step 2), condensed equilibrium (steps 3-4). The strategies are in `flexmb.solvers.ksd`."""

from .eob import EOB, EOBTemplate
from .reduced import ReducedMechanism, template

__all__ = ["EOB", "EOBTemplate", "ReducedMechanism", "template"]
