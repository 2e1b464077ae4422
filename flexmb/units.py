"""Unit systems a mechanism declares, their labels, and the checks that catch numbers in other units.

flexmb's arithmetic is unit-free: any consistent system works. A `UnitSystem` says which one a
mechanism's numbers are in (``Mechanism(units="mm-N-MPa")``), so that named materials
(`flexmb.materials`) resolve in it, tables, the command line and figures label their columns,
and numbers that cannot belong to it warn. Each system is fixed by its length, force and time
units (time is the second in all of them); mass, stress, density ... follow from consistency
(mass = force time^2 / length). The table is `SYSTEMS`; ``docs/units.md`` prints it.
"""

from __future__ import annotations

import math
import warnings

import attrs

from .errors import ParameterError, PlausibilityWarning

__all__ = ["UnitSystem", "SYSTEMS", "system", "label", "column_unit", "QUANTITIES", "check_angle", "check_size",
           "LENGTH_RANGE", "MODULUS_RANGE", "DENSITY_RANGE"]


@attrs.frozen
class UnitSystem:
    """A consistent unit system: ``length`` [m], ``force`` [N] and ``time`` [s] scales of its base
    units, and the names of its units (``names``: quantity -> unit label)."""

    name: str
    length: float
    force: float
    names: dict = attrs.field(eq=False, repr=False)
    time: float = 1.0

    def scale(self, quantity: str) -> float:
        """The SI value of one unit of ``quantity`` in this system (e.g. ``"stress"``: 1e6 for MPa)."""
        L, F, T = self.length, self.force, self.time
        M = F * T**2 / L  # the consistent mass unit
        scales = {"length": L, "force": F, "time": T, "mass": M, "angle": 1.0, "moment": F * L,
                  "stress": F / L**2, "modulus": F / L**2, "density": M / L**3, "inertia": M * L**2,
                  "frequency": 1.0 / T, "stiffness": F / L, "rotational stiffness": F * L,
                  "compliance": L / F, "rotational compliance": 1.0 / (F * L), "area": L**2,
                  "second moment": L**4, "energy": F * L, "mass per length": M / L, "dimensionless": 1.0}
        try:
            return scales[quantity]
        except KeyError:
            raise ParameterError(f"units: no quantity {quantity!r}; known: {', '.join(sorted(scales))}") from None

    def to_si(self, quantity: str, value):
        """``value`` (in this system) in SI."""
        return value * self.scale(quantity)

    def from_si(self, quantity: str, value):
        """``value`` (SI) in this system."""
        return value / self.scale(quantity)

    def label(self, quantity: str) -> str:
        """The unit label of ``quantity`` (``"mm"``, ``"N/mm"`` ...)."""
        return self.names.get(quantity, "-") if quantity in QUANTITIES else f"?{quantity}"


#: Quantities with a label in every system.
QUANTITIES = ("length", "force", "time", "mass", "angle", "moment", "stress", "modulus", "density", "inertia",
              "frequency", "stiffness", "rotational stiffness", "compliance", "rotational compliance", "energy",
              "dimensionless")


def _names(L: str, F: str, M: str, S: str) -> dict:
    return {"length": L, "force": F, "time": "s", "mass": M, "angle": "rad", "moment": f"{F} {L}", "stress": S,
            "modulus": S, "density": f"{M}/{L}^3", "inertia": f"{M} {L}^2", "frequency": "Hz",
            "stiffness": f"{F}/{L}", "rotational stiffness": f"{F} {L}/rad", "compliance": f"{L}/{F}",
            "rotational compliance": f"rad/({F} {L})", "energy": f"{F} {L}", "dimensionless": "-"}


#: The declared unit systems by name. Mass is what consistency gives: kg (SI), t (mm-N-MPa:
#: 1 N s^2/mm = 1000 kg), kg (um-uN-MPa: 1 uN s^2/um = 1 kg), g (mm-uN-Pa, Cammarata's gripper:
#: 1 uN s^2/mm = 1 g; its stress uN/mm^2 is the pascal).
SYSTEMS = {s.name: s for s in (
    UnitSystem("SI", 1.0, 1.0, _names("m", "N", "kg", "Pa")),
    UnitSystem("mm-N-MPa", 1e-3, 1.0, _names("mm", "N", "t", "MPa")),
    UnitSystem("um-uN-MPa", 1e-6, 1e-6, _names("um", "uN", "kg", "MPa")),
    UnitSystem("mm-uN-Pa", 1e-3, 1e-6, _names("mm", "uN", "g", "Pa")),
    UnitSystem("mm-mN-kPa", 1e-3, 1e-3, _names("mm", "mN", "kg", "kPa")),
)}


def system(units) -> UnitSystem | None:
    """The `UnitSystem` named ``units`` (a name of `SYSTEMS` or a `UnitSystem`); None stays None
    (undeclared: SI is assumed for labels and named materials)."""
    if units is None or isinstance(units, UnitSystem):
        return units
    if isinstance(units, str) and units in SYSTEMS:
        return SYSTEMS[units]
    raise ParameterError(f"units={units!r}; valid: {', '.join(SYSTEMS)} (or None: undeclared, SI assumed)")


def label(units, quantity: str) -> str:
    """The unit label of ``quantity`` in ``units`` (None: SI)."""
    return (system(units) or SYSTEMS["SI"]).label(quantity)


#: Plausible sizes of a flexure joint [m]: a MEMS hinge of 0.1 um to a 10 m structure.
LENGTH_RANGE = (1e-7, 10.0)
#: Plausible Young's moduli [Pa]: soft elastomers (~1e5) to diamond (1.2e12).
MODULUS_RANGE = (1e4, 1.3e12)
#: Plausible mass densities [kg/m^3] (a solid): foams and aerogels (~1) to osmium (22 600).
DENSITY_RANGE = (0.5, 3e4)


def check_size(owner: str, E: float, length: float, units=None, density: float = 0.0, what: str = "length",
               stacklevel: int = 3, rules: tuple = ("mm", "GPa")) -> None:
    """Warn (`PlausibilityWarning`) when a joint's modulus ``E``, characteristic ``length`` and
    ``density`` cannot all be in ``units``.

    Declared units: each value converted to SI must lie in `MODULUS_RANGE`, `LENGTH_RANGE`,
    `DENSITY_RANGE` (density 0: massless, not checked). Undeclared (None), the ``rules`` asked
    for: ``"mm"``, an SI modulus (``E > 1e8``) with lengths of millimetre numbers (``length > 2``:
    a flexure over 2 m; its forces come out 1e6 too large), and ``"GPa"``, a GPa modulus (``E <
    1e3``) with lengths in metres (``length < 1``). A joint's constructor, which cannot know the
    units yet, asks for ``"GPa"`` alone; `flexmb.Mechanism.add_joint` for ``"mm"`` where the
    mechanism is undeclared (a mm-uN-Pa gripper arc, E = 1e11 with a 5 mm radius, is plausible).
    """
    # a complex-step design's numbers (`flexmb.design`): their real parts are judged
    E, length, density = (x.real if isinstance(x, complex) or getattr(x, "dtype", None) == complex else x
                          for x in (E, length, density))
    u = system(units)
    msg = None
    if u is None:
        if "mm" in rules and E > 1e8 and length > 2.0:
            msg = (f"E={E:g} with {what} {length:g} looks like an SI modulus (Pa) with lengths in mm: forces come out "
                   f"1e6 too large. Declare the mechanism's units (Mechanism(units='mm-N-MPa')) and give E in MPa "
                   f"(steel 2.1e5) or a named material (material='structural_steel'); in SI the {what} is in m")
        elif "GPa" in rules and E < 1e3 and length < 1.0:
            msg = (f"E={E:g} with {what} {length:g} looks like a modulus in GPa with lengths in m; in SI, E is in Pa "
                   f"(steel 2e11). Declare the units if yours are consistent (e.g. Mechanism(units='mm-N-MPa'))")
    else:
        bad = []
        for q, value, (lo, hi), unit in (("modulus", E, MODULUS_RANGE, "Pa"), ("length", length, LENGTH_RANGE, "m"),
                                         ("density", density, DENSITY_RANGE, "kg/m^3")):
            si = u.to_si(q, value)
            if (q != "density" or value > 0) and not lo <= si <= hi:
                name = "E" if q == "modulus" else what if q == "length" else "density"
                bad.append(f"{name}={value:g} {u.label(q)} = {si:.3g} {unit} (plausible: {lo:g} to {hi:g} {unit})")
        if bad:
            msg = (f"{'; '.join(bad)}, in the declared units {u.name}: is the number in other units? (e.g. an SI "
                   "modulus in mm-N-MPa, or a density in kg/m^3 with mm; named materials resolve in the mechanism's "
                   "units: material='spring_steel')")
    if msg:
        warnings.warn(f"{owner}: {msg}", PlausibilityWarning, stacklevel=stacklevel)


def check_angle(owner: str, name: str, value, stacklevel: int = 3) -> None:
    """Warn (`PlausibilityWarning`) when an angle given in radians exceeds 2 pi in magnitude (a
    scalar, or the norm of a rotation vector, or any of several): likely degrees."""
    try:
        big = [float(x) for x in _magnitudes(value) if abs(float(x)) > 2.0 * math.pi]
    except (TypeError, ValueError):
        return  # not numbers: the caller's own check names it
    if big:
        a = big[0]
        warnings.warn(f"{owner}: {name}={a:g} rad is {abs(a) / (2 * math.pi):.3g} turns; angles are in radians (for "
                      f"{a:g} degrees give {math.radians(a):.6g})", PlausibilityWarning, stacklevel=stacklevel)


def _magnitudes(value) -> list:
    """The angles in ``value``: a scalar, or the norms of the rows of a vector / (k, 3) array."""
    import numpy as np

    raw = np.asarray(value)  # a complex-step design's angles (`flexmb.design`): their real parts
    a = raw.real.astype(float) if raw.dtype.kind == "c" else np.asarray(value, dtype=float)
    if a.ndim == 0:
        return [float(a)]
    if a.ndim == 1 and a.shape[0] == 3:
        return [float(np.linalg.norm(a))]
    if a.ndim == 2 and a.shape[1] == 3:
        return [float(x) for x in np.linalg.norm(a, axis=1)]
    return [float(x) for x in a.ravel()]


_TRANSLATIONS, _ROTATIONS = ("x", "y", "z"), ("rx", "ry", "rz", "rotation")


def column_unit(name: str, units=None) -> str:
    """The unit label of a result column of `flexmb.sweep`, `flexmb.trace` or
    `flexmb.properties` tables in ``units`` (None: SI): ``"<link>.x"`` a length, ``".rotation"``
    an angle, ``".Fx"`` a force, ``".Mz"`` a moment, ``"f1"`` Hz, ``"C.<link>.<row>.<col>"`` the
    compliance entry's, stresses ``"normal"``, ``"shear"``, ``"von_mises"`` (also per joint),
    ``"time"`` s; ``"-"`` for counts, flags, multipliers and safety factors."""
    u = system(units) or SYSTEMS["SI"]
    last = name.rsplit(".", 1)[-1].split("#")[0]
    if name.startswith("C.") and name.count(".") >= 3:
        row, col = name.split(".")[-2:]
        r_rot, c_rot = row in _ROTATIONS, col in _ROTATIONS
        num = u.label("angle") if r_rot else u.label("length")
        den = f"{u.label('force')} {u.label('length')}" if c_rot else u.label("force")
        return f"{num}/({den})" if " " in den else f"{num}/{den}"
    if last in _TRANSLATIONS or last.startswith("rotation") and last != "rotation" and "_" not in last:
        return u.label("length") if last in _TRANSLATIONS else u.label("angle")
    if last.startswith("rotation"):
        return u.label("angle")
    if last in ("Fx", "Fy", "Fz") or name in ("force",) or name.startswith("force_"):
        return u.label("force")
    if last in ("Mx", "My", "Mz"):
        return u.label("moment")
    if last in ("normal", "shear", "von_mises"):
        return u.label("stress")
    if name == "time":
        return "s"
    if name[:1] == "f" and name[1:].isdigit():
        return "Hz"
    return "-"
