"""Discretisation error on request: any quantity of a solve re-computed on meshes refined by 2 and 4
(every flexure's element count doubled through its `flexmb.Joint.mesh_parameter`) and
extrapolated by Richardson (Roache 1998, *Verification and Validation in Computational Science
and Engineering*, Ch. 5: the observed order from three meshes, then the extrapolated value).

The beam elements converge at order 2 for most quantities (e.g. the parasitic drop of a leaf,
the lateral-torsional buckling load: +1.1e-2, +2.7e-3, +5.6e-4 at 8/16/32 elements) and
faster for the end forces of straight leaves; the observed order is measured, not assumed.
"""

from __future__ import annotations

import copy
import math
import warnings
from collections.abc import Callable, Mapping

import attrs
import numpy as np

from ._timing import Stopwatch
from .design_properties import PROPERTIES, property_columns
from .errors import ConvergenceError, ConvergenceWarning, ModelError, ParameterError, UnsupportedStrategyError
from .solvers import make_strategy, solve
from .table import Table

__all__ = ["DiscretisationEstimate", "discretisation_error", "refined", "richardson"]


def refined(mechanism, factor: int = 2):
    """A copy of ``mechanism`` whose every finite-element joint has ``factor`` times its elements
    (``attrs.evolve`` of the joint's `flexmb.Joint.mesh_parameter`); ideal joints (hinges) stay.

    A joint with a finite-element model that names no ``mesh_parameter`` cannot be refined: a
    `UnsupportedStrategyError` names the joint and what its class must expose.
    """
    if not hasattr(mechanism, "graph") or not hasattr(mechanism, "compile"):
        raise ModelError(f"refined: needs a flexmb.Mechanism, got {type(mechanism).__name__}")
    if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or factor < 1:
        raise ParameterError(f"refined: factor={factor!r} must be an integer >= 1")
    out = copy.deepcopy(mechanism)
    for _, _, name, data in out.graph.edges(keys=True, data=True):
        joint = data["joint"]
        if "fe_model" not in joint.capabilities:
            continue  # an ideal joint: exact, nothing to refine
        param = type(joint).mesh_parameter
        if not param or not hasattr(joint, param):
            raise UnsupportedStrategyError(
                f"joint {name!r} (kind {joint.kind!r}) cannot be refined: its class must name the integer parameter "
                f"that sets its number of beam elements in the class attribute `mesh_parameter` (as "
                f"cross_flexure's 'elements_per_leaf'), got {param!r}")
        data["joint"] = attrs.evolve(joint, **{param: int(getattr(joint, param)) * int(factor)})
    return out


def richardson(values, ratio: float = 2.0, order: float | None = None):
    """Richardson extrapolation of ``values`` (levels, ...) on meshes refined by ``ratio`` each.

    Three or more levels: the observed order ``p = log(|q0 - q1| / |q1 - q2|) / log(ratio)`` from
    the last three (Roache 1998, Eq. 5.10.6.1); two levels: ``order`` must be given. Returns
    ``(reference, order)``, ``reference = q_last + (q_last - q_prev) / (ratio^p - 1)``. Where the
    last two differ by round-off only (< 1e-12 relative) the finest value is the reference and
    the order NaN; where the differences change sign (no asymptotic range yet) or the observed
    order is below 0.5, the order is NaN and the reference the finest value (the estimate is then
    the plain difference to the finest mesh, and `DiscretisationEstimate.asymptotic` is False).
    """
    q = np.asarray(values, dtype=float)
    if q.ndim == 0 or len(q) < 2:
        raise ParameterError("richardson: needs values on two or more meshes")
    if len(q) == 2 and order is None:
        raise ParameterError("richardson: two meshes need the order of convergence (order=...)")
    d_last = q[-1] - q[-2]
    scale = np.maximum(np.abs(q[-1]), np.abs(q).max(axis=0) * 1e-3)
    tiny = np.abs(d_last) <= 1e-12 * np.where(scale > 0, scale, 1.0)
    if order is not None:
        p = np.full(q.shape[1:], float(order))
    else:
        d_prev = q[-2] - q[-3]
        with np.errstate(divide="ignore", invalid="ignore"):
            p = np.log(np.abs(d_prev) / np.abs(d_last)) / math.log(ratio)
        p = np.where((d_prev * d_last > 0) & (p >= 0.5) & np.isfinite(p), p, np.nan)
    p = np.where(tiny, np.nan, p)
    with np.errstate(over="ignore", invalid="ignore"):
        ref = np.where(np.isfinite(p), q[-1] + d_last / (ratio ** p - 1.0), q[-1])
    return ref, p


@attrs.frozen(eq=False)
class DiscretisationEstimate:
    """The discretisation error of named quantities of a solve (`discretisation_error`).

    Attributes
    ----------
    names
        The quantities' names (tuple of str).
    values
        (levels, q): each quantity on the given mesh (row 0) and the refined ones.
    elements
        (levels,) ints: the mechanism's beam elements at each level.
    times
        (levels,) wall time [s] of each level's solve and quantities.
    reference
        (q,): the Richardson extrapolation (`richardson`), the converged-mesh estimate.
    order
        (q,): the observed order of convergence (NaN where not in the asymptotic range).
    """

    names: tuple
    values: np.ndarray
    elements: np.ndarray
    times: np.ndarray
    reference: np.ndarray
    order: np.ndarray

    @property
    def value(self) -> np.ndarray:
        """(q,): the quantities on the given mesh."""
        return self.values[0].copy()

    @property
    def error(self) -> np.ndarray:
        """(q,): estimated discretisation error of the given mesh, ``value - reference``."""
        return self.values[0] - self.reference

    @property
    def relative(self) -> np.ndarray:
        """(q,): ``error / |reference|`` (NaN where the reference is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.reference != 0, self.error / np.abs(self.reference), np.nan)

    @property
    def asymptotic(self) -> np.ndarray:
        """(q,) bools: the meshes are in the asymptotic range (a finite observed order >= 0.5)."""
        return np.isfinite(self.order)

    def __getitem__(self, name: str) -> dict:
        """One quantity's numbers: value, reference, error, relative, order, values."""
        try:
            k = self.names.index(name)
        except ValueError:
            raise ModelError(f"no quantity {name!r}; quantities: {', '.join(self.names)}") from None
        return {"value": float(self.values[0, k]), "reference": float(self.reference[k]),
                "error": float(self.error[k]), "relative": float(self.relative[k]), "order": float(self.order[k]),
                "values": self.values[:, k].copy()}

    def table(self) -> Table:
        """One row per quantity: ``quantity``, ``value``, ``reference``, ``error``, ``relative``, ``order``."""
        return Table({"quantity": np.array(self.names, dtype=object), "value": self.value,
                      "reference": self.reference, "error": self.error, "relative": self.relative,
                      "order": self.order})


def _quantities(quantity, property_options: dict) -> Callable:
    """A function solution -> {name: float} from ``quantity`` (see `discretisation_error`)."""
    if callable(quantity):
        def evaluate(sol):
            return _named(getattr(quantity, "__name__", "value"), quantity(sol))
        return evaluate
    which = (quantity,) if isinstance(quantity, str) else tuple(quantity) if isinstance(quantity, (tuple, list)) \
        else None
    if not which or not all(isinstance(w, str) and w in PROPERTIES for w in which):
        raise ParameterError(f"discretisation_error: quantity={quantity!r} must be a function of a Solution or "
                             f"property names among {', '.join(PROPERTIES)}")

    def evaluate(sol):
        cols = property_columns([sol], which, **property_options)
        return {name: float(col[0]) for name, col in cols.items() if np.asarray(col).dtype.kind == "f"}
    return evaluate


def _named(name: str, value) -> dict:
    """{name: float} from a float, an array (``name[i]``) or a mapping of them (its keys)."""
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            out.update(_named(str(key), item))
        return out
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        return {name: float(a)}
    return {f"{name}[{i}]": float(x) for i, x in enumerate(a.ravel())}


def discretisation_error(mechanism, quantity, *, method: str = "conventional", levels: int = 3,
                         property_options: dict | None = None, **options) -> DiscretisationEstimate:
    """The discretisation error of ``quantity`` of ``flexmb.solve(mechanism, method, **options)``:
    the solve repeated on meshes with 2, 4, ... times the elements (`refined`), the quantity
    extrapolated by Richardson with its observed order (`richardson`).

    ``quantity``: a function of a `flexmb.Solution` returning a float, an array or a mapping
    name -> float or array (e.g. ``lambda s: {"moment": s.reaction("B")[5]}``), or the names of
    `flexmb.properties` (``"modes"``, ``"buckling"``, ``"compliance"``, ``"stress"``; their
    columns become the quantities, ``property_options`` go to `flexmb.design_properties.property_columns`).
    ``levels``: meshes in all (3: the observed order; 2: a Richardson pair with the order 2 of the
    beam elements assumed). Cost: with ``levels=3`` about 1 + 2 + 4 = 7 solves of the given mesh.

    Every level is solved with the same ``method`` (a KSD method needs trained data for the
    refined meshes; a closed-form model's strategy, ``"newton"``, has no mesh and is refused). A
    refined level that does not converge ends the refinement with a `flexmb.ConvergenceWarning`
    and the estimate uses the meshes that did (two: a pair with order 2); the given mesh or the
    first refinement not converging raises `flexmb.ConvergenceError`. Returns a `DiscretisationEstimate`.
    """
    strategy = make_strategy(method, options)  # bad options raise before any refinement
    if getattr(strategy, "capability", "fe_model") != "fe_model":  # no finite-element mesh to refine
        raise UnsupportedStrategyError(f"discretisation_error: method {getattr(strategy, 'name', method)!r} solves "
                                       f"a {strategy.capability!r} model (constant-stiffness closed forms) with no "
                                       "mesh to refine; compare with method='conventional' instead")
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or not 2 <= levels <= 5:
        raise ParameterError(f"discretisation_error: levels={levels!r} must be an integer in [2, 5]")
    evaluate = _quantities(quantity, dict(property_options or {}))
    meshes = [mechanism] + [refined(mechanism, 2 ** k) for k in range(1, levels)]  # refusals before any solve
    rows, elements, times = [], [], []
    for k, m in enumerate(meshes):
        watch = Stopwatch()
        sol = solve(m, strategy)
        if not sol.converged:
            why = f"the solve on the {'given mesh' if k == 0 else f'mesh refined by {2 ** k}'} did not converge: " \
                  f"{sol.message}"
            if k < 2:
                raise ConvergenceError(f"discretisation_error: {why}", sol)
            warnings.warn(f"discretisation_error: {why}; the estimate uses the {k} meshes that did",
                          ConvergenceWarning, stacklevel=2)
            break
        rows.append(evaluate(sol))
        times.append(watch.total())
        elements.append(sum(len(e) for e in sol.compiled.joint_elements.values()))
    names = tuple(rows[0])
    if any(tuple(r) != names for r in rows[1:]):
        raise ModelError("discretisation_error: the quantity gave different names on the refined meshes "
                         f"({names} on the given mesh)")
    values = np.array([[r[n] for n in names] for r in rows], dtype=float)
    reference, order = richardson(values, 2.0, None if len(rows) >= 3 else 2.0)
    return DiscretisationEstimate(names=names, values=values, elements=np.array(elements), times=np.array(times),
                               reference=np.atleast_1d(reference), order=np.atleast_1d(order))
