"""`Material`: the elastic constants, density and strength every joint takes, checked once; and the
named engineering materials, each with its source, resolved in a declared unit system."""

from __future__ import annotations

import json
from pathlib import Path

import attrs

import numpy as np

from . import _validate as v
from .errors import ModelError, ParameterError
from .units import SYSTEMS, check_size, system

__all__ = ["Material", "CATALOGUE", "material", "resolve", "STEEL", "params_in_units", "check_joint", "KEYWORDS"]


@attrs.frozen(init=False, kw_only=True)
class Material:
    """A linear-elastic isotropic material, in the numbers of one consistent unit system.

    ``Material(E, G=None, *, nu=None, density=0.0, yield_stress=None, name=None, units=None)``:
    Young's modulus ``E`` > 0; the shear modulus ``G`` > 0 or Poisson's ratio ``nu`` in (-1, 0.5)
    (``G = E / (2 (1 + nu))`` is stored), and ``E / (2 G) - 1`` must lie in (-1, 0.5); mass
    ``density`` >= 0 (0: massless, statics only); ``yield_stress`` > 0 or None (then not checked).
    Units: stress for ``E``, ``G``, ``yield_stress``, mass per length cubed for ``density`` (see
    ``docs/units.md``). ``name``: the catalogue name when it comes from `material`; ``units``: the
    unit system its numbers are in when known (a named material's), else None. Neither takes part
    in equality: two materials with the same numbers are the same material.
    """

    E: float
    G: float
    density: float = 0.0
    yield_stress: float | None = None
    name: str | None = attrs.field(default=None, eq=False)
    units: str | None = attrs.field(default=None, eq=False)

    def __init__(self, E, G=None, *, nu=None, density=0.0, yield_stress=None, name=None, units=None,
                 owner: str = "Material"):
        E = v.positive(owner, "E", E)
        G = v.shear_modulus(owner, E, G, nu)
        G = v.positive(owner, "G", G)
        implied = v.real(E / (2.0 * G) - 1.0)  # a complex modulus (the complex step): its real part judged
        if not -1.0 < implied < 0.5:
            raise ParameterError(f"{owner}: E={v.real(E):g} and G={v.real(G):g} imply Poisson's ratio {implied:.3g}, "
                                 "outside (-1, 0.5); check the units of the moduli")
        density = v.nonnegative(owner, "density", density)
        if yield_stress is not None:
            yield_stress = v.positive(owner, "yield_stress", yield_stress)
        if units is not None:
            units = system(units).name
        self.__attrs_init__(E=E, G=G, density=density, yield_stress=yield_stress, name=name, units=units)

    @property
    def nu(self) -> float:
        """Poisson's ratio ``E / (2 G) - 1``."""
        return self.E / (2.0 * self.G) - 1.0

    def to(self, units) -> Material:
        """The same material in another declared unit system (its own must be known)."""
        if self.units is None:
            raise ParameterError(f"material {self.name or ''}: its unit system is not known; give the numbers in the "
                                 "mechanism's units")
        a, b = system(self.units), system(units)
        s = a.scale("stress") / b.scale("stress")
        d = a.scale("density") / b.scale("density")
        return Material(self.E * s, self.G * s, density=self.density * d,
                        yield_stress=None if self.yield_stress is None else self.yield_stress * s,
                        name=self.name, units=b.name)

    def as_dict(self) -> dict:
        """The numbers (and name, units where known) as a plain dict."""
        out = {"E": self.E, "G": self.G, "density": self.density, "yield_stress": self.yield_stress}
        if self.name is not None:
            out["name"] = self.name
        if self.units is not None:
            out["units"] = self.units
        return out


#: Named materials in SI (E, G or nu, density [kg/m^3], yield stress [Pa]) and their sources, from
#: the data file ``materials.json`` beside this module (docs/units.md prints it).
CATALOGUE = json.loads((Path(__file__).with_name("materials.json")).read_text(encoding="utf-8"))["materials"]
_ALIASES = {"steel": "structural_steel", "aluminum_7075": "aluminium_7075", "al7075": "aluminium_7075",
            "ti-6al-4v": "ti6al4v", "titanium": "ti6al4v", "single_crystal_silicon": "silicon"}

#: The shipped joints' default material (SI): the steel of Dwarshuis et al. (2020), Table 1.
STEEL = Material(200e9, 76.9e9, density=7800.0, units="SI")


def material(name: str, units="SI") -> Material:
    """The named material of `CATALOGUE` (or an alias such as ``"steel"``) in ``units`` (a name of
    `flexmb.units.SYSTEMS`; default SI)."""
    key = _ALIASES.get(name.lower(), name.lower()) if isinstance(name, str) else None
    if key not in CATALOGUE:
        raise ParameterError(f"material {name!r} is not known; named materials: {', '.join(CATALOGUE)}")
    data = {k: x for k, x in CATALOGUE[key].items() if k != "source"}
    return Material(**data, name=key, units="SI").to(units or "SI")


#: Material keyword arguments a joint accepts beside ``material``.
KEYWORDS = ("E", "G", "nu", "density", "yield_stress")


def resolve(owner: str, given, keywords: dict, default: Material | None, default_G=None) -> Material:
    """The material of a joint from its ``material=`` (``given``: a `Material`, a catalogue name
    or None) and its material keywords (``E``, ``G``, ``nu``, ``density``, ``yield_stress``; None:
    not given), checked once; errors name ``owner``.

    Keywords given beside a material replace its values (``attrs.evolve(joint, E=...)`` works);
    keywords alone complete ``default`` (the joint's default material; None: ``E`` is required,
    ``G`` defaults to ``default_G(E)``), as the joints' separate fields did.
    """
    if isinstance(given, str):
        given = material(given)
    elif given is not None and not isinstance(given, Material):
        raise ParameterError(f"{owner}: material={given!r} must be a flexmb.Material or a material name "
                             f"({', '.join(CATALOGUE)})")
    kw = {k: x for k, x in keywords.items() if not (x is None and k in ("G", "nu"))}  # G=None, nu=None: not given
    base = given if given is not None else default
    if base is None and "E" not in kw:
        raise ParameterError(f"{owner}: give Young's modulus E or a material")
    if not kw:
        return base
    E = kw.get("E", None if base is None else base.E)
    G, nu = kw.get("G"), kw.get("nu")
    if G is None and nu is None:  # the shear modulus kept (the material's, the default's) or defaulted
        G = base.G if base is not None else None if default_G is None else default_G(v.positive(owner, "E", E))
    density = kw.get("density", 0.0 if base is None else base.density)
    ys = kw.get("yield_stress", None if base is None else base.yield_stress)
    return Material(E, G, nu=nu, density=density, yield_stress=ys, owner=owner)


def params_in_units(params: dict, units) -> dict:
    """Joint parameters with a named ``material`` resolved in the mechanism's ``units`` (None: SI)."""
    name = params.get("material")
    if isinstance(name, str):
        return {**params, "material": material(name, units or "SI")}
    return params


def check_joint(joint, units, where: str, dim: int) -> None:
    """A joint placed in a mechanism of ``units`` (declared, or None): its `Material`, when its unit
    system is known (a named material's, the shipped joints' default steel: SI), must be in the
    declared ones (`ModelError` naming the joint otherwise: its numbers would be off by powers of
    ten), and its modulus, size and density plausible in them (`flexmb.units.check_size`;
    undeclared: no SI modulus with millimetre lengths)."""
    mat = getattr(joint, "material", None)
    if not isinstance(mat, Material):
        return
    if units is not None and mat.units is not None and mat.units != units.name:
        label = f"{mat.name!r}" if mat.name else "its material" if mat != STEEL else "the default steel"
        raise ModelError(f"{where}: {label} is in {mat.units} numbers (E={mat.E:g}), the mechanism in {units.name}: "
                         f"give material={mat.name or 'structural_steel'!r} to add_joint (it resolves in the "
                         f"mechanism's units), or flexmb.material(name, {units.name!r}), or E, G, density in "
                         f"{units.label('stress')} and {units.label('density')}")
    # the real parts of a complex-step design's numbers (`flexmb.design`) are judged
    size = next((float(v.real(getattr(joint, n))) for n in ("length", "radius")
                 if isinstance(getattr(joint, n, None), (float, complex))), None)
    if size is None:
        size = float(np.linalg.norm(v.real(joint.interface_b(dim))))
    section = getattr(joint, "section", None)  # a leaf spring's own section carries its modulus
    E = getattr(section, "E", None) or mat.E
    if size > 0:
        check_size(where, v.real(E), size, units, v.real(mat.density if section is None else section.density),
                   stacklevel=4, rules=("mm",))


def sources() -> dict:
    """Each named material's source, for the documentation."""
    return {k: d["source"] for k, d in CATALOGUE.items()}


_ = SYSTEMS  # the systems a material resolves in (documentation cross-reference)
