"""Path-following cases: Lee's frame, DaDeppo & Schmidt's deep arch, the Euler strut,
a von Mises truss and Qiu's double curved-beam bistable, with their closed-form references.

Every member is a chain of straight co-rotational beam elements: one ``leaf_spring`` joint of
one element between consecutive links placed along the member's centre line (`polyline`), so a
curved member is a polygon of chords, as a user would build it. A pinned support is a link whose
position is prescribed and whose rotation is free.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipe, ellipk

from ..joints.cross_flexure import CrossFlexure
from ..mechanism import Mechanism
from ..sections import Section

__all__ = ["beam_section", "polyline", "lee_frame", "deep_arch", "euler_strut", "strut_elastica",
           "von_mises_truss", "von_mises_force", "qiu_bistable", "qiu_switching_forces", "qiu_force",
           "LEAF", "bistable_pair", "sine_arch", "FOURBAR", "motor_fourbar", "QIU", "qiu_beam",
           "FRAME", "roorda_frame", "clamped_arch"]


def beam_section(E: float, A: float, I: float, shear: bool = False, G: float | None = None) -> Section:
    """A planar beam section: ``E``, area ``A``, in-plane second moment ``I`` (Euler-Bernoulli
    unless ``shear``; then ``G`` (default E/2.6) with the rectangle's 5/6)."""
    G = E / 2.6 if G is None else G
    k = 5.0 / 6.0 if shear else np.inf
    return Section(E=E, G=G, A=A, Iy=I, Iz=I, It=2.0 * I, ky=k, kz=k)


def polyline(m: Mechanism, points, section: Section, names) -> list[str]:
    """Join ``points`` (n, 2) with one beam element each (``leaf_spring`` of one element) between
    links ``names`` (n; links that do not exist yet are added at their point)."""
    points = np.asarray(points, dtype=float)
    for name, p in zip(names, points):
        if name not in m.links:
            m.add_link(name, p)
    for k in range(len(points) - 1):
        d = points[k + 1] - points[k]
        L = float(np.hypot(*d))
        m.add_joint(names[k], names[k + 1], "leaf_spring", name=f"{names[k]}-{names[k + 1]}", length=L,
                    elements=1, section=section,
                    origin=points[k], rotation=math.atan2(d[1], d[0]))
    return list(names)


def _chain(m, a: str, b: str, pa, pb, n: int, section, prefix: str):
    pts = np.linspace(pa, pb, n + 1)
    names = [a] + [f"{prefix}{i}" for i in range(1, n)] + [b]
    return polyline(m, pts, section, names)


def lee_frame(elements: int = 10, load: float = 1.0, E: float = 720.0, A: float = 6.0, I: float = 2.0,
              L: float = 120.0) -> Mechanism:
    """Lee's frame (Lee, Manuel & Rossow 1968): a column and a beam of length ``L`` joined rigidly
    at the corner C, both far ends pinned (A at the origin, B at (L, L)), a downward ``load`` at
    P, ``L/5`` from the corner. ``elements`` per member (the beam split 1:4 at P). Units are
    the model's own: E = 720, A = 6, I = 2 (a 3 x 2 rectangle), L = 120 as in the literature."""
    sec = beam_section(E, A, I)
    m = Mechanism(dim=2)
    m.add_link("A", (0.0, 0.0))
    m.prescribe("A", x=0.0, y=0.0)
    m.add_link("B", (L, L))
    m.prescribe("B", x=0.0, y=0.0)
    m.add_link("C", (0.0, L))
    m.add_link("P", (L / 5, L))
    n1 = max(1, round(elements / 5))
    _chain(m, "A", "C", (0.0, 0.0), (0.0, L), elements, sec, "col")
    _chain(m, "C", "P", (0.0, L), (L / 5, L), n1, sec, "left")
    _chain(m, "P", "B", (L / 5, L), (L, L), elements - n1, sec, "right")
    m.apply_force("P", (0.0, -load))
    return m


def deep_arch(elements: int = 40, load: float | None = None, radius: float = 100.0, angle_deg: float = 215.0,
              EI: float = 1.0, slenderness: float = 1e4) -> Mechanism:
    """DaDeppo & Schmidt's (1975) deep circular arch: radius R, opening ``angle_deg``, clamped
    at the right end (link "clamp"), hinged at the left ("pin"), a downward ``load`` (default
    ``EI / R^2``, so the load factor is ``P R^2 / EI``) at the apex link "apex". ``elements`` chords in all (even); ``slenderness`` R / r with r^2 = I / A sets
    the (nearly inextensible) axial stiffness."""
    half = math.radians(angle_deg) / 2
    sec = beam_section(1.0, slenderness**2 * EI / radius**2, EI)
    m = Mechanism(dim=2)
    phi = np.linspace(math.pi / 2 - half, math.pi / 2 + half, elements + 1)  # right end to left end
    pts = radius * np.column_stack([np.cos(phi), np.sin(phi)])
    names = ["clamp"] + [f"n{i}" for i in range(1, elements)] + ["pin"]
    names[elements // 2] = "apex"
    m.add_link("clamp", pts[0], fixed=True)
    polyline(m, pts, sec, names)
    m.prescribe("pin", x=0.0, y=0.0)
    m.apply_force("apex", (0.0, -(EI / radius**2 if load is None else load)))
    return m


def euler_strut(elements: int = 20, load: float = 1.0, imperfection: float = 1e-3, L: float = 1.0,
                EI: float = 1.0, EA: float = 1e7) -> Mechanism:
    """A clamped-free strut (a leaf spring from the fixed base "A" to the free tip "B") under an
    axial compressive ``load`` at the tip, with a lateral load ``imperfection * load`` (0: the
    perfect strut, whose straight path bifurcates at the Euler load pi^2 EI / (4 L^2))."""
    sec = beam_section(1.0, EA, EI)
    m = Mechanism(dim=2)
    m.add_link("A", (0.0, 0.0), fixed=True)
    _chain(m, "A", "B", (0.0, 0.0), (L, 0.0), elements, sec, "s")
    m.apply_force("B", (-load, imperfection * load))
    return m


def strut_elastica(tip_rotation):
    """The inextensible clamped-free elastica at tip rotation alpha [rad] (Timoshenko & Gere 1961,
    Sec. 2.7): ``(P / P_E, shortening / L, deflection / L)`` with ``P_E = pi^2 EI / (4 L^2)``,
    ``k = sin(alpha / 2)``: ``P / P_E = (2 K(k) / pi)^2``, shortening ``2 - 2 E(k) / K(k)``,
    deflection ``2 k / K(k)`` (K, E complete elliptic integrals of modulus k)."""
    k = np.sin(np.asarray(tip_rotation, dtype=float) / 2)
    K, E = ellipk(k * k), ellipe(k * k)
    return (2 * K / np.pi) ** 2, 2 - 2 * E / K, 2 * k / K


def von_mises_truss(elements: int = 4, span: float = 1000.0, rise: float = 50.0, E: float = 210000.0,
                    A: float = 100.0, I: float = 1e5, load: float = 1e4) -> Mechanism:
    """Half of a symmetric von Mises two-bar truss (mm, N, MPa): the bar from the pinned support
    "S" at (-span/2, 0) to the apex "T" at (0, rise), which by symmetry moves vertically only
    (x prescribed) with its rotation free (pinned); ``load`` is half the apex load (downward)."""
    sec = beam_section(E, A, I)
    m = Mechanism(dim=2)
    m.add_link("S", (-span / 2, 0.0))
    m.prescribe("S", x=0.0, y=0.0)
    m.add_link("T", (0.0, rise))
    m.prescribe("T", x=0.0)
    _chain(m, "S", "T", (-span / 2, 0.0), (0.0, rise), elements, sec, "b")
    m.apply_force("T", (0.0, -load))
    return m


def von_mises_force(w, span: float = 1000.0, rise: float = 50.0, E: float = 210000.0, A: float = 100.0):
    """Half the apex load [N] at apex deflection ``w`` [mm] (downward) of the pinned two-bar truss
    with the co-rotational beam's axial law ``N = EA (l - l0) / l0``: ``F = -N (rise - w) / l``,
    ``l = sqrt((span/2)^2 + (rise - w)^2)`` (equilibrium of the apex in the deformed state)."""
    w = np.asarray(w, dtype=float)
    b = span / 2
    l0, l = math.hypot(b, rise), np.sqrt(b * b + (rise - w) ** 2)
    return -E * A * (l - l0) / l0 * (rise - w) / l


def qiu_bistable(elements: int = 20, span: float = 3e-3, rise: float = 1.2e-4, thickness: float = 1e-5,
                 width: float = 5e-4, E: float = 169e9, load: float = 1.0, imperfection: float = 1e-3) -> Mechanism:
    """Qiu, Lang & Slocum's (2004) double curved beam: two cosine-shaped clamped-clamped beams
    ``w0 = rise/2 (1 - cos(2 pi x / span))`` joined at their centres, a downward ``load`` [N] on
    the centre (force control). Defaults: a silicon MEMS beam, 3 mm x 10 um x 0.5 mm with a
    120 um rise (Q = h/t = 12).

    Modelled in the plane by symmetry: the left half (``elements`` chords) of one beam of twice
    the bending and axial stiffness, clamped at "L"; the centre link "C" moves vertically only,
    without turning (the joined centres hold mode 2, the symmetry the antisymmetric modes, among
    them one with the third mode's buckling load), under half the load. ``imperfection``: the
    amplitude, relative to ``rise``, of the third buckling mode ``rise/2 (1 - cos(4 pi x /
    span))`` added to the shape: the perfect beam reaches that mode's buckling load on its way
    down, a bifurcation (Qiu's analysis) that the path would pass by; the imperfection turns it
    into the snap-through the device shows.
    """
    I, A = width * thickness**3 / 12.0, width * thickness
    sec = beam_section(E, 2 * A, 2 * I)
    x = np.linspace(0.0, span / 2, elements + 1)
    shape = 1 - np.cos(2 * np.pi * x / span) + imperfection * (1 - np.cos(4 * np.pi * x / span))
    pts = np.column_stack([x, rise / 2 * shape])
    names = ["L"] + [f"q{i}" for i in range(1, elements)] + ["C"]
    m = Mechanism(dim=2)
    m.add_link("L", pts[0], fixed=True)
    polyline(m, pts, sec, names)
    m.prescribe("C", x=0.0, rotation=0.0)
    m.apply_force("C", (0.0, -load / 2))
    return m


def qiu_switching_forces(span: float = 3e-3, rise: float = 1.2e-4, thickness: float = 1e-5,
                         width: float = 5e-4, E: float = 169e9) -> tuple[float, float]:
    """The double curved beam's forward and backward switching forces ``(F_top, F_bot)`` of Qiu,
    Lang & Slocum's (2004) modal model (Sec. III; shallow, inextensible-free axial law, modes 1
    and 3 of the clamped-clamped beam, mode 2 held by the joined centres).

    With ``Q = h / t`` (rise over thickness) and ``Delta = d / h`` (centre travel over rise) one
    beam carries ``F L^3 / (E I h) = 3 pi^4 Q^2 / 2 Delta (Delta - 3/2 + sqrt(1/4 - 4/(3 Q^2)))
    (Delta - 3/2 - sqrt(1/4 - 4/(3 Q^2)))`` while only mode 1 deforms, and ``8 pi^4 - 6 pi^4
    Delta`` once the axial force reaches the third mode's buckling load ``16 pi^2 E I / L^2``,
    between ``Delta_1,2 = 1 -/+ sqrt(1 - 16 / (3 Q^2))``: ``F_top = pi^4 (8 - 6 Delta_1)``,
    ``F_bot = pi^4 (8 - 6 Delta_2)`` (negative), in units of ``E I h / L^3``; the paper rounds
    them to 740 and -370 for its design. Two beams: twice these forces.
    """
    I = width * thickness**3 / 12.0
    Q = rise / thickness
    root = math.sqrt(1.0 - 16.0 / (3.0 * Q * Q))
    unit = 2.0 * E * I * rise / span**3
    return math.pi**4 * (8 - 6 * (1 - root)) * unit, math.pi**4 * (8 - 6 * (1 + root)) * unit


def qiu_force(travel, span: float = 3e-3, rise: float = 1.2e-4, thickness: float = 1e-5, width: float = 5e-4,
              E: float = 169e9):
    """The double curved beam's force [N] at centre travel ``travel`` [m] from Qiu's modal model
    (`qiu_switching_forces`): the mode-1 cubic outside ``Delta_1 ... Delta_2``, the mode-3 line
    inside."""
    I = width * thickness**3 / 12.0
    Q = rise / thickness
    d = np.asarray(travel, dtype=float) / rise
    root = math.sqrt(1.0 - 16.0 / (3.0 * Q * Q))
    s = math.sqrt(0.25 - 4.0 / (3.0 * Q * Q))
    cubic = 1.5 * math.pi**4 * Q * Q * d * (d - 1.5 + s) * (d - 1.5 - s)
    line = math.pi**4 * (8 - 6 * d)
    inside = (d > 1 - root) & (d < 1 + root)
    return np.where(inside, line, cubic) * 2.0 * E * I * rise / span**3


# -- snap-through design cases: builders; their references are in tests/test_snap.py ---------------

#: The device: two steel leaves 50 x 10 x 0.5 mm inclined at 10 deg (mm, N, MPa), rise 8.68 mm
LEAF = dict(L=50.0, t=0.5, w=10.0, E=200000.0, alpha=math.radians(10.0))


def bistable_pair(elements: int = 12, control: str = "motion") -> Mechanism:
    """Two leaves from the ground (G1, G2) to the shuttle S at the apex, mirror images, clamped
    at both ends (Euler-Bernoulli sections: the shooting reference has no shear; the default
    Timoshenko leaf differs by 0.1 %); S guided (x and rotation held) and pushed down: by a
    prescribed travel of twice the rise at load factor 1 (``"motion"``) or by 100 N (``"load"``)."""
    L, t, w, E, a = LEAF["L"], LEAF["t"], LEAF["w"], LEAF["E"], LEAF["alpha"]
    sec = beam_section(E, w * t, w * t**3 / 12)
    m = Mechanism(dim=2)
    m.add_link("G1", (-L * math.cos(a), 0.0), fixed=True)
    m.add_link("G2", (L * math.cos(a), 0.0), fixed=True)
    m.add_link("S", (0.0, L * math.sin(a)))
    m.add_joint("G1", "S", "leaf_spring", length=L, section=sec, elements=elements, origin=(-L * math.cos(a), 0.0),
                rotation=a)
    m.add_joint("G2", "S", "leaf_spring", length=L, section=sec, elements=elements, origin=(L * math.cos(a), 0.0),
                rotation=math.pi - a)
    if control == "load":
        m.prescribe("S", x=0.0, rotation=0.0)
        m.apply_force("S", (0.0, -100.0))
    else:
        m.prescribe("S", x=0.0, y=-2 * L * math.sin(a), rotation=0.0)
    return m


def sine_arch(elements: int = 40, e: float = 6.0, rise: float = 0.01, imperfection: float = 0.0):
    """A half-sine arch ``y = rise sin(pi x / L)`` (L = 1, hinged ends P0, P1) of radius of
    gyration ``r = rise / e``, EI = 1, under the half-sine load ``q0 sin(pi x / L)``, ``q0 = EI
    (pi / L)^4 r`` per unit load factor (so the load factor is Timoshenko & Gere's load
    parameter), lumped at the nodes; ``imperfection``: an antisymmetric part ``imperfection r
    sin(2 pi x / L)`` of the shape."""
    L, r = 1.0, rise / e
    x = np.linspace(0, L, elements + 1)
    y = rise * np.sin(np.pi * x / L) + imperfection * r * np.sin(2 * np.pi * x / L)
    names = ["P0"] + [f"a{i}" for i in range(1, elements)] + ["P1"]
    m = Mechanism(dim=2)
    E = 2e11  # steel, with I = 1 / E: EI = 1
    polyline(m, np.c_[x, y], beam_section(E, 1.0 / (E * r**2), 1.0 / E), names)
    m.prescribe("P0", x=0.0, y=0.0)
    m.prescribe("P1", x=0.0, y=0.0)
    q0 = (np.pi / L) ** 4 * r
    for k in range(1, elements):
        m.apply_force(names[k], (0.0, -q0 * math.sin(np.pi * x[k] / L) * L / elements))
    return m


FOURBAR = dict(a=0.02, b=0.08, c=0.05, d=0.08)  # crank, coupler, rocker, ground [m]: a Grashof crank-rocker


def _rocker_tip(A, P):
    """The coupler-rocker pin B of the rigid four-bar: |B - A| = b, |B - P| = c, above the line AP."""
    b, c = FOURBAR["b"], FOURBAR["c"]
    v = P - A
    L = float(np.linalg.norm(v))
    x = (L**2 + b**2 - c**2) / (2 * L)
    e = v / L
    return A + x * e + math.sqrt(b**2 - x**2) * np.array([-e[1], e[0]])


def motor_fourbar(dim: int, turn: float = 2 * math.pi) -> Mechanism:
    """A crank-rocker four-bar (`FOURBAR`): the crank turned by a hinge motor at the origin, the
    coupler pinned to it and to the rocker, the rocker's pivot a cross flexure (30 mm leaves,
    0.3 mm thick) centred at (d, 0); 2D or 3D (the same plane)."""
    z = (0.0,) if dim == 3 else ()
    a, d = FOURBAR["a"], FOURBAR["d"]
    A0, P = np.array([0.0, a]), np.array([d, 0.0])
    B0 = _rocker_tip(A0, P)
    cf = CrossFlexure(length=0.03, thickness=3e-4, width_inner=0.01, width_outer=0.005, elements_per_leaf=6)
    half = cf.interface_b(2)[1] / 2  # the leaves cross half-way between the blocks
    m = Mechanism(dim=dim)
    m.add_link("G", fixed=True)
    m.add_link("crank", (0.0, 0.0) + z)
    m.add_link("coupler", tuple(A0) + z)
    m.add_link("rocker", (d, half) + z)
    m.add_joint("G", "crank", "hinge", angle=turn, origin=(0.0, 0.0) + z)
    m.add_joint("crank", "coupler", "hinge", origin=tuple(A0) + z)
    m.add_joint("coupler", "rocker", "hinge", origin=tuple(B0) + z)
    m.add_joint("G", "rocker", cf, origin=(d, -half) + z)
    return m


QIU = dict(span=3e-3, rise=1.2e-4, t=1e-5, w=5e-4, E=169e9)  # Qiu, Lang & Slocum (2004): Q = h / t = 12


def qiu_beam(elements: int, shuttle: bool) -> Mechanism:
    """The whole cosine-shaped clamped-clamped beam ``w0 = h/2 (1 - cos(2 pi x / L))``
    (``elements`` chords per half, both ends fixed), its centre C pushed down by twice the rise
    at load factor 1. ``shuttle``: Qiu's double beam, two beams joined by the centre shuttle
    (twice the stiffness, C's rotation and sideways motion held); without it a single beam
    whose centre turns freely."""
    span, rise, t, w, E = (QIU[k] for k in ("span", "rise", "t", "w", "E"))
    k = 2 if shuttle else 1
    n = 2 * elements
    x = np.linspace(0.0, span, n + 1)
    names = ["L"] + [f"q{i}" for i in range(1, n)] + ["R"]
    names[elements] = "C"
    m = Mechanism(dim=2)
    m.add_link("L", (0.0, 0.0), fixed=True)
    m.add_link("R", (span, 0.0), fixed=True)
    polyline(m, np.c_[x, rise / 2 * (1 - np.cos(2 * np.pi * x / span))], beam_section(E, k * w * t, k * w * t**3 / 12),
             names)
    if shuttle:
        m.prescribe("C", x=0.0, rotation=0.0)
    m.prescribe("C", y=-2 * rise)
    return m


#: Roorda's two-bar frame (Roorda 1965; Koiter 1967): two equal steel members 100 x 10 x 1 mm (mm, N, MPa)
FRAME = dict(L=100.0, t=1.0, w=10.0, E=200000.0)


def roorda_frame(elements: int = 12, eccentricity: float = 0.0) -> Mechanism:
    """Roorda's L-frame: a column from the pinned base A (origin) up to the corner C, rigidly
    joined there to a beam out to the pinned support B (`FRAME`: equal members, ``elements``
    each, Euler-Bernoulli sections), pushed down at C along the column by ``EI / L^2`` per unit
    load factor (so the load factor is ``P L^2 / EI``, Koiter's parameter), with the moment
    ``eccentricity * P * L`` of a load off the column's axis (Roorda's imperfection; > 0
    counter-clockwise, towards the beam: the collapsing side).

    B settles with the column's axial shortening ``P L / EA`` (its vertical position prescribed,
    scaled with the load): the beam translates without bending and the fundamental path stays
    the trivial one of the inextensible theory; with B held, the shortening would turn the beam
    and the corner from the start, and the perfect frame would meet a limit point instead of
    its asymmetric bifurcation."""
    L, t, w, E = (FRAME[k] for k in "LtwE")
    EI, EA = E * w * t**3 / 12, E * w * t
    P = EI / L**2
    sec = beam_section(E, w * t, w * t**3 / 12)
    m = Mechanism(dim=2)
    m.add_link("A", (0.0, 0.0))
    m.add_link("C", (0.0, L))
    m.add_link("B", (L, L))
    m.prescribe("A", x=0.0, y=0.0)
    m.prescribe("B", x=0.0, y=-P * L / EA)
    m.add_joint("A", "C", "leaf_spring", length=L, section=sec, elements=elements, origin=(0.0, 0.0),
                rotation=math.pi / 2)
    m.add_joint("C", "B", "leaf_spring", length=L, section=sec, elements=elements, origin=(0.0, L))
    m.apply_force("C", (0.0, -P))
    if eccentricity:
        m.apply_moment("C", eccentricity * P * L)
    return m


def clamped_arch(elements: int = 40, e: float = 15.0, rise: float = 0.01, load: str = "uniform") -> Mechanism:
    """A shallow circular arch of span S = 1 and ``rise`` (L, R: both ends clamped; the crown
    link "crown" at mid-span, ``elements`` even), radius of gyration ``r = rise / e``, EI = 1
    (steel, I = 1 / E), its chords on the circle. ``load``: ``"uniform"``, a downward load of
    EI / S^3 per unit span per unit load factor (lumped at the nodes by their tributary span),
    or ``"point"``, EI / S^2 down at the crown: the load factor is ``q S^3 / EI`` or
    ``Q S^2 / EI``."""
    S, r = 1.0, rise / e
    R = (S * S / 4 + rise * rise) / (2 * rise)
    half = math.asin(S / (2 * R))
    th = np.linspace(-half, half, elements + 1)
    x, y = S / 2 + R * np.sin(th), R * (np.cos(th) - math.cos(half))
    names = ["L"] + [f"a{i}" for i in range(1, elements)] + ["R"]
    names[elements // 2] = "crown"
    m = Mechanism(dim=2)
    m.add_link("L", (x[0], y[0]), fixed=True)
    m.add_link("R", (x[-1], y[-1]), fixed=True)
    E = 2e11
    polyline(m, np.c_[x, y], beam_section(E, 1.0 / (E * r**2), 1.0 / E), names)
    if load == "point":
        m.apply_force("crown", (0.0, -1.0))
    else:
        span = np.zeros(elements + 1)
        span[:-1] += np.diff(x) / 2
        span[1:] += np.diff(x) / 2
        for k in range(1, elements):
            m.apply_force(names[k], (0.0, -span[k]))
    return m
