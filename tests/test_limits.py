"""Limits and plugins (issue 20, class 6): what the API cannot do it refuses with a FlexmbError
that says why, before it allocates or crashes."""

import attrs
import numpy as np
import pytest

import flexmb
from flexmb import ModelError, UnsupportedStrategyError, models
from flexmb.fe import build as fe_build


def _three_x_infinity(**params):
    j = flexmb.ThreeXInfinity(**params)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", j.interface_b(3))
    m.add_joint("A", "B", j)
    return m


def test_a_model_too_big_for_the_machine_is_refused_before_it_is_built(monkeypatch):
    """The issue: ThreeXInfinity(stages=100, elements_per_leaf=10000), inside the documented
    ranges, ran out of memory (3e6 elements). 24 kB per element x 3e6 = 72 GB; refused for a
    16 GB machine before any mesh is made (a mesh of that size takes ~1.3 GB and seconds)."""
    monkeypatch.setattr(fe_build, "memory_bytes", lambda: 16 * 10**9)
    meshed = []
    monkeypatch.setattr(flexmb.ThreeXInfinity, "mesh", lambda self, dim: meshed.append(1))
    with pytest.raises(ModelError, match="3000000 beam elements.*72 GB.*16 GB.*fewer elements"):
        flexmb.solve(_three_x_infinity(stages=100, elements_per_leaf=10000))
    assert not meshed


def test_a_plugin_that_cannot_count_ahead_is_refused_after_its_mesh(monkeypatch):
    monkeypatch.setattr(fe_build, "memory_bytes", lambda: 24_000 * 100)  # room for 100 elements
    monkeypatch.setattr(flexmb.LeafSpring, "element_count", lambda self, dim: None)
    m = models.cantilever(elements=101, dim=2)
    with pytest.raises(ModelError, match="101 beam elements"):
        flexmb.solve(m)
    assert flexmb.solve(models.cantilever(elements=99, dim=2)).converged


def test_every_built_in_joint_counts_its_elements_ahead_exactly():
    for joint, dims in [(flexmb.CrossFlexure(elements_per_leaf=4), (2, 3)), (flexmb.ThreeXInfinity(stages=3), (3,)),
                        (flexmb.LeafSpring(length=0.1, width=0.01, thickness=1e-3, E=2e11, G=8e10), (2, 3)),
                        (flexmb.CurvedBeam(radius=0.2, angle=1.0, E=1e9, width=0.02, height=0.01), (2,))]:
        for dim in dims:
            assert joint.element_count(dim) == len(joint.mesh(dim).elements)


def test_a_plugin_mesh_with_an_unattached_internal_node_is_refused_by_the_mesh_check():
    """The issue: it passed the check and tangent_stiffness then raised LinAlgError."""
    class Loose(flexmb.LeafSpring):
        def mesh(self, dim):
            mesh = super().mesh(dim)
            pts = np.vstack([mesh.points, np.full((1, dim), 0.05)])
            return attrs.evolve(mesh, points=pts, side=np.append(mesh.side, 0))

    for dim in (2, 3):
        m = flexmb.Mechanism(dim=dim)
        m.add_link("A", fixed=True)
        m.add_link("B", position=(0.1, 0, 0)[:dim])
        m.add_joint("A", "B", Loose(elements=4), name="loose")
        for call in (flexmb.solve, lambda m: flexmb.tangent_stiffness(m, method="conventional")):
            with pytest.raises(ModelError, match="'loose'.*internal mesh point 5.*attached to no beam element"):
                call(m)


@pytest.mark.parametrize("method", ["ksd-reduced", "ksd-full"])
def test_ksd_with_every_link_dof_prescribed_is_refused_naming_the_fix(method):
    """The issue: a crash inside LAPACK (_flapack.error)."""
    m = models.cross_flexure_pivot(elements_per_leaf=2, dim=2)
    m.prescribe("B", x=0.0, y=0.0, rotation=0.1)
    with pytest.raises(UnsupportedStrategyError, match="every link DOF is prescribed.*conventional"):
        flexmb.solve(m, method=method)


@pytest.mark.parametrize("name", [["x"], 0, "", 1.5])
def test_a_joint_name_must_be_a_non_empty_string(name):
    """The issue: a list raised TypeError; 0 and "" were silently replaced."""
    m = models.cross_flexure_pivot(elements_per_leaf=2, dim=2)
    m.add_link("C", position=(0.2, 0.0))
    with pytest.raises(ModelError, match="joint name must be a non-empty string"):
        m.add_joint("B", "C", "cross_flexure", name=name)
    assert list(m.joints) == ["cross_flexure"]


def test_automatic_joint_names_never_collide_with_a_users():
    m = flexmb.Mechanism(dim=2)
    for n in "ABC":
        m.add_link(n, fixed=n == "A")
    m.add_joint("A", "B", "cross_flexure", name="cross_flexure_1")
    m.add_joint("B", "C", "cross_flexure")  # would be "cross_flexure_1": takes the next free number
    assert list(m.joints) == ["cross_flexure_1", "cross_flexure_2"]


def test_ksd_refuses_a_prescribed_rotation_no_chain_of_trained_joints_reaches_at_once():
    """Found by tests/test_fuzz.py: a prescribed 1e300 rad kept KSD step 1 busy for minutes.
    One cross flexure trained to +-75 deg (1.309 rad) plus a full turn reaches 7.59 rad."""
    import time

    m = models.cross_flexure_pivot(elements_per_leaf=1, dim=2)
    m.prescribe("B", rotation=1e300)
    t0 = time.perf_counter()
    with pytest.raises(flexmb.DatabaseError, match="1e\\+300 rad is beyond the trained ranges"):
        flexmb.solve(m, method="ksd-reduced")
    assert time.perf_counter() - t0 < 5.0
