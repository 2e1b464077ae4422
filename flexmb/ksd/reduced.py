"""The reduced mechanism of the KSD method (Dwarshuis et al. 2020, Secs. 2.2-2.5): one node per
rigid link, every joint replaced by its database constraints (step 1) or by its condensed EOB
stiffness (steps 3-4).

Step 3 uses the Craig-Bampton stiffness of each joint with node A held in the joint frame
(``F_B = K_T,BB q_B + F_hat_T,B``, Eq. 2.4) and takes the wrench on node A from the statics of
the joint in its current geometry, so the joint wrenches balance exactly, as in the full model.
"""

from __future__ import annotations

import copy

import functools
import os
import stat

import numpy as np

from .. import jit
from .._validate import hashable
from ..database.store import ENVIRONMENT, candidate_names, search_path, shipped
from ..errors import DatabaseError, ModelError, UnsupportedStrategyError
from ..fe.ideal import row_names
from ..fe.model import State
from ..linear import single_threaded
from ..rotations import cross, skew, unskew
from . import constraints
from .eob import EOBTemplate
from .eob_table import SLACK, lookup_for
from .geometry import ACTIVE, JointFrames, LinkPoses, compose, expm, intended_angle

__all__ = ["ReducedMechanism", "template"]

_EYE = np.eye(3)
_BUILT: set = set()  # the attribute names `ReducedMechanism.__init__` sets
#: ``Q.reshape(9) @ _DUNSKEW`` = ``0.5 (trace(Q) I - Q)`` flattened, d unskew(Q) / d omega (dQ = skew(omega) Q)
_DUNSKEW = 0.5 * (np.outer(_EYE.ravel(), _EYE.ravel()) - np.eye(9))


@functools.lru_cache(maxsize=64)
def _cached_template(joint, dim: int, data) -> EOBTemplate:
    return _with_lookup(EOBTemplate(joint, dim, data), joint)


_KERNELS: list = []


def kernels():
    """`flexmb.ksd.reduced_jit`, imported on first use (it imports numba: not with flexmb) and
    kept: a function-level relative import costs a Python call per use (Python 3.11 checks the
    importer's ``__package__`` against ``__spec__.parent``), six per KSD-reduced solve."""
    if not _KERNELS:
        from . import reduced_jit

        _KERNELS.append(reduced_jit)
    return _KERNELS[0]


def _with_lookup(tpl: EOBTemplate, joint) -> EOBTemplate:
    """``tpl`` with its database's tabulated condensation attached when it applies."""
    tpl.lookup = lookup_for(tpl, joint)
    return tpl


@functools.lru_cache(maxsize=256)
def _constraint_set(tpl: EOBTemplate, names: tuple, D0: bytes, b0: bytes) -> constraints.ConstraintSet:
    """The `ConstraintSet` of joints with one template (their ``D0`` and ``b0`` as bytes), built once."""
    return constraints.ConstraintSet(names, tpl.data, np.frombuffer(D0), np.frombuffer(b0).reshape(-1, 3))


def template(joint, dim: int, folder=None) -> EOBTemplate:
    """The joint's `EOBTemplate` with its database (cached per joint value and database content)."""
    if "database" not in joint.capabilities:
        raise UnsupportedStrategyError(
            f"joint kind {joint.kind!r} has no joint database (KSD needs one); it offers {sorted(joint.capabilities)}")
    data = shipped(joint, dim, folder)  # read on every call; one `JointData` per file content
    if not hashable(joint):  # a plugin joint that is not a value: no caching
        return _with_lookup(EOBTemplate(joint, dim, data), joint)
    return _cached_template(joint, dim, data)


#: what `flexmb.database.store.search_path` depends on besides its argument (`user_path`'s inputs)
_SEARCH_INPUTS = (ENVIRONMENT, "XDG_DATA_HOME", "HOME", "USERPROFILE", "LOCALAPPDATA")


@functools.lru_cache(maxsize=64)
def _folders(folder, environment: tuple) -> tuple:
    return tuple(os.fspath(f) for f in search_path(folder))


@functools.lru_cache(maxsize=256)
def _candidates(folder, environment: tuple, names: tuple) -> tuple:
    """The paths `template` tries for the files ``names`` (`candidate_names`), in `search_path`'s order."""
    return tuple(os.path.join(f, name) for f in _folders(folder, environment) for name in names)


_ENVIRON_OWNER = os.environ  # the mapping whose storage `_ENVIRON` is (a replaced os.environ is read through)
_ENVIRON = getattr(os.environ, "_data", None)  # CPython's os.environ storage (bytes keys on POSIX)
_ENVIRON_KEYS = tuple(os.environ.encodekey(k) for k in _SEARCH_INPUTS) if _ENVIRON is not None and hasattr(
    os.environ, "encodekey") else None


_ACCESS = os.access in os.supports_follow_symlinks  # a link's own existence without an exception (POSIX)


def _environment() -> tuple:
    """The values of `_SEARCH_INPUTS` (what `search_path` depends on besides its argument): read
    from os.environ's own dict where CPython keeps one (os.environ.get costs four Python calls a
    key, 5 keys per set-up check), else through os.environ: also where os.environ was replaced
    (``unittest.mock.patch("os.environ", {...})``: its storage read, the new mapping's variables
    were not seen)."""
    if _ENVIRON_KEYS is not None and os.environ is _ENVIRON_OWNER:
        get = _ENVIRON.get
        return tuple([get(k) for k in _ENVIRON_KEYS])
    return tuple(os.environ.get(k) for k in _SEARCH_INPUTS)


def _database_file(joint, dim: int, folder) -> tuple:
    """Where `template` finds ``joint``'s database and in what state: the folders searched, the
    file found (None if none) and its identity and times (device, inode, size, modification and
    status-change times [ns]). A file replaced (a new inode), rewritten (new times) or given its
    old modification time back (`os.utime` sets the status-change time) changes it; equal
    signatures mean `template` reads the same file as when they were taken. One ``access`` per
    candidate (`flexmb.database.store.candidate_names`, two per folder) searched (a folder without the file:
    no exception), an ``lstat`` where the file is, a ``stat`` where it is a link (far cheaper than
    `template`'s reading and parsing the file)."""
    folder = None if folder is None else os.fspath(folder)
    environment = _environment()
    folders = _folders(folder, environment)
    for path in _candidates(folder, environment, _file_names(joint, dim)):
        if _ACCESS and not os.access(path, os.F_OK, follow_symlinks=False):
            continue  # as `locate` (os.path.lexists): nothing there; no exception raised
        try:
            st = os.lstat(path)
        except FileNotFoundError:  # nothing there, not even a broken link: the next folder
            continue
        except OSError:
            return folders, path, None
        if stat.S_ISLNK(st.st_mode):
            try:
                st = os.stat(path)
            except OSError:  # a broken link: `template` stops here (and refuses)
                return folders, path, None
        return folders, path, (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    return folders, None, None


def _file_names(joint, dim: int) -> tuple:
    """`flexmb.database.store.candidate_names` of ``joint`` (kept per joint value: it is immutable)."""
    if hashable(joint):
        return _cached_file_names(joint, dim)
    return candidate_names(joint, dim)


@functools.lru_cache(maxsize=256)
def _cached_file_names(joint, dim: int) -> tuple:
    return candidate_names(joint, dim)


def _embed(v: np.ndarray, dim: int) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if dim == 3:
        return v.copy()
    out = np.zeros(v.shape[:-1] + (3,))
    out[..., :2] = v
    return out


class ReducedMechanism:
    """Links, joint frames, constraint groups and loads of a compiled mechanism, in 3D form."""

    def __init__(self, compiled, folder=None):
        problem = compiled.problem
        model = problem.model
        dim = self.dim = model.dim
        self.compiled, self.folder = compiled, folder
        self._links(problem)
        names, a, b, rot, b0, origin, groups = self._joints(compiled, folder)
        self._joint_frames(names, a, b, rot, b0, origin, groups)
        r0 = self._constraint_layout()
        # hinges (flexmb.fe.ideal.Hinges of the full model, between link nodes): their kept
        # constraint rows join step 1's equations (positions over the length, rotations in rad) and
        # step 3's equilibrium with their multipliers, as in the full model
        self.hinges = model.hinges
        self.n_equations = r0 if self.hinges is None else self._hinge_layout(r0)
        if self.hinges is None:
            self.lam_rate = np.zeros(r0)
        self._load_layout(problem.loads, dim)
        _BUILT.update(vars(self))  # the attributes a set-up has when built (`rebind` keeps only these)

    def _links(self, problem) -> None:
        """The links (3D form): reference positions, prescribed and free coordinates, FE DOFs."""
        model, dim, compiled = problem.model, self.dim, self.compiled
        self.n_links = nL = len(compiled.link_node)
        self.X0 = _embed(model.x0[:nL], dim)
        nd = model.ndof
        act = ACTIVE[dim]
        self.active = act
        # prescribed link DOFs (all prescribed DOFs belong to links)
        pres = problem.prescribed
        link_of, comp = np.divmod(pres, nd)
        self.prescribed = link_of * 6 + act[comp]
        self._set_values(problem.values)
        is_free = np.zeros(6 * nL, dtype=bool)
        is_free[(np.arange(nL)[:, None] * 6 + act).ravel()] = True
        is_free[self.prescribed] = False
        self.free = np.flatnonzero(is_free)
        # FE DOF index of every embedded link DOF (for reactions)
        self.fe_dofs = (np.arange(nL)[:, None] * nd + np.arange(nd)).ravel()
        self.emb_dofs = (np.arange(nL)[:, None] * 6 + act).ravel()

    def _joints(self, compiled, folder):
        """The flexure joints (hinges are the full model's, `_hinge_layout`): their names, links,
        placements and interface B, grouped by template (one EOB template per distinct joint
        value, its database file's signature kept for `current`)."""
        dim, model = self.dim, compiled.problem.model
        names, a, b, rot, b0, origin, groups, seen, used = [], [], [], [], [], [], {}, {}, []
        for key, jt, pl, side_a, side_b in compiled.joints:
            if "ideal" in jt.capabilities:  # a hinge: its exact constraints, from the full model (below)
                if model.hinges is None or key not in model.hinges.names:
                    raise UnsupportedStrategyError(
                        f"joint {key!r} ({jt.kind}) is an ideal joint the full model does not hold as a hinge "
                        "(flexmb.fe.ideal); KSD includes hinges only: use method='conventional'")
                continue
            try:
                if hashable(jt) and jt in seen:
                    tpl = seen[jt]
                else:  # the file's signature before the template: a file changed in between is seen later
                    signature = _database_file(jt, dim, folder) if "database" in jt.capabilities else None
                    tpl = template(jt, dim, folder)
                    used.append((jt, tpl, signature))
            except DatabaseError as exc:
                raise DatabaseError(f"joint {key!r}: {exc}") from None
            if hashable(jt):
                seen[jt] = tpl
            cons = constraints.check_names(f"joint {key!r} ({jt.kind})", jt.kinematic_constraints(dim), dim)
            groups.setdefault(id(tpl), (tpl, cons, []))[2].append(len(names))
            names.append(key)
            a.append(compiled.link_node[side_a])
            b.append(compiled.link_node[side_b])
            rot.append(pl.rotation)
            b0.append(jt.interface_b(dim))
            origin.append(pl.origin)
        if not names:
            if model.hinges is not None:
                raise UnsupportedStrategyError(
                    "KSD: the mechanism has hinges only, no flexure joint with a database: nothing for the EOBs "
                    "(steps 2-4); use method='conventional'")
            raise ModelError("the mechanism has no joints")
        self._templates = used  # (joint, template, database file signature) per distinct joint value
        return names, a, b, rot, b0, origin, groups

    def _joint_frames(self, names, a, b, rot, b0, origin, groups) -> None:
        """The joints' frames on their links, sizes and groups (joints sharing a template)."""
        dim, compiled = self.dim, self.compiled
        self.joint_names = names
        self.b0 = _embed(np.array(b0), dim)
        self.frames = self._frames(np.array(a), np.array(b), rot, origin)
        self.D0 = np.sqrt((self.b0 * self.b0).sum(axis=1))
        self.groups = [(tpl, cons, np.array(idx)) for tpl, cons, idx in groups.values()]
        # how to take a group's joints from per-joint arrays (all of them: a view, not a copy)
        self._take = [slice(None)] if len(self.groups) == 1 else [idx for _, _, idx in self.groups]
        self.joint_nodes = [compiled.joint_nodes[k] for k in names]
        #: each group's internal FE nodes (Jg, n), by the id of its joint index array (step 4)
        self._group_nodes = {id(idx): np.array([self.joint_nodes[j] for j in idx]) for _, _, idx in self.groups}
        # characteristic length for scaling translations against rotations
        self.length = float(self.D0.sum()) / len(self.D0)

    def _constraint_layout(self) -> int:
        """Step 1's equation rows (joint, constraint) per group and where each group's (Jg, m_c, 12)
        gradients go in the Jacobian (m, 6 n_links) (a joint's 12 columns are distinct: links
        a != b); returns the number of rows."""
        names, nL = self.joint_names, self.n_links
        self.rows = [(names[j], c) for tpl, cons, idx in self.groups for j in idx for c in cons]
        cols = np.concatenate([self.frames.a[:, None] * 6 + np.arange(6), self.frames.b[:, None] * 6 + np.arange(6)],
                              axis=1)
        self._cols = cols  # (J, 12)
        self._sets, self._jac_at, r0 = [], [], 0
        for tpl, cons, idx in self.groups:
            self._sets.append(_constraint_set(tpl, cons, self.D0[idx].tobytes(), self.b0[idx].tobytes()))
            row = r0 + np.arange(len(idx) * len(cons)).reshape(len(idx), len(cons), 1)
            self._jac_at.append((row * 6 * nL + cols[idx][:, None, :]).ravel())
            r0 += len(idx) * len(cons)
        return r0

    def _hinge_layout(self, r0: int) -> int:
        """The hinges' kept rows after the joints' ``r0`` (step 1), their motors' rate in the load
        factor, and their blocks in step 3 (links' DOFs, then the multipliers after the 6 n_links
        link DOFs); returns the number of equations."""
        hinges, dim, nL, act = self.hinges, self.dim, self.n_links, self.active
        H, R = hinges.active.shape
        self._hinge_links = (np.arange(nL)[:, None] * 6 + act)[hinges.node].reshape(H, -1)  # (H, 2 nd)
        self._hinge_row_scale = np.where(np.arange(R) < dim, 1.0 / self.length, 1.0)
        h, k = np.nonzero(hinges.active)
        self._hinge_rows = (h, k)
        row = r0 + np.arange(len(h))
        self._hinge_jac_at = (row[:, None] * 6 * nL + self._hinge_links[h]).ravel()
        # d(constraint)/d(load factor): the motor rows (their angle ramps with it, 2D and 3D alike)
        self.lam_rate = np.zeros(r0 + len(h))
        motor = k == R - 1
        self.lam_rate[r0 + np.flatnonzero(motor)] = -hinges.angle[h[motor]]
        self.rows += [(hinges.names[i], row_names(dim)[j]) for i, j in zip(h, k)]
        self.hinge_dofs = hinges.dofs((np.arange(nL)[:, None] * 6 + act), 6 * nL)
        return r0 + len(h)

    def _load_layout(self, loads, dim: int) -> None:
        """The dead loads in 3D form and, for step 3, where the joints' wrenches on links b and a
        and the loads go in the residual, and each joint's 12 x 12 block and each offset load's
        3 x 3 block in the flattened tangent."""
        nL, cols = self.n_links, self._cols
        self.load_node = loads.node
        self._set_loads(loads)
        ld = self.load_node[:, None] * 6
        self._r_at = np.concatenate([np.concatenate([cols[:, 6:], cols[:, :6]], axis=1).ravel(),  # per joint: b, a
                                     (ld + np.arange(6)).ravel()])
        lr = ld + np.arange(3, 6)
        self._K_at = np.concatenate([(cols[:, :, None] * 6 * nL + cols[:, None, :]).ravel(),
                                     (lr[:, :, None] * 6 * nL + lr[:, None, :]).ravel()])

    def _frames(self, a: np.ndarray, b: np.ndarray, rot: list, origin: list) -> JointFrames:
        """The joints' `JointFrames` from their links ``a``, ``b`` (J,), placements' rotations and
        origins (global, undeformed), with `X0` and `b0` set."""
        dim = self.dim
        P = np.repeat(_EYE[None], len(a), axis=0)
        P[:, :dim, :dim] = rot
        origin = _embed(np.array(origin), dim)
        return JointFrames(a, b, origin - self.X0[a], origin + (P @ self.b0[..., None])[..., 0] - self.X0[b], P)

    def _set_loads(self, loads) -> None:
        """The dead loads' offsets, forces and moments in 3D form (`load_node` fixed)."""
        dim = self.dim
        self.load_offset = _embed(loads.offset, dim)
        self.load_force = _embed(loads.force, dim)
        self.load_moment = loads.moment if dim == 3 else np.concatenate(
            [np.zeros((len(loads.node), 2)), loads.moment], axis=1)

    def _set_values(self, values: np.ndarray) -> None:
        """The prescribed values (on `prescribed`) and the moves of step 1 they give."""
        self.values = values
        link, comp = np.divmod(self.prescribed, 6)
        tr = comp < 3
        W = np.zeros((self.n_links, 3))  # prescribed rotation vector of each link (all three or none, 3D)
        W[link[~tr], comp[~tr] - 3] = values[~tr]
        lr = np.unique(link[~tr])
        self._moves = ((link[tr], comp[tr], values[tr]), (lr, W[lr]))

    def with_values(self, compiled) -> ReducedMechanism | None:
        """This set-up for ``compiled``, the same compiled mechanism with other prescribed values
        (`flexmb.problem.StaticProblem.with_motion`: the same model, loads and prescribed DOFs),
        or None when it is not that. Joint frames, templates, constraint sets and step 1's
        start at rest are shared; what the values give (step 1's moves, its turn rate, the
        reachability verdict) is redone. A motion sweep of the manipulator builds its set-up
        once instead of per value."""
        new, old = compiled.problem, self.compiled.problem
        if (new.model is not old.model or new.loads is not old.loads or compiled.link_node != self.compiled.link_node
                or not np.array_equal(new.prescribed, old.prescribed)):
            return None
        out = copy.copy(self)
        out.compiled = compiled
        out._set_values(np.asarray(new.values, dtype=float))
        for derived in ("_reachable", "_kinematics_args", "_tabulated"):  # what the values enter
            vars(out).pop(derived, None)
        start = vars(self).get("_kinematic_start")
        if start is not None:  # at rest (lam = 0) the same; the turn rate follows the values
            out._kinematic_start = start[:-1] + (None,)
        return out

    def rebind(self, compiled) -> ReducedMechanism | None:
        """This set-up for ``compiled``, another mechanism of the same structure (a design loop's new
        mechanism): the same links, joints (equal values, on the same sides), prescribed
        DOFs and loaded links, no hinges, with other link positions, joint placements, prescribed
        values and loads. Templates, constraint sets, groups and index maps are shared; the numbers
        (links' reference positions, joint frames, loads, moves) are recomputed and what steps 1-4
        derived from them is dropped, so the result is the set-up `ReducedMechanism(compiled)`
        builds. None when ``compiled`` is not such a mechanism."""
        new, old = compiled.problem, self.compiled.problem
        if (self.hinges is not None or getattr(new.model, "hinges", None) is not None
                or compiled.link_node != self.compiled.link_node or len(compiled.joints) != len(self.joint_names)
                or any(k != name or (jt is not j0 and not (hashable(jt) and jt == j0)) or (sa, sb) != (a0, b0)
                       for (k, jt, _, sa, sb), (name, j0, _, a0, b0) in zip(compiled.joints, self.compiled.joints))
                or new.model.dim != self.dim or not np.array_equal(new.prescribed, old.prescribed)
                or not np.array_equal(new.loads.node, old.loads.node)):
            return None
        out = copy.copy(self)
        for derived in set(vars(out)) - _BUILT:  # what steps 1-4 derived from the numbers on first use
            del vars(out)[derived]
        out.compiled = compiled
        out.X0 = _embed(new.model.x0[:self.n_links], self.dim)
        out.frames = out._frames(self.frames.a, self.frames.b, [pl.rotation for _, _, pl, _, _ in compiled.joints],
                                 [pl.origin for _, _, pl, _, _ in compiled.joints])
        out._set_values(np.asarray(new.values, dtype=float))
        out._set_loads(new.loads)
        out._keep_derived(self)
        return out

    def _keep_derived(self, old: ReducedMechanism) -> None:
        """What `rebind` keeps of ``old``'s derived values, each the value this set-up would derive:
        the data files' provenance (the same joints, templates and folder), step 1's compiled arrays
        with this set-up's frames, and step 1's start at rest (turn rate redone) when the links'
        reference positions and the joint frames are the same numbers (another configuration of
        one design)."""
        kept = vars(old)
        if "_provenance" in kept:
            self._provenance = kept["_provenance"]
        arrays = kept.get("_kinematics_jit")
        if arrays is not None:
            order, fr, c = arrays["order"], self.frames, np.ascontiguousarray
            self._kinematics_jit = dict(arrays, s_a=c(fr.s_a[order]), s_b=c(fr.s_b[order]), P=c(fr.P[order]))
        start = kept.get("_kinematic_start")
        if start is not None and np.array_equal(self.X0, old.X0) and all(
                np.array_equal(getattr(self.frames, k), getattr(old.frames, k)) for k in ("s_a", "s_b", "P")):
            self._kinematic_start = start[:-1] + (None,)

    def current(self) -> bool:
        """Whether the joint databases this set-up was built from are still the ones `template`
        would read (same folders searched, same file, same bytes); False when one changed or is gone."""
        for jt, _, signature in self._templates:
            if signature is None or signature[2] is None or _database_file(jt, self.dim, self.folder) != signature:
                return False
        return True

    # -- poses ------------------------------------------------------------------------------
    def rest(self) -> LinkPoses:
        """The links' undeformed poses (reference positions [m], identity rotations)."""
        return LinkPoses(self.X0.copy(), np.repeat(_EYE[None], self.n_links, axis=0), np.zeros(self.n_links))

    def with_prescribed(self, poses: LinkPoses, lam: float = 1.0) -> LinkPoses:
        """``poses`` with the prescribed components set to ``lam`` times their values (exactly)."""
        x, R, angle = poses.x.copy(), poses.R.copy(), poses.angle.copy()
        (lt, ct, vt), (lr, W) = self._moves
        x[lt, ct] = self.X0[lt, ct] + lam * vt
        if len(lr):
            R[lr] = expm(lam * W)
            angle[lr] = lam * W[:, 2]
        return LinkPoses(x, R, angle)

    # -- step 1: kinematics -------------------------------------------------------------------
    def _fe_pose(self, poses: LinkPoses):
        """The links' positions (n, dim) and rotations as the full model holds them (2D angles, 3D matrices)."""
        return poses.x[:, :self.dim], (poses.angle if self.dim == 2 else poses.R)

    def hinge_angles(self, poses: LinkPoses, near=None):
        """The 3D hinges' relative angles [rad] (H,) at ``poses``, each the branch nearest to ``near``
        (the angles a step started from: turns counted as the full model counts them,
        `flexmb.fe.ideal.Hinges.advance`); None in 2D (link angles count turns) or without hinges."""
        if self.hinges is None or self.dim == 2:
            return None
        return self.hinges.relative_angle(poses.R, near)

    def constraint_equations(self, poses: LinkPoses, jacobian: bool | str = True, values: bool = True,
                             lam: float = 1.0, hinge_angles=None):
        """Values (m,) and Jacobian (m, 6 n_links) of all joints' kinematic constraints; the
        intended rotations ``theta`` (J,) and relative positions ``p`` (J, 3).
        ``jacobian="deferred"`` returns a function that computes the Jacobian when called (a
        converged iterate never needs it); False returns None. ``values=False`` returns None
        for the values. The hinges' kept rows come last (`flexmb.fe.ideal`; positions over
        `length`), their motors at the fraction ``lam`` of their angles, a 3D hinge's angle taken
        nearest to ``hinge_angles`` (`hinge_angles`; None: within one turn)."""
        fr = self.frames
        p, R, geo = fr.relative(poses)
        theta, dth = intended_angle(R)
        parts = [cs.evaluate(p[idx], R[idx], theta[idx], dth[idx], deferred=True)
                 for idx, cs in zip(self._take, self._sets)]
        vals = None if not values else (parts[0][0].ravel() if len(parts) == 1 else
                                        np.concatenate([v.ravel() for v, _ in parts]))
        if self.hinges is not None:
            h, k = self._hinge_rows
            ch, gh, _ = self.hinges.residual_rows(*self._fe_pose(poses), lam, angles=hinge_angles)
            if values:
                vals = np.concatenate([vals, (ch * self._hinge_row_scale)[h, k]])

        def jac():
            Jrel = fr.relative_jacobian(geo)
            out = np.zeros((self.n_equations, 6 * self.n_links))
            flat = out.reshape(-1)
            for idx, (_, gradients), at in zip(self._take, parts, self._jac_at):
                flat[at] = (gradients() @ Jrel[idx]).ravel()  # (Jg, m_c, 12)
            if self.hinges is not None:
                flat[self._hinge_jac_at] = (gh * self._hinge_row_scale[:, None])[h, k].ravel()
            return out

        if not jacobian:
            return vals, None, theta, p
        return vals, (jac if jacobian == "deferred" else jac()), theta, p

    def tabulated_plan(self):
        """KSD-reduced's numba path with every joint's condensation tabulated, prepared once per
        set-up (kept on the set-up; `with_values` drops it): per group of joints its indices,
        `flexmb.ksd.eob_table.Lookup.kernel_args` split around the per-solve arguments, its internal
        nodes' count and FE nodes; per joint the rotations [rad] within which a solve takes this
        path, (J,) arrays: in the trained range (up to step 1's 1e-9 rad, as the strategy's range
        check) and on the table's grid (up to `flexmb.ksd.eob_table.SLACK`, `Lookup.covers`); steps 3-4's set-up
        arguments. None where a joint has no table (its EOB is evaluated per solve: the general path)."""
        plan = vars(self).get("_tabulated")
        if plan is not None:
            return plan or None
        J = len(self.joint_names)
        lo, hi, groups = np.zeros(J), np.zeros(J), []
        for tpl, _, idx in self.groups:
            lookup = tpl.lookup
            if lookup is None:
                self._tabulated = False
                return None
            t, coef, k, root, powers, ocoef, emb = lookup.kernel_args()
            groups.append((idx, (t, coef, k), (root, powers, ocoef, emb), tpl.n_nodes - 2, tpl.dim))
            (tl, th), (kl, kh) = tpl.data.range, lookup.range
            lo[idx], hi[idx] = max(tl - 1e-9, kl - SLACK), min(th + 1e-9, kh + SLACK)
        fr, model, dim = self.frames, self.compiled.problem.model, self.dim
        frames = (fr.a, fr.b, fr.s_a, fr.s_b, fr.P)
        loads = (self._cols, self.load_node, self.load_offset, self.load_force, self.load_moment, self.free)
        N = model.n_nodes
        reference = (model.x0, np.repeat(np.eye(3)[None], N if dim == 3 else 0, axis=0), np.zeros(N if dim == 2 else 0))
        nodes = tuple(np.ascontiguousarray(self._group_nodes[id(idx)], dtype=np.int64) for idx, *_ in groups)
        plan = self._tabulated = (groups, lo, hi, frames, loads, nodes, reference,
                                 (self.fe_dofs, self.emb_dofs, int(model.n_dofs)))
        return plan

    # -- step 2: the joints' EOBs, condensed ---------------------------------------------------
    def condensed_joints(self, theta: np.ndarray, p_hat: np.ndarray, *, lookup: bool, compiled: bool):
        """KSD step 2: every joint's EOB at its intended rotation ``theta`` (J,) [rad] and node B's
        near position ``p_hat`` (J, 3), condensed on node B with node A held (Craig-Bampton,
        Eq. 2.5). Returns ``K`` (J, 6, 6) and ``F_hat`` (J, 6) in the joint frames (inactive planar
        rows zero), per group of joints its EOB (an `flexmb.ksd.eob.EOB`, or with ``compiled`` the
        arrays ``[recover, internal positions, internal rotations or angles]`` the numba step 4
        reads) and how many joints were looked up. ``lookup``: a group whose rotations its
        tabulated condensation covers reads it (`flexmb.ksd.eob_table`) instead of evaluating its
        EOB (not for KSD-full, whose step 5 needs the EOBs' element fields)."""
        dim, emb = self.dim, ACTIVE[self.dim]
        J = len(self.joint_names)
        K, Fh = np.zeros((J, 6, 6)), np.zeros((J, 6))
        eobs, tabulated = [], 0
        for tpl, _, idx in self.groups:
            if lookup and tpl.lookup is not None and tpl.lookup.covers(theta[idx]):
                tabulated += len(idx)
                if compiled:  # tabulated, one numba call (flexmb.ksd.reduced_jit.eob_lookup)
                    eobs.append(list(tpl.lookup.compiled(theta, p_hat, idx, K, Fh)[2:]))
                    continue
                e = tpl.lookup(theta[idx], p_hat[idx, :dim])  # tabulated (flexmb.ksd.eob_table)
            elif compiled:  # outside the compiled solve's thread limit: the Craig-Bampton solves' BLAS
                with single_threaded():
                    e = tpl.evaluate(theta[idx], p_hat[idx, :dim], held_a=True)
            else:
                e = tpl.evaluate(theta[idx], p_hat[idx, :dim], held_a=True)
            K[idx[:, None, None], emb[:, None], emb] = e.K_T
            Fh[idx[:, None], emb] = e.F_hat_T
            eobs.append([np.ascontiguousarray(a) for a in (e.recover, e.node_position[:, 2:], e.node_rotation[:, 2:]
                         if dim == 3 else e.node_angle[:, 2:])] if compiled else e)
        return K, Fh, eobs, tabulated

    # -- step 3: equilibrium with the condensed joints ----------------------------------------
    def step3_unknowns(self) -> np.ndarray:
        """Step 3's unknowns among the links' 6 n_links coordinates and the hinges' multipliers
        (after them): the free link coordinates, then every multiplier."""
        if self.hinges is None:
            return self.free
        return np.concatenate([self.free, 6 * self.n_links + np.arange(self.hinges.n_rows)])

    def step3_residual(self, poses: LinkPoses, multipliers, hinge_angles, K, F_hat, p_hat, R_hat):
        """Step 3's residual on the links' coordinates (and, with hinges, the saddle point of the
        full model's hinges, `flexmb.fe.ideal`: their multipliers' forces on the links, their
        scaled constraints on the multiplier rows) and its tangent as a function (`equilibrium`'s
        deferred one)."""
        if self.hinges is None:
            return self.equilibrium(poses, K, F_hat, p_hat, R_hat, tangent="deferred")
        n = 6 * self.n_links
        r, Kr = self.equilibrium(poses, K, F_hat, p_hat, R_hat, tangent="deferred")
        rh, Kh = self.hinge_response(poses, multipliers, angles=hinge_angles)
        rh[:n] += r

        def tangent():
            out = Kh()
            out[:n, :n] += Kr()
            return out

        return rh, tangent

    def step3_moved(self, poses: LinkPoses, multipliers, hinge_angles, x: np.ndarray):
        """The unknowns moved by a Newton correction ``x`` on `step3_unknowns`: the links' poses
        (exponential map), the multipliers (added), the 3D hinges' angles (turns counted)."""
        dz = np.zeros(6 * self.n_links)
        if self.hinges is None:
            dz[self.free] = x
            return poses.moved(dz), multipliers, hinge_angles
        nf = len(self.free)
        dz[self.free] = x[:nf]
        poses = poses.moved(dz)
        return poses, multipliers + x[nf:], self.hinge_angles(poses, hinge_angles)


    def equilibrium(self, poses: LinkPoses, K: np.ndarray, F_hat: np.ndarray, p_hat: np.ndarray,
                    R_hat: np.ndarray, tangent: bool | str = True):
        """Residual (6 n_links,) = joint wrenches on the links minus applied loads, and its
        Jacobian (6 n_links, 6 n_links). ``K`` (J, 6, 6), ``F_hat`` (J, 6): each joint's
        condensed stiffness on node B (node A held) about its near pose ``p_hat`` (J, 3),
        ``R_hat`` (J, 3, 3), in the joint frame. ``tangent="deferred"`` returns a function that
        computes the Jacobian when called (a converged Newton iterate never needs it).
        With the numba kernels one pass of `flexmb.ksd.reduced_jit.equilibrium` (the same terms;
        the tangent always)."""
        if jit.enabled():
            return self._equilibrium_compiled(poses, K, F_hat, p_hat, R_hat, tangent)
        fr = self.frames
        p, Rrel, geo = fr.relative(poses)
        Q = Rrel @ np.swapaxes(R_hat, 1, 2)
        xi = np.concatenate([p - p_hat, unskew(Q)], axis=1)
        w = (K @ xi[..., None])[..., 0] + F_hat
        fm = (geo["F"][:, None] @ w.reshape(-1, 2, 3, 1))[..., 0]  # (J, 2, 3): force and moment on B in global axes
        S = skew(np.concatenate([fm, geo["rb"][:, None], geo["ra"][:, None]], axis=1))  # of f, mB, rb, ra
        f = fm[:, 0]
        m = fm[:, 1:] + (S[:, 2:] @ fm[:, :1, :, None])[..., 0]  # (J, 2, 3): moments about b and a
        on_links = np.concatenate([f, m[:, 0], -f, -m[:, 1]], axis=1)  # on b, on a
        offset, d, loads = self._loads(poses)
        r = np.bincount(self._r_at, np.concatenate([on_links.ravel(), -loads.ravel()]), minlength=6 * self.n_links)

        def jacobian():
            Jrel = fr.relative_jacobian(geo)
            Jrel[:, 3:] = (Q.reshape(-1, 1, 9) @ _DUNSKEW).reshape(-1, 3, 3) @ Jrel[:, 3:]
            dw = K @ Jrel  # (J, 6, 12)
            D = geo["F"][:, None] @ dw.reshape(-1, 2, 3, 12)  # d(f, mB)
            D[..., 3:6] -= S[:, :2]  # F turns with link a
            # d(mB + r x f) = dmB + skew(r) df - skew(f) dr about b and a, with
            # d(rb) = (0, 0, 0, -skew(rb)) and d(ra) = (-I, 0, I, -skew(rb))
            dm = D[:, 1:] + S[:, 2:] @ D[:, :1]
            dm[..., 9:12] += (S[:, 0] @ S[:, 2])[:, None]
            dm[:, 1, :, 0:3] += S[:, 0]
            dm[:, 1, :, 6:9] -= S[:, 0]
            blocks = np.concatenate([-D[:, 0], -dm[:, 1], D[:, 0], dm[:, 0]], axis=1)  # (J, 12, 12): on a, on b
            entries = blocks.ravel()
            if offset:
                G = skew(self.load_force) @ skew(d)  # d(d x f)/dphi of loads at offset points
                entries = np.concatenate([entries, -G.ravel()])
            n = 6 * self.n_links
            return np.bincount(self._K_at[:entries.size], entries, minlength=n * n).reshape(n, n)

        if not tangent:
            return r, None
        return r, (jacobian if tangent == "deferred" else jacobian())

    def _loads(self, poses: LinkPoses):
        """Whether loads sit at offsets, the offsets turned with their links (L, 3) (None
        without) and the loads (L, 6) on the links' reference points."""
        if not self.load_offset.any():
            return False, None, np.concatenate([self.load_force, self.load_moment], axis=1)
        d = (poses.R[self.load_node] @ self.load_offset[..., None])[..., 0]
        return True, d, np.concatenate([self.load_force, self.load_moment + cross(d, self.load_force)], axis=1)

    def _equilibrium_compiled(self, poses: LinkPoses, K, F_hat, p_hat, R_hat, tangent):
        """`equilibrium` through `flexmb.ksd.reduced_jit.equilibrium` (numpy's calls
        on (J, 3, 3) stacks otherwise)."""
        n = 6 * self.n_links
        fr = self.frames
        offset, d, loads = self._loads(poses)
        r = np.zeros(n)
        T = np.zeros((n, n) if tangent else (1, 1))
        p, Rrel, geo = fr.relative(poses)
        f = np.ascontiguousarray
        kernels().equilibrium(f(p, dtype=float), f(Rrel, dtype=float), f(geo["F"], dtype=float), f(geo["Ft"], dtype=float),
                              f(geo["rb"], dtype=float), f(geo["ra"], dtype=float), f(K, dtype=float),
                              f(F_hat, dtype=float), f(p_hat, dtype=float), f(R_hat, dtype=float), self._cols,
                              self._r_at[12 * len(fr.a):], f(loads.ravel(), dtype=float), bool(tangent), r, T)
        if not tangent:
            return r, None
        if offset:  # d(d x f)/dphi of loads at offset points
            np.add.at(T.reshape(-1), self._K_at[144 * len(fr.a):], -(skew(self.load_force) @ skew(d)).ravel())
        return r, ((lambda: T) if tangent == "deferred" else T)

    def hinge_response(self, poses: LinkPoses, multipliers: np.ndarray, tangent: bool = True, angles=None):
        """The hinges' forces (6 n_links + n_rows,): their multipliers' forces and springs' moments
        on the links' rows, their scaled constraint values on the multiplier rows (last), and the
        tangent (a function, as `equilibrium`'s deferred one), at the full motors' angles; ``angles``
        as `constraint_equations`' ``hinge_angles``."""
        F, K = self.hinges.response(*self._fe_pose(poses), multipliers, 1.0, tangent=tangent, angles=angles)
        n = 6 * self.n_links + self.hinges.n_rows
        at = self.hinge_dofs
        r = np.bincount(at.ravel(), F.ravel(), minlength=n)

        def jacobian():
            flat = (at[:, :, None] * n + at[:, None, :]).ravel()
            return np.bincount(flat, K.ravel(), minlength=n * n).reshape(n, n)

        return r, jacobian

    # -- step 4: back to the full model -----------------------------------------------------
    def internal_nodes(self, poses: LinkPoses, eobs, p_hat, R_hat, multipliers=None, hinge_angles=None,
                       displacements: bool = False):
        """KSD step 4: every joint's internal nodes from its interface displacement (Eq. 2.6) about
        its EOB's near configuration. Returns the full model's `State` and, with
        ``displacements``, per group of joints the node displacements (Jg, N nd) from the EOBs'
        near poses (`eob_axial_stress` reads them; else an empty list). ``eobs`` as
        `condensed_joints` returns them (its compiled arrays: `fe_state_compiled`)."""
        if eobs and isinstance(eobs[0], list):  # the numba path's arrays
            return self.fe_state_compiled(poses, [(idx, *e) for (_, _, idx), e in zip(self.groups, eobs)], p_hat,
                                          R_hat), []
        dim = self.dim
        emb = ACTIVE[dim]
        nd = len(emb)
        p, Rrel, _ = self.frames.relative(poses)
        xi_B = np.concatenate([p - p_hat, unskew(Rrel @ np.swapaxes(R_hat, 1, 2))], axis=1)[:, emb]
        internal, q_nodes = [], []
        for (tpl, _, idx), e in zip(self.groups, eobs):
            n_int = tpl.n_nodes - 2
            xi = -((e.recover[:, :, :nd] @ xi_B[idx][..., None])[..., 0] + e.recover[:, :, nd])
            if displacements:
                q_nodes.append(np.concatenate([np.zeros((len(idx), nd)), xi_B[idx], xi], axis=1))
            xi = xi.reshape(len(idx), n_int, nd)
            x = e.node_position[:, 2:] + xi[..., :dim]
            if dim == 2:
                rot = e.node_angle[:, 2:] + xi[..., 2]
            else:
                rot = compose(xi[..., 3:], e.node_rotation[:, 2:])
            internal.append((idx, x, rot))
        return self.fe_state(poses, internal, multipliers, hinge_angles), q_nodes

    def eob_axial_stress(self, eobs, q_nodes):
        """A function replacing the joint elements' axial forces in the full model's generalised
        stresses by the EOBs' (`EOBTemplate.axial_force` of the node displacements ``q_nodes``,
        `internal_nodes`): KSD-full's first geometric stiffness in step 5 (step 4's positions are
        exact to first order only; their axial forces up to 15x the converged ones)."""
        names, elements = self.joint_names, self.compiled.joint_elements
        at, values = [], []
        for (tpl, _, idx), e, q in zip(self.groups, eobs, q_nodes):
            at.append(np.concatenate([elements[names[j]] for j in idx]))
            values.append(tpl.axial_force(e, q).ravel())
        at, values = np.concatenate(at), np.concatenate(values)

        def geometric_stress(sigma):
            out = sigma.copy()
            out[at, 0] = values
            return out

        return geometric_stress


    def fe_state(self, poses: LinkPoses, internal, multipliers: np.ndarray | None = None, hinge_angles=None):
        """The full model's `State`: link nodes from ``poses``; ``internal`` is a list of
        ``(idx, x, rot)`` per group of joints sharing a mesh: joint indices (Jg,), internal node
        positions (Jg, n, dim) and rotations in each joint's frame (angles [rad] (Jg, n) in 2D,
        matrices (Jg, n, 3, 3) in 3D). ``multipliers``, ``hinge_angles``: the hinges' (step 3; None
        without hinges, angles None in 2D)."""
        model = self.compiled.problem.model
        dim = self.dim
        pos = model.x0.copy()
        nL = self.n_links
        pos[:nL] = poses.x[:, :dim]
        if dim == 2:
            rot = np.zeros(model.n_nodes)
            rot[:nL] = poses.angle  # accumulated, not wrapped: the FE state's angles may exceed pi
        else:
            rot = np.repeat(_EYE[None], model.n_nodes, axis=0)
            rot[:nL] = poses.R
        oA, F = self.frames.frame_a(poses)
        for idx, xl, Rl in internal:
            if xl.shape[1] == 0:
                continue
            nodes = self._group_nodes[id(idx)] if id(idx) in self._group_nodes else np.array(
                [self.joint_nodes[j] for j in idx])  # (Jg, n)
            pos[nodes] = (oA[idx, None] + _embed(xl, dim) @ np.swapaxes(F[idx], 1, 2))[..., :dim]  # matmul, not einsum
            if dim == 2:  # global rotation from rest = side-A link's angle + angle in the joint frame
                rot[nodes] = poses.angle[self.frames.a[idx]][:, None] + Rl
            else:
                rot[nodes] = F[idx, None] @ Rl @ np.swapaxes(self.frames.P[idx], 1, 2)[:, None]
        if self.hinges is None:
            return State(pos, rot)
        return State(pos, rot, np.array(multipliers, dtype=float),
                     None if hinge_angles is None else np.array(hinge_angles, dtype=float))

    def fe_state_compiled(self, poses: LinkPoses, internal, p_hat: np.ndarray, R_hat: np.ndarray) -> State:
        """Step 4 and `fe_state` (no hinges) through `flexmb.ksd.reduced_jit.internal`, one call per
        group: ``internal`` holds per group ``(idx, recover, x_int, rot_int)`` (step 2's recovery
        (Jg, n_i nd, nd + 1) and the internal nodes' near poses: positions (Jg, n_i, dim),
        rotations (Jg, n_i, 3, 3) in 3D or angles (Jg, n_i) in 2D), ``p_hat``, ``R_hat`` (J, 3),
        (J, 3, 3) node B's near pose."""
        kernel = kernels().internal
        try:
            x0, rot0, frames, none = self._state_arrays
        except AttributeError:  # what does not change from solve to solve, kept with the set-up
            model, fr = self.compiled.problem.model, self.frames
            rot0 = np.zeros(model.n_nodes) if self.dim == 2 else np.repeat(_EYE[None], model.n_nodes, axis=0)
            none = (np.empty((0, 0, 3, 3)), np.empty((0, 0)))  # the other dimension's orientations
            frames = (fr.a, fr.b, fr.s_a, fr.s_b, fr.P)
            x0, rot0, frames, none = self._state_arrays = (model.x0, rot0, frames, none)
        dim, nL = self.dim, self.n_links
        pos, rot = x0.copy(), rot0.copy()
        pos[:nL] = poses.x[:, :dim]
        rot[:nL] = poses.angle if dim == 2 else poses.R
        ang, rot = (rot, none[0]) if dim == 2 else (np.empty(0), rot)
        for idx, recover, x_int, rot_int in internal:
            if x_int.shape[1] == 0:
                continue
            kernel(poses.x, poses.R, poses.angle, *frames, p_hat, R_hat, idx, self._group_nodes[id(idx)], recover,
                   x_int, rot_int if dim == 3 else none[0], rot_int if dim == 2 else none[1], self.active, dim, pos,
                   rot, ang)
        return State(pos, ang if dim == 2 else rot)

    def reaction_vector(self, r_links: np.ndarray) -> np.ndarray:
        """The full model's residual layout with the reduced residual on the link DOFs."""
        out = np.zeros(self.compiled.problem.model.n_dofs)
        out[self.fe_dofs] = r_links[self.emb_dofs]
        return out


def setup_key(folder) -> tuple:
    return "ksd", None if folder is None else os.fspath(folder)


def reduced_mechanism(compiled, folder=None) -> ReducedMechanism:
    """The `ReducedMechanism` of ``compiled`` (steps 1-2's set-up: joint frames, templates,
    constraint sets, the start of step 1), built once per compiled mechanism and database folder
    (`flexmb.solve` keeps the compiled model of an unchanged mechanism, `flexmb.compiled`) and
    rebuilt when a joint database it read has changed (`ReducedMechanism.current`)."""
    key = setup_key(folder)
    derived = getattr(compiled, "derived", {})
    red = derived.get(key)
    if red is not None and red.current():
        return red
    red = derived[key] = ReducedMechanism(compiled, folder)
    return red
