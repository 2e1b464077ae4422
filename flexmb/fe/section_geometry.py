"""The beam elements as the solids they stand for, and the points' motion in a mode shape.

A beam element of a rectangular section (`flexmb.sections.rectangle`: ``2 ymax`` thick along
local y, ``2 zmax`` wide along local z) is drawn and exported as the box between its two end
sections. Each end section turns with its FE node (the co-rotational state: ``ny = R ny0``,
``nz = R nz0`` with ``R`` the end point's node rotation, as the element's deformations of
Eq. A.4 read them), so a twisted or bent leaf shows as a twisted or bent plate. Corners are
ordered ``(+y, +z), (-y, +z), (-y, -z), (+y, -z)``: their right-hand normal is the local ``x``
axis, from end p towards end q (local axes right-handed), as VTK's hexahedron wants.

A circular section (`flexmb.sections.circle`) is drawn as the prism on a regular polygon of
`CIRCLE_POINTS` vertices on the circle (its real diameter; the polygon's area is
``n sin(2 pi / n) / (2 pi)`` of the circle's, 0.974 at 16), ordered counter-clockwise from +y in
the (y, z) plane, so its right-hand normal is the local x axis too.
"""

from __future__ import annotations

import numpy as np

from ..rotations import cross

__all__ = ["rectangle_elements", "shaped_elements", "section_frames", "section_corners", "section_outlines",
           "point_motion", "mode_scale", "CORNER_SIGNS", "CIRCLE_POINTS", "OUTLINES", "MODE_SIZE_FRACTION"]

#: (y, z) signs of the four corners of a rectangle section, in drawing order.
CORNER_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
#: Vertices of the polygon a circular section is drawn as: a round wire reads as round (8 looked
#: octagonal), and the VTK file stays small (8 hexahedra per element, `flexmb.export.mode_mesh`).
CIRCLE_POINTS = 16
_ANGLES = 2.0 * np.pi * np.arange(CIRCLE_POINTS) / CIRCLE_POINTS
#: Each drawn section shape's outline in units of ``(ymax, zmax)``, (K, 2), counter-clockwise in (y, z).
OUTLINES = {"rectangle": CORNER_SIGNS, "circle": np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=1)}


def shaped_elements(model) -> dict:
    """``{shape: element indices}`` (sorted) of the elements whose section shape has an outline
    (`OUTLINES`: rectangles and circles), shapes without elements left out."""
    shapes = [s.shape for s in model.elements.sections]
    out = {}
    for shape in OUTLINES:
        idx = np.array([i for i, s in enumerate(shapes) if s == shape], dtype=np.int64)
        if len(idx):
            out[shape] = idx
    return out


def rectangle_elements(model) -> np.ndarray:
    """Indices of the elements whose section is a rectangle (`Section.shape`), sorted."""
    return shaped_elements(model).get("rectangle", np.zeros(0, dtype=np.int64))


def section_frames(model, state, elements) -> tuple[np.ndarray, np.ndarray]:
    """Current local y and z axes at both ends of ``elements``, each (E, 2, 3) (2D: y in the plane,
    z the global z axis)."""
    el = model.elements
    master = model.point_master[el.ends[elements]]  # (E, 2)
    if model.dim == 3:
        R = state.rotations[master]  # (E, 2, 3, 3)
        ny = np.einsum("epij,ej->epi", R, el.ny0[elements])
        nz = np.einsum("epij,ej->epi", R, el.nz0[elements])
        return ny, nz
    angle = el.alpha0[elements][:, None] + state.rotations[master]  # (E, 2)
    ny = np.stack([-np.sin(angle), np.cos(angle), np.zeros_like(angle)], axis=-1)
    nz = np.zeros_like(ny)
    nz[..., 2] = 1.0
    return ny, nz


def section_outlines(model, state, elements, shape: str, points=None) -> np.ndarray:
    """Outline points (E, 2, K, 3) [m] of the end sections of ``elements`` (all of section
    ``shape``, `OUTLINES`) in ``state``: ``x_end + y_k ymax ny + z_k zmax nz``; planar models in
    3D coordinates (z = 0 the plane, the width out of it). ``points``: `FEModel.point_positions`
    of ``state`` if already computed."""
    el = model.elements
    P = model.point_positions(state) if points is None else points
    x = np.asarray(P, dtype=float)[el.ends[elements]]  # (E, 2, dim)
    if x.shape[-1] == 2:
        x = np.concatenate([x, np.zeros(x.shape[:-1] + (1,))], axis=-1)
    ny, nz = section_frames(model, state, elements)
    half = np.array([[el.sections[i].ymax, el.sections[i].zmax] for i in elements], dtype=float).reshape(-1, 2)
    unit = OUTLINES[shape]
    ys = unit[None, :, 0] * half[:, 0:1]  # (E, K)
    zs = unit[None, :, 1] * half[:, 1:2]
    return x[:, :, None, :] + ys[:, None, :, None] * ny[:, :, None, :] + zs[:, None, :, None] * nz[:, :, None, :]


def section_corners(model, state, elements, points=None) -> np.ndarray:
    """Corners (E, 2, 4, 3) [m] of the end sections of rectangle ``elements`` in ``state``:
    ``x_end +- ymax ny +- zmax nz`` in the order of `CORNER_SIGNS` (`section_outlines`)."""
    return section_outlines(model, state, elements, "rectangle", points)


def point_motion(model, state, shape: np.ndarray, at: np.ndarray, master: np.ndarray) -> np.ndarray:
    """Linearised displacement (K, 3) of material points ``at`` (K, 3) [m] rigidly attached to the
    nodes ``master`` (K,) under the nodal motion ``shape`` (N, ndof) (a mode shape:
    ``[dx, dy, dtheta]`` in 2D, ``[dx, dy, dz, spin]`` in 3D): ``du + dphi x (at - x_node)``."""
    shape = np.asarray(shape, dtype=float)
    dim = model.dim
    x_node = np.zeros((len(master), 3))
    x_node[:, :dim] = state.positions[master]
    du = np.zeros((len(master), 3))
    du[:, :dim] = shape[master, :dim]
    spin = np.zeros((len(master), 3))
    if dim == 3:
        spin[:] = shape[master, 3:6]
    else:
        spin[:, 2] = shape[master, 2]
    return du + cross(spin, np.asarray(at, dtype=float) - x_node)


#: The default deformation scale of mode pictures (`flexmb.plot.plot_mode`, `flexmb.export.mode_mesh`):
#: the largest point displacement of the drawn mode is this fraction of the mechanism's size
#: (the largest extent of its points): visible, and small enough that the linearised shape
#: still reads as the motion (a leaf turned by 0.1 rad shortens its chord by 0.2 %).
MODE_SIZE_FRACTION = 0.1


def mode_scale(model, state, shape, points=None, motion=None) -> float:
    """The scale that makes the largest linearised point displacement of ``shape`` (N, ndof)
    `MODE_SIZE_FRACTION` of the mechanism's size at ``state``; a shape that moves no point (all
    rotation about the points themselves) is scaled to a largest turn of that fraction [rad].
    ``points`` (P, dim) and ``motion`` (P, 3): the model's points and their motion if known."""
    P = model.point_positions(state) if points is None else np.asarray(points)
    if motion is None:
        at = np.zeros((len(P), 3))
        at[:, :model.dim] = P[:, :model.dim]
        motion = point_motion(model, state, shape, at, model.point_master)
    size = float(np.ptp(P, axis=0).max())
    big = float(np.linalg.norm(motion, axis=1).max())
    if big > 0 and size > 0:
        return MODE_SIZE_FRACTION * size / big
    turn = float(np.abs(np.asarray(shape)[:, model.dim:]).max())
    return MODE_SIZE_FRACTION / turn if turn > 0 else 1.0
