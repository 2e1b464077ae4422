"""Parameter checks for joint plugins: each returns the value (a float, an int, the text) or
raises `flexmb.ParameterError` naming the joint, the parameter and its valid range: the one-line
message the command line prints (``flexmb train``: exit 2). The shipped joints use the same checks.

``owner`` is the joint's kind (the message starts with it); ``name`` the parameter::

    from flexmb.joints import validate as v

    def __attrs_post_init__(self):
        v.positive("circular_notch", "radius", self.radius)             # (0, inf)
        v.integer("circular_notch", "elements", self.elements, 2, v.MAX_ELEMENTS)

See docs/plugins.md for a complete joint.
"""

from __future__ import annotations

from .. import _validate

__all__ = ["positive", "nonnegative", "finite", "in_open_range", "integer", "choice", "flag", "shear_modulus",
           "modulus_units", "MAX_ELEMENTS"]

#: The largest element count a joint should accept for one leaf or arc (memory, not accuracy).
MAX_ELEMENTS = _validate.MAX_ELEMENTS


def positive(owner: str, name: str, value) -> float:
    """``value`` as a float, finite and > 0 (lengths, moduli)."""
    return _validate.positive(owner, name, value)


def nonnegative(owner: str, name: str, value) -> float:
    """``value`` as a float, finite and >= 0 (a density, a gap)."""
    return _validate.nonnegative(owner, name, value)


def finite(owner: str, name: str, value) -> float:
    """``value`` as a finite float (not a string, a boolean, NaN or inf)."""
    return _validate.finite(owner, name, value)


def in_open_range(owner: str, name: str, value, lo: float, hi: float, unit: str = "") -> float:
    """``value`` as a float strictly between ``lo`` and ``hi`` (``unit`` is shown in the message)."""
    return _validate.in_open_range(owner, name, value, lo, hi, unit)


def integer(owner: str, name: str, value, lo: int, hi: int | None = None) -> int:
    """``value`` as an int in ``[lo, hi]`` (a bool or a float is refused: an element count)."""
    return _validate.integer(owner, name, value, lo, hi)


def choice(owner: str, name: str, value, valid) -> str:
    """``value`` if it is one of the strings ``valid`` (the message lists them)."""
    return _validate.choice(owner, name, value, valid)


def flag(owner: str, name: str, value) -> bool:
    """``value`` if it is True or False (not a truthy string such as ``"no"``)."""
    return _validate.flag(owner, name, value)


def shear_modulus(owner: str, E, G, nu, default=None) -> float:
    """The shear modulus from ``G`` or Poisson's ratio ``nu`` in (-1, 0.5) (``G = E / (2 (1 + nu))``),
    ``default`` when neither is given; both given (``G`` other than ``default``) is refused."""
    return _validate.shear_modulus(owner, E, G, nu, default)


def modulus_units(owner: str, E: float, length: float) -> None:
    """Warn (`flexmb.PlausibilityWarning`) when ``E`` and a characteristic ``length`` look like
    mixed unit systems (GPa with metres, an SI modulus with millimetre lengths)."""
    _validate.modulus_units(owner, E, length, stacklevel=5)
