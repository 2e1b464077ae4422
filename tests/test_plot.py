"""Figures (`flexmb.plot`): what is drawn is exactly the model's geometry, headless.

Counts and coordinates are read back from the artists (each `plot_mechanism` artist carries a
``gid``, see the module docstring) and compared with the model: one line per beam element and
configuration, one shape per link, end points equal to `Solution.node_positions`.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

import flexmb
from flexmb import plot
from flexmb.errors import MissingExtraError, ModelError, ParameterError
from tolerances import EXACT

pytest.importorskip("matplotlib")


def _artists(ax, gid):
    """Lines, patches and collections of ``ax`` with this ``gid``."""
    return [a for a in (*ax.lines, *ax.patches, *ax.collections) if a.get_gid() == gid]


def _lines(ax, gid):
    return [a for a in ax.lines if a.get_gid() == gid]


def _xyz(line):
    """The vertices of a 2D or 3D line, (n, dim)."""
    data = line.get_data_3d() if hasattr(line, "get_data_3d") else line.get_data()
    return np.column_stack([np.asarray(d, dtype=float) for d in data])


@pytest.fixture(scope="module")
def pivot2d():
    return flexmb.solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=2, rotation=0.3),
                        method="conventional")


@pytest.fixture(scope="module")
def pivot3d():
    return flexmb.solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=3, rotation=0.3),
                        method="conventional")


@pytest.fixture(scope="module")
def fourbar():
    return flexmb.solve(flexmb.models.fourbar(elements_per_leaf=1, displacement=0.05), method="conventional")


def _check_beams(ax, sol):
    """One line per beam element in each configuration, ends at the solution's points."""
    model = sol.compiled.problem.model
    ends = model.elements.ends
    for which, P in (("undeformed", model.point_x0), ("deformed", sol.node_positions())):
        lines = _lines(ax, f"beam-{which}")
        assert len(lines) == len(ends)
        for line, (a, b) in zip(lines, ends):
            np.testing.assert_allclose(_xyz(line), P[[a, b]], **EXACT)
        assert len(_artists(ax, f"link-{which}")) == len(sol.compiled.link_node)
    texts = [t for t in ax.texts if t.get_gid() == "label"]
    assert sorted(t.get_text() for t in texts) == sorted(sol.compiled.link_node)


@pytest.mark.parametrize("name", ["pivot2d", "pivot3d", "fourbar"])
def test_plot_mechanism_draws_every_beam_element_at_the_solved_points(name, request, tmp_path):
    sol = request.getfixturevalue(name)
    assert sol.converged
    ax = plot.plot_mechanism(sol)
    assert (ax.name == "3d") == (sol.dim == 3)
    _check_beams(ax, sol)
    path = plot.save(ax, tmp_path / name)
    assert path == tmp_path / f"{name}.png" and path.stat().st_size > 10_000


def test_plot_mechanism_2d_has_equal_aspect_and_collinear_blocks_as_thick_lines(pivot2d):
    ax = plot.plot_mechanism(pivot2d, undeformed=False)
    assert ax.get_aspect() == 1.0
    assert not _artists(ax, "beam-undeformed") and not _artists(ax, "link-undeformed")
    # the planar pivot's connector blocks hold their node and two collinear leaf ends: a segment
    # between the leaf ends, which are the block's extreme points
    model = pivot2d.compiled.problem.model
    P = pivot2d.node_positions()
    for line, (name, node) in zip(_lines(ax, "link-deformed"), pivot2d.compiled.link_node.items()):
        leaf_ends = P[(model.point_master == node) & (np.arange(len(P)) != node)]
        np.testing.assert_allclose(np.sort(_xyz(line), axis=0), np.sort(leaf_ends, axis=0), **EXACT)


def test_plot_mechanism_3d_has_equal_data_ranges(pivot3d, fourbar):
    for sol in (pivot3d, fourbar):
        ax = plot.plot_mechanism(sol)
        spans = [np.diff(lim)[0] for lim in (ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d())]
        np.testing.assert_allclose(spans, spans[0], rtol=1e-12)
        lo = np.array([ax.get_xlim3d()[0], ax.get_ylim3d()[0], ax.get_zlim3d()[0]])
        hi = lo + spans[0]
        P = np.concatenate([sol.node_positions(), sol.compiled.problem.model.point_x0])
        assert np.all(P >= lo) and np.all(P <= hi)
        # flat or solid blocks are polygons (Poly3DCollection), one per link and configuration
        assert len(_artists(ax, "link-deformed")) == len(sol.compiled.link_node)


def test_plot_mechanism_of_a_ksd_reduced_solution_uses_its_recovered_internal_nodes():
    m = flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=3, rotation=0.3)
    sol = flexmb.solve(m, method="ksd-reduced")
    assert sol.converged and len(sol.compiled.joint_nodes["cross_flexure"]) > 0
    _check_beams(plot.plot_mechanism(sol), sol)


def test_plot_mechanism_of_an_unsolved_mechanism_draws_the_undeformed_shape_only():
    m = flexmb.models.fourbar(elements_per_leaf=1, displacement=0.05)
    ax = plot.plot_mechanism(m)
    model = m.compile().problem.model
    lines = _lines(ax, "beam-undeformed")
    assert len(lines) == len(model.elements.ends)
    for line, (a, b) in zip(lines, model.elements.ends):
        np.testing.assert_allclose(_xyz(line), model.point_x0[[a, b]], **EXACT)
    assert len(_artists(ax, "link-undeformed")) == len(m.links)
    assert not [a for a in ax.get_children() if str(a.get_gid()).endswith("-deformed")]
    labels = {t.get_text(): t.get_position() for t in ax.texts}
    assert set(labels) == set(m.links)
    np.testing.assert_allclose(labels["top"], m.links["top"].position[:2], **EXACT)


def test_plot_mechanism_of_a_closed_form_solution_draws_links_and_flexure_chords():
    """``method="newton"`` has no beam elements: each flexure is a chord between its attachments."""
    sol = flexmb.solve(flexmb.models.gripper(force=100.0), method="newton")
    assert sol.converged
    ax = plot.plot_mechanism(sol)
    assert not _lines(ax, "beam-deformed")
    n_links, n_flex = len(sol.compiled.link_node), 4
    P = sol.node_positions()  # link reference points, then each flexure's two attachment points
    chords = _lines(ax, "flexure-deformed")
    assert len(chords) == n_flex and len(_lines(ax, "flexure-undeformed")) == n_flex
    for k, line in enumerate(chords):
        np.testing.assert_allclose(_xyz(line), P[n_links + 2 * k: n_links + 2 * k + 2], **EXACT)
    assert len(_artists(ax, "link-deformed")) == n_links


def test_plot_mechanism_draws_on_given_axes_and_overlays(pivot2d):
    ax = plot.plot_mechanism(pivot2d, deformed=False, labels=False)
    assert plot.plot_mechanism(pivot2d, ax, undeformed=False) is ax
    n = len(pivot2d.compiled.problem.model.elements.ends)
    assert len(_lines(ax, "beam-undeformed")) == len(_lines(ax, "beam-deformed")) == n
    assert len(ax.texts) == len(pivot2d.compiled.link_node)


def test_plot_mechanism_rejects_bad_input(pivot2d, pivot3d):
    with pytest.raises(ParameterError, match="solution"):
        plot.plot_mechanism(42)
    with pytest.raises(ParameterError, match="labels"):
        plot.plot_mechanism(pivot2d, labels="yes")
    with pytest.raises(ParameterError, match="draws nothing"):
        plot.plot_mechanism(pivot2d, undeformed=False, deformed=False)
    with pytest.raises(ParameterError, match="3D"):
        plot.plot_mechanism(pivot3d, plot.plot_mechanism(pivot2d))  # 2D axes for a spatial mechanism
    with pytest.raises(ParameterError, match="ax"):
        plot.plot_mechanism(pivot2d, ax="axes")


def test_plot_force_curve_with_a_callable_reference(fourbar):
    d = np.array([0.01, 0.03, 0.05])
    m = flexmb.models.fourbar(elements_per_leaf=1)
    force = []
    for x in d:
        m.prescribe("top", x=x)
        force.append(flexmb.solve(m, method="conventional").reaction("top")[0])

    def linear(x):
        return flexmb.models.fourbar_linear_force(x, elements_per_leaf=1)

    ax = plot.plot_force_curve(d, force, reference=linear, label="flexmb")
    (f_line,), (r_line,) = _lines(ax, "force"), _lines(ax, "reference")
    np.testing.assert_allclose(_xyz(f_line), np.column_stack([d, force]), **EXACT)
    np.testing.assert_allclose(r_line.get_ydata(), [linear(x) for x in d], **EXACT)
    assert r_line.get_linestyle() == "--" and r_line.get_color() == "k"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["flexmb", "linear"]
    assert ax.get_xlabel() == "displacement [m]" and ax.get_ylabel() == "force [N]"


def test_plot_force_curve_reference_as_array_or_scalar_only_function():
    d = np.linspace(0.0, 1.0, 4)
    ax = plot.plot_force_curve(d, 2 * d, reference=lambda x: float(x) ** 2)  # float() fails on arrays
    np.testing.assert_allclose(_lines(ax, "reference")[0].get_ydata(), d**2, **EXACT)
    ax = plot.plot_force_curve(d, 2 * d, reference=3 * d, reference_label="FE")
    np.testing.assert_allclose(_lines(ax, "reference")[0].get_ydata(), 3 * d, **EXACT)
    assert ax.get_legend().get_texts()[-1].get_text() == "FE"


@pytest.mark.parametrize("kwargs, match", [
    (dict(displacement=[0.0, 1.0], force=[1.0]), "force has shape"),
    (dict(displacement=[[0.0, 1.0]], force=[1.0, 2.0]), "displacement"),
    (dict(displacement=[0.0, np.nan], force=[1.0, 2.0]), "finite"),
    (dict(displacement=[0.0, 1.0], force=[1.0, 2.0], reference=[1.0]), "reference"),
    (dict(displacement=[0.0, 1.0], force=[1.0, 2.0], xlabel=3), "xlabel"),
])
def test_plot_force_curve_rejects_bad_input(kwargs, match):
    d, f = kwargs.pop("displacement"), kwargs.pop("force")
    with pytest.raises(ParameterError, match=match):
        plot.plot_force_curve(d, f, **kwargs)


@pytest.fixture(scope="module")
def rotation_sweep():
    return [flexmb.solve(flexmb.models.cross_flexure_pivot(elements_per_leaf=2, dim=dim, rotation=r),
                         method="conventional") for dim in (2, 3) for r in (0.1, 0.2, 0.3)]


def test_plot_trajectory_follows_the_link_poses(rotation_sweep):
    for sols in (rotation_sweep[:3], rotation_sweep[3:]):
        ax = plot.plot_trajectory(sols, "B", color="C3")
        (line,) = _lines(ax, "trajectory")
        np.testing.assert_allclose(_xyz(line), [s.pose("B")[0] for s in sols], **EXACT)
        assert line.get_marker() == "o" and line.get_label() == "B"


def test_plot_trajectory_of_a_named_point_over_a_sweep():
    m = flexmb.models.gripper()
    sols = flexmb.sweep(m, [0.0, 50.0, 100.0], method="newton")
    ax = plot.plot_mechanism(sols[-1])
    assert plot.plot_trajectory(sols, "body3", "end_effector", ax) is ax
    (line,) = _lines(ax, "trajectory")
    np.testing.assert_allclose(_xyz(line), [s.point("body3", "end_effector") for s in sols], **EXACT)


def test_plot_trajectory_rejects_bad_input(rotation_sweep):
    with pytest.raises(ModelError, match="no link named 'C'"):
        plot.plot_trajectory(rotation_sweep[:3], "C")
    with pytest.raises(ParameterError, match="empty"):
        plot.plot_trajectory([], "B")
    with pytest.raises(ParameterError, match=r"solutions\[1\]"):
        plot.plot_trajectory([rotation_sweep[0], 1.0], "B")
    with pytest.raises(ParameterError, match="sequence"):
        plot.plot_trajectory(rotation_sweep[0], "B")
    with pytest.raises(ParameterError, match="mix planar and spatial"):
        plot.plot_trajectory(rotation_sweep[2:4], "B")


RECORDS = [
    {"method": "conventional", "iterations": 42, "time": 0.8},
    {"method": "ksd-reduced", "iterations": 5, "time": 0.04, "label": "KSD (reduced)"},
    {"method": "ksd-full", "iterations": 9, "time": 0.2},
]


def test_plot_strategies_bars_equal_the_records(tmp_path):
    ax_it, ax_t = plot.plot_strategies(RECORDS)
    assert ax_it.figure is ax_t.figure
    for ax, key in ((ax_it, "iterations"), (ax_t, "time")):
        bars = _artists(ax, key)
        assert [b.get_height() for b in bars] == [r[key] for r in RECORDS]
        assert [t.get_text() for t in ax.get_xticklabels()] == ["conventional", "KSD (reduced)", "ksd-full"]
    assert ax_t.get_yscale() == "log" and ax_it.get_yscale() == "linear"
    assert plot.save((ax_it, ax_t), tmp_path / "strategies.png").stat().st_size > 10_000


def test_plot_strategies_draws_on_a_given_pair_of_axes():
    from matplotlib.figure import Figure

    axes = tuple(Figure().subplots(1, 2))
    assert plot.plot_strategies(RECORDS[:1], axes) == axes
    with pytest.raises(ParameterError, match="pair"):
        plot.plot_strategies(RECORDS, axes[0])


@pytest.mark.parametrize("records, match", [
    ([], "empty"),
    ({"method": "newton", "iterations": 1, "time": 1.0}, "list of dicts"),
    ([{"method": "newton", "time": 1.0}], "lacks 'iterations'"),
    ([{"method": "newton", "iterations": 1.5, "time": 1.0}], "iterations"),
    ([{"method": "newton", "iterations": 1, "time": 0.0}], "time"),
    ([{"method": 3, "iterations": 1, "time": 1.0}], "method"),
])
def test_plot_strategies_rejects_bad_records(records, match):
    with pytest.raises(ParameterError, match=match):
        plot.plot_strategies(records)


def test_save_adds_png_and_makes_directories(pivot2d, tmp_path):
    ax = plot.plot_mechanism(pivot2d)
    path = plot.save(ax.figure, tmp_path / "sub" / "pivot", dpi=60)
    assert path.name == "pivot.png" and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ParameterError, match="ax_or_fig"):
        plot.save("figure", tmp_path / "x.png")
    with pytest.raises(ParameterError, match="dpi"):
        plot.save(ax, tmp_path / "x.png", dpi=0)


def test_every_plot_function_names_the_plot_extra_without_matplotlib(monkeypatch, pivot2d):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)  # import fails as if not installed
    calls = [lambda: plot.plot_mechanism(pivot2d), lambda: plot.plot_force_curve([0.0], [1.0]),
             lambda: plot.plot_trajectory([pivot2d], "B"), lambda: plot.plot_strategies(RECORDS),
             lambda: plot.save(None, "x.png")]
    for call in calls:
        with pytest.raises(MissingExtraError, match=r"flexmb\[plot\]") as info:
            call()
        assert isinstance(info.value, ImportError)


@pytest.mark.slow
def test_plots_need_no_display_and_no_pyplot(tmp_path):
    """In a fresh interpreter without a display: importing flexmb.plot imports no matplotlib,
    drawing and saving work and never load pyplot (no backend switch, no global figures)."""
    code = (
        "import sys, flexmb, flexmb.plot as p\n"
        "assert 'matplotlib' not in sys.modules\n"
        "m = flexmb.models.cross_flexure_pivot(elements_per_leaf=1, dim=3)\n"
        f"p.save(p.plot_mechanism(m), {str(tmp_path / 'fresh.png')!r})\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
    )
    env = {k: val for k, val in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MPLBACKEND")}
    subprocess.run([sys.executable, "-c", code], check=True, env=env, cwd=os.getcwd(), timeout=60)
    assert (tmp_path / "fresh.png").stat().st_size > 10_000


# -- maps of parameter studies -------------------------------------------------------------------

def test_map_cells_hold_the_table_values_on_their_grid(tmp_path):
    table = flexmb.Table({"t": [1.0, 1.0, 2.0, 2.0], "a": [0.1, 0.2, 0.1, 0.2], "k": [1.0, 2.0, 3.0, 4.0]})
    ax = plot.plot_map(table, "t", "a", "k")
    (mesh,) = _artists(ax, "map")
    # rows are the y values (a), columns the x values (t)
    np.testing.assert_array_equal(np.asarray(mesh.get_array()).reshape(2, 2), [[1.0, 3.0], [2.0, 4.0]])
    assert plot.save(ax, tmp_path / "map.png").stat().st_size > 5_000


def test_map_rejects_missing_columns_and_incomplete_grids():
    with pytest.raises(ParameterError, match="no column 'z'"):
        plot.plot_map({"t": [1.0], "a": [1.0]}, "t", "a", "z")
    with pytest.raises(ParameterError, match="full grid"):
        plot.plot_map({"t": [1.0, 2.0, 2.0], "a": [0.1, 0.2, 0.1], "k": [1.0, 2.0, 3.0]}, "t", "a", "k")


