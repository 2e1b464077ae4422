"""flexmb against a peer code on its own mesh: `flexmb.peers.ExudynModel` (needs exudyn, the
``peers`` extra; skipped without it)."""

import sys

import numpy as np
import pytest

import flexmb
from flexmb.errors import MissingExtraError, ModelError, UnsupportedStrategyError
from flexmb.rotations import expm_so3

pytest.importorskip("exudyn")
from flexmb.peers import ExudynModel  # noqa: E402


def _tilted_pivot(n: int, turn: float, frame=(0.3, -0.4, 0.5)) -> flexmb.Mechanism:
    """A Table 1 cross flexure whose joint frame is turned by the rotation vector ``frame``,
    link B turned by ``turn`` [rad] about the joint axis (its position free)."""
    R = expm_so3(np.array(frame))
    joint = flexmb.joint("cross_flexure", elements_per_leaf=n)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=R @ joint.interface_b(3))
    m.add_joint("A", "B", joint, rotation=frame)
    m.prescribe("B", rotation=tuple(turn * R[:, 2]))
    return m


@pytest.mark.parametrize("axis", [1, 2])
def test_one_element_cantilever_gives_both_closed_forms(axis):
    """One element, a small tip force along global y (bending about the leaf's compliant axis,
    I_z) or z (the stiff one, I_y): flexmb's element is the exact Timoshenko beam,
    v = F L^3 / (3 EI) + F L / (k G A); Exudyn's geometrically exact beam interpolates linearly
    with one-point integration, v = F L^3 / (4 EI) + F L / (k G A) (its closed form for one
    element). Both at once check the section, the frames and the tie of the tip link."""
    m = flexmb.models.cantilever(elements=1, dim=3, thickness=5e-3)
    F = np.zeros(3)
    F[axis] = 1e-2  # N: v / L ~ 1e-6, geometric non-linearity ~ 1e-12
    m.apply_force("tip", tuple(F))
    leaf = m.joints["leaf"]
    sec = flexmb.sections.rectangle(leaf.width, leaf.thickness, leaf.E, leaf.G)
    EI = leaf.E * (sec.Iz if axis == 1 else sec.Iy)
    L, shear = leaf.length, F[axis] * leaf.length / (sec.ky * leaf.G * sec.A)
    ours = flexmb.solve(m).displacement("tip")[axis]
    peer = ExudynModel(m.compile()).solve(absolute_tolerance=1e-8)
    assert peer.converged
    theirs = peer.state.positions[1, axis] - m.compile().problem.model.x0[1, axis]
    assert ours == pytest.approx(F[axis] * L**3 / (3 * EI) + shear, rel=1e-6)
    assert theirs == pytest.approx(F[axis] * L**3 / (4 * EI) + shear, rel=1e-6)


def test_prescribed_rotation_and_its_reaction_in_a_turned_frame():
    """A cross flexure in a turned frame, B turned 30 deg about the joint axis: Exudyn's model
    follows the prescribed orientation exactly (B's rotation = flexmb's to 1e-9) and its reaction
    moment, in global axes, agrees with flexmb's to the beams' modelling difference: 1e-3 of the
    moment at 3 el./leaf (measured 2.2e-4; refining both, flexmb at 6 / 12 el./leaf and Exudyn
    each element split in 2 / 4: 1.9e-5 / 8.8e-6). A wrong axis or sign of the reaction's
    transformation would be off by the moment itself."""
    m = _tilted_pivot(3, np.radians(30.0))
    ours = flexmb.solve(m)
    peer = ExudynModel(m.compile()).solve(load_steps=4)
    assert peer.converged and peer.residual < 5e-7
    node = ours.compiled.link_node["B"]
    np.testing.assert_allclose(peer.state.rotations[node], ours.state.rotations[node], atol=1e-9)
    a, b = ours.reaction("B")[3:], peer.reactions["B"][3:]
    assert np.abs(a - b).max() < 1e-3 * np.linalg.norm(a)
    assert np.abs(peer.positions - ours.node_positions()).max() < 5e-4  # m (measured 1.2e-4; leaves 0.1 m)


def test_fourbar_agrees_and_both_meshes_converge_to_one_answer():
    """Four-bar (Sec. 4.3) at d = 0.1 m, 2 el./leaf: the actuation forces differ by the beams'
    discretisation errors (measured 0.23 %), and refining both (flexmb 4 el./leaf, Exudyn each
    element split in two) brings them together (measured 0.04 %), as both converge to the
    continuum answer at rate h^2."""
    coarse = flexmb.models.fourbar(2, displacement=0.1)
    fine = flexmb.models.fourbar(4, displacement=0.1)
    f_coarse, f_fine = (flexmb.solve(m).reaction("top")[0] for m in (coarse, fine))
    peers = [ExudynModel(coarse.compile(), refine=k).solve(load_steps=4) for k in (1, 2)]
    assert all(p.converged for p in peers)
    e_coarse, e_fine = (p.reactions["top"][0] for p in peers)
    assert abs(e_coarse - f_coarse) < 5e-3 * f_coarse
    assert abs(e_fine - f_fine) < 0.25 * abs(e_coarse - f_coarse)
    assert np.abs(peers[0].positions - flexmb.solve(coarse).node_positions()).max() < 5e-4  # m (measured 2.3e-4)


def test_bad_input_is_refused_by_name(monkeypatch):
    c3 = flexmb.models.cantilever(elements=2, dim=3).compile()
    with pytest.raises(UnsupportedStrategyError, match="3D"):
        ExudynModel(flexmb.models.cantilever(elements=2, dim=2).compile())
    hinged = flexmb.models.cantilever(elements=2, dim=3)
    hinged.add_link("arm", position=(0.2, 0.0, 0.0))
    hinged.add_joint("tip", "arm", "hinge", origin=(0.1, 0.0, 0.0), k=1.0)
    with pytest.raises(UnsupportedStrategyError, match="hinges"):
        ExudynModel(hinged.compile())
    with pytest.raises(ModelError, match="node_type"):
        ExudynModel(c3, node_type="quaternion")
    with pytest.raises(ModelError, match="refine"):
        ExudynModel(c3, refine=0)
    with pytest.raises(ModelError, match="linear_solver"):
        ExudynModel(c3).solve(linear_solver="pardiso")
    monkeypatch.setitem(sys.modules, "exudyn", None)  # as if not installed
    with pytest.raises(MissingExtraError, match="peers"):
        ExudynModel(c3)
