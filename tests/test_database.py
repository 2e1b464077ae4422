"""Joint database (Dwarshuis et al. 2020, Secs. 2.1, 3.1, 4.1): training, fits, file format, refusals."""

import json
import warnings

import numpy as np
import pytest

import flexmb
from flexmb import database as db
from flexmb.errors import DatabaseError, ExtrapolationWarning


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n", [1, 3, 5])
def test_shipped_data_load_and_match_the_joint(dim, n):
    j = flexmb.CrossFlexure(elements_per_leaf=n)
    data = db.shipped(j, dim)
    assert data.kind == "cross_flexure" and data.dim == dim and data.key["elements_per_leaf"] == n
    assert np.degrees(data.range[0]) == -75.0 and np.degrees(data.range[1]) == 75.0
    # 2D: one angle per element (2 leaves); 3D: a rotation vector per element (3 leaves, Sec. 3.1)
    assert data.elements.coefficients.shape == (2 * n if dim == 2 else 9 * n, 5)


@pytest.mark.parametrize("dim", [2, 3])
def test_fits_reproduce_fe_runs_between_the_samples(dim):
    """The fits interpolate: at rotations between the 5-degree samples, fresh FE runs agree with
    the shipped polynomials within the fit residuals stated in the file (x 2 for interpolation):
    B's position to 2.2e-4 D0, D/D0 (Eq. 4.1) to 4.2e-5, element rotations (Eq. 4.2, fifth
    order) to 4e-4 rad."""
    j = flexmb.CrossFlexure(elements_per_leaf=3)
    data = db.shipped(j, dim)
    theta = np.radians([-72.5, -37.5, 2.5, 22.5, 57.5])
    run = db.simulate(j, dim, theta)
    D0 = data.length
    for k, name in enumerate(("x/D0", "y/D0")):
        f = data.function(name)
        np.testing.assert_allclose(f(theta), run.b_position[:, k] / D0, rtol=0, atol=2 * f.max_residual)
        assert f.max_residual < 1.2e-4
    g = data.function("D/D0-1")
    np.testing.assert_allclose(g(theta), np.linalg.norm(run.b_position, axis=1) / D0 - 1, rtol=0,
                               atol=2 * g.max_residual)
    np.testing.assert_allclose(data.elements(theta), run.element_rotation.reshape(len(theta), -1), rtol=0,
                               atol=2 * data.elements.max_residual)
    assert data.elements.max_residual < 2e-4
    if dim == 3:
        assert run.max_unintended_reaction < 1e-6  # the held z and tilts need no force (symmetric joint)


def test_length_ratio_is_even_as_eq_4_1():
    """Eq. (4.1): D/D0 = 1 + g1 t^2 + g2 t^4 + g3 t^6, symmetric in the rotation. flexmb measures
    g1 = +0.0508 (Table 1, 3 el./leaf): the interface nodes move apart, D/D0 = 1.042 at 60 deg."""
    data = db.shipped(flexmb.CrossFlexure(), 3)
    f = data.function("D/D0-1")
    np.testing.assert_array_equal(f.powers, [2, 4, 6])
    assert f.coefficients[0] == pytest.approx(0.0508, abs=1e-4)
    t = np.radians(60)
    assert f(t) == pytest.approx(f(-t)) == pytest.approx(0.0418, abs=1e-4)


def test_round_trip_is_exact(tmp_path):
    j = flexmb.CrossFlexure(elements_per_leaf=2)
    data = db.train(j, 2, range_deg=(-20, 20), step_deg=10)
    back = db.load(db.save(data, tmp_path / "x.json"))
    assert back.key == data.key and back.mesh_hash == data.mesh_hash and back.range == data.range
    for name, f in data.functions.items():
        np.testing.assert_array_equal(back.functions[name].coefficients, f.coefficients)
    np.testing.assert_array_equal(back.elements.coefficients, data.elements.coefficients)
    np.testing.assert_array_equal(back.nodes.coefficients, data.nodes.coefficients)


def _copy(tmp_path, mutate):
    j = flexmb.CrossFlexure()
    src = db.data_path() / db.file_name(j.kind, 3, j.database_key())
    body = json.loads(src.read_text())
    mutate(body)
    (tmp_path / src.name).write_text(json.dumps(body))
    return j


def test_corrupted_file_is_refused(tmp_path):
    j = _copy(tmp_path, lambda b: b["functions"]["D/D0-1"]["coefficients"].__setitem__(0, 0.0))
    with pytest.raises(DatabaseError, match="corrupted.*checksum"):
        db.shipped(j, 3, folder=tmp_path)


def test_truncated_file_is_refused(tmp_path):
    j = flexmb.CrossFlexure()
    name = db.file_name(j.kind, 3, j.database_key())
    (tmp_path / name).write_text((db.data_path() / name).read_text()[:200])
    with pytest.raises(DatabaseError, match="corrupted"):
        db.shipped(j, 3, folder=tmp_path)


def test_stale_file_is_refused(tmp_path):
    """A file whose checksum is right but whose mesh is not the one flexmb builds today."""
    from flexmb.database.store import _checksum

    def mutate(b):
        b["mesh_hash"] = "0" * 16
        b["checksum"] = _checksum(b)

    j = _copy(tmp_path, mutate)
    with pytest.raises(DatabaseError, match="stale"):
        db.shipped(j, 3, folder=tmp_path)


def test_other_format_version_is_refused(tmp_path):
    from flexmb.database.store import _checksum

    def mutate(b):
        b["format_version"] = 99
        b["checksum"] = _checksum(b)

    j = _copy(tmp_path, mutate)
    with pytest.raises(DatabaseError, match="format version 99"):
        db.shipped(j, 3, folder=tmp_path)


def test_missing_data_names_the_training_command():
    with pytest.raises(DatabaseError, match="flexmb train cross_flexure"):
        db.shipped(flexmb.CrossFlexure(angle=0.6), 3)
    with pytest.raises(flexmb.UnsupportedStrategyError, match="no joint database"):
        db.shipped(flexmb.LeafSpring(), 2)


def test_queries_outside_the_range_warn_or_fail():
    data = db.shipped(flexmb.CrossFlexure(), 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        data.check_range(np.radians(74.9))  # inside: silent
    with pytest.warns(ExtrapolationWarning, match="outside the trained range"):
        data.check_range(np.radians(80))
    with pytest.raises(DatabaseError, match="80.00 deg"):
        data.check_range(np.radians(80), strict=True)


def test_train_command_writes_a_loadable_file(tmp_path, capsys):
    from flexmb import cli

    assert cli.main(["train", "--dim", "2", "--elements", "1", "--range", "10", "--out", str(tmp_path)]) == 0
    files = list(tmp_path.glob("*.json"))
    assert len(files) == 1 and db.load(files[0]).dim == 2
    assert "max fit residuals" in capsys.readouterr().out
