"""`imperfect`: a mechanism whose stress-free geometry is moved along a buckling or critical mode.

What Abaqus users do with ``*IMPERFECTION``: a perfect symmetric device bifurcates; the device
as made has imperfections, and its snap load depends on their size (Koiter 1945). The helper
moves every node of the finite-element model (link reference points, the joints' mesh points)
by ``amplitude`` times a mode, scaled so that its largest node translation is ``amplitude``,
and returns a new `Mechanism` built on the moved geometry, stress-free there; sweeping the
amplitude (`flexmb.trace` of each) gives the imperfection sensitivity.
"""

from __future__ import annotations

import copy

import attrs
import numpy as np

from .errors import ModelError, ParameterError
from .fe.build import IDEAL
from .fe.joint_points import Remeshed
from .mechanism import Placement

__all__ = ["imperfect"]


def imperfect(mechanism, mode, amplitude: float, *, which: int = 0):
    """A copy of ``mechanism`` whose undeformed geometry is moved along ``mode``.

    Parameters
    ----------
    mechanism
        The perfect `flexmb.Mechanism` (unchanged).
    mode
        A `flexmb.path.Critical` (its critical mode ``which``) or an increment of every DOF of
        the mechanism's finite-element model (n_dofs,) (`Solution.state` order, e.g. a buckling
        mode mapped back to the model).
    amplitude
        The largest node translation of the imperfection [m], signed (the sign picks the side).
    which
        Which of a multiple critical point's modes (0).

    Returns a new `Mechanism`: links moved, each joint's mesh moved (a `Remeshed` joint), hinges'
    origins moved with their side-A link; loads, prescribed motions, named points and points
    inside joints as given.
    """
    owner = "imperfect"
    phi = _mode(owner, mode, which)
    amplitude = float(amplitude)
    if not np.isfinite(amplitude):
        raise ParameterError(f"{owner}: amplitude={amplitude!r} must be a finite length [m]")
    compiled = mechanism.compile("fe_model")
    model = compiled.problem.model
    if len(phi) != model.n_dofs:
        raise ModelError(f"{owner}: the mode has {len(phi)} DOFs, the mechanism's finite-element model {model.n_dofs}: "
                         "take it from a path or solution of this mechanism")
    return _moved(mechanism, compiled, _node_motion(model, phi, amplitude))


def _mode(owner: str, mode, which: int) -> np.ndarray:
    if hasattr(mode, "modes"):
        modes = mode.modes
        if not 0 <= which < len(modes):
            raise ParameterError(f"{owner}: which={which!r}; the critical point has {len(modes)} mode(s)")
        return modes[which]
    phi = np.asarray(mode, dtype=float)
    if phi.ndim != 1 or not np.all(np.isfinite(phi)):
        raise ParameterError(f"{owner}: mode must be a Critical or a finite 1-D array of DOF increments")
    return phi


def _node_motion(model, phi: np.ndarray, amplitude: float):
    """``(t, r)``: every node's translation (n_nodes, dim) [m] and small rotation (n_nodes, nrot)
    [rad] along ``phi``, scaled so the largest node translation is ``amplitude``."""
    d = model.node_part(phi)
    t, r = d[:, : model.dim], d[:, model.dim:]
    largest = float(np.max(np.linalg.norm(t, axis=1)))
    if not largest > 0:
        raise ParameterError("imperfect: the mode moves no node (a rotation-only mode): give another")
    scale = amplitude / largest
    return scale * t, scale * r


def _rigid(t, r, node, offset: np.ndarray) -> np.ndarray:
    """The motion of points at ``offset`` (k, dim) from nodes ``node`` (k,) moving by ``(t, r)``."""
    if offset.shape[1] == 2:
        return t[node] + r[node, 0][:, None] * np.column_stack([-offset[:, 1], offset[:, 0]])
    return t[node] + np.cross(r[node], offset)


def _moved(mechanism, compiled, motion):
    """The new mechanism: the links at their moved reference points, the joints' meshes moved
    (in their own frames), the hinges' origins moved with their side-A link."""
    t, r = motion
    model = compiled.problem.model
    master = model.point_master
    delta = _rigid(t, r, master, model.point_x0 - model.x0[master])
    out = copy.copy(mechanism)
    out.graph = mechanism.graph.copy()
    node = compiled.link_node
    for name, lk in mechanism.links.items():
        out.graph.nodes[name]["link"] = attrs.evolve(lk, position=lk.position + delta[node[name]])
    start = len(node)
    built = {k: joint for k, joint, *_ in compiled.joints}  # as compiled (points inside joints: split meshes)
    for a, b, key, data in out.graph.edges(keys=True, data=True):
        joint, pl = data["joint"], data["placement"]
        if IDEAL in joint.capabilities:
            n = node[data["sides"][0]]
            move = _rigid(t, r, np.array([n]), (pl.origin - model.x0[n])[None])[0]
            data["placement"] = Placement(pl.origin + move, pl.rotation)
            continue
        own = len(joint.mesh(mechanism.dim).points)  # the joint's own points first, then the split points
        local = delta[start:start + own] @ pl.rotation  # global -> the joint's frame
        data["joint"] = Remeshed(joint, (), local)
        start += len(built[key].mesh(mechanism.dim).points)
    out._loads = list(mechanism._loads)
    out._prescribed = dict(mechanism._prescribed)
    out._points = dict(mechanism._points)
    return out
