"""Accuracy by default: every converged finite-element result carries the
estimate of its discretisation error, and one whose estimate exceeds the accuracy target warns,
once per kind of result and mesh (a loop or a sweep over one mesh warns once).

The estimate is a Richardson pair (Roache 1998, *Verification and Validation in Computational
Science and Engineering*, Ch. 5, with the beam elements' order 2 assumed, as
`flexmb.discretisation_error` does with two meshes): the same equilibrium on a *companion* mesh,
every flexure's element count (`flexmb.Joint.mesh_parameter`) halved (all even) or else doubled,
started from the solution's own configuration carried onto the companion's nodes (`transfer`)
and converged there by Newton (`flexmb.problem.StaticProblem.continued_from`: one or two
iterations). With ``q`` on the given mesh of size ``h`` and ``q_c`` on ``r h``:
``q* = q + (q - q_c) / (r^2 - 1)`` (``r = 2``), ``q* = q_c + (q_c - q) / 3`` (``r = 1/2``),
and the error ``q - q*``. A property (`flexmb.modes`, `flexmb.buckling`, `flexmb.compliance`,
`flexmb.Solution.stresses`) is evaluated on the companion equilibrium the same way.

What is estimated (`Estimate.names`): for a solve, the prescribed components of the reactions
and the free components of the links' displacements; for the properties, the frequencies, the
buckling multipliers, the compliance entries and the peak stresses. Each error is relative to the
quantity, or to 1 % of the largest of its kind when the quantity is smaller than that (a
reaction component or a rotation that is zero by symmetry is not a quantity a designer reads).

`set_target` changes the target (default 1 %) or, with None, switches the estimates off (the
cost of a solve as before: the companion costs ~0.2-0.5 of a solve, BENCHMARKS.md "accuracy").
Solutions of the KSD-reduced model (their state is not the full model's equilibrium) and of
the closed-form models (no mesh) carry an estimate that says why it is not available.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import math
import os
import threading
import warnings
import weakref

import attrs
import numpy as np

from .errors import DiscretisationWarning, FlexmbError, ParameterError
from .fe.model import State
from .mechanism import COMPILED_FROM
from . import _warnings, results
from .rotations import expm_so3, logm_so3

__all__ = ["Estimate", "Deferred", "DEFAULT_TARGET", "target", "set_target", "estimate", "attach", "check",
           "companion_solution", "full_solution", "critical_estimate", "prepare", "transfer", "reset_warnings", "off"]

#: The accuracy target: the largest relative discretisation error a result may carry unwarned.
DEFAULT_TARGET = 0.01
#: A quantity smaller than this fraction of the largest of its kind is judged against that fraction.
FLOOR = 0.01
#: The companion's convergence tolerance (`flexmb.solvers.Conventional`'s rtol): its difference to
#: the result is ~1e-3 relative and wanted to a few per cent of itself
COMPANION_RTOL = 1e-7


def _from_environment() -> float | None:
    """The target from ``$FLEXMB_ACCURACY`` (a relative error, or ``off``), else the default."""
    text = os.environ.get("FLEXMB_ACCURACY", "").strip().lower()
    if not text:
        return DEFAULT_TARGET
    if text in ("off", "none", "0"):
        return None
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 < value < 1.0:
        warnings.warn(f"FLEXMB_ACCURACY={text!r} is neither a relative error in (0, 1) nor 'off': the target is "
                      f"{DEFAULT_TARGET}", UserWarning, stacklevel=2)
        return DEFAULT_TARGET
    return value


_STATE = {"target": _from_environment()}
_LOCAL = threading.local()  # .off: estimates suspended in this thread (a companion's own properties)
_WARNED: set = set()
_COMPANIONS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # FE model -> (compiled, ratio, note)
_SOLVED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # Solution -> (companion Solution | None, note)
_ESTIMATES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # Solution -> its Estimate
_FULL: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # KSD-reduced Solution -> (full Solution | None, note)


def target() -> float | None:
    """The accuracy target (relative; None: estimates off)."""
    return _STATE["target"]


def set_target(value: float | None = DEFAULT_TARGET) -> float | None:
    """Set the accuracy target to ``value`` (relative, in (0, 1); default 0.01), or switch the
    estimates off with None; returns the previous target."""
    if value is not None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value < 1.0:
            raise ParameterError(f"set_target: value={value!r} must be a relative error in (0, 1), or None "
                                 "(no estimates)")
        value = float(value)
    old, _STATE["target"] = _STATE["target"], value
    return old


def reset_warnings() -> None:
    """Forget which results have warned (each warns once per kind of result and mesh)."""
    _WARNED.clear()


@contextlib.contextmanager
def off():
    """Context manager: no estimates (and no warnings) in this thread inside; for solves on a
    mesh chosen on purpose (database training, the companion's own properties)."""
    before = getattr(_LOCAL, "off", False)
    _LOCAL.off = True
    try:
        yield
    finally:
        _LOCAL.off = before


@contextlib.contextmanager
def quiet():
    """Context manager: no estimates and no warnings from this thread inside (the companion's own
    solves and properties): its warnings are recorded and dropped (`flexmb._warnings.recording`,
    which other threads' warnings pass by; `warnings.catch_warnings` would swap the process's
    warning state and silence a dask worker's other thread)."""
    with off(), _warnings.recording():
        yield


def _active() -> bool:
    return _STATE["target"] is not None and not getattr(_LOCAL, "off", False)


@attrs.frozen(eq=False)
class Estimate:
    """The estimated discretisation error of one result (module notes).

    Attributes
    ----------
    kind
        ``"solve"``, ``"modes"``, ``"buckling"``, ``"compliance"`` or ``"stress"``.
    names
        The quantities (tuple of str), e.g. ``"reaction stage y"``, ``"f2"``, ``"C[1,1]"``.
    value, companion
        (q,): the quantities on the result's mesh and on the companion mesh.
    ratio
        The companion's element size over the result's (2: half the elements; 0.5: twice).
    scale
        (q,): what each error is relative to: ``max(|value|, 1 % of the largest of its kind)``.
    elements
        (elements of the result's mesh, of the companion's).
    target
        The accuracy target when estimated.
    note
        Why no estimate is available (then ``names`` is empty), or "".
    basis
        What the pair was solved as when it is not the result itself, or "": a KSD-reduced
        result's is the full model's equilibrium on the result's own mesh (its discretisation
        error; the reduction's own is KSD's error estimate).
    """

    kind: str
    names: tuple = ()
    value: np.ndarray = attrs.field(factory=lambda: np.zeros(0))
    companion: np.ndarray = attrs.field(factory=lambda: np.zeros(0))
    ratio: float = 2.0
    scale: np.ndarray = attrs.field(factory=lambda: np.zeros(0))
    elements: tuple = (0, 0)
    target: float = DEFAULT_TARGET
    note: str = ""
    basis: str = ""

    @property
    def available(self) -> bool:
        """Whether there is an estimate (else `note` says why)."""
        return not self.note

    @property
    def reference(self) -> np.ndarray:
        """(q,): the Richardson extrapolation of the pair, order 2 (module notes)."""
        q, qc, r = self.value, self.companion, self.ratio
        if r > 1.0:
            return q + (q - qc) / (r * r - 1.0)
        s = 1.0 / r
        return qc + (qc - q) / (s * s - 1.0)

    @property
    def error(self) -> np.ndarray:
        """(q,): the estimated error of `value`, ``value - reference``."""
        return self.value - self.reference

    @property
    def relative(self) -> np.ndarray:
        """(q,): ``|error| / scale`` (see `scale`)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(self.error) / self.scale
        return np.where(np.isfinite(self.value) & np.isfinite(self.companion) & (self.scale > 0), rel, np.nan)

    @property
    def worst(self) -> tuple[str, float]:
        """``(name, relative error)`` of the quantity with the largest estimated error
        (``("", 0.0)`` when there is none)."""
        rel = self.relative
        if not len(rel) or np.all(np.isnan(rel)):
            return "", 0.0
        k = int(np.nanargmax(rel))
        return self.names[k], float(rel[k])

    @property
    def exceeds(self) -> bool:
        """Whether the largest estimated relative error is above `target`."""
        return self.available and self.worst[1] > self.target

    def __getitem__(self, name: str) -> dict:
        """One quantity's numbers: value, companion, reference, error, relative."""
        try:
            k = self.names.index(name)
        except ValueError:
            raise FlexmbError(f"no quantity {name!r}; quantities: {', '.join(self.names) or 'none'}") from None
        return {"value": float(self.value[k]), "companion": float(self.companion[k]),
                "reference": float(self.reference[k]), "error": float(self.error[k]),
                "relative": float(self.relative[k])}

    def columns(self) -> dict:
        """The quantities as columns (a `flexmb.Table` takes them): ``quantity``, ``value``,
        ``reference``, ``error``, ``relative``."""
        return dict({"quantity": np.array(self.names, dtype=object), "value": self.value.copy(),
                      "reference": self.reference, "error": self.error, "relative": self.relative})

    def __repr__(self) -> str:
        if not self.available:
            return f"Estimate({self.kind}: not available: {self.note})"
        name, rel = self.worst
        basis = f"; {self.basis}" if self.basis else ""
        return (f"Estimate({self.kind}: largest {100 * rel:.2g} % ({name}), {len(self.names)} quantities, "
                f"elements {self.elements[0]} vs {self.elements[1]} on the companion, target {100 * self.target:g} %"
                f"{basis})")


def _unavailable(kind: str, note: str) -> Estimate:
    return Estimate(kind, target=_STATE["target"] or DEFAULT_TARGET, note=note)


# -- the companion mesh -----------------------------------------------------------------------------

def _counts(compiled) -> tuple[dict | None, str]:
    """``{joint: elements}`` of the flexures of ``compiled`` with a mesh parameter, or None and why."""
    counts = {}
    for name, joint, *_ in compiled.joints:
        if "fe_model" not in joint.capabilities:
            continue  # an ideal joint: exact
        param = type(joint).mesh_parameter
        if not param or not isinstance(getattr(joint, param, None), (int, np.integer)):
            return None, (f"joint {name!r} (kind {joint.kind!r}) names no integer mesh_parameter, so its mesh cannot "
                          "be refined or coarsened")
        counts[name] = (param, int(getattr(joint, param)))
    if not counts:
        return None, "no joint with a mesh (ideal joints only)"
    return counts, ""


def _companion(compiled):
    """``(companion compiled, ratio, note)`` for the FE model of ``compiled``, built once per model."""
    model = compiled.problem.model
    kept = _COMPANIONS.get(model)
    if kept is not None:
        return kept
    kept = _build_companion(compiled)
    _COMPANIONS[model] = kept
    return kept


def _build_companion(compiled):
    if getattr(compiled, "joint_points", None):
        return None, 2.0, ("points inside a joint (Mechanism.add_joint_point) sit on nodes of the given mesh: no "
                           "companion mesh is built for them; flexmb.discretisation_error estimates any quantity")
    ref = COMPILED_FROM.get(compiled.problem.model)
    mechanism = ref() if ref is not None else None
    if mechanism is None:
        return None, 2.0, "the mechanism this result was solved from is gone (the companion mesh is built from it)"
    counts, note = _counts(compiled)
    if counts is None:
        return None, 2.0, note
    coarse = all(n % 2 == 0 for _, n in counts.values())
    ratio = 2.0 if coarse else 0.5
    joints = {name: (joint, placement) for name, joint, placement, *_ in compiled.joints}
    out = copy.copy(mechanism)  # shares the links, loads and motions (compiling only reads them)
    out.graph = mechanism.graph.copy()  # new edge data dicts: the joints replaced below are the copy's
    for _, _, name, data in out.graph.edges(keys=True, data=True):
        if name not in joints:
            return None, ratio, "the mechanism changed after it was solved (a joint was added)"
        joint, placement = joints[name]
        if name in counts:
            param, n = counts[name]
            joint = attrs.evolve(joint, **{param: n // 2 if coarse else 2 * n})
        data["joint"], data["placement"] = joint, placement
    try:
        with quiet():
            comp = out.compile("fe_model")
    except FlexmbError as exc:
        return None, ratio, f"the companion mesh could not be built: {exc}"
    p, q = compiled.problem, comp.problem
    if (list(comp.link_node) != list(compiled.link_node) or not np.array_equal(p.prescribed, q.prescribed)
            or not np.array_equal(p.loads.node, q.loads.node) or (p.model.hinges is None) != (q.model.hinges is None)):
        return None, ratio, "the mechanism changed after it was solved (links, motions or loads)"
    return comp, ratio, ""


def transfer(state: State, fine, coarse) -> State:
    """``state`` of ``fine`` (a `flexmb.compiled.Compiled`) carried onto the nodes of ``coarse``,
    a mesh of the same mechanism: the links' nodes copied; each joint's internal node copied from
    the fine node at the same undeformed place, else placed on the fine element of the same joint
    nearest to it and most nearly parallel to its own elements (leaves that cross share places),
    by linear interpolation along it (positions; rotations along the relative rotation of its ends)."""
    fm, cm = fine.problem.model, coarse.problem.model
    n_links = len(fine.link_node)
    pos = np.array(cm.x0, dtype=float)
    rot = np.zeros(cm.n_nodes) if fm.dim == 2 else np.tile(np.eye(3), (cm.n_nodes, 1, 1))
    pos[:n_links] = state.positions[:n_links]
    rot[:n_links] = state.rotations[:n_links]
    points = fm.point_positions(state)
    size = float(fine.problem.model_length)
    for name, nodes in coarse.joint_nodes.items():
        els = fine.joint_elements.get(name)
        if len(nodes) and els is not None and len(els):
            p, r = _joint_transfer(state, fm, cm, points, (els, fine.joint_nodes[name]),
                                   coarse.joint_elements[name], nodes, size)
            pos[nodes], rot[nodes] = p, r
    mult = None if state.multipliers is None else state.multipliers.copy()
    angles = None if state.hinge_angles is None else state.hinge_angles.copy()
    return State(pos, rot, mult, angles)


def _directions(model, els) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start, unit direction and length of elements ``els`` of ``model`` (undeformed)."""
    ends = model.elements.ends[els]
    a, b = model.point_x0[ends[:, 0]], model.point_x0[ends[:, 1]]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    return a, d / np.where(length > 0, length, 1.0)[:, None], length


def _joint_transfer(state, fm, cm, points, fine_joint, coarse_els, nodes, size):
    """The positions and rotations of one joint's coarse internal ``nodes`` (`transfer`);
    ``fine_joint``: the joint's elements and internal nodes in the fine model."""
    els, fine_nodes = fine_joint
    a, u, length = _directions(fm, els)
    _, uc, _ = _directions(cm, coarse_els)
    owner_c = cm.point_master[cm.elements.ends[coarse_els]]  # (e_c, 2) coarse nodes of each coarse element
    x = cm.x0[nodes]
    # the direction of each coarse node's first element (a node no element ends at: any direction)
    first = np.full(len(nodes), -1)
    for col in (1, 0):
        hit = np.searchsorted(nodes, owner_c[:, col])
        ok = (hit < len(nodes)) & (nodes[np.minimum(hit, len(nodes) - 1)] == owner_c[:, col])
        first[hit[ok]] = np.flatnonzero(ok)
    direction = np.where(first[:, None] >= 0, uc[np.maximum(first, 0)], 0.0)
    rel = x[:, None, :] - a[None]  # (k, e, dim)
    s = np.clip(np.einsum("kej,ej->ke", rel, u) / np.where(length > 0, length, 1.0), 0.0, 1.0)
    gap = np.linalg.norm(rel - (s * length)[..., None] * u[None], axis=2)
    parallel = np.abs(direction @ u.T)  # (k, e); 0 for a node without elements
    score = gap / max(size, 1e-300) + np.where(first[:, None] >= 0, 1.0 - parallel, 0.0)
    e = np.argmin(score, axis=1)
    k = np.arange(len(nodes))
    s = s[k, e]
    ends = fm.elements.ends[els[e]]
    pa, pb = ends[:, 0], ends[:, 1]
    pos = (1.0 - s)[:, None] * points[pa] + s[:, None] * points[pb]
    ma, mb = fm.point_master[pa], fm.point_master[pb]
    # a fine node at the node's own undeformed place (a rigid body's node, a nested mesh's node):
    # the chosen element's end there if it has one (leaves crossing share places), else any
    near = np.linalg.norm(fm.x0[fine_nodes][None] - x[:, None], axis=2) <= 1e-9 * size  # (k, f)
    at = np.where(s < 0.5, ma, mb)
    own = np.linalg.norm(fm.x0[at] - x, axis=1) <= 1e-9 * size
    same = own | near.any(axis=1)
    at = np.where(own, at, fine_nodes[np.argmax(near, axis=1)] if len(fine_nodes) else at)
    pos[same] = state.positions[at[same]]
    if fm.dim == 2:
        rot = (1.0 - s) * state.rotations[ma] + s * state.rotations[mb]
        rot[same] = state.rotations[at[same]]
    else:
        Ra, Rb = state.rotations[ma], state.rotations[mb]
        rot = Ra @ expm_so3(s[:, None] * logm_so3(Ra.transpose(0, 2, 1) @ Rb))
        rot[same] = state.rotations[at[same]]
    return pos, rot


def _prescribed_totals(problem, state) -> np.ndarray:
    """The prescribed DOFs' values at ``state`` as totals from the undeformed configuration."""
    m = problem.model
    node, comp = np.divmod(problem.prescribed, m.ndof)
    out = np.zeros(len(node))
    tr = comp < m.dim
    out[tr] = state.positions[node[tr], comp[tr]] - m.x0[node[tr], comp[tr]]
    if m.dim == 2:
        out[~tr] = state.rotations[node[~tr]]
    elif np.any(~tr):
        w = logm_so3(state.rotations[node[~tr]])
        out[~tr] = w[np.arange(len(w)), comp[~tr] - 3]
    return out


#: What a KSD-reduced result's pair is solved as (`Estimate.basis`).
REDUCED_BASIS = ("the full model's equilibrium on this mesh, converged from the KSD-reduced state (KSD-full's answer): "
                 "the mesh's error; KSD-reduced's own is KSD's error estimate")


def full_solution(solution):
    """``(Solution or None, note)``: ``solution`` when it is the full model's equilibrium, else (a
    KSD-reduced solution) the full model's equilibrium on the same mesh converged by Newton from
    its state (as KSD-full's step 5), computed once per solution."""
    if type(solution).full_equilibrium:
        return solution, ""
    kept = _FULL.get(solution)
    if kept is None:
        kept = _solve_full(solution)
        _FULL[solution] = kept
    return kept


def _solve_full(solution):
    from .solvers.conventional import Conventional

    if not solution.converged:
        return None, "the solve did not converge"
    compiled = solution.compiled
    if not hasattr(getattr(compiled.problem, "model", None), "elements"):
        return None, "a closed-form model has no mesh (no discretisation error)"
    state = solution.state
    try:
        with quiet():
            full = Conventional(rtol=COMPANION_RTOL).solve(
                attrs.evolve(compiled, problem=compiled.problem.continued_from(state)), state=state)
    except (FlexmbError, np.linalg.LinAlgError, ArithmeticError, RuntimeError) as exc:
        return None, f"the full model's solve from the reduced state failed: {exc}"
    if not full.converged:
        return None, f"the full model did not converge from the reduced state: {full.message}"
    return full, ""


def companion_solution(solution):
    """``(companion Solution or None, ratio, note)``: ``solution``'s equilibrium on the companion
    mesh (module notes; a KSD-reduced solution's: that of `full_solution`), computed once per solution."""
    kept = _SOLVED.get(solution)
    if kept is not None:
        return kept
    full, note = full_solution(solution)
    kept = (None, 2.0, note) if full is None else _solve_companion(full)
    _SOLVED[solution] = kept
    return kept


def _solve_companion(solution):
    from .solvers.conventional import Conventional

    if not solution.converged:
        return None, 2.0, "the solve did not converge"
    compiled = solution.compiled
    if not hasattr(getattr(compiled.problem, "model", None), "elements"):
        return None, 2.0, "a closed-form model has no mesh (no discretisation error)"
    base, ratio, note = _companion(compiled)
    if base is None:
        return None, ratio, note
    fine = compiled.problem
    start = transfer(solution.state, compiled, base)
    problem = base.problem.with_loads(fine.loads).with_motion(_prescribed_totals(fine, solution.state))
    try:
        with quiet():
            comp = Conventional(rtol=COMPANION_RTOL).solve(attrs.evolve(base, problem=problem.continued_from(start)),
                                                           state=start)
    except (FlexmbError, np.linalg.LinAlgError, ArithmeticError, RuntimeError) as exc:
        return None, ratio, f"the companion mesh's solve failed: {exc}"
    if not comp.converged:
        return None, ratio, f"the companion mesh did not converge: {comp.message}"
    return comp, ratio, ""


# -- the estimates ------------------------------------------------------------------------------------

def _elements(compiled) -> int:
    return int(sum(len(e) for e in compiled.joint_elements.values()))


def _scales(values: np.ndarray, kinds: np.ndarray | None = None, least=None) -> np.ndarray:
    """``max(|value|, FLOOR x the largest |value| of its kind)`` (kinds: an int per quantity); NaN
    where that is not above ``least[kind]`` (round-off: nothing of that kind to judge)."""
    v = np.abs(np.asarray(values, dtype=float))
    kinds = np.zeros(len(v), dtype=int) if kinds is None else np.asarray(kinds)
    out = v.copy()
    for k in np.unique(kinds):
        sel = kinds == k
        finite = v[sel][np.isfinite(v[sel])]
        top = float(finite.max()) if len(finite) else 0.0
        out[sel] = np.maximum(v[sel], FLOOR * top)
        floor = 0.0 if least is None else least.get(int(k), 0.0)
        out[sel] = np.where(out[sel] > floor, out[sel], np.nan)
    return out


def _least(solution, force: float, L: float) -> dict:
    """Per kind, the size below which a quantity is round-off, not judged: reactions (forces,
    moments over the model length) within ``ROUNDOFF_RESIDUALS`` times the solve's residual
    tolerance or 1e-6 of the force scale (the unloaded four-bar's ground reaction, 4.7e-9 N at a
    2.2e-8 N tolerance, read 530 % before), displacements 1e-9 of the model length."""
    tol = float(getattr(solution, "tolerance", 0.0) or 0.0)
    tol = tol if np.isfinite(tol) else 0.0
    reaction = max(1e-6 * force, ROUNDOFF_RESIDUALS * tol)
    return {0: reaction, 1: reaction, 2: 1e-9 * L}


#: Reactions below this many residual tolerances are round-off (`_least`).
ROUNDOFF_RESIDUALS = 10.0


def _solve_quantities(solution, L: float) -> tuple[list, np.ndarray, np.ndarray]:
    """(names, values, kinds) of a solve: the prescribed components of the reactions (kinds 0:
    forces, 1: moments over the model length) and the free components of the links'
    displacements (2: translations and rotations times ``L``, the given mesh's model length)."""
    problem = solution.compiled.problem
    m = problem.model
    labels = ("x", "y", "rotation") if m.dim == 2 else ("x", "y", "z", "rx", "ry", "rz")
    pres = set(problem.prescribed.tolist())
    names, values, kinds = [], [], []
    state = solution.state
    for link, node in solution.compiled.link_node.items():
        r = solution.residual[m.node_dofs[node]]
        d = np.concatenate([state.positions[node] - m.x0[node],
                            [state.rotations[node]] if m.dim == 2 else logm_so3(state.rotations[node])])
        for c, label in enumerate(labels):
            moment = c >= m.dim
            if node * m.ndof + c in pres:
                names.append(f"reaction {link} {label}")
                values.append(r[c])
                kinds.append(1 if moment else 0)
            else:
                names.append(f"displacement {link} {label}")
                values.append(d[c])
                kinds.append(2)
    values, kinds = np.array(values, dtype=float), np.array(kinds)
    scaled = values * np.where(kinds == 1, 1.0 / L, 1.0)
    rot = np.array([k == 2 and n.split()[-1] in ("rotation", "rx", "ry", "rz") for n, k in zip(names, kinds)])
    scaled = np.where(rot, values * L, scaled)
    return names, scaled, np.where(kinds == 1, 0, kinds)  # moments / L and forces together


def estimate(solution) -> Estimate:
    """The estimated discretisation error of ``solution``'s reactions and displacements
    (`Estimate`, kind ``"solve"``), computed once per solution."""
    kept = _ESTIMATES.get(solution)
    if kept is not None:
        return kept
    if _STATE["target"] is None:
        return _unavailable("solve", "estimates are off (flexmb.accuracy.set_target(None))")
    comp, ratio, note = companion_solution(solution)
    if comp is None:
        out = _unavailable("solve", note)
    else:
        full = full_solution(solution)[0]
        L = float(full.compiled.problem.model_length)  # one length for both meshes
        names, q, kinds = _solve_quantities(full, L)
        _, qc, _ = _solve_quantities(comp, L)
        force = float(getattr(full.compiled.problem, "force_scale", 0.0) or 0.0)
        least = _least(full, force, L)
        out = Estimate("solve", tuple(names), q, qc, ratio, _scales(q, kinds, least),
                       (_elements(full.compiled), _elements(comp.compiled)), _STATE["target"],
                       basis="" if full is solution else REDUCED_BASIS)
    _ESTIMATES[solution] = out
    if full_solution(solution)[0] is not solution:  # estimated on request (solve does not): warn here
        warn(out, solution.compiled, stacklevel=4)
    return out


def _mesh_key(compiled) -> tuple:
    return tuple(sorted((joint.kind, name, getattr(joint, type(joint).mesh_parameter or "", None))
                        for name, joint, *_ in compiled.joints))


def warn(est: Estimate, compiled, stacklevel: int = 3) -> None:
    """Warn (`flexmb.DiscretisationWarning`) when ``est`` exceeds its target, once per kind of
    result and mesh; every time while the thread records its warnings (a study's design, a
    sweep's value: `flexmb._warnings.recording`), so each record is the same in any order."""
    if not est.exceeds:
        return
    key = (est.kind, _mesh_key(compiled))
    if key in _WARNED and _warnings.current() is None:
        return
    _WARNED.add(key)
    name, rel = est.worst
    warnings.warn(f"{est.kind}: estimated discretisation error {100 * rel:.2g} % ({name}) above the "
                  f"{100 * est.target:g} % target on this mesh ({est.elements[0]} beam elements, against "
                  f"{est.elements[1]}): refine the joints (elements, elements_per_leaf); .discretisation holds the "
                  "estimate; shown once per kind of result and mesh", DiscretisationWarning, stacklevel=stacklevel)


def prepare(compiled) -> None:
    """Build the companion mesh of ``compiled`` now (a compile, no solve) for an estimate made
    later on request (a KSD-reduced solution's, a path's critical point's): the mechanism it is
    built from may be gone by then."""
    if _active() and hasattr(getattr(compiled.problem, "model", None), "elements"):
        _companion(compiled)


def check(solution, stacklevel: int = 3) -> None:
    """Estimate ``solution``'s error now (when the estimates are on) and warn if it exceeds the
    target: what `flexmb.solve` does with every converged finite-element solution."""
    if not _active() or not solution.converged or not hasattr(getattr(solution.compiled.problem, "model", None),
                                                               "elements"):
        return
    if not type(solution).full_equilibrium:  # KSD-reduced: its estimate costs a KSD-full solve; on request
        prepare(solution.compiled)
        return
    est = estimate(solution)
    warn(est, solution.compiled, stacklevel + 1)


# -- a path's critical point -------------------------------------------------------------------------

#: Arc-length steps the companion path may take from the point before the critical point to meet it.
CRITICAL_STEPS = 40
#: Earlier points of the path tried as the companion path's start when the one before the critical
#: point has no equilibrium on the companion mesh at its load factor (the companion's limit lies below it).
CRITICAL_STARTS = 4


def critical_estimate(critical, tracer) -> Estimate:
    """The estimated discretisation error of a critical point of a `flexmb.trace` path (`flexmb.EquilibriumPath.snap`):
    its load factor and its solution's reactions and displacements (`estimate`'s), against the
    same critical point on the companion mesh, traced there from the path's point before it
    (carried onto the companion by `transfer`, converged at its load factor, then followed by the
    path's own arc-length control until the first critical point). Computed once per critical
    point; warns once per mesh when above the target."""
    kept = _ESTIMATES.get(critical)
    if kept is not None:
        return kept
    if _STATE["target"] is None:
        return _unavailable("critical", "estimates are off (flexmb.accuracy.set_target(None))")
    comp, ratio, note = _companion_critical(critical, tracer)
    if comp is None:
        out = _unavailable("critical", note)
    else:
        full = critical.solution
        L = float(full.compiled.problem.model_length)
        names, q, kinds = _solve_quantities(full, L)
        _, qc, _ = _solve_quantities(comp, L)
        force = float(getattr(full.compiled.problem, "force_scale", 0.0) or 0.0)
        least = _least(full, force, L)
        names, kinds = ["load factor"] + names, np.concatenate([[3], kinds])
        q, qc = np.concatenate([[critical.load_factor], q]), np.concatenate([[comp.load_factor], qc])
        out = Estimate("critical", tuple(names), q, qc, ratio, _scales(q, kinds, least),
                       (_elements(full.compiled), _elements(comp.compiled)), _STATE["target"])
    _ESTIMATES[critical] = out
    if _active():
        warn(out, critical.solution.compiled, stacklevel=4)
    return out


def _companion_critical(critical, tracer):
    """``(Solution at the companion's critical point or None, ratio, note)`` (`critical_estimate`)."""
    if tracer is None:
        return None, 2.0, "the path this critical point was located on is not known (a critical point made by hand)"
    if getattr(tracer.problem, "_offset", None) is not None:
        return None, 2.0, ("a path traced from a start solution (trace(start=...)): its companion path is not "
                           "estimated; flexmb.discretisation_error estimates any quantity")
    base, ratio, note = _companion(tracer.compiled)
    if base is None:
        return None, ratio, note
    arcs = np.array([p.arc for p in tracer.points])
    before = np.flatnonzero(arcs < critical.arc_length)
    if not len(before):
        return None, ratio, "no point of the path before the critical point"
    metric = attrs.evolve(tracer.metric, model=base.problem.model)  # the path's metric on the companion's DOFs
    note = "the companion mesh had no equilibrium at the load factors of the points before the critical point"
    for k in before[::-1][:CRITICAL_STARTS]:
        start = _companion_start(tracer, base, metric, tracer.points[k])
        if start is None:
            continue
        ds = float(arcs[k + 1] - arcs[k]) if k + 1 < len(arcs) else critical.arc_length - arcs[k]
        p, note = _follow_to_critical(tracer.strategy, base.problem, metric, start, ds, critical)
        if p is not None:
            sol = tracer.solution(p, f"{critical.kind} point on the companion mesh at load factor {p.lam:.10g}")
            return attrs.evolve(sol, compiled=base), ratio, ""
    return None, ratio, note


def _companion_start(tracer, base, metric, point):
    """The path's ``point`` carried onto the companion mesh and converged there at its load factor
    (None: no equilibrium there), running the path's way (its ``dlam/ds`` sign)."""
    from .solvers.arclength import PathPoint

    state = transfer(point.state, tracer.compiled, base)
    n = base.problem.model.n_dofs
    guess = PathPoint(state, point.lam, np.zeros(n), np.zeros(n), 1.0, 1.0, 0, np.zeros(0), 1.0, point.arc, 0)
    with quiet():
        a = tracer.strategy.step(base.problem, metric, guess, 0.0, fix_lam=point.lam)
    if a is None or a.tangent_lam == 0.0:
        return None
    way = 1.0 if point.dlam_ds >= 0.0 else -1.0
    direction = way if a.tangent_lam > 0 else -way
    return attrs.evolve(a, direction=direction, dlam_ds=direction * a.tangent_lam, arc=point.arc)


def _follow_to_critical(strategy, problem, metric, start, ds: float, critical):
    """The first critical point of the companion path from ``start`` (within `CRITICAL_STEPS`), or
    None and why; one of another kind than ``critical``'s is refused."""
    steps = 0
    with quiet():
        for event in strategy.follow(problem, metric, start, ds, "primary"):
            if event[0] == "stuck":
                return None, f"the companion path stopped: {event[1]}"
            if event[0] == "critical":
                if event[1] != critical.kind:
                    return None, (f"the companion path meets a {event[1]} point first, not a {critical.kind} point: "
                                  "the critical point is not resolved by both meshes")
                return event[2], ""
            steps += 1
            if steps >= CRITICAL_STEPS:
                break
    return None, f"the companion path met no critical point within {CRITICAL_STEPS} steps"


# -- the properties ---------------------------------------------------------------------------------

class EstimatedArray(np.ndarray):
    """An array result (`flexmb.buckling`, `flexmb.compliance`) with its ``discretisation``
    `Estimate` (arrays derived from it carry None)."""

    discretisation = None

    def __array_finalize__(self, obj):
        self.discretisation = None

    def __reduce__(self):  # pickled as a plain array
        return np.asarray(self).copy().__reduce__()


def _modes_quantities(result) -> tuple[list, np.ndarray, np.ndarray | None]:
    f = np.asarray(result.frequencies, dtype=float)
    return [f"f{k + 1}" for k in range(len(f))], np.abs(f), None


def _buckling_quantities(result) -> tuple[list, np.ndarray, np.ndarray | None]:
    lam = np.asarray(result, dtype=float)
    return [f"buckling{k + 1}" for k in range(len(lam))], lam, None


def _compliance_quantities(result) -> tuple[list, np.ndarray, np.ndarray | None]:
    C = np.asarray(result, dtype=float)
    n = len(C)
    d = np.sqrt(np.abs(np.diag(C)))
    names = [f"C[{i},{j}]" for i in range(n) for j in range(n)]
    values = C.ravel()
    # each entry against sqrt(C_ii C_jj) (a diagonal against itself): per-entry kinds below
    scale = np.outer(d, d).ravel()
    return names, values, scale


def _stress_quantities(result) -> tuple[list, np.ndarray, np.ndarray | None]:
    s = result.summary()
    names = [k for k in ("normal", "shear", "von_mises") if k in s]
    return names, np.array([s[k] for k in names], dtype=float), None


_QUANTITIES = {"modes": _modes_quantities, "buckling": _buckling_quantities,
               "compliance": _compliance_quantities, "stress": _stress_quantities}


def attach(kind: str, result, solution, again, stacklevel: int = 3):
    """``result`` (of property ``kind`` of ``solution``) with its estimate: ``again(companion)``
    evaluates the property on the companion solution. Arrays come back as `EstimatedArray`,
    objects with a ``discretisation`` field evolved; a warning when the estimate exceeds the target."""
    if not _active() or solution is None or not getattr(solution, "converged", False):
        return result
    if type(solution).full_equilibrium:
        est = _property_estimate(kind, result, solution, again)
        warn(est, solution.compiled, stacklevel + 1)
    else:  # KSD-reduced: the pair costs a KSD-full solve and the companion's; estimated on first use
        est = Deferred(functools.partial(_deferred_property, kind, result, solution, again))
    if isinstance(result, np.ndarray):
        out = np.array(result).view(EstimatedArray)
        out.discretisation = est
        return out
    return attrs.evolve(result, discretisation=est)


class Deferred:
    """An `Estimate` computed on first use (any attribute, an item, repr), then kept: a
    KSD-reduced result's (its pair costs a KSD-full solve and the companion's; `full_solution`).
    Pickled as the estimate it resolves to."""

    def __init__(self, compute):
        self._compute, self._value = compute, None

    def resolve(self) -> Estimate:
        """The estimate (computed now if it was not)."""
        if self._value is None:
            self._value, self._compute = self._compute(), None
        return self._value

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.resolve(), name)

    def __getitem__(self, name: str) -> dict:
        return self.resolve()[name]

    def __repr__(self) -> str:
        return repr(self.resolve())

    def __reduce__(self):
        return _resolved, (self.resolve(),)


def _resolved(est: Estimate) -> Estimate:
    return est


def _deferred_property(kind: str, result, solution, again) -> Estimate:
    est = _property_estimate(kind, result, solution, again)
    warn(est, solution.compiled, stacklevel=5)
    return est


def _property_estimate(kind: str, result, solution, again) -> Estimate:
    """The `Estimate` of ``result`` (`attach`); a KSD-reduced solution's pair is the property on
    the full model's equilibrium on its mesh and on the companion mesh (`full_solution`)."""
    comp, ratio, note = companion_solution(solution)
    if comp is None:
        return _unavailable(kind, note)
    full = full_solution(solution)[0]
    try:
        with quiet():
            other = again(comp)
            fine = result if full is solution else again(full)
    except (FlexmbError, np.linalg.LinAlgError, ArithmeticError, RuntimeError) as exc:
        return _unavailable(kind, f"the property failed on the companion mesh: {exc}")
    names, q, scale = _QUANTITIES[kind](fine)
    _, qc, _ = _QUANTITIES[kind](other)
    if len(qc) != len(q):
        return _unavailable(kind, "the companion mesh gave another number of values")
    scale = _scales(q, least={0: 0.0}) if scale is None else np.where(scale > 0, scale, np.nan)
    return Estimate(kind, tuple(names), q, qc, ratio, scale, (_elements(full.compiled), _elements(comp.compiled)),
                    _STATE["target"], basis="" if full is solution else REDUCED_BASIS)


def relative_worst(result) -> float:
    """The largest estimated relative error a result carries (NaN: none available)."""
    est = getattr(result, "discretisation", None)
    est = est.resolve() if isinstance(est, Deferred) else est
    if not isinstance(est, Estimate) or not est.available:
        return math.nan
    return est.worst[1]


results.ESTIMATES.update(solve=estimate, property=attach)  # the hooks of Solution and the property functions
