"""Stresses in the beam elements from their generalised stresses (Appendix A).

The generalised stresses ``sigma = S e`` conjugate to the deformations of Eq. (A.4) (lengths
[m]) are forces [N]: ``sigma_1`` the axial force N, ``L0 sigma_2`` the torque T about the chord,
``L0 sigma_3``, ``L0 sigma_4`` the bending moments My about local y at ends p and q, ``L0
sigma_5``, ``L0 sigma_6`` those about local z (2D: ``L0 sigma_2``, ``L0 sigma_3`` about z), each
the section moment of beam theory (equal at both ends in pure bending, ``M = EI kappa``). The
transverse shear forces follow from the element's equilibrium (no distributed load),
``Vy = (Mz_p - Mz_q) / l``, ``Vz = (My_q - My_p) / l`` with ``l`` the current chord length.

At a point ``(y, z)`` of a section (local axes, centroid origin)::

    sigma_x = N/A + My z/Iy - Mz y/Iz
    tau     = T tau_T(y, z) + Vy tau_Vy(y, z) + Vz tau_Vz(y, z)          (tau_xy, tau_xz)
    von Mises = sqrt(sigma_x^2 + 3 |tau|^2)

with Saint-Venant torsion (rectangle: the exact series of the Prandtl stress function, Timoshenko
& Goodier 1970, Sec. 109; circle: ``T r/It`` along the perimeter) and the elementary (Jourawski)
transverse shear: ``3V/(2A)(1 - (y/ymax)^2)`` in a rectangle, ``4V/(3A)(1 - (y/r)^2)`` averaged
over the chord of a circle (the exact elastic value of a circle is ``(3 + 2 nu)/(2 (1 + nu))``
``V/A``, 3.6 % above at nu = 0.3; the transverse shear of a slender flexure is small beside
its bending stress). Each quantity's peak is taken over both element ends and over points on the
section's perimeter, where a solid section's normal and torsional shear stresses peak
(`PERIMETER_POINTS`, `perimeter_peaks`).

A variable section (a notch hinge, a tapered leaf) is a chain of elements each of one section:
its stiffness (`flexmb.JointMesh.sections`) an average over the element, e.g. the harmonic mean
of ``I(x)`` that gives the element's exact rotation under a uniform moment. Its stresses are
recovered with the element's *stress section* (`flexmb.JointMesh.stress_sections`, default the
element's own): the joint gives there the section where the element is thinnest and puts a node
where the joint is thinnest, so the peak is that section's ``M ymax / Iz`` at the throat, not the
averaged section's (6 % low for a right circular notch; with the thinnest section within 0.3 % of
Paros & Weisbord's ``6 k theta / (b t^2)``, tests/test_plugin_notch.py). Without stress sections a
``concentration`` factor (`element_stresses`) is the alternative.
"""

from __future__ import annotations

import functools
import weakref

import attrs
import numpy as np

from .. import jit
from .._validate import positive
from ..errors import ModelError, ParameterError
from ..sections import section_values
from . import stress_jit

__all__ = ["peak_normal_stress", "section_table", "SectionTable", "section_resultants", "stress_points", "perimeter_peaks", "element_stresses", "Stresses",
           "PERIMETER_POINTS", "COARSE_STEP", "TORSION_TERMS"]

#: Points on a section's perimeter (a rectangle: a quarter per side, cosine-clustered at the
#: corners, where the torsional shear falls from its peak to zero within a thickness; a circle:
#: evenly spaced). Measured against 16 times as many on random combinations of all six section
#: forces: never high, at most 9e-6 low (tests/test_stress.py; 512 points: 1.4 % low on a
#: 20 x 1 rectangle, the coarse search missing the peak).
PERIMETER_POINTS = 2048
#: The coarse search's stride (`perimeter_peaks`).
COARSE_STEP = 16
#: Terms of the rectangle's torsion series (odd n up to 2 TORSION_TERMS - 1): the corner terms
#: fall as 1/n^2; 400 terms give the mid-side shear of Timoshenko & Goodier's table to 1e-5.
TORSION_TERMS = 400


def _with_axial(sig, axial):
    """``sig`` (E, k) with the axial forces of ``axial = (elements, N)`` in column 0 (a copy), or as is."""
    if axial is None:
        return sig
    sig = sig.copy()
    sig[axial[0], 0] = axial[1]
    return sig


@attrs.frozen(eq=False)
class SectionTable:
    """Per-element section data of a `BeamElements` batch, (E,) arrays (NaN where a section leaves
    it None): what the stress and plausibility checks read on every solve, gathered once per batch
    (`section_table`). ``yield_stress`` inf where not given; ``circle`` the circular sections;
    ``length`` each element's joint's beam length [m] (the sum of its elements' ``L0``)."""

    E: np.ndarray
    A: np.ndarray
    Iy: np.ndarray
    Iz: np.ndarray
    ymax: np.ndarray
    zmax: np.ndarray
    density: np.ndarray
    yield_stress: np.ndarray
    circle: np.ndarray
    yield_given: np.ndarray  # whether each section gives a yield stress
    length: np.ndarray
    has_y: bool  # every section gives ymax
    has_z: bool  # every section gives zmax
    #: ((section, element indices), ...): the elements whose sections `perimeter_peaks` reads alike
    stress_groups: tuple = ()


_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def section_table(elements) -> SectionTable:
    """The `SectionTable` of ``elements`` (a frozen `flexmb.fe.model.BeamElements` whose sections
    are a tuple: it cannot change), built on first use and kept while the batch lives: the
    manipulator's plausibility check read its 81 sections' attributes in three Python loops on
    every solve (a visible share of a KSD-reduced solve)."""
    try:
        return _TABLES[elements]
    except (KeyError, TypeError):
        pass
    # stresses are recovered at each element's stress section (`flexmb.JointMesh.stress_sections`:
    # the thinnest of a variable section), its mass read from its own
    sections = getattr(elements, "stress_sections", None) or elements.sections
    E, A, Iz = section_values(sections, ("E", "A", "Iz"))  # what every beam element reads
    # a plugin section may lack the others (a planar one Iy; density, shape and fibres are optional)
    Iy = np.array([getattr(s, "Iy", np.nan) for s in sections], dtype=float)
    rho = np.array([getattr(s, "density", 0.0) for s in elements.sections], dtype=float)
    fibre = [(getattr(s, "ymax", None), getattr(s, "zmax", None)) for s in sections]
    y = np.array([np.nan if a is None else a for a, _ in fibre], dtype=float)
    z = np.array([np.nan if b is None else b for _, b in fibre], dtype=float)
    given = np.array([getattr(s, "yield_stress", None) is not None for s in sections], dtype=bool)
    ys = np.array([s.yield_stress if g else np.inf for s, g in zip(sections, given)], dtype=float)
    owner = np.asarray(elements.owner)
    total = np.bincount(owner, weights=elements.L0, minlength=int(owner.max(initial=-1)) + 1)
    groups = {}
    for i, s in enumerate(sections):
        groups.setdefault(_stress_key(s), (s, []))[1].append(i)
    table = SectionTable(E=E, A=A, Iy=Iy, Iz=Iz, ymax=y, zmax=z, density=rho, yield_stress=ys, yield_given=given,
                         circle=np.array([getattr(s, "shape", None) == "circle" for s in sections], dtype=bool),
                         length=total[owner], has_y=all(a is not None for a, _ in fibre),
                         has_z=all(b is not None for _, b in fibre),
                         stress_groups=tuple((s, np.array(idx, dtype=np.int64)) for s, idx in groups.values()))
    for a in attrs.astuple(table, recurse=False):
        if isinstance(a, np.ndarray):
            a.flags.writeable = False
    if isinstance(elements.sections, tuple):  # a list could change: no cache
        try:
            _TABLES[elements] = table
        except TypeError:  # not weak-referenceable
            pass
    return table


def peak_normal_stress(model, state, axial=None) -> np.ndarray:
    """Peak normal stress [Pa] of every element of ``model`` (an `FEModel`) in ``state``, shape (E,):
    the largest over the two ends of ``|N|/A + |My| zmax/Iy + |Mz| ymax/Iz`` (3D; in 2D bending
    about z only); for a circle ``|N|/A + sqrt(My^2 + Mz^2) r/I`` (the resultant moment's extreme
    fibre). No shear (see `element_stresses`). ``axial``: ``(elements, N [N])`` replacing those
    elements' axial forces (a KSD-reduced solution's from its EOBs)."""
    tab = section_table(model.elements)
    if not tab.has_y or (model.dim == 3 and not tab.has_z):
        raise ModelError("peak stress needs the extreme-fibre distances ymax, zmax of every section "
                         "(flexmb.sections.rectangle sets them)")
    sig = _with_axial(model.stresses(state)[1], axial)
    axial = np.abs(sig[:, 0]) / tab.A
    L0 = model.elements.L0[:, None]
    if model.dim == 2:
        return axial + np.abs(L0 * sig[:, 1:3]).max(axis=1) * tab.ymax / tab.Iz
    My, Mz = L0 * sig[:, 2:4], L0 * sig[:, 4:6]  # ends p, q
    bend = np.abs(My) * (tab.zmax / tab.Iy)[:, None] + np.abs(Mz) * (tab.ymax / tab.Iz)[:, None]
    circle = tab.circle
    if circle.any():
        bend[circle] = np.hypot(My[circle], Mz[circle]) * (tab.ymax / tab.Iz)[circle, None]
    return axial + bend.max(axis=1)


def section_resultants(model, state, axial=None) -> np.ndarray:
    """Section forces of every element at both ends, local axes, (E, 2, 6) in 3D as
    ``[N, Vy, Vz, T, My, Mz]`` [N, N m], (E, 2, 3) in 2D as ``[N, Vy, Mz]`` (see the module notes);
    ``axial`` as in `peak_normal_stress`."""
    el = model.elements
    e, sig = model.stresses(state)
    sig = _with_axial(sig, axial)
    L0 = el.L0
    l = L0 + e[:, 0]
    nE = len(L0)
    if model.dim == 2:
        out = np.empty((nE, 2, 3))
        out[:, :, 0] = sig[:, 0:1]
        out[:, :, 1] = (L0 * (sig[:, 1] - sig[:, 2]) / l)[:, None]
        out[:, :, 2] = L0[:, None] * sig[:, 1:3]
        return out
    out = np.empty((nE, 2, 6))
    out[:, :, 0] = sig[:, 0:1]
    out[:, :, 1] = (L0 * (sig[:, 4] - sig[:, 5]) / l)[:, None]
    out[:, :, 2] = (L0 * (sig[:, 3] - sig[:, 2]) / l)[:, None]
    out[:, :, 3] = (L0 * sig[:, 1])[:, None]
    out[:, :, 4] = L0[:, None] * sig[:, 2:4]
    out[:, :, 5] = L0[:, None] * sig[:, 4:6]
    return out


def _cosh_ratio(x, X):
    """cosh(x)/cosh(X) and sinh(x)/cosh(X) for |x| <= X without overflow."""
    ax = np.abs(x)
    f = np.exp(ax - X) / (1.0 + np.exp(-2.0 * X))
    return f * (1.0 + np.exp(-2.0 * ax)), np.sign(x) * f * (1.0 - np.exp(-2.0 * ax))


def _rectangle_torsion(p, q, a, b):
    """Saint-Venant shear (tau_p, tau_q) per unit ``G theta`` at points (p, q) of the rectangle
    ``|p| <= a <= b >= |q|`` (Timoshenko & Goodier 1970, Sec. 109: Prandtl's stress function
    ``phi = a^2 - p^2 - 32 a^2/pi^3 sum_n odd (-1)^((n-1)/2)/n^3 cosh(n pi q/2a)/cosh(n pi b/2a)
    cos(n pi p/2a)``, ``tau_p = dphi/dq``, ``tau_q = -dphi/dp``; the parabola summed in closed
    form, so the series falls exponentially away from the short sides)."""
    n = np.arange(1, 2 * TORSION_TERMS, 2, dtype=float)[:, None]
    sgn = np.where(((n - 1) / 2) % 2 == 0, 1.0, -1.0)
    k = n * np.pi / (2.0 * a)
    ch, sh = _cosh_ratio(k * q, k * b)
    c = 16.0 * a / np.pi**2
    tau_q = 2.0 * p - c * np.sum(sgn / n**2 * ch * np.sin(k * p), axis=0)
    tau_p = -c * np.sum(sgn / n**2 * sh * np.cos(k * p), axis=0)
    return tau_p, tau_q


def _rectangle_torsion_rim(p, q, a, b):
    """`_rectangle_torsion` at points on the rim (``|p| = a`` or ``|q| = b``), from the rim's
    one-dimensional series, each side's distinct distances evaluated once: at ``|p| = a``,
    ``tau_q = sign(p) (2a - 16a/pi^2 sum 1/n^2 cosh(n pi q/2a)/cosh(n pi b/2a))``, ``tau_p = 0``;
    at ``|q| = b``, ``tau_p = -sign(q) 16a/pi^2 sum (-1)^((n-1)/2)/n^2 tanh(n pi b/2a)
    cos(n pi p/2a)``, ``tau_q = 0``; nil at the corners (exactly; the truncated series leaves
    ~1e-3 of the peak there)."""
    n = np.arange(1, 2 * TORSION_TERMS, 2, dtype=float)[:, None]
    sgn = np.where(((n - 1) / 2) % 2 == 0, 1.0, -1.0)
    k = n * np.pi / (2.0 * a)
    c = 16.0 * a / np.pi**2
    tau_p, tau_q = np.zeros_like(p), np.zeros_like(q)
    long, short = np.abs(p) == a, np.abs(q) == b
    corner = long & short
    d, inv = np.unique(np.abs(q[long & ~corner]), return_inverse=True)
    ch = _cosh_ratio(k * d, k * b)[0]
    tau_q[long & ~corner] = np.sign(p[long & ~corner]) * (2.0 * a - c * np.sum(ch / n**2, axis=0))[inv]
    d, inv = np.unique(np.abs(p[short & ~corner]), return_inverse=True)
    g = c * np.sum(sgn / n**2 * np.tanh(k * b) * np.cos(k * d), axis=0)
    tau_p[short & ~corner] = -np.sign(q[short & ~corner]) * g[inv]
    return tau_p, tau_q


@functools.lru_cache(maxsize=256)
def _points(shape: str, ymax: float, zmax: float, A: float, It: float):
    n = PERIMETER_POINTS
    if shape == "circle":
        th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
        c, s = np.cos(th), np.sin(th)
        yz = ymax * np.stack([c, s], axis=1)
        t = np.stack([-s, c], axis=1)  # tangent: positive torque turns +y towards +z
        tT = (ymax / It) * t
        tVy = (-(4.0 / (3.0 * A)) * s)[:, None] * t  # tau_xy = 4V/3A (1 - y^2/r^2) on the chord, tangent at the rim
        tVz = ((4.0 / (3.0 * A)) * c)[:, None] * t
        return yz, tT, tVy, tVz
    # n/4 points per side from one corner (included) to the next (excluded), clustered at the corners
    u = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, n // 4 + 1)[:-1]))
    y = np.concatenate([np.full_like(u, ymax), ymax * (1 - 2 * u), np.full_like(u, -ymax), ymax * (2 * u - 1)])
    z = np.concatenate([zmax * (2 * u - 1), np.full_like(u, zmax), zmax * (1 - 2 * u), np.full_like(u, -zmax)])
    # torsion: p the narrow direction (half a), q the long one; (p, q, x) right-handed or not
    if ymax <= zmax:
        tp, tq = _rectangle_torsion_rim(y, z, ymax, zmax)
        tT = np.stack([tp, tq], axis=1)
    else:
        tp, tq = _rectangle_torsion_rim(z, y, zmax, ymax)
        tT = -np.stack([tq, tp], axis=1)
    tT = tT / It  # G theta = T / It
    tVy = np.stack([1.5 / A * (1.0 - (y / ymax) ** 2), np.zeros_like(y)], axis=1)
    tVz = np.stack([np.zeros_like(z), 1.5 / A * (1.0 - (z / zmax) ** 2)], axis=1)
    return np.stack([y, z], axis=1), tT, tVy, tVz


def stress_points(section):
    """Perimeter points of a `Section` with a known ``shape`` and their stresses per unit load:
    ``(yz (P, 2) [m], tau_T (P, 2) [1/m^3], tau_Vy (P, 2), tau_Vz (P, 2) [1/m^2])``, the shear
    vectors ``(tau_xy, tau_xz)`` per unit torque and per unit shear force (module notes)."""
    if section.shape is None:
        raise ModelError("shear and von Mises stresses need the section's shape: build it with "
                         "flexmb.sections.rectangle or flexmb.sections.circle (Section.shape)")
    return tuple(a.copy() for a in _points(*_points_key(section)))


def _points_key(section) -> tuple:
    """`_points`'s arguments (its cache key) for a section with a known shape."""
    return (section.shape, *(float(x) for x in (section.ymax, section.zmax, section.A, section.It)))


@functools.lru_cache(maxsize=256)
def _units(key, Iy, Iz, points: int, step: int) -> tuple[np.ndarray, np.ndarray]:
    """`_points`'s per-point fields as the numba search reads them (8, P): ``z/Iy``, ``y/Iz``
    (as `_fields` divides them), then ``tau_T``, ``tau_Vy``, ``tau_Vz`` (two components each),
    padded by ``step`` points on each side with those one period away (8, P + 2 step: each fine
    window contiguous); their coarse points (every ``step``-th), contiguous; and each field's
    largest magnitude (8,). ``points``, ``step``: the
    `PERIMETER_POINTS` and `COARSE_STEP` they are for (part of the cache key)."""
    yz, tT, tVy, tVz = _points(*key)
    units = np.ascontiguousarray(np.stack([yz[:, 1] / Iy, yz[:, 0] / Iz, *tT.T, *tVy.T, *tVz.T]))
    padded = np.ascontiguousarray(np.concatenate([units[:, -step:], units, units[:, :step]], axis=1))
    umax = np.abs(units).max(axis=1)
    for a in (padded, units, umax):
        a.flags.writeable = False
    return padded, np.ascontiguousarray(units[:, ::step]), umax


def _fields(pts, r, idx=None):
    """sigma_x and |tau|^2 at perimeter points ``idx`` (all if None; else (m, k) per row of r)."""
    yz, tT, tVy, tVz = pts
    if idx is not None:
        yz, tT, tVy, tVz = yz[idx], tT[idx], tVy[idx], tVz[idx]  # (m, k, 2)
    N, Vy, Vz, T, My, Mz, A, Iy, Iz = (x[:, None] if isinstance(x, np.ndarray) else x for x in r)
    sx = N / A + My * (yz[..., 1] / Iy) - Mz * (yz[..., 0] / Iz)
    # per component, not a trailing axis of 2 (numpy's reductions over it are slow): the same sums
    t0 = T * tT[..., 0] + Vy * tVy[..., 0] + Vz * tVz[..., 0]
    t1 = T * tT[..., 1] + Vy * tVy[..., 1] + Vz * tVz[..., 1]
    return sx, t0 * t0 + t1 * t1


def perimeter_peaks(section, resultants):
    """Peak ``|sigma_x|``, ``|tau|`` and von Mises stress [Pa] over a section's perimeter for
    section forces ``resultants`` (n, ..., 6) ``[N, Vy, Vz, T, My, Mz]`` or (n, ..., 3) ``[N, Vy,
    Mz]`` (2D), each reduced over all but the first axis: three arrays of shape (n,).

    Each peak is searched on every `COARSE_STEP`-th of the `PERIMETER_POINTS` points, then on all
    points within one coarse step of the best coarse point."""
    key = _points_key(section) if section.shape is not None else None
    pts = _points(*key) if key is not None else stress_points(section)
    r = np.asarray(resultants, dtype=float)
    n = len(r)
    r = r.reshape(-1, r.shape[-1])
    if jit.enabled() and len(r):  # the same search compiled (flexmb.fe.stress_jit)
        if r.shape[-1] == 6:
            rows = np.ascontiguousarray(r)
        else:  # planar: [N, Vy, Mz], no Vz, T, My (as below)
            rows = np.zeros((len(r), 6))
            rows[:, 0], rows[:, 1], rows[:, 5] = r[:, 0], r[:, 1], r[:, 2]
        out = np.empty((len(r), 6))
        A, Iy, Iz = float(section.A), float(section.Iy), float(section.Iz)
        stress_jit.perimeter_search(*_units(key, Iy, Iz, PERIMETER_POINTS, COARSE_STEP), rows, A, Iy, Iz,
                                    COARSE_STEP, out)
        normal, shear, vm = np.empty(n), np.empty(n), np.empty(n)
        stress_jit.peaks_per_element(out, len(r) // n if n else 1, normal, shear, vm)
        return normal, shear, vm
    if r.shape[-1] == 3:  # planar: no torsion, no shear along z, no bending about y
        N, Vy, Mz = r.T
        T = Vz = My = np.zeros_like(N)
    else:
        N, Vy, Vz, T, My, Mz = r.T
    r = (N, Vy, Vz, T, My, Mz, section.A, section.Iy, section.Iz)
    P, step = len(pts[0]), COARSE_STEP
    sx, t2 = _fields(tuple(a[::step] for a in pts), r)  # the coarse points, shared by every row
    window = np.arange(-step, step + 1)
    out = []
    for value in (np.abs(sx), t2, sx**2 + 3.0 * t2):
        best = value.argmax(axis=1) * step
        fsx, ft2 = _fields(pts, r, (best[:, None] + window) % P)
        fine = (np.abs(fsx), ft2, fsx**2 + 3.0 * ft2)[len(out)]
        out.append(np.maximum(value.max(axis=1), fine.max(axis=1)).reshape(n, -1).max(axis=1))
    return out[0], np.sqrt(out[1]), np.sqrt(out[2])


@attrs.frozen(eq=False)
class Stresses:
    """Peak stresses of every element [Pa], shape (E,), each over both ends and its section's
    perimeter, times the element's stress-concentration factor (`element_stresses`).

    ``normal``: peak ``|sigma_x|``; ``shear``: peak ``|tau|`` (torsion and transverse);
    ``von_mises``: peak ``sqrt(sigma_x^2 + 3 tau^2)``; ``concentration``: the factor applied;
    ``safety``: ``limit / von_mises`` (None when no element has a limit; NaN for an element
    without one); ``limit``: each element's limit [Pa] (NaN: none) or None;
    ``joints``: joint name -> element indices.
    """

    normal: np.ndarray
    shear: np.ndarray
    von_mises: np.ndarray
    concentration: np.ndarray
    safety: np.ndarray | None
    limit: np.ndarray | None
    joints: dict

    def joint(self, name: str) -> dict:
        """Peaks of one joint: ``{"normal", "shear", "von_mises"[, "safety"]}`` (safety: the minimum)."""
        try:
            idx = self.joints[name]
        except KeyError:
            raise ModelError(f"no joint named {name!r}; joints: {', '.join(self.joints)}") from None
        out = {k: float(getattr(self, k)[idx].max()) for k in ("normal", "shear", "von_mises")}
        if self.safety is not None:
            out["safety"] = _nanmin(self.safety[idx])
        return out

    def summary(self) -> dict:
        """The whole mechanism's peaks (and the minimum safety factor), as in `joint`."""
        out = {k: float(getattr(self, k).max(initial=0.0)) for k in ("normal", "shear", "von_mises")}
        if self.safety is not None:
            out["safety"] = _nanmin(self.safety)
        return out


def _nanmin(a) -> float:
    a = a[~np.isnan(a)]
    return float(a.min()) if len(a) else np.nan


def _factors(owner, joints, n_elements, concentration):
    kt = np.ones(n_elements)
    if concentration is None:
        return kt
    if not isinstance(concentration, dict):
        kt[:] = _factor(owner, "concentration", concentration)
        return kt
    for name, value in concentration.items():
        if name not in joints:
            raise ModelError(f"{owner}: concentration names no joint {name!r}; joints: {', '.join(joints)}")
        kt[joints[name]] = _factor(owner, f"concentration[{name!r}]", value)
    return kt


def _factor(owner, name, value) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = np.nan
    if isinstance(value, (bool, str, bytes)) or not np.isfinite(x) or x < 1.0:
        raise ParameterError(f"{owner}: {name}={value!r} must be a stress-concentration factor >= 1")
    return x


def _stress_key(section):
    """What `perimeter_peaks` reads of a section (its shape, extreme fibres, A, It, Iy, Iz): sections
    equal in these share one perimeter search, the same numbers per element. The manipulator's 9
    joints' 81 sections are 2 such values. A section without a shape, or
    whose values are not plain numbers, keeps its own group (by identity)."""
    try:
        key = (section.shape,) + tuple(float(getattr(section, k)) for k in ("ymax", "zmax", "A", "It", "Iy", "Iz"))
    except (AttributeError, TypeError, ValueError):
        return id(section)
    return key if section.shape is not None and type(section).__name__ == "Section" else id(section)


@attrs.frozen(eq=False)
class _Plan:
    """What `stress_jit.element_peaks` reads of a batch's sections, per `SectionTable` and
    (`PERIMETER_POINTS`, `COARSE_STEP`): each element's group (E,), the groups' padded and coarse
    unit fields (G, 8, P + 2 step), (G, 8, P / step), their largest magnitudes (G, 8) and areas (G,)."""

    group: np.ndarray
    units: np.ndarray
    coarse: np.ndarray
    umax: np.ndarray
    A: np.ndarray
    sizes: tuple  # (PERIMETER_POINTS, COARSE_STEP) it is for


_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _plan(tab: SectionTable, n_elements: int):
    """The `_Plan` of ``tab``, built once per table and perimeter sizes; None when a group's
    section has no known shape or its values are not numbers (the per-group path reports it)."""
    sizes = (PERIMETER_POINTS, COARSE_STEP)
    plan = _PLANS.get(tab)
    if plan is not None and plan.sizes == sizes:
        return plan
    group = np.full(n_elements, -1, dtype=np.int64)
    units, coarse, umax, A = [], [], [], []
    try:
        for g, (s, idx) in enumerate(tab.stress_groups):
            if s.shape is None:
                return None
            u, c, um = _units(_points_key(s), float(s.Iy), float(s.Iz), *sizes)
            units.append(u)
            coarse.append(c)
            umax.append(um)
            A.append(float(s.A))
            group[idx] = g
    except (AttributeError, TypeError, ValueError):
        return None
    if (group < 0).any() or not units:
        return None
    plan = _Plan(group, np.ascontiguousarray(np.stack(units)), np.ascontiguousarray(np.stack(coarse)),
                 np.ascontiguousarray(np.stack(umax)), np.array(A), sizes)
    for a in (plan.group, plan.units, plan.coarse, plan.umax, plan.A):
        a.flags.writeable = False
    _PLANS[tab] = plan
    return plan


def _peaks(model, state, tab, kt, axial):
    """Per element its peak normal, shear and von Mises stresses times ``kt`` (`element_stresses`):
    one numba pass over the elements' generalised stresses (`stress_jit.element_peaks`, the
    per-group path's numbers to the last bit: tests/test_stress.py) when `flexmb.jit.enabled` and
    every section's shape is known, else per group of equal sections (`perimeter_peaks`)."""
    el = model.elements
    nE = len(el.L0)
    plan = _plan(tab, nE) if jit.enabled() and nE else None
    if plan is None:
        res = section_resultants(model, state, axial)  # (E, 2, k)
        normal, shear, vm = np.zeros(nE), np.zeros(nE), np.zeros(nE)
        for s, idx in tab.stress_groups:
            normal[idx], shear[idx], vm[idx] = perimeter_peaks(s, res[idx])
        return kt * normal, kt * shear, kt * vm
    e, sig = model.stresses(state)
    sig = _with_axial(sig, axial)  # a copy: the model's arrays untouched
    normal, shear, vm = np.empty(nE), np.empty(nE), np.empty(nE)
    stress_jit.element_peaks(np.ascontiguousarray(e, dtype=float), np.ascontiguousarray(sig, dtype=float),
                             el.L0, model.dim, plan.group, plan.units, plan.coarse, plan.umax, plan.A, plan.sizes[1], kt,
                             np.empty((2, 6)), normal, shear, vm)
    return normal, shear, vm


def element_stresses(model, state, joints: dict, concentration=None, limit=None, axial=None) -> Stresses:
    """Peak normal, shear and von Mises stresses [Pa] of every element (module notes), times a
    stress-concentration factor ``concentration`` (one number for all, or ``{joint: factor}``,
    factors >= 1, default 1), and with a material ``limit`` [Pa] (yield or fatigue strength) the
    safety factors ``limit / von_mises``; without ``limit``, each element's section's
    ``yield_stress`` where given. ``joints``: joint name -> element indices; ``axial`` as in
    `peak_normal_stress`."""
    owner = "stresses"
    el = model.elements
    kt = _factors(owner, joints, len(el.L0), concentration)
    if limit is not None:
        lim = positive(owner, "limit", limit)  # a stress [Pa]: the yield or fatigue strength
    nE = len(el.L0)
    tab = section_table(el)
    normal, shear, vm = _peaks(model, state, tab, kt, axial)
    if limit is not None:
        lims = np.full(nE, lim)
    else:
        lims = np.where(tab.yield_given, tab.yield_stress, np.nan)
    safety = None
    if not np.all(np.isnan(lims)):
        with np.errstate(divide="ignore", invalid="ignore"):
            safety = np.where(vm > 0, lims / np.where(vm > 0, vm, 1.0), np.where(np.isnan(lims), np.nan, np.inf))
    return Stresses(normal, shear, vm, kt, safety, None if safety is None else lims,
                    {k: np.asarray(v).copy() for k, v in joints.items()})
