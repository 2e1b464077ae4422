"""The closed-form builder: a planar `flexmb.Mechanism` -> its links-only `LinkageProblem`.

Cammarata et al. (2022): rigid links (3 DOFs each) joined by constant-stiffness flexures whose
end wrench follows from their closed-form compliance (`flexmb.joints.ClosedForm`).
"""

from __future__ import annotations

import numpy as np

from ..boundary import actuation_row, boundary
from ..compiled import Compiled
from ..errors import ModelError, TopologyError, UnsupportedStrategyError
from ..joints._base import FLEXURE_MODELS, ClosedForm, Joint
from ..rotations import rot2
from .flexures import FlexureSet
from .problem import LinkageModel, LinkageProblem

__all__ = ["build", "CAPABILITY"]

CAPABILITY = "closed_form"  # what a joint must offer (`Joint.capabilities`) to be built here


def build(mechanism) -> Compiled:
    """The links-only `LinkageProblem` of a planar ``mechanism`` (Cammarata et al. 2022): every
    joint a constant-stiffness flexure between its interface frames (Eqs. 18-28)."""
    links = mechanism.links
    mechanism.check(links)
    if mechanism.dim != 2:
        raise UnsupportedStrategyError("the closed-form (method='newton') model is planar: use a dim=2 mechanism")
    names = list(links)
    link_node = {n: i for i, n in enumerate(names)}
    x0 = np.array([links[n].position for n in names]).reshape(-1, 2)
    rows = []
    for a, b, key, data in mechanism.graph.edges(keys=True, data=True):
        jt: Joint = data["joint"]
        if CAPABILITY not in jt.capabilities:
            raise UnsupportedStrategyError(
                f"joint {key!r} ({jt.kind}) has no closed-form model (method='newton'); it offers "
                f"{sorted(jt.capabilities)}: use method='conventional'")
        cf = _checked_closed_form(key, jt)
        side_a, side_b = data["sides"]
        pl = data["placement"]  # a flexmb.mechanism.Placement
        ia, ib = link_node[side_a], link_node[side_b]
        end = pl.to_global(cf.end)
        B_j = pl.rotation @ rot2(cf.end_angle)
        rows.append((ia, ib, pl.origin - x0[ia], end - x0[ib], pl.rotation, B_j, rot2(cf.end_angle),
                     rot2(cf.end_angle).T @ cf.end, pl.rotation @ cf.end, cf.stiffness,
                     cf.model == "partial-nonlinear"))
    if not rows:
        raise TopologyError("the mechanism has no joints")
    cols = [np.array(c) for c in zip(*rows)]
    flex = FlexureSet(*[c.astype(np.int64) if k < 2 else c for k, c in enumerate(cols)])
    pres, vals, loads, _ = boundary(mechanism, link_node)  # planar: no rotation chains
    problem = LinkageProblem(LinkageModel(x0, flex), pres, vals, loads)
    joints = tuple((k, d["joint"], d["placement"], *d["sides"]) for _, _, k, d in mechanism.graph.edges(keys=True, data=True))
    return Compiled(problem, link_node, mechanism.points, {}, actuation_row(mechanism, loads), joints=joints)


def _checked_closed_form(key: str, joint: Joint) -> ClosedForm:
    """The joint's `ClosedForm`, checked (a plugin's mistakes named here)."""
    cf = joint.closed_form(2)
    where = f"joint {key!r} ({joint.kind})"
    K = np.asarray(cf.stiffness, dtype=float)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ModelError(f"{where}: closed-form stiffness must be a finite (3, 3) array, got shape {K.shape}")
    if np.shape(cf.end) != (2,) or not np.all(np.isfinite(cf.end)) or not np.isfinite(cf.end_angle):
        raise ModelError(f"{where}: closed-form end must be a finite (2,) position and a finite angle")
    if cf.model not in FLEXURE_MODELS:
        raise ModelError(f"{where}: closed-form model {cf.model!r}; valid: {', '.join(FLEXURE_MODELS)}")
    return ClosedForm(K, np.asarray(cf.end, dtype=float), float(cf.end_angle), cf.model)
