"""Rigid intermediate bodies inside a joint mesh (`JointMesh.body`): exact rigid constraints."""

from typing import ClassVar

import attrs
import numpy as np
import pytest

import flexmb
from flexmb.errors import ModelError
from flexmb.joints import INTERNAL, SIDE_A, SIDE_B, Joint, JointMesh
from flexmb.sections import rectangle

EI_WIDTH, THICKNESS, E, G = 0.01, 1e-3, 200e9, 76.9e9


@attrs.frozen
class SplitLeaf(Joint):
    """A straight leaf along x: ``n`` elements over ``l1``, a rigid block of length ``c`` (three
    points, one body), ``n`` elements over ``l2``."""

    kind: ClassVar[str] = "split_leaf_test"
    l1: float = 0.04
    c: float = 0.02
    l2: float = 0.06
    n: int = 6
    bad_body: bool = False

    def interface_b(self, dim):
        b = np.zeros(dim)
        b[0] = self.l1 + self.c + self.l2
        return b

    def mesh(self, dim):
        n = self.n
        x = np.r_[np.linspace(0, self.l1, n + 1), self.l1 + 0.5 * self.c,
                  self.l1 + self.c + np.linspace(0, self.l2, n + 1)]
        pts = np.zeros((len(x), dim))
        pts[:, 0] = x
        side = np.full(len(x), INTERNAL)
        side[0], side[-1] = SIDE_A, SIDE_B
        body = np.full(len(x), -1)
        body[n:n + 3] = 0  # block: end of segment 1, its middle, start of segment 2
        if self.bad_body:
            body[0] = 1
        elements = [(k, k + 1) for k in range(n)] + [(n + 2 + k, n + 3 + k) for k in range(n)]
        sec = rectangle(EI_WIDTH, THICKNESS, E, G)
        return JointMesh(points=pts, side=side, elements=np.array(elements), sections=(sec,) * (2 * n),
                         ny0=np.tile([0.0, 1.0, 0.0], (2 * n, 1)) if dim == 3 else None, body=body)


def _mechanism(joint, dim, moment):
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim))
    m.add_joint("A", "B", joint, name="leaf")
    m.apply_moment("B", moment if dim == 2 else (0.0, 0.0, moment))
    return m


def _walk(segments, kappa):
    """Closed form of the discrete model under a constant moment: each element keeps its chord
    L0 and turns by kappa L0, its chord at the mean heading of its ends; a rigid block stays
    straight. ``segments``: (length, elements or 0 for rigid)."""
    pos, h = np.zeros(2), 0.0
    for length, n in segments:
        if n == 0:
            pos = pos + length * np.array([np.cos(h), np.sin(h)])
            continue
        L0 = length / n
        for _ in range(n):
            pos = pos + L0 * np.array([np.cos(h + 0.5 * kappa * L0), np.sin(h + 0.5 * kappa * L0)])
            h += kappa * L0
    return pos, h


@pytest.mark.parametrize("dim", [2, 3])
def test_rigid_block_carries_no_rotation_and_stays_straight(dim):
    """End moment M on leaf-block-leaf: curvature M/EI in the leaves, none in the block; the tip
    turns by M (l1 + l2)/EI exactly (Euler's elastica, constant moment) and sits where the
    element-by-element walk of `_walk` puts it."""
    j = SplitLeaf()
    EI = E * EI_WIDTH * THICKNESS**3 / 12
    M = EI * 2.0 / (j.l1 + j.l2)  # 2 rad of bending in total
    sol = flexmb.solve(_mechanism(j, dim, M))
    assert sol.converged, sol.message
    kappa = M / EI
    tip, heading = _walk([(j.l1, j.n), (j.c, 0), (j.l2, j.n)], kappa)
    assert sol.rotation_vector("B")[-1] == pytest.approx(heading, abs=1e-9)
    assert heading == pytest.approx(2.0)
    np.testing.assert_allclose(sol.pose("B")[0][:2], tip, rtol=0, atol=1e-9 * j.interface_b(2)[0])
    # the block's three points keep their distances (one rigid body, one FE node)
    pts = sol.node_positions()
    first = len(sol.compiled.link_node)  # the joint's points follow the links'
    block = pts[first + j.n:first + j.n + 3]
    np.testing.assert_allclose(np.linalg.norm(block[2] - block[0]), j.c, rtol=1e-12)
    np.testing.assert_allclose(block[1], 0.5 * (block[0] + block[2]), atol=1e-14)
    assert len(sol.compiled.joint_nodes["leaf"]) == 2 * (j.n - 1) + 1


def test_body_on_an_interface_point_is_refused():
    m = _mechanism(SplitLeaf(bad_body=True), 2, 1.0)
    with pytest.raises(ModelError, match="body must be .* >= 0 only on INTERNAL points"):
        m.compile()
