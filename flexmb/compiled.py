"""`Compiled`: a mechanism turned into a problem a strategy can solve, with the maps back to links."""

from __future__ import annotations

import attrs

__all__ = ["Compiled"]


@attrs.frozen(eq=False)
class Compiled:
    """A mechanism turned into a problem (a `flexmb.problem.StaticProblem` from `flexmb.fe.build`,
    a `flexmb.closed_form.problem.LinkageProblem` from `flexmb.closed_form.build`), with the maps
    back to links and points."""

    problem: object
    link_node: dict  # link name -> node index
    points: dict  # named points: name -> (link, offset [m])
    joint_elements: dict  # joint name -> element indices
    actuation: tuple | None = None  # (row of the actuation in problem.loads, unit direction)
    joint_nodes: dict = attrs.field(factory=dict)  # joint name -> FE node indices of its internal nodes
    joints: tuple = ()  # (name, joint, placement, side A link, side B link) at compile time
    fixed: tuple = ()  # names of the fixed links (the ground)
