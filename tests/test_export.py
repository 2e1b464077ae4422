"""Specification of the VTK export (`flexmb.export`, optional extra ``export``).

Where the expectations come from:

* the export's purpose: a designer opens the file in ParaView and sees the model flexmb solved,
  so the points read back are `Solution.node_positions` (planar models at z = 0), there is one
  beam line cell per element in the model's order, and the point and cell data are the
  solution's own displacements, rotations, peak stresses and joint indices;
* rigid connections are rigid: each line joins two points of one body, so its length does not
  change with the deformation, and every point off its body's reference point is reached;
* the ParaView collection format: ``<VTKFile type="Collection">`` with one
  ``<DataSet timestep=... file=...>`` per time step, in order;
* bad input is answered as elsewhere in flexmb (tests/test_errors.py): a `FlexmbError` naming
  the parameter; a missing extra a `MissingExtraError` naming ``pip install 'flexmb[export]'``.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET

import attrs
import numpy as np
import pytest
from tolerances import EXACT

import flexmb
from flexmb.errors import MissingExtraError, ModelError, ParameterError, UnsupportedStrategyError
from flexmb.testing import joint_mechanism

meshio = pytest.importorskip("meshio")
export = pytest.importorskip("flexmb.export")


def solve(m):
    s = flexmb.solve(m, method="conventional")
    assert s.converged, s.message
    return s


@pytest.fixture(scope="module")
def pivot3():
    return solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=3, rotation=0.5))


@pytest.fixture(scope="module")
def pivot2():
    return solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.5))


@pytest.fixture(scope="module")
def hinge():
    """One `ThreeXInfinity` (two rigid intermediate bodies), placed tilted, turned 0.3 rad."""
    joint = flexmb.ThreeXInfinity(elements_per_leaf=1)
    return solve(joint_mechanism(joint, 3, rotation=(0.2, 0.1, -0.1), motion=0.3))


def model_of(s):
    return s.compiled.problem.model


def undeformed_points(s):
    model = model_of(s)
    return model.point_positions(model.initial_state())


def pad3(a):
    return np.pad(a, ((0, 0), (0, 3 - a.shape[1])))


def check_matches_solution(mesh, s):
    """The mesh (as read back: one line block, beams first) shows the solution."""
    model, E = model_of(s), len(model_of(s).elements.L0)
    x = s.node_positions()
    np.testing.assert_allclose(mesh.points, pad3(x), **EXACT)
    lines = np.concatenate([c.data for c in mesh.cells if c.type == "line"])
    kind = np.concatenate(mesh.cell_data["kind"])
    assert np.count_nonzero(kind == 0) == E
    np.testing.assert_array_equal(kind[:E], 0)
    np.testing.assert_array_equal(lines[:E], model.elements.ends)
    np.testing.assert_allclose(mesh.point_data["displacement"], pad3(x - undeformed_points(s)), **EXACT)
    np.testing.assert_allclose(np.concatenate(mesh.cell_data["peak_stress"])[:E], s.peak_stress(),
                               rtol=1e-12, atol=0.0)
    joint = np.concatenate(mesh.cell_data["joint"])
    for j, (name, idx) in enumerate(s.compiled.joint_elements.items()):
        np.testing.assert_array_equal(joint[idx], j, err_msg=name)


# -- what the file holds ------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".vtu", ".vtk"])
def test_spatial_pivot_round_trip_is_the_solution(pivot3, tmp_path, suffix):
    path = export.write_vtk(pivot3, tmp_path / f"pivot{suffix}")
    assert path == tmp_path / f"pivot{suffix}" and path.is_file()
    mesh = meshio.read(path)
    check_matches_solution(mesh, pivot3)
    # link B's reference point (point 1) turns with B: rotation vector (0, 0, 0.5)
    np.testing.assert_allclose(mesh.point_data["rotation"][1], pivot3.rotation_vector("B"), **EXACT)
    np.testing.assert_allclose(mesh.point_data["rotation"][0], 0.0, **EXACT)


def test_planar_pivot_is_padded_with_z_zero(pivot2, tmp_path):
    mesh = meshio.read(export.write_vtk(pivot2, tmp_path / "pivot2d.vtu"))
    check_matches_solution(mesh, pivot2)
    assert mesh.points.shape[1] == 3 and np.all(mesh.points[:, 2] == 0.0)
    assert np.all(mesh.point_data["displacement"][:, 2] == 0.0)
    rot = mesh.point_data["rotation"]
    np.testing.assert_allclose(rot[:, :2], 0.0, **EXACT)
    np.testing.assert_allclose(rot[:, 2], pivot2.state.rotations[model_of(pivot2).point_master], **EXACT)
    np.testing.assert_allclose(rot[1, 2], 0.5, **EXACT)  # the prescribed rotation of link B


def test_field_data_reports_the_solver_state(pivot3, tmp_path):
    mesh = meshio.read(export.write_vtk(pivot3, tmp_path / "pivot.vtu"))
    assert mesh.field_data["converged"].tolist() == [1]
    assert mesh.field_data["load_factor"].tolist() == [1.0]
    assert mesh.field_data["iterations"].tolist() == [pivot3.iterations]
    assert mesh.field_data["undeformed"].tolist() == [0]
    in_memory = export.to_meshio(pivot3)
    assert in_memory.info["method"] == "conventional"
    assert in_memory.info["joints"] == ["cross_flexure"] and in_memory.info["links"] == ["A", "B"]


def test_a_failed_solve_is_exported_as_not_converged(pivot3, tmp_path):
    failed = attrs.evolve(pivot3, converged=False, load_factor=0.25)
    mesh = meshio.read(export.write_vtk(failed, tmp_path / "failed.vtu"))
    assert mesh.field_data["converged"].tolist() == [0]
    assert mesh.field_data["load_factor"].tolist() == [0.25]


def test_rigid_connections_keep_their_length_and_reach_every_attached_point(hinge):
    """The tilted three_x_infinity: links and the joint's two intermediate bodies."""
    mesh, model = export.to_meshio(hinge), model_of(hinge)
    assert [c.type for c in mesh.cells] == ["line", "line"]
    rigid = mesh.cells[1].data
    assert np.all(mesh.cell_data["kind"][1] == 1) and np.all(mesh.cell_data["peak_stress"][1] == 0.0)
    master = model.point_master
    np.testing.assert_array_equal(master[rigid[:, 0]], master[rigid[:, 1]])  # one body per line
    x, x0 = hinge.node_positions(), undeformed_points(hinge)
    np.testing.assert_allclose(np.linalg.norm(x[rigid[:, 1]] - x[rigid[:, 0]], axis=1),
                               np.linalg.norm(x0[rigid[:, 1]] - x0[rigid[:, 0]], axis=1), **EXACT)
    # every point away from its body's reference point (the FE node) ends exactly one line
    away = np.flatnonzero(np.linalg.norm(model.point_offset, axis=1) > 1e-12)
    np.testing.assert_array_equal(np.sort(rigid[:, 1]), away)
    # the intermediate bodies belong to the joint (index 0), the links' connections to no joint
    joint, link = mesh.cell_data["joint"][1], mesh.cell_data["link"][1]
    inner = np.isin(master[rigid[:, 0]], hinge.compiled.joint_nodes["joint"])
    assert inner.any() and (~inner).any()
    np.testing.assert_array_equal(joint[inner], 0)
    np.testing.assert_array_equal(link[inner], -1)
    np.testing.assert_array_equal(joint[~inner], -1)
    np.testing.assert_array_equal(link[~inner], master[rigid[~inner, 0]])  # links A = 0, B = 1


def test_three_x_infinity_hinge_round_trip(hinge, tmp_path):
    mesh = meshio.read(export.write_vtk(hinge, tmp_path / "hinge.vtu"))
    check_matches_solution(mesh, hinge)
    np.testing.assert_allclose(mesh.point_data["rotation"][1], hinge.rotation_vector("B"), **EXACT)


def test_manipulator_joints_are_numbered_in_order(tmp_path):
    s = solve(flexmb.models.manipulator(case="joint", rotation=0.2, elements=1))
    mesh = meshio.read(export.write_vtk(s, tmp_path / "manipulator.vtu"))
    check_matches_solution(mesh, s)
    E = len(model_of(s).elements.L0)
    assert sorted(set(mesh.cell_data["joint"][0][:E].tolist())) == [0, 1, 2]


def test_undeformed_configuration(pivot3):
    mesh = export.to_meshio(pivot3, undeformed=True)
    np.testing.assert_allclose(mesh.points, undeformed_points(pivot3), **EXACT)
    for name in ("displacement", "rotation"):
        np.testing.assert_allclose(mesh.point_data[name], 0.0, **EXACT)
    np.testing.assert_allclose(mesh.cell_data["peak_stress"][0], 0.0, atol=1e-3)  # Pa; ~1e8 when deformed
    assert mesh.field_data["undeformed"].tolist() == [1]
    assert np.max(export.to_meshio(pivot3).cell_data["peak_stress"][0]) > 1e6


def test_missing_section_fibres_give_nan_stress_not_an_error(pivot2, monkeypatch):
    def no_fibres(model, state):
        raise ModelError("peak stress needs the extreme-fibre distances")

    monkeypatch.setattr(export, "peak_normal_stress", no_fibres)
    mesh = export.to_meshio(pivot2)
    assert np.all(np.isnan(mesh.cell_data["peak_stress"][0]))
    assert np.all(mesh.cell_data["peak_stress"][1] == 0.0)


# -- series -------------------------------------------------------------------------------------
def test_series_writes_numbered_files_and_a_collection(tmp_path):
    rotations = [0.1, 0.2, 0.3]
    sols = [solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=1, dim=2, rotation=r)) for r in rotations]
    pvd = export.write_series(sols, tmp_path / "sweep.pvd", times=rotations)
    assert pvd == tmp_path / "sweep.pvd"
    root = ET.parse(pvd).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    datasets = root.findall("./Collection/DataSet")
    assert [d.get("file") for d in datasets] == ["sweep_0000.vtu", "sweep_0001.vtu", "sweep_0002.vtu"]
    assert [float(d.get("timestep")) for d in datasets] == rotations
    for d, s in zip(datasets, sols):
        mesh = meshio.read(tmp_path / d.get("file"))
        np.testing.assert_allclose(mesh.points[:, :2], s.node_positions(), **EXACT)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.pvd"] + [d.get("file") for d in datasets]


def test_series_default_timesteps_count_from_zero(pivot2, tmp_path):
    root = ET.parse(export.write_series((pivot2, pivot2), tmp_path / "s.pvd")).getroot()
    assert [d.get("timestep") for d in root.iter("DataSet")] == ["0", "1"]


# -- bad input ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["pivot.txt", "pivot", "pivot.pvd", "pivot.vtu.gz"])
def test_write_vtk_rejects_other_suffixes(pivot2, tmp_path, name):
    with pytest.raises(ParameterError, match=r"path=.*" + name.replace(".", r"\.") + r".*\.vtu, \.vtk"):
        export.write_vtk(pivot2, tmp_path / name)
    assert not any(tmp_path.iterdir())


def test_write_series_needs_a_pvd_path(pivot2, tmp_path):
    with pytest.raises(ParameterError, match=r"write_series: path=.*sweep\.vtu.*\.pvd"):
        export.write_series([pivot2], tmp_path / "sweep.vtu")


@pytest.mark.parametrize("bad", [None, "solution", 3, np.zeros(3)])
@pytest.mark.slow
def test_non_solutions_are_rejected(bad, tmp_path):
    with pytest.raises(ParameterError, match="solution must be a flexmb Solution"):
        export.to_meshio(bad)
    with pytest.raises(ParameterError, match="solution"):
        export.write_vtk(bad, tmp_path / "x.vtu")
    with pytest.raises(ParameterError, match=r"solutions\[1\]"):
        export.write_series([flexmb.solve(flexmb.models.cantilever(elements=1)), bad], tmp_path / "x.pvd")
    assert not any(tmp_path.iterdir())  # nothing written before every solution is checked


def test_write_series_rejects_empty_and_single_and_bad_times(pivot2, tmp_path):
    with pytest.raises(ParameterError, match="solutions is empty"):
        export.write_series([], tmp_path / "s.pvd")
    with pytest.raises(ParameterError, match="use write_vtk"):
        export.write_series(pivot2, tmp_path / "s.pvd")
    with pytest.raises(ParameterError, match="times must hold 2"):
        export.write_series([pivot2, pivot2], tmp_path / "s.pvd", times=[0.0])
    with pytest.raises(ParameterError, match="times must hold 1"):
        export.write_series([pivot2], tmp_path / "s.pvd", times=[float("nan")])
    with pytest.raises(ParameterError, match="times must be a sequence"):
        export.write_series([pivot2], tmp_path / "s.pvd", times=["a"])
    assert not any(tmp_path.iterdir())


def test_closed_form_newton_solution_is_refused_with_the_way_out(tmp_path):
    s = flexmb.solve(flexmb.models.gripper(), method="newton")
    for call in (lambda: export.to_meshio(s), lambda: export.write_vtk(s, tmp_path / "g.vtu"),
                 lambda: export.write_series([s], tmp_path / "g.pvd")):
        with pytest.raises(UnsupportedStrategyError, match=r"finite-element solution.*method='conventional'"):
            call()


def test_missing_meshio_names_the_extra(pivot2, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "meshio", None)  # makes `import meshio` raise ImportError
    for call in (lambda: export.to_meshio(pivot2), lambda: export.write_vtk(pivot2, tmp_path / "x.vtu"),
                 lambda: export.write_series([pivot2], tmp_path / "x.pvd")):
        with pytest.raises(MissingExtraError, match=r"pip install 'flexmb\[export\]'") as info:
            call()
        assert isinstance(info.value, ImportError)
    assert not any(tmp_path.iterdir())


# -- I/O faults: a FlexmbError, and nothing half written (issue 20, class 4) -----------------
@pytest.mark.parametrize("where", ["missing/pivot.vtu", "a_file/pivot.vtu"])
def test_an_unwritable_path_is_a_parameter_error(pivot2, tmp_path, where):
    """main raised the raw FileNotFoundError / NotADirectoryError from meshio."""
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(ParameterError, match="write_vtk: cannot write"):
        export.write_vtk(pivot2, tmp_path / where)
    with pytest.raises(ParameterError, match="write_series: cannot write"):
        export.write_series([pivot2], tmp_path / where.replace(".vtu", ".pvd"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def _disk_full_after(monkeypatch, calls: int):
    """meshio.write that writes ``calls`` files, then half a file and fails as a full disk does."""
    import errno

    original, count = meshio.write, [0]

    def write(path, mesh, **kwargs):
        count[0] += 1
        if count[0] > calls:
            with open(path, "wb") as f:
                f.write(b"<VTKFile")  # half a file
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(path, mesh, **kwargs)

    monkeypatch.setattr(meshio, "write", write)


def test_a_failed_write_vtk_leaves_the_earlier_file(pivot2, pivot3, tmp_path, monkeypatch):
    path = export.write_vtk(pivot2, tmp_path / "pivot.vtu")
    before = path.read_bytes()
    _disk_full_after(monkeypatch, 0)
    with pytest.raises(ParameterError, match="No space left"):
        export.write_vtk(pivot3, path)
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["pivot.vtu"]


def test_a_failed_series_leaves_no_partial_series_and_the_earlier_one_intact(pivot2, pivot3, tmp_path, monkeypatch):
    """The third file fails (a full disk): main left two new .vtu files beside the old collection,
    which then played a mix of both series; now the earlier series is untouched."""
    export.write_series([pivot2, pivot2, pivot2], tmp_path / "sweep.pvd", times=[1.0, 2.0, 3.0])
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    _disk_full_after(monkeypatch, 2)
    with pytest.raises(ParameterError, match="write_series: cannot write .*nothing was written"):
        export.write_series([pivot3, pivot3, pivot3, pivot3], tmp_path / "sweep.pvd")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
