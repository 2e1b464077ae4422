"""Parameter checks for joint plugins: each returns the value (as a float or int) or raises
`flexmb.ParameterError` naming the joint, the parameter and its valid range, the one-line
message the command line prints. The shipped joints use the same checks.

``owner`` is the joint's kind (what the message starts with); ``name`` the parameter::

    from flexmb.joints import validate as v

    def __attrs_post_init__(self):
        v.positive("circular_notch", "radius", self.radius)             # (0, inf)
        v.integer("circular_notch", "elements", self.elements, 2, v.MAX_ELEMENTS)
        v.choice("circular_notch", "model", self.model, ("a", "b"))

See docs/plugins.md for a complete joint.
"""

from .._validate import (MAX_ELEMENTS, choice, finite, flag, in_open_range, integer, modulus_units, nonnegative,
                         positive, shear_modulus)

__all__ = ["positive", "nonnegative", "finite", "in_open_range", "integer", "choice", "flag", "shear_modulus",
           "modulus_units", "MAX_ELEMENTS"]
