"""Sweeps of an actuation force or a prescribed motion, and the tangent stiffness of a mechanism in its link DOFs."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Mapping, Sequence

import attrs
import numpy as np
import scipy.linalg as sla

from . import _validate as v
from . import _warnings
from . import jit
from .closed_form.problem import TERMS, LinkageProblem
from .units import check_angle
from .errors import ConvergenceError, ModelError, ParameterError, UnsupportedStrategyError
from .plausibility import check
from .problem import PointLoads
from .results import Solution
from .solvers import make_strategy
from .table import Table

__all__ = ["sweep", "iter_sweep", "SweepResult", "tangent_stiffness", "find_actuation", "STARTS"]

STARTS = ("undeformed", "previous")


def _with_actuation(compiled, value: float):
    row, direction = compiled.actuation
    ld = compiled.problem.loads
    force = ld.force.copy()
    force[row] = value * direction
    return PointLoads(ld.node, ld.offset, force, ld.moment)


def sweep(mechanism, values, *, motion: tuple[str, str] | None = None, method: str | object = "conventional",
          start: str = "previous", progress: bool | None = None, properties=None, **options) -> SweepResult:
    """Solve ``mechanism`` for each of ``values``: actuation forces [N] (`Mechanism.set_actuation`)
    by default, or with ``motion=(link, component)`` the prescribed value of that component of a
    link (``"x"``, ``"y"``, ``"z"`` [m]; ``"rotation"`` [rad], in 3D rotation vectors, shape
    (n, 3)) or of a point inside a joint (`Mechanism.add_joint_point`; the finite-element model);
    the component must already be prescribed (`Mechanism.prescribe`).

    ``start="previous"`` starts each solve from the last converged solution (continuation, the
    paper's Fig. 12 warm start; the conventional method then steps from the previous value to
    the next); ``"undeformed"`` starts every solve from the undeformed configuration. The KSD
    strategies always start from their own kinematic solution. ``method`` and ``options`` as in
    `flexmb.solve`. ``progress``: a progress bar on stderr (tqdm; None = only on a terminal).
    The mechanism is compiled once and never modified.

    Returns a `SweepResult`: a sequence of one `Solution` per value, in order, whose
    `SweepResult.table` gives the results as arrays and CSV. Nothing is lost to one value: a
    solve that fails is kept (``converged=False``), and so is one where the strategy raises (a
    `DatabaseError` outside the trained range, any other error): its Solution's ``message``
    names the value and the error, its numbers are NaN. The next value starts from the last
    converged one. Only ``raise_on_failure=True`` stops a sweep, with the `ConvergenceError` asked for;
    Ctrl-C ends it with the solutions computed so far (``interrupted=True``, a UserWarning).
    ``properties``: design properties added to the table, a sequence of names (``"modes"``,
    ``"buckling"``, ``"compliance"``, ``"stress"``) or a mapping of the keyword arguments of
    `flexmb.design_properties.properties` (e.g. ``{"which": ("modes",), "n_modes": 3}``).
    """
    from tqdm.auto import tqdm

    if progress is not None:  # "no" would be taken as True
        v.flag("sweep", "progress", progress)
    caught = []  # each value's warnings (`_checked`), for the table's "warnings" column
    values, solutions = _plan(mechanism, values, motion, method, start, options, compiled_loop=not progress,
                              record=caught)
    if isinstance(solutions, Sequence):  # run already, as numba loops
        result = SweepResult(solutions, values, "force")
    else:
        bar = tqdm(solutions, total=len(values), desc="sweep", unit="solve", leave=False,
                   disable=None if progress is None else not progress)
        done = _until_interrupted(bar, len(values))
        result = SweepResult(done, values[: len(done)], "force" if motion is None else ".".join(motion))
        result.interrupted = len(done) < len(values)
        result.warnings = caught[: len(done)]
    if properties is not None:
        from .design_properties import property_columns

        kw = dict(properties) if isinstance(properties, Mapping) else {"which": properties}
        result.property_table = Table(property_columns(result.solutions, **kw))
    return result


def _until_interrupted(bar, total: int) -> list:
    """The solutions of ``bar`` (a tqdm over the sweep's generator) up to Ctrl-C: an interrupted
    sweep returns those computed, with a UserWarning (a numba loop runs at once: not these)."""
    import warnings

    done = []
    try:
        for sol in bar:
            done.append(sol)
    except KeyboardInterrupt:
        warnings.warn(f"sweep: interrupted (Ctrl-C) after {len(done)} of {total} values; the solutions computed "
                      "are returned (SweepResult.interrupted)", UserWarning, stacklevel=3)
    finally:
        bar.close()
    return done


def iter_sweep(mechanism, values, *, motion: tuple[str, str] | None = None, method: str | object = "conventional",
               start: str = "previous", **options):
    """`sweep` as a generator: yields each `Solution` as soon as it is computed, failed ones
    included as in `sweep` (the arguments are checked at the call, before the first solve)."""
    return _plan(mechanism, values, motion, method, start, options)[1]


def _plan(mechanism, values, motion, method, start, options, compiled_loop=False, record=None):
    """Checked sweep values (n,) or (n, width) and the generator of their solutions (or, with
    ``compiled_loop``, the solutions of `_compiled_force_sweep` when it applies)."""
    v.choice("sweep", "start", start, STARTS)
    strategy = make_strategy(method, options)
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"sweep() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    if motion is None:
        values = _forces("sweep", values)
    else:
        comps = _motion_dofs(mechanism, motion)
        values = _motions(values, motion, len(comps))
    compiled = mechanism.compile(getattr(strategy, "capability", "fe_model"))
    if motion is None and compiled.actuation is None:
        raise ModelError("sweep: the mechanism has no actuation; declare the swept force with "
                         "Mechanism.set_actuation(link, direction), or sweep a prescribed motion with motion=(link, "
                         "component)")
    slots = None if motion is None else _prescribed_slots(compiled, motion, comps)
    warm = start == "previous" and _warm_starts(strategy)
    if compiled_loop and slots is None and jit.enabled() and hasattr(strategy, "sweep_forces"):
        return values, _checked_lazily(_compiled_force_sweep(strategy, compiled, values, warm),
                                       getattr(strategy, "raise_on_failure", False))

    def solutions():
        last = last_values = None  # the last converged solution and its prescribed values
        for value in values:
            previous = last if warm else None
            t0 = time.perf_counter()
            try:
                if slots is None:
                    sol = _solve_at(strategy, compiled, float(value), previous)
                else:
                    vals = compiled.problem.values.copy()
                    vals[slots] = value
                    # from the previous solution: the rotations move along the requested values
                    problem = compiled.problem.with_motion(vals, start=None if previous is None else previous.state,
                                                           start_values=None if previous is None else last_values)
                    moved = attrs.evolve(compiled, problem=problem)
                    if hasattr(strategy, "share_setup"):  # KSD: the set-up built once, moved to each value
                        strategy.share_setup(compiled, moved)
                    sol = _solve(strategy, moved, previous)
            except Exception as exc:  # kept, with the reason: one value never costs the others
                if isinstance(exc, ConvergenceError) and getattr(strategy, "raise_on_failure", False):
                    raise  # asked for: raise_on_failure=True stops the sweep at its first failure
                sol = _failed(strategy, compiled, value, exc, time.perf_counter() - t0)
            if sol.converged:
                last, last_values = sol, (None if slots is None else vals)
            yield sol

    return (values if slots is None or len(slots) > 1 else values[:, 0]), _checked(solutions(), record)


def _checked(solutions, record=None):
    """The solutions, each checked as `flexmb.solve` checks (ConvergenceWarning, PlausibilityWarning);
    with a list ``record``, each value's warnings (its solve's and its check's) are appended to
    it as text (``"Category: message"`` joined by ``" | "``) and raised again."""
    it = iter(solutions)
    while True:
        with _warnings.recording() if record is not None else contextlib.nullcontext([]) as caught:
            try:
                sol = next(it)
            except StopIteration:
                return
            check(sol, stacklevel=4)
        if record is not None:
            _warnings.raise_again(caught)
            record.append(_warnings.as_text(caught))
        yield sol


def _checked_lazily(sweep, raise_on_failure: bool):
    """A compiled force sweep (`flexmb.solvers.newton.ForceSweep`), checked as `_checked` checks
    without building every Solution: each failed value warns (those are built; with
    ``raise_on_failure`` the first raises its `ConvergenceError`, as the per-solve path does), and
    of the converged ones the value that moved the links farthest, where the closed form's
    missing shortening (0.6 d^2 / L against d) weighs most."""
    failed = np.flatnonzero(~np.asarray(sweep.converged, dtype=bool))
    if raise_on_failure and len(failed):
        sol = sweep[int(failed[0])]
        raise ConvergenceError(sol.message, sol)
    for k in failed:
        check(sweep[int(k)], stacklevel=4)
    ok = np.flatnonzero(np.asarray(sweep.converged, dtype=bool))
    if len(ok):
        x0 = sweep._compiled.problem.model.x0  # the links' rest positions
        moved = np.abs(sweep.positions[ok] - x0).reshape(len(ok), -1).max(axis=1)
        check(sweep[int(ok[np.argmax(moved)])], stacklevel=4)
    return sweep


_COMPONENTS = {2: {"x": [0], "y": [1], "rotation": [2]}, 3: {"x": [0], "y": [1], "z": [2], "rotation": [3, 4, 5]}}


def _motion_dofs(mechanism, motion) -> list[int]:
    """Component indices of ``motion = (link, component)`` within a link's DOFs."""
    comps = _COMPONENTS[mechanism.dim]
    if (not isinstance(motion, tuple) or len(motion) != 2 or not all(isinstance(x, str) for x in motion)
            or motion[1] not in comps):
        raise ParameterError(f"sweep: motion={motion!r} must be a (link, component) tuple with component one of "
                             f"{', '.join(comps)}")
    points = getattr(mechanism, "joint_points", {})
    if motion[0] not in mechanism.links and motion[0] not in points:
        what = "link or joint point" if points else "link"
        raise ModelError(f"sweep: no {what} named {motion[0]!r}; links: {', '.join(mechanism.links)}"
                         + (f"; joint points: {', '.join(points)}" if points else ""))
    return comps[motion[1]]


def _motions(values, motion, width: int) -> np.ndarray:
    try:
        a = None if isinstance(values, (str, bytes)) else np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        a = None
    shape = "(n,)" if width == 1 else f"(n, {width})"
    if a is not None and width == 1 and a.ndim == 1:
        a = a[:, None]
    if a is None or a.ndim != 2 or a.shape[1] != width or len(a) == 0 or not np.all(np.isfinite(a)):
        raise ParameterError(f"sweep: values of motion {motion!r} must be finite numbers of shape {shape}, got "
                             f"{values!r}")
    if motion[1] == "rotation":  # radians meant: a value above 2 pi is likely degrees
        check_angle(f"sweep of link {motion[0]!r}", "rotation", a if width == 3 else a[:, 0], stacklevel=5)
    return a


def _prescribed_slots(compiled, motion, comps) -> np.ndarray:
    """Positions of the swept DOFs in ``compiled.problem.prescribed`` (of a link or a point inside
    a joint, `Mechanism.add_joint_point`)."""
    problem = compiled.problem
    inside = motion[0] not in compiled.link_node
    node = compiled.joint_points[motion[0]] if inside else compiled.link_node[motion[0]]
    dofs = problem.model.node_dofs[node][comps]
    if not np.all(np.isin(dofs, problem.prescribed)):
        raise ModelError(f"sweep: the {motion[1]} of {'joint point' if inside else 'link'} {motion[0]!r} is not "
                         f"prescribed; prescribe it first, e.g. Mechanism.prescribe({motion[0]!r}, {motion[1]}=0.0)")
    if any(np.isin(dofs, d).any() for d, _ in getattr(problem, "rotation_paths", ())):
        raise ModelError(f"sweep: link {motion[0]!r} has a chain of rotations prescribed; sweep a single rotation "
                         f"vector instead")
    return np.searchsorted(problem.prescribed, dofs)


def _failed(strategy, compiled, value, exc: Exception, seconds: float) -> Solution:
    """The `Solution` of a value whose solve raised: not converged, the error in its message."""
    method = getattr(strategy, "name", type(strategy).__name__)
    at = np.round(np.asarray(value, dtype=float), 12).tolist()
    return Solution.failed(method, compiled, f"{method} at {at}: {type(exc).__name__}: {exc}", {"total": seconds})


def _warm_starts(strategy) -> bool:
    """Whether the strategy's ``solve`` takes a starting ``state`` (Newton-type strategies);
    known per solve function after the first look (inspect.signature once, not per solve)."""
    import inspect

    solve = getattr(strategy, "solve", None)
    kind = getattr(solve, "__func__", solve)  # the function, shared by a class's instances
    if kind not in _WARM:
        try:
            _WARM[kind] = "state" in inspect.signature(strategy.solve).parameters
        except (TypeError, ValueError):
            _WARM[kind] = False
    return _WARM[kind]


_WARM: dict = {}


def _compiled_force_sweep(strategy, compiled, values, warm):
    """A force sweep as compiled Newton loops (`flexmb.solvers.newton.Newton.sweep_forces`): the
    gripper's opening-closing sweep an order of magnitude faster (BENCHMARKS.md, Gripper); the
    same iterations and equilibria as the per-solve path (tests/test_closed_form_jit.py)."""
    return strategy.sweep_forces(compiled, values, warm, lambda value: _with_actuation(compiled, value))


def _forces(owner: str, forces) -> np.ndarray:
    try:
        values = None if isinstance(forces, (str, bytes)) else np.atleast_1d(np.asarray(forces, dtype=float))
    except (TypeError, ValueError):
        values = None
    if values is None or values.ndim != 1 or len(values) == 0 or not np.all(np.isfinite(values)):
        raise ParameterError(f"{owner}: forces must be a non-empty 1-D sequence of finite numbers, got {forces!r}")
    return values


def _solve(strategy, compiled, previous=None):
    if previous is None or not _warm_starts(strategy):
        return strategy.solve(compiled)
    return strategy.solve(compiled, state=previous.state)


def _solve_at(strategy, compiled, value: float, previous=None):
    """Solve at actuation ``value``, from the converged ``previous`` solution if given."""
    # a load-stepping strategy steps the load from where ``previous`` was in equilibrium
    start = None if previous is None else previous.compiled.problem.loads
    problem = compiled.problem.with_loads(_with_actuation(compiled, value), start=start)
    return _solve(strategy, attrs.evolve(compiled, problem=problem), previous)


class _Columns(dict):
    """Table columns that never overwrite: a taken name gets the first free ``#2``, ``#3`` ... suffix."""

    def __setitem__(self, name, values):
        key, k = name, 1
        while key in self:
            k += 1
            key = f"{name}#{k}"
        super().__setitem__(key, values)

    def update(self, other):
        for name, values in other.items():
            self[name] = values


def _link_columns(sols, link: str) -> dict:
    """`SweepResult.table`'s columns of one link (or point inside a joint): its position, rotation
    and, where a DOF of it is fixed or prescribed, the reaction."""
    compiled, dim = sols[0].compiled, sols[0].dim
    axes = "xyz"[:dim]
    problem = compiled.problem
    held = set(np.asarray(problem.prescribed) // problem.model.ndof)
    pos = np.array([s.pose(link)[0] for s in sols])
    rot = np.array([s.rotation_vector(link) for s in sols])
    cols = {f"{link}.{a}": pos[:, i] for i, a in enumerate(axes)}
    if dim == 2:
        cols[f"{link}.rotation"] = rot[:, 0]
    else:
        cols.update({f"{link}.rotation_{a}": rot[:, i] for i, a in enumerate(axes)})
    node = compiled.link_node[link] if link in compiled.link_node else compiled.joint_points.get(link)
    if node in held:
        w = np.array([s.reaction(link) for s in sols])
        labels = [f"F{a}" for a in axes] + (["Mz"] if dim == 2 else [f"M{a}" for a in axes])
        cols.update({f"{link}.{n}": w[:, i] for i, n in enumerate(labels)})
    return cols


class SweepResult(Sequence):
    """The solutions of a `sweep` (a sequence: ``len``, indexing, iteration) with ``values``, the
    swept quantity's name ``quantity`` (``"force"`` or ``"link.component"``) and `table`."""

    def __init__(self, solutions: list, values: np.ndarray, quantity: str):
        self.solutions, self._values, self.quantity = solutions, np.array(values, dtype=float), quantity
        #: whether Ctrl-C ended the sweep before its last value (the values are those solved)
        self.interrupted = False

        #: the `properties` columns requested from `sweep`, a `Table` (None: none)
        self.property_table = None
        #: each value's warnings as text (`sweep`; None: not recorded, a compiled force sweep's)
        self.warnings = None

    @property
    def values(self) -> np.ndarray:
        """The swept values, (n,) or (n, 3) (a copy)."""
        return self._values.copy()

    def __getitem__(self, i):
        return self.solutions[i]

    def __len__(self) -> int:
        return len(self.solutions)

    def __repr__(self) -> str:
        ok = sum(s.converged for s in self.solutions)
        return f"SweepResult({len(self)} solves of {self.quantity}, {ok} converged)"

    @property
    def converged(self) -> np.ndarray:
        """Whether each solve converged, (n,) bool (a copy; a compiled sweep's flags without
        building its Solutions)."""
        flags = getattr(self.solutions, "converged", None)  # flexmb.solvers.newton.ForceSweep
        if flags is not None:
            return np.array(flags, dtype=bool)
        return np.array([s.converged for s in self.solutions])

    def table(self, links=None, points=()) -> Table:
        """Results as a `flexmb.table.Table` of 1-D arrays, one row per value.

        Columns: the swept value(s) (``"force"`` [N], or e.g. ``"B.x"``, ``"B.rotation"``, 3D
        rotations as ``"B.rotation_x"`` ...), ``converged``, ``warnings`` (each value's warnings as text,
        ``""`` for none; not in a compiled force sweep's table), ``iterations``, ``time`` [s]; for every
        link in ``links`` (default: all) its position ``"<link>.x"`` ... [m], rotation
        ``"<link>.rotation"`` (2D) or rotation vector ``"<link>.rotation_x"`` ... [rad], and for
        links with a fixed or prescribed DOF the reaction ``"<link>.Fx"`` ... [N],
        ``"<link>.Mz"`` ... [N m] (``links`` may name points inside joints, `Mechanism.add_joint_point`);
        for every named point in ``points`` its position [m]. Write it
        with ``.to_csv(path)``; ``result.table().to_pandas()`` makes a data frame.

        Nothing is overwritten: a column keeps the first name it takes, in the order above, and
        a later column whose name is taken gets the first free ``"<name>#2"``, ``"<name>#3"`` ...
        So the swept values keep their column: sweeping ``motion=("B", "x")``, ``"B.x"`` holds
        the prescribed displacements and link B's position is ``"B.x#2"``; a point named like a
        link has its columns after the link's.
        """
        sols = self.solutions
        compiled = sols[0].compiled
        dim = sols[0].dim
        axes = "xyz"[:dim]
        cols = _Columns()
        vals = self._values.reshape(len(sols), -1)
        names = [self.quantity] if vals.shape[1] == 1 else [f"{self.quantity}_{a}" for a in "xyz"]
        cols.update({n: vals[:, i] for i, n in enumerate(names)})
        cols["converged"] = self.converged
        if self.warnings is not None and len(self.warnings) == len(sols):
            cols["warnings"] = np.array(self.warnings, dtype=str)
        cols["iterations"] = np.array([s.iterations for s in sols])
        cols["time"] = np.array([s.wall_time.get("total", np.nan) for s in sols])
        for link in list(compiled.link_node) if links is None else list(links):
            cols.update(_link_columns(sols, link))
        for name in points:
            owner = compiled.points.get(name, (None,))[0]
            if owner is None:
                raise ModelError(f"no point named {name!r}; points: {', '.join(compiled.points) or 'none'}")
            xyz = np.array([s.point(owner, name) for s in sols])
            cols.update({f"{name}.{a}": xyz[:, i] for i, a in enumerate(axes)})
        if self.property_table is not None:
            cols.update(self.property_table)
        return Table(cols)

    def to_csv(self, path, links=None, points=()):
        """``self.table(links, points).to_csv(path)``; returns the path."""
        return self.table(links, points).to_csv(path)


def tangent_stiffness(mechanism, solution=None, terms: bool = False, *, method: str | None = None):
    """Tangent stiffness K_T = dR/dq of ``mechanism`` in its free link DOFs, at rest or at ``solution``.

    Rows and columns are the free DOFs of the links in the order they were added (x, y, theta per
    planar link; for the gripper body 2, 3, 4 x (x, y, theta): 9 x 9, Table 2 at rest). Units
    follow the model (N/m, N, N m).

    ``method="newton"`` (the default when every joint has a closed form): the closed-form K_T of
    Cammarata et al. (2022); with ``terms=True`` a dict of its terms ``"I"``, ``"II"``, ``"III"``
    (Eq. 26-28) and ``"load"`` (dead loads away from the link reference points), which sum to
    K_T. ``method="conventional"``: the finite-element tangent statically condensed onto the
    link DOFs (internal beam nodes eliminated); no terms. At rest the loads count at load
    factor 1 (their load stiffness); with ``solution`` its own model, loads and state are used.
    """
    if solution is not None:
        if not isinstance(solution, Solution):
            raise ModelError(f"tangent_stiffness: solution must be a flexmb.Solution, got {type(solution).__name__}")
        compiled, state = solution.compiled, solution.state
        if method is not None and method != solution.method and {method, solution.method} != {"newton"}:
            raise UnsupportedStrategyError(f"tangent_stiffness: solution is from method {solution.method!r}, "
                                           f"not {method!r}")
    else:
        if not hasattr(mechanism, "compile"):
            raise ModelError(f"tangent_stiffness() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
        if method is None:
            caps = [j.capabilities for j in mechanism.joints.values()]
            method = "newton" if mechanism.dim == 2 and all("closed_form" in c for c in caps) else "conventional"
        capability = {"newton": "closed_form", "conventional": "fe_model"}.get(method)
        if capability is None:
            raise UnsupportedStrategyError(f"tangent_stiffness: method={method!r}; valid: newton, conventional")
        compiled = mechanism.compile(capability)
        state = compiled.problem.model.initial_state()  # the undeformed configuration (prescribed motion not applied)
    problem = compiled.problem
    links = np.sort(np.array(list(compiled.link_node.values()), dtype=np.int64))
    link_dofs = problem.model.node_dofs[links].ravel()
    keep = link_dofs[np.isin(link_dofs, problem.free)]
    if isinstance(problem, LinkageProblem):
        _, parts = problem.evaluate(state)
        ix = np.ix_(keep, keep)
        if terms:
            return {name: parts[name][ix].copy() for name in TERMS}
        return sum(parts.values())[ix]
    if terms:
        raise UnsupportedStrategyError("tangent_stiffness: terms are defined for the closed-form model "
                                       "(method='newton'), not the finite-element model")
    if getattr(problem.model, "hinges", None) is not None:
        raise UnsupportedStrategyError(
            f"tangent_stiffness: the ideal joints {list(problem.model.hinges.names)} make the links infinitely stiff "
            "in the directions they constrain; use flexmb.compliance (finite, zero in those directions)")
    _, Kff, _, _ = problem.evaluate(state, 1.0)
    K = Kff.toarray()
    pos = np.searchsorted(problem.free, keep)
    inner = np.setdiff1d(np.arange(len(problem.free)), pos)
    if len(inner) == 0:
        return K[np.ix_(pos, pos)]
    Kii = K[np.ix_(inner, inner)]
    return K[np.ix_(pos, pos)] - K[np.ix_(pos, inner)] @ sla.solve(Kii, K[np.ix_(inner, pos)])


def find_actuation(mechanism, point: tuple[str, str], forces, *, coordinate: int = 0, target: float = 0.0,
                   method: str | object = "conventional", xtol: float = 1e-10, **options) -> float:
    """The actuation force [N] at which coordinate ``coordinate`` of the named ``point`` =
    (link, name) reaches ``target`` (the gripper's clamp closes: end-effector x = 0).

    Sweeps ``forces`` (warm-started) until the coordinate crosses ``target``, then refines between
    the two bracketing forces with Brent's method (to ``xtol`` [N]), each solve warm-started from
    the lower one. Raises `ModelError` when the sweep fails or never crosses.
    """
    values = _forces("find_actuation", forces)
    if (not isinstance(point, tuple) or len(point) != 2 or not all(isinstance(x, str) for x in point)):
        raise ParameterError(f"find_actuation: point={point!r} must be a (link, point name) tuple")
    dim = getattr(mechanism, "dim", 2)
    if isinstance(coordinate, bool) or not isinstance(coordinate, (int, np.integer)) or not 0 <= coordinate < dim:
        raise ParameterError(f"find_actuation: coordinate={coordinate!r} must be an integer in 0..{dim - 1}")
    target = v.finite("find_actuation", "target", target)
    xtol = v.positive("find_actuation", "xtol", xtol)
    prev = None
    for sol, F in zip(iter_sweep(mechanism, values, method=method, **options), values):
        if not sol.converged:
            raise ModelError(f"find_actuation: no equilibrium at actuation {F:.6g} before the crossing: {sol.message}")
        g = sol.point(*point)[coordinate] - target
        if g == 0.0:
            return float(F)
        if prev is not None and np.sign(g) != np.sign(prev[2]):
            break
        prev = (F, sol, g)
    else:
        raise ModelError(f"find_actuation: {point[1]!r} coordinate {coordinate} does not reach {target} for "
                         f"actuation in [{values[0]:.6g}, {values[-1]:.6g}]")
    from scipy.optimize import brentq

    strategy = make_strategy(method, options)
    lower = prev[1]

    def gap(F):
        s = _solve_at(strategy, lower.compiled, F, lower)
        if not s.converged:
            raise ModelError(f"find_actuation: no equilibrium at actuation {F:.6g}: {s.message}")
        return s.point(*point)[coordinate] - target

    return float(brentq(gap, prev[0], F, xtol=xtol))
