"""A third-party flexmb joint, as a plugin author writes one (see README "Writing your own joint")."""

from typing import ClassVar

import attrs
import numpy as np

import flexmb
from flexmb.joints import SIDE_A, SIDE_B, JointMesh
from flexmb.sections import rectangle


@attrs.frozen(kw_only=True)
class SingleLeaf(flexmb.Joint):
    """A straight steel leaf of ``length`` [m], ``width`` x ``thickness`` [m], as one beam element."""

    kind: ClassVar[str] = "single_leaf"
    parameter_ranges: ClassVar[dict] = {"length": (0.05, 0.2), "thickness": (5e-4, 2e-3)}
    length: float = 0.1
    width: float = 0.02
    thickness: float = 1e-3

    def interface_b(self, dim):
        return np.eye(dim)[0] * self.length

    def mesh(self, dim):
        return JointMesh(points=np.stack([np.zeros(dim), self.interface_b(dim)]), side=np.array([SIDE_A, SIDE_B]),
                         elements=np.array([[0, 1]]), sections=(rectangle(self.width, self.thickness, 200e9, 76.9e9),),
                         ny0=np.array([[0.0, 1.0, 0.0]]) if dim == 3 else None)
