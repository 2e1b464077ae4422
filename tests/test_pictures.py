"""Pictures a flexure designer reads (issue 22, item 9): leaves as plates, mode shapes, the
frequencies over the stroke, and modes in ParaView with the leaves' real cross-sections.

The case beyond the papers: a spatial parallel guide of two leaf springs in mm, N, MPa, t/mm^3, s
(50 x 10 x 0.5 mm steel leaves 20 mm apart, stage B moved 5 mm across the leaves).
"""

from __future__ import annotations

import attrs
import numpy as np
import pytest

import flexmb
from flexmb.fe.section_geometry import (MODE_SIZE_FRACTION, mode_scale, point_motion, rectangle_elements,
                                        section_corners)

pytest.importorskip("matplotlib")
meshio = pytest.importorskip("meshio")
from flexmb import export, plot  # noqa: E402

L, WIDTH, THICK, GAP = 50.0, 10.0, 0.5, 20.0  # mm


def parallel_guide(stroke: float = 5.0, elements: int = 3) -> flexmb.Mechanism:
    """Two leaves along x at y = 0 and y = GAP, clamped in the fixed block A and the stage B."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", (0.0, GAP / 2, 0.0), fixed=True)
    m.add_link("B", (L, GAP / 2, 0.0), mass=5e-5, inertia=2e-6 * np.eye(3))  # 50 g, t mm^2
    for k, y in enumerate((0.0, GAP)):
        m.add_joint("A", "B", "leaf_spring", name=f"leaf{k}", origin=(0.0, y, 0.0), length=L, width=WIDTH,
                    thickness=THICK, E=200000.0, G=76900.0, density=7.8e-9, elements=elements)
    m.prescribe("B", y=stroke)
    return m


@pytest.fixture(scope="module")
def guide():
    sol = flexmb.solve(parallel_guide(), method="conventional")
    assert sol.converged
    return sol


@pytest.fixture(scope="module")
def guide_modes(guide):
    return flexmb.modes(guide, n_modes=3)


@pytest.fixture(scope="module")
def planar_modes():
    """The planar cross-flexure pivot turned 0.3 rad, its steel leaves' own mass only (SI)."""
    sol = flexmb.solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=3, dim=2, rotation=0.3),
                       method="conventional")
    return flexmb.modes(sol, n_modes=2)


def _faces(coll) -> np.ndarray:
    """The 3D faces (F, 4, 3) a Poly3DCollection holds (matplotlib keeps them in ``_faces``)."""
    return np.asarray(coll._faces)


def _by_gid(ax, gid):
    return [a for a in (*ax.lines, *ax.collections) if a.get_gid() == gid]


def _line_ends(line) -> np.ndarray:
    data = line.get_data_3d() if hasattr(line, "get_data_3d") else line.get_data()
    return np.array(data, dtype=float).T


# -- leaves as plates ---------------------------------------------------------------------------
def test_undeformed_leaves_are_plates_of_their_width_and_thickness_about_the_leaf_axis():
    mech = parallel_guide(elements=2)
    ax = plot.plot_mechanism(mech, unit="mm")
    (plates,) = _by_gid(ax, "plate-undeformed")
    faces = _faces(plates)
    assert faces.shape == (4 * 4, 4, 3)  # 2 leaves x 2 elements, 4 long faces each
    # every corner is +-THICK/2 across (local y = global y) and +-WIDTH/2 along z from its leaf's axis
    # (leaf_spring: width along the joint's z, thickness along y; flexmb.sections.rectangle)
    corners = faces.reshape(-1, 3)
    axis_y = np.where(corners[:, 1] > GAP / 2, GAP, 0.0)
    np.testing.assert_allclose(np.abs(corners[:, 1] - axis_y), THICK / 2, rtol=1e-12)
    np.testing.assert_allclose(np.abs(corners[:, 2]), WIDTH / 2, rtol=1e-12)
    assert set(np.round(corners[:, 0], 9)) == {0.0, 25.0, 50.0}  # the element ends along the leaf
    assert ax.get_xlabel() == "x [mm]" and ax.get_zlabel() == "z [mm]"


def test_deformed_plates_turn_with_the_stage(guide):
    """At the stage B's clamp the end sections are B's: ``x_end + R_B (+-h/2 e_y +-b/2 e_z)``, with
    R_B from `Solution.pose` (independent of the element frames the plates are built from)."""
    ax = plot.plot_mechanism(guide)
    (plates,) = _by_gid(ax, "plate-deformed")
    model = guide.compiled.problem.model
    idx = rectangle_elements(model)
    assert len(idx) == 6 and _faces(plates).shape == (4 * 6, 4, 3)
    C = section_corners(model, guide.state, idx)
    P = model.point_positions(guide.state)
    xB, RB = guide.pose("B")
    ends = model.elements.ends[idx]
    at_B = model.point_master[ends[:, 1]] == guide.compiled.link_node["B"]  # ends in B's clamps
    assert at_B.sum() == 2
    for e in np.flatnonzero(at_B):
        for c, (sy, sz) in enumerate([(1, 1), (-1, 1), (-1, -1), (1, -1)]):
            expect = P[ends[e, 1]] + RB @ np.array([0.0, sy * THICK / 2, sz * WIDTH / 2])
            np.testing.assert_allclose(C[e, 1, c], expect, atol=1e-12 * L)
    # the faces drawn are these corners, the four long sides of each box
    faces = _faces(plates).reshape(6, 4, 4, 3)
    np.testing.assert_allclose(faces[:, :, 0], C[:, 0], atol=1e-12 * L)
    np.testing.assert_allclose(faces[:, :, 2], np.roll(C[:, 1], -1, axis=1), atol=1e-12 * L)


def test_a_deformation_scale_magnifies_the_parasitic_motion(guide):
    """Scale 20: the drawn nodes at x0 + 20 (x - x0), so the stage's parasitic shortening (its x
    displacement; closed form 0.6 d^2/L = 0.3 mm for d = 5 mm on 50 mm, measured 0.275 mm at 3
    elements per leaf, 0.2991 at 12, 0.3005 at 24) is drawn as 5.5 mm."""
    model = guide.compiled.problem.model
    ax = plot.plot_mechanism(guide, scale=20.0, unit="mm")
    x0, x = model.x0, guide.state.positions
    on_node = np.flatnonzero(np.linalg.norm(model.point_offset, axis=1) == 0.0)
    drawn = {}
    for line, pq in zip(_by_gid(ax, "beam-deformed"), model.elements.ends):
        for j in range(2):
            drawn[pq[j]] = _line_ends(line)[j]
    checked = [p for p in on_node if p in drawn]
    assert len(checked) >= 2 * 2  # each leaf's two internal nodes
    for p in checked:
        n = model.point_master[p]
        np.testing.assert_allclose(drawn[p], x0[n] + 20.0 * (x[n] - x0[n]), rtol=1e-12, atol=1e-10)
    assert ax.get_title() == "deformation x 20"
    with pytest.raises(flexmb.FlexmbError, match="scale"):
        plot.plot_mechanism(guide, scale=-1.0)


def test_plates_can_be_left_out_and_planar_figures_have_none(guide, planar_modes):
    assert not _by_gid(plot.plot_mechanism(guide, plates=False), "plate-deformed")
    assert not [c for c in plot.plot_mechanism(planar_modes.solution).collections
                if (c.get_gid() or "").startswith("plate")]


# -- mode shapes --------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["guide", "planar"])
def test_mode_figure_is_the_equilibrium_plus_scale_times_the_shape_at_the_nodes(case, request):
    modes = request.getfixturevalue(f"{case}_modes")
    sol = modes.solution
    model = sol.compiled.problem.model
    k = 1
    ax = plot.plot_mode(modes, k)
    scale = mode_scale(model, sol.state, modes.shapes[k])
    # default scale: the largest point motion is 10 % of the mechanism's size
    P = model.point_positions(sol.state)
    at = np.zeros((len(P), 3))
    at[:, :model.dim] = P
    u = point_motion(model, sol.state, modes.shapes[k], at, model.point_master)
    assert scale * np.linalg.norm(u, axis=1).max() == pytest.approx(MODE_SIZE_FRACTION * np.ptp(P, axis=0).max())
    lines = _by_gid(ax, "beam-mode")
    eq = _by_gid(ax, "beam-equilibrium")
    ends = model.elements.ends
    assert len(lines) == len(eq) == len(ends)
    on_node = np.linalg.norm(model.point_offset, axis=1) == 0.0  # points that are FE nodes
    checked = 0
    for line, line0, pq in zip(lines, eq, ends):
        X, X0 = _line_ends(line), _line_ends(line0)
        np.testing.assert_allclose(X0, P[pq], atol=1e-12)
        for j in range(2):
            if on_node[pq[j]]:
                n = model.point_master[pq[j]]
                np.testing.assert_allclose(X[j], sol.state.positions[n] + scale * modes.shapes[k][n, :model.dim],
                                           rtol=1e-12, atol=1e-12 * np.ptp(P))
                checked += 1
    assert checked >= len(ends)  # every element has at least one end on a node
    f = modes.frequencies[k]
    assert ax.get_title().startswith(f"mode {k + 1}: {f:.4g} Hz")
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["equilibrium", f"mode {k + 1} x {scale:.3g}"]
    labelled = [a.get_label() for a in ax.lines if not a.get_label().startswith("_")]
    assert labelled == ["equilibrium", f"mode {k + 1} x {scale:.3g}"]  # each legend entry is a drawn line


def test_mode_figure_with_a_given_scale_and_the_guide_plates(guide_modes):
    ax = plot.plot_mode(guide_modes, 0, scale=2.0, unit="mm")
    assert "scale 2" in ax.get_title() and ax.get_xlabel() == "x [mm]"
    assert _faces(_by_gid(ax, "plate-mode")[0]).shape == (24, 4, 3)


def test_mode_figure_rejects_bad_input(guide_modes, guide):
    with pytest.raises(flexmb.FlexmbError, match=r"k=3 must be in \[0, 2\]"):
        plot.plot_mode(guide_modes, 3)
    with pytest.raises(flexmb.FlexmbError, match="flexmb.Modes"):
        plot.plot_mode(guide, 0)
    bare = attrs.evolve(guide_modes, solution=None)
    with pytest.raises(flexmb.FlexmbError, match="solution="):
        plot.plot_mode(bare, 0)
    assert plot.plot_mode(bare, 0, solution=guide).get_title() == plot.plot_mode(guide_modes, 0).get_title()


# -- frequencies over the stroke ------------------------------------------------------------------
def test_frequency_plot_draws_the_f_columns_over_the_stroke(guide):
    strokes = [0.0, 2.5, 5.0]
    sols = [flexmb.solve(parallel_guide(d), method="conventional") for d in strokes]
    props = flexmb.properties(sols, which=("modes",), n_modes=3)
    table = {"B.y": np.array(strokes), **{c: np.asarray(props[c]) for c in ("f1", "f2", "f3")}}
    ax = plot.plot_frequencies(table, "B.y", xlabel="stage stroke [mm]")
    lines = ax.get_lines()
    assert [ln.get_gid() for ln in lines] == ["f1", "f2", "f3"]
    for ln in lines:
        np.testing.assert_array_equal(ln.get_xdata(), strokes)
        np.testing.assert_array_equal(ln.get_ydata(), table[ln.get_gid()])
    assert ax.get_xlabel() == "stage stroke [mm]" and ax.get_ylabel() == "frequency [Hz]"
    # the 5 mm configuration is the fixture's: same first frequency
    assert table["f1"][-1] == pytest.approx(flexmb.modes(guide, n_modes=1).frequencies[0], rel=1e-9)


def test_frequency_plot_in_degrees_lists_only_drawn_curves():
    table = {"B.rotation_z": np.radians([0.0, 15.0, 30.0]), "f2": [20.0, np.nan, 18.0], "f10": [90.0, 80.0, 70.0],
             "f1": [10.0, 11.0, 12.0], "f3": [np.nan] * 3}
    ax = plot.plot_frequencies(table, "B.rotation_z", degrees=True)
    assert [ln.get_gid() for ln in ax.get_lines()] == ["f1", "f2", "f10"]  # numeric order; f3 has no value
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["f1", "f2", "f10"]
    np.testing.assert_allclose(ax.get_lines()[0].get_xdata(), [0.0, 15.0, 30.0])
    assert ax.get_xlabel() == "B.rotation_z [deg]"
    with pytest.raises(flexmb.FlexmbError, match="no frequency columns"):
        plot.plot_frequencies({"x": [1.0]}, "x")
    with pytest.raises(flexmb.FlexmbError, match="no column"):
        plot.plot_frequencies(table, "B.y")


# -- modes in ParaView ---------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".vtu", ".vtk"])
def test_mode_file_holds_the_shape_and_the_leaves_as_hexahedra(guide_modes, tmp_path, suffix):
    sol, k = guide_modes.solution, 0
    model = sol.compiled.problem.model
    path = export.write_mode(guide_modes, k, tmp_path / f"mode{suffix}")
    mesh = meshio.read(path)
    hexes = np.concatenate([c.data for c in mesh.cells if c.type == "hexahedron"])
    assert len(hexes) == len(rectangle_elements(model)) == 6
    X, mode = mesh.points, mesh.point_data["mode"]
    # at the stage's reference point the field is the stage's shape (Modes.link_shapes)
    nB = sol.compiled.link_node["B"]
    np.testing.assert_allclose(mode[nB], guide_modes.link_shapes["B"][k][:3], rtol=1e-12)
    # at every FE node the field is the node's translation in the shape
    nodes = np.flatnonzero(np.linalg.norm(model.point_offset, axis=1) == 0.0)
    master = model.point_master[nodes]
    np.testing.assert_allclose(mode[nodes], guide_modes.shapes[k][master, :3], rtol=1e-12, atol=1e-12)
    # the hexahedra's corners are the end sections (flexmb.fe.section_geometry)
    C = section_corners(model, sol.state, rectangle_elements(model))
    np.testing.assert_allclose(X[hexes].reshape(-1, 2, 4, 3), C, atol=1e-12 * L)
    # each corner moves as its section: central difference of the corners under +-eps x shape
    eps = 1e-6
    du = np.zeros(model.n_dofs)
    du[:model.n_node_dofs] = eps * guide_modes.shapes[k].ravel()
    Cp = section_corners(model, model.apply_increment(sol.state, du), rectangle_elements(model))
    Cm = section_corners(model, model.apply_increment(sol.state, -du), rectangle_elements(model))
    np.testing.assert_allclose(mode[hexes].reshape(-1, 2, 4, 3), (Cp - Cm) / (2 * eps), rtol=1e-6,
                               atol=1e-8 * np.abs(mode).max())
    # VTK's hexahedron: the right-hand normal of the first face points into the cell (positive volume)
    H = X[hexes]
    n = np.cross(H[:, 1] - H[:, 0], H[:, 2] - H[:, 1])
    assert np.all(np.einsum("ei,ei->e", n, H[:, 4:].mean(axis=1) - H[:, :4].mean(axis=1)) > 0)
    scaled = mesh.point_data["mode_scaled"]
    size = np.ptp(model.point_positions(sol.state), axis=0).max()
    if suffix == ".vtu":  # field data: .vtu only (see flexmb.export)
        assert mesh.field_data["frequency"][0] == pytest.approx(guide_modes.frequencies[k], rel=1e-12)
    # default scale as the figures': largest FE point motion 10 % of the size (corners move a bit more)
    n_fe = len(model.point_master)
    assert np.linalg.norm(scaled[:n_fe], axis=1).max() == pytest.approx(MODE_SIZE_FRACTION * size, rel=1e-9)


def test_planar_mode_file_gives_the_leaves_their_width_out_of_the_plane(planar_modes, tmp_path):
    model = planar_modes.solution.compiled.problem.model
    mesh = meshio.read(export.write_mode(planar_modes, 0, tmp_path / "pivot_mode.vtu", scale=3.0))
    hexes = np.concatenate([c.data for c in mesh.cells if c.type == "hexahedron"])
    idx = rectangle_elements(model)
    assert len(hexes) == len(idx)
    half_width = np.array([model.elements.sections[i].zmax for i in idx])
    np.testing.assert_allclose(np.abs(mesh.points[hexes][..., 2]), np.broadcast_to(half_width[:, None], hexes.shape),
                               rtol=1e-12)
    np.testing.assert_allclose(mesh.point_data["mode_scaled"], 3.0 * mesh.point_data["mode"])
    H = mesh.points[hexes]  # positive volume (VTK's ordering) in the plane too
    n = np.cross(H[:, 1] - H[:, 0], H[:, 2] - H[:, 1])
    assert np.all(np.einsum("ei,ei->e", n, H[:, 4:].mean(axis=1) - H[:, :4].mean(axis=1)) > 0)
    np.testing.assert_allclose(mesh.point_data["mode"][..., 2], 0.0, atol=1e-300)  # planar motion


def test_mode_file_with_lines_only_keeps_the_configuration_layout(guide_modes, guide, tmp_path):
    mesh = meshio.read(export.write_mode(guide_modes, 2, tmp_path / "lines.vtu", sections=False))
    lines = export.to_meshio(guide)
    assert [c.type for c in mesh.cells] == ["line"]
    assert len(mesh.cells[0].data) == sum(len(c.data) for c in lines.cells)
    np.testing.assert_allclose(mesh.points, lines.points, atol=1e-12)
    with pytest.raises(flexmb.FlexmbError, match="suffix"):
        export.write_mode(guide_modes, 0, tmp_path / "mode.txt")
    with pytest.raises(flexmb.FlexmbError, match=r"k=5"):
        export.write_mode(guide_modes, 5, tmp_path / "mode.vtu")


# -- round wires as tubes -----------------------------------------------------------------------
DIAMETER = 1.2  # mm


def wire_guide(stroke: float = 3.0) -> flexmb.Mechanism:
    """The parallel guide on two round steel wires of 1.2 mm (mm, N, MPa, t/mm^3)."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", (0.0, GAP / 2, 0.0), fixed=True)
    m.add_link("B", (L, GAP / 2, 0.0), mass=5e-5, inertia=2e-6 * np.eye(3))
    wire = flexmb.circle(DIAMETER, E=200000.0, nu=0.3, density=7.8e-9)
    for k, y in enumerate((0.0, GAP)):
        m.add_joint("A", "B", flexmb.LeafSpring(length=L, elements=3, section=wire),
                    name=f"wire{k}", origin=(0.0, y, 0.0))
    m.prescribe("B", y=stroke)
    return m


def _polygon_area(P) -> float:
    """Area of a planar polygon P (K, 3) (the shoelace formula as half the summed cross products)."""
    c = P.mean(axis=0)
    return 0.5 * float(np.linalg.norm(sum(np.cross(P[k] - c, P[(k + 1) % len(P)] - c) for k in range(len(P)))))


def test_round_wires_are_drawn_as_tubes_of_their_diameter():
    sol = flexmb.solve(wire_guide())
    assert sol.converged, sol.message
    ax = plot.plot_mechanism(sol)
    (tubes,) = _by_gid(ax, "plate-deformed")
    faces = _faces(tubes)
    assert faces.shape == (6 * 16, 4, 3)  # 2 wires x 3 elements, a 16-gon's sides each
    model = sol.compiled.problem.model
    P = model.point_positions(sol.state)
    ends = model.elements.ends
    # each face's first edge lies on an end section: its points at the radius from the element's
    # end point, and each end's 16 points span the diameter and (a regular 16-gon on the circle)
    # 16/2 sin(2 pi/16) = 0.9745 of the circle's area
    ring = faces[:, :2].reshape(6, 16, 2, 3)[:, :, 0]  # (E, 16, 3) the first end's outline
    r = np.linalg.norm(ring - P[ends[:, 0]][:, None], axis=2)
    np.testing.assert_allclose(r, DIAMETER / 2, rtol=1e-12)
    for e in range(6):
        span = np.linalg.norm(ring[e][:, None] - ring[e][None], axis=2).max()
        assert span == pytest.approx(DIAMETER, rel=1e-12)
        assert _polygon_area(ring[e]) == pytest.approx(8 * np.sin(np.pi / 8) * (DIAMETER / 2) ** 2, rel=1e-12)
        assert _polygon_area(ring[e]) / (np.pi * DIAMETER**2 / 4) == pytest.approx(0.9745, abs=1e-4)


def test_round_wire_mode_file_holds_the_wires_as_prisms_of_their_cross_section(tmp_path):
    sol = flexmb.solve(wire_guide())
    md = flexmb.modes(sol, n_modes=2)
    model = sol.compiled.problem.model
    mesh = meshio.read(export.write_mode(md, 0, tmp_path / "wire_mode.vtu"))
    hexes = np.concatenate([c.data for c in mesh.cells if c.type == "hexahedron"])
    assert len(hexes) == 6 * 8  # 8 hexahedra per element about its centreline
    H = mesh.points[hexes]
    # positive volume in VTK's ordering: the first face's right-hand normal points into the cell
    n = np.cross(H[:, 1] - H[:, 0], H[:, 2] - H[:, 1])
    assert np.all(np.einsum("ei,ei->e", n, H[:, 4:].mean(axis=1) - H[:, :4].mean(axis=1)) > 0)
    # each element's 8 bottom faces tile its end section: together the 16-gon of its diameter
    area = np.array([_polygon_area(h[:4]) for h in H]).reshape(6, 8).sum(axis=1)
    np.testing.assert_allclose(area, 8 * np.sin(np.pi / 8) * (DIAMETER / 2) ** 2, rtol=1e-12)
    # the outline points move as their sections: central differences under +-eps x shape
    eps, k = 1e-6, 0
    du = np.zeros(model.n_dofs)
    du[:model.n_node_dofs] = eps * md.shapes[k].ravel()
    idx = np.arange(len(model.elements.L0))
    from flexmb.fe.section_geometry import section_outlines
    Cp = section_outlines(model, model.apply_increment(sol.state, du), idx, "circle")
    Cm = section_outlines(model, model.apply_increment(sol.state, -du), idx, "circle")
    C = section_outlines(model, sol.state, idx, "circle")
    X, mode = mesh.points, mesh.point_data["mode"]
    for e in idx:
        for end in range(2):
            for c in range(16):
                (j,) = np.flatnonzero(np.linalg.norm(X - C[e, end, c], axis=1) < 1e-9 * L)[:1]
                np.testing.assert_allclose(mode[j], (Cp[e, end, c] - Cm[e, end, c]) / (2 * eps), rtol=1e-6,
                                           atol=1e-8 * np.abs(mode).max())
