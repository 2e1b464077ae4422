"""Sweeps of the actuation force, and the tangent stiffness of a mechanism in its link DOFs."""

from __future__ import annotations

import attrs
import numpy as np
import scipy.linalg as sla

from . import _validate as v
from .closed_form.problem import TERMS, LinkageProblem
from .errors import ModelError, ParameterError, UnsupportedStrategyError
from .problem import PointLoads
from .results import Solution
from .solvers import make_strategy

__all__ = ["sweep", "iter_sweep", "tangent_stiffness", "find_actuation", "STARTS"]

STARTS = ("undeformed", "previous")


def _with_actuation(compiled, value: float):
    row, direction = compiled.actuation
    ld = compiled.problem.loads
    force = ld.force.copy()
    force[row] = value * direction
    return PointLoads(ld.node, ld.offset, force, ld.moment)


def sweep(mechanism, forces, *, method: str | object = "conventional", start: str = "previous", **options) -> list:
    """Solve ``mechanism`` for each actuation force in ``forces`` [N] (`Mechanism.set_actuation`).

    ``start="previous"`` starts each solve from the last converged solution (continuation, the
    paper's Fig. 12 warm start; the conventional method then steps the load from the previous
    value); ``"undeformed"`` starts every solve from the undeformed configuration. ``method``
    and ``options`` as in `flexmb.solve`. The mechanism is compiled once and never modified.
    Returns one `Solution` per force, in order; failed solves are kept (``converged=False``).
    """
    return list(iter_sweep(mechanism, forces, method=method, start=start, **options))


def iter_sweep(mechanism, forces, *, method: str | object = "conventional", start: str = "previous", **options):
    """`sweep` as a generator: yields each `Solution` as soon as it is computed."""
    if start not in STARTS:
        raise ParameterError(f"sweep: start={start!r}; valid: {', '.join(STARTS)}")
    values = _forces("sweep", forces)
    strategy = make_strategy(method, options)
    if not hasattr(mechanism, "compile"):
        raise ModelError(f"sweep() needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    compiled = mechanism.compile(getattr(strategy, "capability", "fe_model"))
    if compiled.actuation is None:
        raise ModelError("sweep: the mechanism has no actuation; declare the swept force with "
                         "Mechanism.set_actuation(link, direction)")
    last = None  # the last converged solution
    for value in values:
        sol = _solve_at(strategy, compiled, float(value), last if start == "previous" else None)
        if sol.converged:
            last = sol
        yield sol


def _forces(owner: str, forces) -> np.ndarray:
    try:
        values = None if isinstance(forces, (str, bytes)) else np.atleast_1d(np.asarray(forces, dtype=float))
    except (TypeError, ValueError):
        values = None
    if values is None or values.ndim != 1 or len(values) == 0 or not np.all(np.isfinite(values)):
        raise ParameterError(f"{owner}: forces must be a non-empty 1-D sequence of finite numbers, got {forces!r}")
    return values


def _solve_at(strategy, compiled, value: float, previous=None):
    """Solve at actuation ``value``, from the converged ``previous`` solution if given."""
    # a load-stepping strategy steps the load from where ``previous`` was in equilibrium
    start = None if previous is None else previous.compiled.problem.loads
    problem = compiled.problem.with_loads(_with_actuation(compiled, value), start=start)
    return strategy.solve(attrs.evolve(compiled, problem=problem), state=None if previous is None else previous.state)


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
