"""The EOB condensation tabulated against the joint angle (issue 21 item 4): database format
version 3, its side file, the lookup against direct condensation, and KSD-reduced with and
without the table.

References: the direct Craig-Bampton condensation `EOBTemplate.evaluate` (Dwarshuis et al.
2020, Eqs. 2.4-2.6) is the reference of every tabulated value; the tolerances are the measured
interpolation errors (degree-7 splines on a 1 deg grid, 5e-11 relative on the manipulator's
joint) with a margin of 20.
"""

from __future__ import annotations

import json

import attrs
import numpy as np
import pytest

import flexmb
from flexmb.database import eob_format, store, training
from flexmb.errors import DatabaseError
from flexmb.joints import CrossFlexure, ThreeXInfinity
from flexmb.ksd.eob import EOBTemplate
from flexmb.ksd.eob_table import lookup_for
from flexmb.ksd.reduced import template
from flexmb.solvers import KSDReduced


def _rel(a, b):
    return float(np.abs(a - b).max() / np.abs(b).max())


def _compare(tpl, rng, n=6, tol=1e-9):
    lo, hi = tpl.lookup.range
    theta = rng.uniform(lo, hi, n)
    b = tpl.node_x0[1] + 0.01 * np.abs(tpl.node_x0[1]).max() * rng.normal(size=(n, tpl.dim))
    ref = tpl.evaluate(theta, b, held_a=True)
    got = tpl.lookup(theta, b)
    for name in ("K_T", "F_hat_T", "recover", "node_position", "node_rotation"):
        assert _rel(getattr(got, name), getattr(ref, name)) < tol, name
    if tpl.dim == 2:
        assert _rel(got.node_angle, ref.node_angle) < tol


def test_shipped_manipulator_joint_table_reproduces_the_condensation():
    """The shipped three_x_infinity table (the manipulator's joint) = direct condensation."""
    tpl = template(ThreeXInfinity(elements_per_leaf=3), 3)
    assert tpl.lookup is not None
    _compare(tpl, np.random.default_rng(0))


def test_a_planar_cross_flexure_table_built_from_its_database(tmp_path):
    """A case no paper has: a 2D cross flexure (2 el./leaf) tabulated, saved and read back."""
    joint = CrossFlexure(elements_per_leaf=2)
    data = training.with_eob_table(joint, store.shipped(joint, 2))
    path = store.save(data, tmp_path / store.file_name(joint.kind, 2, joint.database_key()))
    assert store.side_file(path).exists() and store.side_file(path).name.endswith(eob_format.SUFFIX)
    back = store.load(path)
    assert back.eob_table is not None and back.eob_table.source is not None
    np.testing.assert_array_equal(back.eob_table.values, data.eob_table.values)
    tpl = EOBTemplate(joint, 2, back)
    tpl.lookup = lookup_for(tpl, joint)
    _compare(tpl, np.random.default_rng(1))


def test_a_table_is_used_only_for_the_joint_it_belongs_to():
    """Other parameters (a thicker leaf): no lookup, the condensation is computed."""
    joint = ThreeXInfinity(elements_per_leaf=3, thickness=5e-4)
    data = store.shipped(ThreeXInfinity(elements_per_leaf=3), 3)
    assert lookup_for(EOBTemplate(joint, 3, data), joint) is None
    assert lookup_for(EOBTemplate(ThreeXInfinity(elements_per_leaf=3), 3, data), ThreeXInfinity(elements_per_leaf=3)) is not None


@pytest.mark.parametrize("case", ["joint", "location"])
@pytest.mark.slow
def test_ksd_reduced_with_the_table_equals_the_computed_condensation(case, monkeypatch):
    """The manipulator at 45 deg: same equilibrium within the tabulation error."""
    m = flexmb.models.manipulator(case, rotation=np.radians(45.0))
    compiled = m.compile()
    fast = KSDReduced().solve(compiled)
    tpl = template(ThreeXInfinity(elements_per_leaf=3), 3)
    monkeypatch.setattr(tpl, "lookup", None)
    ref = KSDReduced().solve(compiled)
    assert fast.converged and ref.converged
    assert _rel(fast.node_positions(), ref.node_positions()) < 1e-9
    links = ("ground", "link1", "link2", "link3")
    scale = max(np.abs(ref.reaction(link)).max() for link in links)  # the joint moments or end forces
    for link in links:  # (free components carry residual-level noise, compared against that scale)
        np.testing.assert_allclose(fast.reaction(link), ref.reaction(link), rtol=0, atol=1e-8 * scale)


def _rewrite(path, **changes):
    body = json.loads(path.read_text())
    body.update(changes)
    for k, v in list(body.items()):
        if v is None and k != "eob_table":
            del body[k]
    body["checksum"] = store._checksum(body)
    path.write_text(json.dumps(body))


@pytest.fixture
def saved(tmp_path):
    joint = ThreeXInfinity(elements_per_leaf=3)
    src = store.shipped(joint, 3)
    path = store.save(src, tmp_path / store.file_name(joint.kind, 3, joint.database_key()))
    return path


def test_version_2_files_are_read_without_a_table_and_version_1_refused(saved):
    _rewrite(saved, format_version=2, eob_table=None)
    data = store.load(saved)
    assert data.eob_table is None and data.functions  # migrated on reading: the fits unchanged
    _rewrite(saved, format_version=1)
    with pytest.raises(DatabaseError, match="format version 1"):
        store.load(saved)


def test_an_altered_or_missing_side_file_is_refused_when_used(saved):
    side = store.side_file(saved)
    raw = bytearray(side.read_bytes())
    raw[100] ^= 1
    side.write_bytes(bytes(raw))
    eob_format._LOADED.clear()
    data = store.load(saved)
    with pytest.raises(DatabaseError, match="does not match"):
        data.eob_table.values
    side.unlink()
    eob_format._LOADED.clear()
    with pytest.raises(DatabaseError, match="cannot be read"):
        store.load(saved).eob_table.values


def test_a_malformed_table_entry_is_refused(saved):
    body = json.loads(saved.read_text())
    for bad in ({**body["eob_table"], "degree": 4}, {**body["eob_table"], "values_file": "../x.eob.bin"},
                {**body["eob_table"], "shape": [1, 2]}, {**body["eob_table"], "theta": [0.1, 0.0]}, "table"):
        _rewrite(saved, eob_table=bad)
        with pytest.raises(DatabaseError, match="eob_table"):
            store.load(saved)


def test_the_table_round_trips_exactly(tmp_path):
    data = store.shipped(ThreeXInfinity(elements_per_leaf=3), 3)
    table = attrs.evolve(data.eob_table, data=np.array(data.eob_table.values), source=None)
    path = store.save(attrs.evolve(data, eob_table=table), tmp_path / "x.json")
    back = store.load(path).eob_table
    assert back.layout == table.layout and back.degree == table.degree and back.parameters == table.parameters
    np.testing.assert_array_equal(back.values, table.values)
    np.testing.assert_array_equal(back.theta, table.theta)


def test_mass_and_strength_parameters_keep_the_table():
    """Density and yield stress do not enter the stiffness condensation (Eqs. 3.8-3.11), and an
    unset option (``nu=None`` with ``G`` given) changes nothing: the shipped table still applies;
    a stiffness parameter (E) does change it."""
    for joint in (ThreeXInfinity(elements_per_leaf=3, yield_stress=1.0e9), ThreeXInfinity(elements_per_leaf=3, density=2700.0)):
        assert template(joint, 3).lookup is not None
    assert template(ThreeXInfinity(elements_per_leaf=3, E=70e9), 3).lookup is None
