"""Beam cross-sections: the stiffness data a beam element needs (SI units)."""

from __future__ import annotations

import functools
import math
import numbers

import attrs
import numpy as np

from . import _validate as v
from ._warnings import renamed
from .errors import ParameterError

__all__ = ["Section", "rectangle", "circle", "section_values", "torsion_constant_rectangle", "shear_coefficient_rectangle",
           "shear_coefficient_circle", "SHAPES", "STEEL_DENSITY"]

#: Cross-section shapes whose stresses `flexmb.fe.stress` can evaluate at the perimeter.
SHAPES = ("rectangle", "circle")


def torsion_constant_rectangle(width: float, thickness: float, terms: int = 50) -> float:
    """Saint-Venant torsion constant I_t [length^4] of a solid rectangle.

    Exact series (Timoshenko & Goodier, *Theory of Elasticity*, 3rd ed., Sec. 109), the form
    SPACAR uses: ``I_t = (1/3)(2a)^3(2b)[1 - (192/pi^5)(a/b) sum_{n odd} tanh(n pi b / 2a)/n^5]``
    with ``a = min/2``, ``b = max/2`` (complex sides, the complex step of `flexmb.design`: ordered
    by their real parts, the series carried in complex arithmetic).
    """
    if v.is_complex(width) or v.is_complex(thickness):
        small, large = (width, thickness) if v.real(width) <= v.real(thickness) else (thickness, width)
        a, b = 0.5 * complex(small), 0.5 * complex(large)
    else:
        a, b = 0.5 * min(width, thickness), 0.5 * max(width, thickness)
    n = np.arange(1, 2 * terms, 2, dtype=float)
    series = np.sum(np.tanh(n * math.pi * b / (2.0 * a)) / n**5)
    return (2 * a) ** 3 * (2 * b) / 3.0 * (1.0 - 192.0 / math.pi**5 * (a / b) * series)


def shear_coefficient_rectangle(poisson: float) -> float:
    """Timoshenko shear coefficient of a rectangle, ``k = 10(1+nu)/(12+11 nu)`` (Cowper 1966)."""
    return 10.0 * (1.0 + poisson) / (12.0 + 11.0 * poisson)


def shear_coefficient_circle(poisson: float) -> float:
    """Timoshenko shear coefficient of a solid circle, ``k = 6(1+nu)/(7+6 nu)`` (Cowper 1966)."""
    return 6.0 * (1.0 + poisson) / (7.0 + 6.0 * poisson)


@attrs.frozen(kw_only=True)
class Section:
    """Stiffness data of a beam cross-section in its principal axes (local y, z).

    Parameters
    ----------
    E, G
        Young's and shear modulus [stress].
    A
        Area [area].
    Iy, Iz
        Second moments of area about the local y and z axes [length^4].
    It
        Torsion constant [length^4].
    ky, kz
        Shear coefficients for shear along local y and z [-] (``inf`` = no shear deformation).
    ymax, zmax
        Distances of the extreme fibres from the centroid along local y and z [length], for bending
        stresses (``None``: unknown, `flexmb.fe.stress` refuses).
    density
        Mass density [density] (in another consistent unit system: mass per length cubed, e.g.
        g/mm^3 with mm, uN and s), >= 0; 0 (default): a massless section, for statics only.
        The beam elements' mass (`flexmb.fe.mass`) uses ``density A`` per length and the rotary
        inertias ``density Iy``, ``density Iz`` and ``density (Iy + Iz)`` (about the axis).
    shape
        ``"rectangle"`` (``2 ymax x 2 zmax``) or ``"circle"`` (radius ``ymax = zmax``), set by
        `rectangle` and `circle`: `flexmb.fe.stress` then gives shear and von Mises stresses at
        the perimeter; None (default): unknown, normal stress at the corners ``(+-ymax, +-zmax)``
        only.
    yield_stress
        The material's yield stress [stress], optional: a solve whose peak normal stress exceeds it
        warns (`flexmb.PlausibilityWarning`); None (default): not checked.
    """

    E: float
    G: float
    A: float
    Iy: float
    Iz: float
    It: float
    ky: float = 5.0 / 6.0
    kz: float = 5.0 / 6.0
    ymax: float | None = None
    zmax: float | None = None
    density: float = 0.0
    shape: str | None = None
    yield_stress: float | None = None

    def __attrs_post_init__(self):
        v.nonnegative("Section", "density", self.density)
        if self.yield_stress is not None:
            v.positive("Section", "yield_stress", self.yield_stress)
        if self.shape is not None:
            v.choice("Section", "shape", self.shape, SHAPES)
            for name in ("ymax", "zmax"):
                v.positive("Section", name, getattr(self, name))
            if self.shape == "circle" and self.ymax != self.zmax:
                raise ParameterError(f"Section: a circle has ymax = zmax (its radius), got {self.ymax!r}, {self.zmax!r}")
        for name in ("E", "G", "A", "Iy", "Iz", "It"):
            v.positive("Section", name, getattr(self, name))
        for name in ("ky", "kz"):  # inf is allowed: no shear deformation (a complex one: the complex step)
            val = getattr(self, name)
            if v.accepts_complex() and v.is_complex(val) and math.isfinite(val.imag):
                val = val.real
            if not (isinstance(val, numbers.Real) and not isinstance(val, bool) and val > 0):
                raise ParameterError(f"Section: {name}={val!r} must be > 0 (valid range: (0, inf])")


#: The section builders' default density [density]: steel, as the shipped joints' (their ``density``
#: parameter [density], steel default 7800), so a leaf given
#: ``section=rectangle(...)`` weighs what the same leaf without it does. In other units give
#: ``density`` (mass per length cubed); 0 makes a massless section, which `flexmb.modes` refuses
#: by name where it leaves a free direction without mass.
STEEL_DENSITY = 7800.0


def rectangle(width: float, thickness: float, E: float, G: float | None = None, density: float = STEEL_DENSITY, *,
              nu: float | None = None, yield_stress: float | None = None) -> Section:
    """Rectangular section ``width x thickness`` [length]; local z along the width, local y along the thickness.

    So ``Iz = width thickness^3 / 12`` is the compliant (leaf-spring) bending stiffness and
    ``Iy = thickness width^3 / 12`` the stiff one, as in SPACAR's leaf-spring data.
    Poisson's ratio for the shear coefficient is ``E / (2G) - 1``; give ``G`` or ``nu`` (then
    ``G = E / (2 (1 + nu))``). ``density`` [density] >= 0 (`STEEL_DENSITY`; 0: massless; see `Section`);
    ``yield_stress`` [stress] optional (see `Section`).
    """
    args = (width, thickness, E, G, density, nu, yield_stress)
    if all(type(a) in _PLAIN for a in args):  # a frozen value of plain numbers: built once (joint meshing)
        return _rectangle_cached(*args)
    return _rectangle(width, thickness, E, G, density, nu=nu, yield_stress=yield_stress)


_PLAIN = (float, int, type(None))


@functools.lru_cache(maxsize=1024, typed=True)
def _rectangle_cached(width, thickness, E, G, density, nu, yield_stress) -> Section:
    return _rectangle(width, thickness, E, G, density, nu=nu, yield_stress=yield_stress)


def _rectangle(width: float, thickness: float, E: float, G: float | None = None, density: float = STEEL_DENSITY, *,
               nu: float | None = None, yield_stress: float | None = None) -> Section:
    """`rectangle` itself."""
    width = v.positive("rectangle", "width", width)
    thickness = v.positive("rectangle", "thickness", thickness)
    E = v.positive("rectangle", "E", E)
    G = v.positive("rectangle", "G", v.shear_modulus("rectangle", E, G, nu))
    density = v.nonnegative("rectangle", "density", density)
    if v.is_complex((width, thickness, E, G, density)):  # the complex step (`flexmb.design`)
        props = dict(A=width * thickness, Iy=thickness * width**3 / 12.0, Iz=width * thickness**3 / 12.0)
    else:
        w, t = np.float64(width), np.float64(thickness)  # numpy floats overflow to inf, checked below
        with np.errstate(over="ignore", under="ignore"):
            props = dict(A=float(w * t), Iy=float(t * w**3 / 12.0), Iz=float(w * t**3 / 12.0))
    v.finite_model(f"rectangle {v.real(width):g} x {v.real(thickness):g} m", props)
    nu = E / (2.0 * G) - 1.0
    if not -1.0 < v.real(nu) < 0.5:
        raise ParameterError(
            f"rectangle: E={v.real(E):g} Pa and G={v.real(G):g} Pa imply Poisson's ratio {v.real(nu):.3g}, outside "
            "(-1, 0.5); check the units of the moduli"
        )
    k = shear_coefficient_rectangle(nu)
    return Section(E=E, G=G, It=torsion_constant_rectangle(width, thickness), ky=k, kz=k,
                   ymax=0.5 * _number(thickness), zmax=0.5 * _number(width), density=density, shape="rectangle",
                   yield_stress=yield_stress, **props)


def circle(diameter: float, E: float, G: float | None = None, density: float = STEEL_DENSITY, *,
           nu: float | None = None, yield_stress: float | None = None) -> Section:
    """Solid circular section of ``diameter`` [length] (a wire flexure): ``A = pi r^2``,
    ``Iy = Iz = pi r^4 / 4``, torsion constant ``It = pi r^4 / 2`` (exact, the polar moment),
    Cowper's shear coefficient (`shear_coefficient_circle`), Poisson's ratio ``E / (2G) - 1`` (or
    give ``nu``: ``G = E / (2 (1 + nu))``); ``density`` [density] >= 0 (`STEEL_DENSITY`) and
    ``yield_stress`` [stress] (optional) as in `Section`."""
    diameter = v.positive("circle", "diameter", diameter)
    E = v.positive("circle", "E", E)
    G = v.positive("circle", "G", v.shear_modulus("circle", E, G, nu))
    density = v.nonnegative("circle", "density", density)
    if v.is_complex((diameter, E, G, density)):  # the complex step (`flexmb.design`)
        r = 0.5 * diameter
        props = dict(A=math.pi * r**2, Iy=math.pi * r**4 / 4.0, Iz=math.pi * r**4 / 4.0, It=math.pi * r**4 / 2.0)
    else:
        r = 0.5 * np.float64(diameter)
        with np.errstate(over="ignore", under="ignore"):
            props = dict(A=float(math.pi * r**2), Iy=float(math.pi * r**4 / 4.0), Iz=float(math.pi * r**4 / 4.0),
                         It=float(math.pi * r**4 / 2.0))
    v.finite_model(f"circle of diameter {v.real(diameter):g} m", props)
    nu = E / (2.0 * G) - 1.0
    if not -1.0 < v.real(nu) < 0.5:
        raise ParameterError(f"circle: E={v.real(E):g} Pa and G={v.real(G):g} Pa imply Poisson's ratio "
                             f"{v.real(nu):.3g}, outside (-1, 0.5); check the units of the moduli")
    k = shear_coefficient_circle(nu)
    return Section(E=E, G=G, ky=k, kz=k, ymax=_number(r), zmax=_number(r), density=density, shape="circle",
                   yield_stress=yield_stress, **props)


def shear_factor(num, k, den):
    """``num / (k den)`` in complex arithmetic (the complex step of `flexmb.design`), for the shear
    factor ``phi = 12 E I / (k G A L0^2)`` (Eq. A.16): a shear coefficient ``k = inf`` (no shear
    deformation) gives 0, where complex ``inf`` times a number is ``nan``."""
    inf = np.isinf(np.real(k))
    return np.where(inf, 0.0, num / (np.where(inf, 1.0, k) * den))


def _number(x):
    """``float(x)``, or ``x`` as a complex number where it is one (the complex step)."""
    return complex(x) if v.is_complex(x) else float(x)


def section_values(sections, names) -> np.ndarray:
    """The named values (e.g. ``("E", "A")``) of a sequence of sections as a (len(names), n)
    float array (complex where a section's are: the complex step); each distinct section object is
    read once (a mesh repeats a few sections)."""
    distinct = {}
    code = [distinct.setdefault(id(s), (len(distinct), s))[0] for s in sections]
    rows = [[getattr(s, n) for n in names] for _, s in distinct.values()]
    table = np.array(rows, dtype=v.real_or_complex(rows))
    return table.reshape(-1, len(names))[code].T


#: ``properties``, `section_values`' name until flexmb 0.2: warns, kept one release
__getattr__ = renamed("flexmb.sections", {"properties": "flexmb.sections.section_values"})
