"""Small validators that raise `ParameterError` naming the parameter and its valid range.

Within a complex-step build (`complex_step`, entered by `flexmb.design.builds`) complex numbers
pass where a real one is asked for, judged by their real part and returned as they came: the
design is built at ``p + i h`` and its model's rates are read from the imaginary parts
(``docs/plugins.md``, "Complex-step safe joints"). Outside one, complex input is refused as
before; real numbers take the float path unchanged.
"""

from __future__ import annotations

import cmath
import contextlib
import contextvars
import math
import os

import numpy as np

from .errors import ParameterError

#: Whether a complex-step build of `flexmb.design` is running (`complex_step`): only then do the
#: validators take complex numbers; elsewhere a complex value is refused as not a real number.
_COMPLEX_STEP = contextvars.ContextVar("flexmb_complex_step", default=False)


@contextlib.contextmanager
def complex_step():
    """A context in which design quantities may be complex (the complex step of `flexmb.design`:
    `flexmb.design.builds`, `flexmb.testing.check_complex_step`)."""
    token = _COMPLEX_STEP.set(True)
    try:
        yield
    finally:
        _COMPLEX_STEP.reset(token)


def accepts_complex() -> bool:
    """Whether a complex-step build is running (`complex_step`): the validators then take complex
    design quantities; outside one they refuse them (or fail as on any non-real input), as before."""
    return _COMPLEX_STEP.get()


def is_complex(value) -> bool:
    """Whether ``value`` (a number, an array or a sequence of them) is complex: a complex-step
    perturbed design quantity (`flexmb.design`). (Data already validated; the validators of input
    take complex numbers only within `complex_step`.)"""
    if isinstance(value, (complex, np.complexfloating)):
        return True
    if isinstance(value, (tuple, list)):  # items may be None or of mixed kinds
        return any(map(is_complex, value))
    return isinstance(value, np.ndarray) and value.dtype.kind == "c"


def _input_dtype(value) -> type:
    """The dtype an input array is taken as: complex within `complex_step` where it is complex,
    else float (outside a complex step, complex input fails as it always did)."""
    return complex if _COMPLEX_STEP.get() and is_complex(value) else float


def real(value):
    """The real part of a complex number or array (what the validators judge), else ``value``."""
    return value.real if is_complex(value) else value


def real_or_complex(value) -> type:
    """``complex`` for complex ``value`` (the complex step of `flexmb.design`), else ``float``: the
    dtype that keeps a design quantity's imaginary part."""
    return complex if is_complex(value) else float


def array(value) -> np.ndarray:
    """``np.asarray(value, dtype=float)``, or complex where ``value`` is within a complex step (never
    dropping an imaginary part)."""
    return np.asarray(value, dtype=_input_dtype(value))


def sin(x):
    """``math.sin`` of a real number; ``cmath.sin`` of a complex one (the complex step)."""
    return cmath.sin(x) if isinstance(x, (complex, np.complexfloating)) else math.sin(x)


def cos(x):
    """``math.cos`` of a real number; ``cmath.cos`` of a complex one (the complex step)."""
    return cmath.cos(x) if isinstance(x, (complex, np.complexfloating)) else math.cos(x)


def atan2(y, x):
    """``math.atan2(y, x)`` of real numbers; of complex ones (a complex step) the real parts' angle
    with the imaginary part carried to first order, ``(x dy - y dx) / (x^2 + y^2)``."""
    if not (isinstance(x, (complex, np.complexfloating)) or isinstance(y, (complex, np.complexfloating))):
        return math.atan2(y, x)
    x, y = complex(x), complex(y)
    return complex(math.atan2(y.real, x.real), (x.real * y.imag - y.real * x.imag) / (x.real**2 + y.real**2))


def norms(rows: np.ndarray) -> np.ndarray:
    """Euclidean lengths of the rows of ``rows`` (n, d): ``np.linalg.norm`` for real rows; for
    complex ones (a complex step) the analytic continuation ``sqrt(r . r)`` (the modulus would drop
    the imaginary part)."""
    if np.iscomplexobj(rows):
        return np.sqrt(np.einsum("ei,ei->e", rows, rows))
    return np.linalg.norm(rows, axis=1)


def positive(owner: str, name: str, value) -> float:
    """Return ``value`` as float if finite and > 0, else raise naming ``owner.name`` (a complex
    value: judged by its real part and returned as it is)."""
    v = finite(owner, name, value)
    if not real(v) > 0.0:
        raise ParameterError(f"{owner}: {name}={value!r} must be > 0 (valid range: (0, inf))")
    return v


def nonnegative(owner: str, name: str, value) -> float:
    """Return ``value`` as float if finite and >= 0, else raise naming ``owner.name``."""
    v = finite(owner, name, value)
    if not real(v) >= 0.0:
        raise ParameterError(f"{owner}: {name}={value!r} must be >= 0 (valid range: [0, inf))")
    return v


def finite(owner: str, name: str, value) -> float:
    """``value`` as a float if it is a finite real number (a complex one with finite parts: as a
    Python complex, the complex step), else raise naming ``owner.name``."""
    if isinstance(value, (str, bytes, bool)):
        raise ParameterError(f"{owner}: {name}={value!r} is not a real number")
    if isinstance(value, (complex, np.complexfloating)):
        if not _COMPLEX_STEP.get():
            raise ParameterError(f"{owner}: {name}={value!r} is not a real number")
        if not (math.isfinite(value.real) and math.isfinite(value.imag)):
            raise ParameterError(f"{owner}: {name}={value!r} must be finite")
        return complex(value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{owner}: {name}={value!r} is not a real number") from None
    if not math.isfinite(v):
        raise ParameterError(f"{owner}: {name}={value!r} must be finite")
    return v


def in_open_range(owner: str, name: str, value, lo: float, hi: float, unit: str = "") -> float:
    v = finite(owner, name, value)
    if not lo < real(v) < hi:
        raise ParameterError(f"{owner}: {name}={value!r}{unit} outside the valid range ({lo:g}, {hi:g}){unit}")
    return v


#: Largest element count per leaf / arc a joint accepts: far beyond converged meshes (the
#: Table 1 cross flexure is within 0.1 % at 5) and small enough that the model fits in memory.
MAX_ELEMENTS = 10_000


def integer(owner: str, name: str, value, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{owner}: {name}={value!r} must be an integer")
    if value < lo or (hi is not None and value > hi):
        rng = f"[{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise ParameterError(f"{owner}: {name}={value!r} outside the valid range {rng}")
    return int(value)


def vector(owner: str, name: str, value, size: int) -> np.ndarray:
    """``value`` as a new float array of shape (size,) (a copy: the caller's array stays theirs;
    complex where ``value`` is, the complex step)."""
    try:
        a = np.array(value, dtype=_input_dtype(value))
    except (TypeError, ValueError):
        raise ParameterError(f"{owner}: {name}={value!r} is not a vector of {size} real numbers") from None
    if a.shape != (size,):
        raise ParameterError(f"{owner}: {name} must have shape ({size},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{owner}: {name}={a.tolist()} must be finite (no NaN/inf)")
    return a


def finite_model(owner: str, values: dict) -> None:
    """Raise naming the parameters when derived model quantities overflow or vanish."""
    bad = [k for k, x in values.items() if not (np.all(np.isfinite(x)) and np.all(np.abs(x) > 0))]
    if bad:
        raise ParameterError(f"{owner}: the parameters give non-finite or zero {', '.join(bad)}; "
                             "check their magnitudes and units (SI: m, Pa)")


def rigid_body(owner: str, mass, inertia, center, dim: int):
    """``(mass, inertia, center)`` of a rigid body as fresh floats/arrays, checked: mass finite >= 0,
    inertia (3D: (3, 3) symmetric positive semi-definite with principal moments obeying the
    triangle inequality ``I1 + I2 >= I3``; 2D: a scalar >= 0; None: zero), center finite (dim,)."""
    m = nonnegative(owner, "mass", mass)
    c = np.zeros(dim) if center is None else vector(owner, "center", center, dim)
    if dim == 2:
        return m, (0.0 if inertia is None else nonnegative(owner, "inertia", inertia)), c
    if inertia is None:
        return m, np.zeros((3, 3)), c
    try:
        J = np.array(inertia, dtype=_input_dtype(inertia))
    except (TypeError, ValueError):
        raise ParameterError(f"{owner}: inertia={inertia!r} is not a (3, 3) tensor of real numbers") from None
    if J.shape != (3, 3) or not np.all(np.isfinite(J)):
        raise ParameterError(f"{owner}: inertia must be a finite (3, 3) tensor [kg m^2], got shape {J.shape}")
    if np.iscomplexobj(J):  # the complex step: the real part judged, the tensor kept
        _inertia(owner, J.real.copy())
        return m, 0.5 * (J + J.T), c
    return m, _inertia(owner, J), c


def _inertia(owner: str, J: np.ndarray) -> np.ndarray:
    """A real inertia tensor ``J`` (3, 3), checked (`rigid_body`), symmetrised."""
    scale = float(np.abs(J).max())
    tol = 1e-12 * scale
    if not np.all(np.abs(J - J.T) <= tol):
        raise ParameterError(f"{owner}: inertia tensor is not symmetric (largest |J - J^T| "
                             f"{np.abs(J - J.T).max():.3g}); give it about the centre of mass in the link's axes")
    J = 0.5 * (J + J.T)
    p = np.linalg.eigvalsh(J)
    if p[0] < -1e-10 * scale:
        raise ParameterError(f"{owner}: inertia tensor is not positive semi-definite (principal moments "
                             f"{', '.join(f'{x:.4g}' for x in p)} kg m^2)")
    if p[0] + p[1] < p[2] - 1e-10 * scale:
        raise ParameterError(f"{owner}: the principal moments {', '.join(f'{x:.4g}' for x in p)} kg m^2 violate "
                             "the triangle inequality I1 + I2 >= I3 (no mass distribution has them)")
    return J


def shear_modulus(owner: str, E, G, nu, default=None):
    """The shear modulus from ``G`` or from Poisson's ratio ``nu`` in (-1, 0.5) (``G = E / (2 (1 + nu))``);
    ``default`` when neither is given. ``G`` other than ``default`` together with ``nu`` is refused."""
    if nu is None:
        if G is None and default is None:
            raise ParameterError(f"{owner}: give the shear modulus G or Poisson's ratio nu")
        return default if G is None else G
    nu = in_open_range(owner, "nu", nu, -1.0, 0.5)
    if G is not None and G != default:
        raise ParameterError(f"{owner}: give G or nu, not both (G={G!r}, nu={nu!r})")
    return positive(owner, "E", E) / (2.0 * (1.0 + nu))


def modulus_units(owner: str, E: float, length: float, what: str = "length", stacklevel: int = 4) -> None:
    """Warn (`PlausibilityWarning`) when Young's modulus looks like GPa with lengths in metres:
    E < 1e3 with a ``length`` below 1. (GPa in SI puts metals at 40-400; MPa with mm, a consistent
    system, at 1e3-4e5 and lengths above 1.)"""
    if real(E) < 1e3 and real(length) < 1.0:
        import warnings

        from .errors import PlausibilityWarning

        warnings.warn(f"{owner}: E={E:g} with {what} {length:g} looks like a modulus in GPa with lengths in m; in SI, "
                      f"E is in Pa (steel 2e11). Ignore this if your units are consistent (e.g. kN and mm)",
                      PlausibilityWarning, stacklevel=stacklevel)


def frozen(a) -> np.ndarray:
    """A read-only copy of array ``a``: what a model object stores, so no caller can change it
    (complex where ``a`` is: the complex step)."""
    out = np.array(a, dtype=_input_dtype(a))
    out.flags.writeable = False
    return out


def flag(owner: str, name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{owner}: {name}={value!r} must be True or False")
    return bool(value)


def choice(owner: str, name: str, value, valid) -> str:
    if not isinstance(value, str) or value not in valid:
        raise ParameterError(f"{owner}: {name}={value!r}; valid: {', '.join(valid)}")
    return value


def computed(owner: str, what: str, fn):
    """``fn()``, or a `ParameterError` when the parameters' magnitudes make it overflow, divide
    by zero or come out non-finite (lengths or moduli in the wrong units, e.g. mm for m)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        try:
            out = fn()
        except (OverflowError, ZeroDivisionError, np.linalg.LinAlgError):
            out = None
    if out is None or not np.all(np.isfinite(out)):
        raise ParameterError(f"{owner}: the {what} is not finite for these parameters; check their magnitudes and "
                             "units (SI: m, Pa)")
    return out


def hashable(obj) -> bool:
    """Whether ``obj`` can key a cache: hashed by value (joints are immutable values, the shipped
    ones frozen attrs classes). A plugin's may not hash, or hash by identity (a plain class, an
    ``attrs.define(eq=False)`` one) while its attributes can be set in place: a cache keyed on it
    would return what it computed before the change, so neither counts."""
    if getattr(type(obj), "__hash__", None) in (None, object.__hash__):
        return False
    try:
        hash(obj)
    except TypeError:
        return False
    return True


# -- attrs validators of a strategy's options (the owner named in messages: the class's ``name``) --

def _owner(instance) -> str:
    return getattr(type(instance), "name", None) or type(instance).__name__


def positive_option(instance, attribute, value):
    """A finite number > 0."""
    positive(_owner(instance), attribute.name, value)


def count_option(instance, attribute, value):
    """An integer >= 1."""
    integer(_owner(instance), attribute.name, value, 1)


def above_one_option(instance, attribute, value):
    """A finite number > 1."""
    if not finite(_owner(instance), attribute.name, value) > 1.0:
        raise ParameterError(f"{_owner(instance)}: {attribute.name}={value!r} outside the valid range (1, inf)")


def flag_option(instance, attribute, value):
    """True or False."""
    flag(_owner(instance), attribute.name, value)


def unit_interval_option(instance, attribute, value):
    """A finite number in (0, 1]."""
    if not 0.0 < finite(_owner(instance), attribute.name, value) <= 1.0:
        raise ParameterError(f"{_owner(instance)}: {attribute.name}={value!r} outside the valid range (0, 1]")


def relative_tolerance_option(instance, attribute, value):
    """A relative tolerance in (0, 1): 1 or more accepts any state (the undeformed one included)."""
    in_open_range(_owner(instance), attribute.name, value, 0.0, 1.0)


def choice_option(valid):
    """A validator accepting one of the strings ``valid``."""
    def validate(instance, attribute, value):
        choice(_owner(instance), attribute.name, value, valid)
    return validate


def folder_option(instance, attribute, value):
    """None or the path of an existing folder (a misspelt one would be passed over silently)."""
    if value is not None and not isinstance(value, (str, os.PathLike)):
        raise ParameterError(f"{_owner(instance)}: {attribute.name}={value!r} must be a folder path or None "
                             "(the shipped data)")
    if value is not None and not os.path.isdir(value):  # searched first, then the user's and the shipped data:
        raise ParameterError(f"{_owner(instance)}: {attribute.name}={os.fspath(value)!r} is not a folder (no "
                             "such directory); a misspelt folder would be passed over for the user folder and the "
                             "shipped data without a word. Give the folder `flexmb train --out` wrote, or None")
