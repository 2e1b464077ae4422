"""Ready-made mechanisms from the papers."""

from __future__ import annotations

import attrs
import numpy as np

from . import _validate as v
from .errors import DatabaseError, ParameterError
from .joints.cross_flexure import CrossFlexure
from .joints.curved_beam import CurvedBeam
from .joints.leaf_spring import LeafSpring
from .joints.three_x_infinity import ThreeXInfinity
from .ksd.kinematics import solve_kinematics
from .compiled import compiled_for
from .ksd.reduced import reduced_mechanism
from .mechanism import Mechanism
from .problem import path_load_factors
from .registry import joint_from_params
from .rotations import expm_so3

__all__ = ["cantilever", "cross_flexure_pivot", "fourbar", "gripper", "manipulator", "manipulator_rotations",
           "MANIPULATOR"]


def cross_flexure_pivot(elements_per_leaf: int = 3, dim: int = 3, rotation: float = 0.0, **joint_params) -> Mechanism:
    """A single cross flexure (Dwarshuis et al. 2020, Sec. 4.1-4.2, Table 1 defaults).

    Link ``"A"`` (the lower connector block, interface node A at the origin) is fixed; link
    ``"B"`` (the upper block, node B) is rotated by ``rotation`` [rad] about the joint axis z and
    free in x and y (in 3D, its z displacement and tilts are held at zero). The reaction on B
    about z is the moment of Fig. 7. ``joint_params`` go to `CrossFlexure`.
    """
    v.finite("cross_flexure_pivot", "rotation", rotation)
    joint = joint_from_params(CrossFlexure, elements_per_leaf=elements_per_leaf, **joint_params)
    m = Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim))
    m.add_joint("A", "B", joint, name="cross_flexure")
    if dim == 2:
        m.prescribe("B", rotation=rotation)
    else:
        m.prescribe("B", z=0.0, rotation=(0.0, 0.0, rotation))
    return m


def fourbar(elements_per_leaf: int = 3, displacement: float = 0.0, moment: float = 0.0, *, dim: int = 3,
            width: float = 0.4, height: float = 0.3, **joint_params) -> Mechanism:
    """The four-bar of Dwarshuis et al. (2020), Sec. 4.3, Fig. 9: four cross flexures (Table 1).

    Link ``"ground"`` (fixed) carries the two lower cross flexures ``"bottom_left"`` and
    ``"bottom_right"``, ``width`` [m] apart (W = 0.4 m) on the x axis; rigid vertical links
    ``"left"`` and ``"right"`` of length ``height`` [m] (H = 0.3 m, from the upper block of the
    lower flexure to the lower block of the upper flexure) carry ``"top_left"`` and
    ``"top_right"``, whose upper blocks hold link ``"top"``. Every flexure stands upright (node
    B above node A, the joint frame parallel to the global axes), so the pivots (the leaf
    crossings) are ``height + D0`` apart, D0 = L sin(alpha) = 0.0707 m: the paper's largest
    actuation d = 0.3 m turns the flexures by 54 degrees, inside the trained range.

    The reference point of ``"top"`` is the centre of the upper link (x = 0, at the height of the
    upper flexures' B nodes); its x displacement is prescribed to ``displacement`` [m] (the
    actuation; the reaction is the actuation force F of Fig. 10) and an extra ``moment`` [N m]
    about z acts on it (Fig. 12). ``joint_params`` go to `CrossFlexure`.
    """
    v.finite("fourbar", "displacement", displacement)
    v.finite("fourbar", "moment", moment)
    v.positive("fourbar", "width", width)
    v.positive("fourbar", "height", height)
    joint = joint_from_params(CrossFlexure, elements_per_leaf=elements_per_leaf, **joint_params)
    D0 = float(joint.interface_b(2)[1])
    half = 0.5 * width
    m = Mechanism(dim=dim)
    pt = (lambda x, y: (x, y)) if dim == 2 else (lambda x, y: (x, y, 0.0))
    m.add_link("ground", fixed=True)
    m.add_link("left", position=pt(-half, D0 + 0.5 * height))
    m.add_link("right", position=pt(half, D0 + 0.5 * height))
    m.add_link("top", position=pt(0.0, 2 * D0 + height))
    for side, x, link in (("left", -half, "left"), ("right", half, "right")):
        m.add_joint("ground", link, joint, name=f"bottom_{side}", origin=pt(x, 0.0))
        m.add_joint(link, "top", joint, name=f"top_{side}", origin=pt(x, D0 + height))
    m.prescribe("top", x=displacement)
    if moment:
        m.apply_moment("top", moment if dim == 2 else (0.0, 0.0, moment))
    return m


#: Link geometry of `manipulator` [m, rad]: a post of ``post`` above joint 1's node B up to joint
#: 2, then link 2 of length ``arm2`` at ``angle2`` above the horizontal to joint 3, and link 3 of
#: length ``arm3`` at ``angle3`` to the end point (flexmb's choice in the spirit of Fig. 13).
MANIPULATOR = {"post": 0.15, "arm2": 0.30, "angle2": np.radians(30.0), "arm3": 0.25, "angle3": np.radians(-30.0)}
MANIPULATOR_CASES = ("joint", "location")


def manipulator_rotations(rotation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orientations (3, 3) of links 1-3 with all three joints turned by ``rotation`` [rad] and
    no unintended motion: ``Rz(r)``, ``Rz(r) Ry(r)``, ``Rz(r) Ry(2 r)``."""

    Rz, Ry = expm_so3(np.array([0.0, 0.0, rotation])), expm_so3(np.array([0.0, rotation, 0.0]))
    return Rz, Rz @ Ry, Rz @ Ry @ Ry


def manipulator(case: str = "joint", rotation: float = 0.0, elements: int | None = None, *, geometry: dict | None = None,
                **joint_params) -> Mechanism:
    """The spatial three-link manipulator of Dwarshuis et al. (2020), Sec. 4.4, Fig. 13, with
    three `ThreeXInfinity` joints (``joint_params``; ``elements`` per leaf, default 3).

    Link ``"ground"`` (fixed) holds joint ``"joint1"`` (axis global z, node A at the origin,
    node B on the axis above it); link ``"link1"`` is a post of `MANIPULATOR` ``post`` up to
    ``"joint2"``, whose axis is global y; ``"link2"`` runs ``arm2`` at ``angle2`` in the x-z
    plane to ``"joint3"`` (axis global y) and ``"link3"`` ``arm3`` at ``angle3`` to the end
    point, its reference point. Links 1 and 2 start at the B nodes of joints 1 and 2.

    ``case="joint"``: the three joint rotations are prescribed to ``rotation`` [rad] by
    prescribing the orientations of the links as chains of the joint rotations
    (`Mechanism.prescribe`, `manipulator_rotations`), so every load step of the conventional
    method keeps the joints untilted; the links' positions stay
    free, so the reactions are moments only (the joint moments of the paper's joint case; under
    pure moments the symmetric joints have no tilt, so holding the tilt costs no reaction).
    ``case="location"``: the x, y, z position of the end point is prescribed to where the joint
    case puts it (as Sec. 4.4; from the joints' trained kinematics, which the joint case's
    equilibrium follows exactly), and its reactions are three forces.
    ``rotation`` must lie in the joints' trained range, +-45 deg. ``geometry`` overrides entries of
    `MANIPULATOR` (``post``, ``arm2``, ``arm3`` [m] > 0, ``angle2``, ``angle3`` [rad]): other joint
    placements of the same mechanism, as a design loop varies them.
    """
    if case not in MANIPULATOR_CASES:
        raise ParameterError(f"manipulator: case={case!r}; valid: {', '.join(MANIPULATOR_CASES)}")
    limit = ThreeXInfinity.motion_range
    v.finite("manipulator", "rotation", rotation)
    if abs(rotation) > limit + 1e-12:
        raise ParameterError(f"manipulator: rotation={rotation!r} rad ({np.degrees(rotation):.1f} deg) is outside "
                             f"the range of the three_x_infinity joints, +-{np.degrees(limit):.0f} deg")
    if elements is not None:
        joint_params["elements_per_leaf"] = elements
    joint_params.setdefault("elements_per_leaf", 3)  # the mesh of the shipped database (not the joint's default)
    joint = joint_from_params(ThreeXInfinity, **joint_params)
    return _manipulator(case, rotation, joint, _manipulator_geometry(geometry))


def _manipulator(case: str, rotation: float, joint: ThreeXInfinity, g: dict) -> Mechanism:
    """`manipulator` of checked arguments: ``joint`` at its three places, the geometry ``g``."""
    D0 = float(joint.interface_b(3)[2])
    (_, _, b2, end), (_, a2, a3) = _frames(D0, g)
    ez = np.array([0.0, 0.0, 1.0])
    m = Mechanism(dim=3)
    m.add_link("ground", fixed=True)
    m.add_link("link1", position=D0 * ez)
    m.add_link("link2", position=b2)
    m.add_link("link3", position=end)
    y_axis = (-0.5 * np.pi, 0.0, 0.0)  # turns the joint's z axis onto global y
    m.add_joint("ground", "link1", joint, name="joint1")
    m.add_joint("link1", "link2", joint, name="joint2", origin=a2, rotation=y_axis)
    m.add_joint("link2", "link3", joint, name="joint3", origin=a3, rotation=y_axis)
    m.add_point("link3", "end", end)
    R = manipulator_rotations(rotation)
    if case == "joint":
        z, y = np.array([0.0, 0.0, rotation]), np.array([0.0, rotation, 0.0])
        m.prescribe("link1", rotation=z)
        m.prescribe("link2", rotation=[z, y])
        m.prescribe("link3", rotation=[z, 2 * y])
    else:
        point = _joint_case_end_point(rotation, joint, g, R, (a2, a3), end)
        m.prescribe("link3", **dict(zip("xyz", point - end)), path=_kinematic_path(rotation, (a2, a3), end, point))
    return m


#: waypoints of the location case's end-point path (`_kinematic_path`)
PATH_POINTS = 8


def _kinematic_path(rotation, origins, end, point) -> np.ndarray:
    """The location case's end-point displacements [m] at the load factors
    `flexmb.problem.path_load_factors` (`PATH_POINTS` of them): where the rigid links put it with
    the joints turned by ``lam * rotation``, plus ``lam`` times the difference of ``point`` (the
    trained kinematics) from the rigid end: the path the mechanism follows by turning its joints
    (a straight line takes joint 3 to 56 deg and back at 45 deg)."""
    rigid = lambda lam: _end_point(manipulator_rotations(lam * rotation), origins, end)  # noqa: E731
    miss = point - rigid(1.0)
    out = np.array([rigid(lam) - end + lam * miss for lam in path_load_factors(PATH_POINTS)])
    out[-1] = point - end
    return out


def _manipulator_geometry(geometry: dict | None) -> dict:
    """`MANIPULATOR` with ``geometry``'s entries (checked: known names, finite, lengths > 0)."""
    if not geometry:
        return MANIPULATOR
    unknown = sorted(set(geometry) - set(MANIPULATOR))
    if unknown:
        raise ParameterError(f"manipulator: unknown geometry {unknown}; valid: {sorted(MANIPULATOR)}")
    g = dict(MANIPULATOR)
    for name, value in geometry.items():
        g[name] = (v.positive if name in ("post", "arm2", "arm3") else v.finite)("manipulator", name, value)
    return g


#: The joint case's kinematics per (rotation, joint) (`_joint_case_kinematics`), at most
#: `JOINT_CASE_KEPT` entries, the oldest dropped first.
_JOINT_CASE: dict = {}
JOINT_CASE_KEPT = 64


def _joint_case_end_point(rotation, joint, g, R, origins, end) -> np.ndarray:
    """Where the joint case puts the end point [m]: its KSD kinematics (joints turned by
    ``rotation`` with their trained offsets, Sec. 2.1), which the joint case's equilibrium keeps
    (no unintended load); rigid-link kinematics about the joint axes if the joint is untrained.

    The kinematics is solved once per ``rotation`` and joint, on `MANIPULATOR`'s geometry (its end
    point returned as solved there). Each joint's relative motion (`_relative_motions`) does not
    depend on where the joints are placed (the links are rigid, the joints' frames keep their
    orientations and the links' rotations are prescribed), so other placements chain the same
    motions through their own geometry (`_chained_end_point`)."""
    kept = _joint_case_kinematics(rotation, joint)
    if kept is None:
        return _end_point(R, origins, end)
    point, motions = kept
    if all(g[k] == MANIPULATOR[k] for k in MANIPULATOR):
        return point.copy()
    return _chained_end_point(motions, _frames(float(joint.interface_b(3)[2]), g))


def _joint_case_kinematics(rotation, joint):
    """``(end point, relative motions)`` of the joint case at ``rotation`` on `MANIPULATOR`'s
    geometry (KSD kinematics), None for an untrained joint; kept per (rotation, joint) while the
    joint databases read stay the same (`flexmb.ksd.reduced.ReducedMechanism.current`)."""
    key = (float(rotation), joint)
    kept = _JOINT_CASE.get(key)
    if kept is not None and kept[2].current():
        return kept[:2]
    m = _manipulator("joint", rotation, joint, MANIPULATOR)
    try:  # the joint case's compiled structure and KSD set-up kept from the last call (flexmb.compiled)
        compiled = compiled_for(m)
        red = reduced_mechanism(compiled)
        poses = solve_kinematics(red)[0]
    except DatabaseError:
        return None
    frames = _frames(float(joint.interface_b(3)[2]), MANIPULATOR)
    nodes = [compiled.link_node[name] for name in ("ground", "link1", "link2", "link3")]
    point = poses.x[nodes[3]].copy()
    while len(_JOINT_CASE) >= JOINT_CASE_KEPT:
        del _JOINT_CASE[next(iter(_JOINT_CASE))]
    _JOINT_CASE[key] = point, _relative_motions(poses.x[nodes], poses.R[nodes], frames), red
    return point, _JOINT_CASE[key][1]


def _frames(D0: float, g: dict) -> tuple[list, list]:
    """Reference points of links ground, 1, 2, 3 and origins (node A) of joints 1-3 [m] for the
    geometry ``g`` (`MANIPULATOR`'s entries) and the joint's height ``D0``."""
    ex, ey, ez = np.eye(3)
    a2 = (D0 + g["post"]) * ez
    b2 = a2 + D0 * ey
    a3 = b2 + g["arm2"] * (np.cos(g["angle2"]) * ex + np.sin(g["angle2"]) * ez)
    b3 = a3 + D0 * ey
    end = b3 + g["arm3"] * (np.cos(g["angle3"]) * ex + np.sin(g["angle3"]) * ez)
    return [np.zeros(3), D0 * ez, b2, end], [np.zeros(3), a2, a3]


def _relative_motions(x, R, frames) -> list:
    """Per joint j (1-3), ``(S, d)``: link j's motion relative to link j - 1 in link j - 1's
    undeformed frame, ``P -> o + S (P - o) + d`` about the joint's origin ``o``, from the links'
    poses ``x`` (4, 3), ``R`` (4, 3, 3) (ground first)."""
    X, origins = frames
    out = []
    for k, o in enumerate(origins, start=1):
        S = R[k - 1].T @ R[k]
        d = X[k - 1] + R[k - 1].T @ (x[k] + R[k] @ (o - X[k]) - x[k - 1]) - o
        out.append((S, d))
    return out


def _chained_end_point(motions, frames) -> np.ndarray:
    """Link 3's reference point [m] moved by the joints' relative ``motions`` chained from the
    ground through the geometry ``frames`` (`_frames`)."""
    X, origins = frames
    x, R = X[0], np.eye(3)
    for k, (o, (S, d)) in enumerate(zip(origins, motions), start=1):
        x = x + R @ (o + d + S @ (X[k] - o) - X[k - 1])
        R = R @ S
    return x


def _end_point(R, origins, end) -> np.ndarray:
    """End point [m] with links 1-3 turned by ``R`` about the joint axes through nodes A."""
    a2, a3 = origins
    A2 = R[0] @ a2  # joint 1's axis passes through the origin
    A3 = A2 + R[1] @ (a3 - a2)
    return A3 + R[2] @ (end - a3)


def fourbar_linear_force(displacement: float, elements_per_leaf: int = 3, height: float = 0.3,
                         **joint_params) -> float:
    """F_lin = 4 E I d / (L H^2) [N], Eq. (4.7), with I of Eq. (4.4) for the four-bar's flexures."""
    joint = joint_from_params(CrossFlexure, elements_per_leaf=elements_per_leaf, **joint_params)
    return 4.0 * joint.E * joint.second_moment * displacement / (joint.length * height**2)


def cantilever(elements: int = 8, dim: int = 2, **leaf_params) -> Mechanism:
    """A straight leaf spring clamped in link ``"ground"`` (fixed) with a free link ``"tip"``.

    The beam runs along +x from the origin; load the tip with `Mechanism.apply_force` /
    `apply_moment`. ``leaf_params`` go to `LeafSpring` (defaults: 0.1 x 0.02 x 0.001 m steel).
    """
    leaf = joint_from_params(LeafSpring, elements=elements, **leaf_params)
    m = Mechanism(dim=dim)
    m.add_link("ground", fixed=True)
    m.add_link("tip", position=leaf.interface_b(dim))
    m.add_joint("ground", "tip", leaf, name="leaf")
    return m


#: Cammarata et al. (2022), Table 1 [mm]: centres of mass, hinge centres, local base vectors.
GRIPPER_TABLE_1 = {
    "G2": (1.5, 0.2), "G3": (1.8, 1.5), "G4": (1.0, 1.5),
    "O_a": (0.5, 0.0), "O_b": (1.8478, 0.7654), "O_c": (1.1928, 1.9), "O_d": (0.5, 1.5),
    "s_1a": (0.6848, 0.0765), "s_2a": (-0.8413, -0.3218), "s_2b": (0.2139, 0.7140),
    "s_3b": (0.0408, -0.5348), "s_3c": (-0.4140, 0.3482), "s_3EE": (-1.3571, 1.6991),
    "s_4c": (0.3342, 0.2586), "s_4d": (-0.6000, -0.1732), "s_1d": (0.3714, 1.6532),
    "radius": 0.2, "angles_deg": (300.0, 320.0, 330.0, 250.0), "b": 0.025, "h": 0.005,
}
#: Young's moduli [uN/mm^2] (1 GPa = 1e9 uN/mm^2): silicon 100 GPa, nylon 3.84 GPa (Sec. 5.1).
GRIPPER_MATERIALS = {"silicon": 100e9, "nylon": 3.84e9}
#: Densities [g/mm^3], the mass unit consistent with mm, uN and s (1 uN s^2/mm = 1e-3 kg = 1 g):
#: silicon 2329 kg/m^3, nylon 1150 kg/m^3 (handbook values; the paper gives none). Mass only:
#: the static results do not depend on them.
GRIPPER_DENSITIES = {"silicon": 2.329e-3, "nylon": 1.15e-3}


def gripper(material: str = "silicon", model: str = "partial-nonlinear", force: float = 0.0,
            elements: int = 16, width: float | None = None, height: float | None = None) -> Mechanism:
    """The MEMS gripper of Cammarata et al. (2022), Sec. 5, Table 1, in mm and uN.

    Rigid bodies ``"body1"`` (fixed, frame at the origin) ... ``"body4"`` (reference points at the
    centres of mass G2, G3, G4), joined by four circular curved beams a (1-2), b (2-3), c (3-4),
    d (4-1). Each beam is an arc of Table 1's radius (0.2 mm) and angle about its hinge centre,
    running counter-clockwise from the first body's attachment point (s_1a, s_2b, s_3c, s_4d);
    its end lands on the second body's attachment point within 2e-4 mm (checked). This is the
    construction of the paper: its Table 2 is reproduced to all printed digits.

    The actuation (`Mechanism.actuation`, swept by `flexmb.sweep`) is the force ``force`` [uN] on
    body 2 at G2 along +y; the named point ``"end_effector"`` on body 3 is G3 + s_3EE.
    ``model`` ("linear" | "partial-nonlinear") selects the wrench model of the closed form
    (``method="newton"``); ``elements`` is the number of beam elements per arc in flexmb's fully
    non-linear finite-element model (``method="conventional"``). ``width`` and ``height`` [mm]
    replace Table 1's cross-section b = 0.025, h = 0.005 (the cross-section study, Fig. 10).
    Masses are in g (the unit consistent with mm, uN and s): the arcs' densities in g/mm^3
    (`GRIPPER_DENSITIES`), so `flexmb.modes` gives frequencies in Hz.
    """
    if not isinstance(material, str) or material not in GRIPPER_MATERIALS:
        raise ParameterError(f"gripper: material={material!r}; valid: {sorted(GRIPPER_MATERIALS)}")
    t = {k: np.asarray(x, dtype=float) if not isinstance(x, (float, int)) else x for k, x in GRIPPER_TABLE_1.items()}
    origin = {"body1": np.zeros(2), "body2": t["G2"], "body3": t["G3"], "body4": t["G4"]}
    m = Mechanism(dim=2, units="mm-uN-Pa")
    m.add_link("body1", fixed=True)
    for name in ("body2", "body3", "body4"):
        m.add_link(name, position=origin[name])
    hinges = (("a", "body1", "body2", "s_1a", "s_2a"), ("b", "body2", "body3", "s_2b", "s_3b"),
              ("c", "body3", "body4", "s_3c", "s_4c"), ("d", "body4", "body1", "s_4d", "s_1d"))
    for (h, bi, bj, si, sj), deg in zip(hinges, t["angles_deg"]):
        center = t[f"O_{h}"]
        # through() checks that both attachment points lie on one circle about the hinge centre
        beam, placement = CurvedBeam.through(center, origin[bi] + t[si], origin[bj] + t[sj],
                                             E=GRIPPER_MATERIALS[material], width=t["b"] if width is None else width,
                                             height=t["h"] if height is None else height,
                                             elements=elements, model=model,
                                             density=GRIPPER_DENSITIES[material])
        if abs(np.degrees(beam.angle) - deg) > 0.5:  # Table 1 lists the angles: the geometry must agree
            raise ParameterError(f"gripper: hinge {h} spans {np.degrees(beam.angle):.2f} deg, Table 1 says {deg}")
        start_dir = placement["rotation"] - np.pi / 2  # direction of the first attachment from the centre
        beam = attrs.evolve(beam, radius=t["radius"], angle=np.radians(deg))
        placement = {"origin": center + t["radius"] * np.array([np.cos(start_dir), np.sin(start_dir)]),
                     "rotation": placement["rotation"]}
        m.add_joint(bi, bj, beam, name=h, **placement)
    m.add_point("body3", "end_effector", t["G3"] + t["s_3EE"])
    m.set_actuation("body2", (0.0, 1.0), value=force)
    return m
