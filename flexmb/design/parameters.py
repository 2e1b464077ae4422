"""Design parameters: a design is ``build(p) -> Mechanism`` over named floats with bounds.

`Parameter` and `Design` are data; `flexmb.design.builds.model_rates` turns a design at ``p`` into the rates of
change of its compiled model's numbers (`MODEL_FIELDS`) per parameter, the one piece of the
gradient that differentiates the user's build. It is the complex step through the build
(Squire & Trapp 1998; Martins, Sturdza & Alonso 2003): one build per parameter at
``p_k + i h`` (``h`` = `H` times the parameter's scale), whose model numbers
(`flexmb.fe.build.numbers`: no problem, no sparsity pattern, no solver set-up) carry
``N(p) + i h N'(p)`` to round-off, no difference, no step to choose. Everything downstream of
the model numbers is exact too (complex step through the element kernels,
`flexmb.design.partials`; linear algebra, `flexmb.design.adjoint`).

flexmb's validators, joints, sections, placements, masses and loads carry complex numbers
(judged by their real parts). Where a build or a joint plugin cannot carry them (``float()``,
``math.sin``, a comparison or ``max()`` on ``p``: an error) the parameter falls back to central
differences of the build, and a check along one direction catches a build that drops an
imaginary part silently (``abs()``, ``np.linalg.norm``): `flexmb.design.builds` has the rule;
``docs/plugins.md``, "Complex-step safe joints", and `flexmb.testing.check_complex_step` are for
plugin authors.

The topology must not depend on ``p``: the structure of the model (element ends, node and point
numbering, DOF layout, prescribed DOFs, load and mass rows) is compared between the builds, and a
change is refused (`flexmb.TopologyError` naming the parameter).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import attrs
import numpy as np

from ..errors import ParameterError, TopologyError, UnsupportedStrategyError

__all__ = ["Parameter", "Design", "as_design", "ModelRates", "model_numbers", "MODEL_FIELDS",
           "RELATIVE_STEP", "H"]

#: Relative step of central differences of the build (times the parameter's scale): the fallback
#: where the complex step cannot pass and the check of the complex-step rates along one direction
#: (`flexmb.design.builds`); truncation ~ step^2 and round-off ~ eps / step balance near 1e-5
#: (errors ~1e-10 relative on smooth builds).
RELATIVE_STEP = 1e-5

#: The complex step of the build, relative to the parameter's scale: far below the round-off of
#: any model number (its square vanishes beside 1), far above underflow.
H = 1e-30

#: The numbers of a compiled finite-element model that a parameter can change (what the residual,
#: tangent and mass depend on besides the state): point offsets from their master nodes, element
#: lengths, stiffness, frames and mass per length, the nodes' reference positions, the links' rigid
#: masses, the loads, the prescribed values and the named points' offsets.
MODEL_FIELDS = ("point_offset", "L0", "S", "ny0", "nz0", "alpha0", "rho_A", "local_mass", "x0", "rigid_mass",
                "rigid_inertia", "rigid_offset", "load_offset", "load_force", "load_moment", "values", "chains", "points")


@attrs.frozen
class Parameter:
    """A named design parameter: ``value`` within [``lower``, ``upper``] (its unit is the build's).

    ``scale``: the parameter's typical size, for the build's complex step (`H` times it) and the
    difference steps (`RELATIVE_STEP` times it); default ``max(|value|, (upper - lower) /
    100)``, 1 where both are 0 or unbounded."""

    name: str
    value: float
    lower: float = -math.inf
    upper: float = math.inf
    scale: float | None = None

    def __attrs_post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"design parameter name must be a non-empty string, got {self.name!r}")
        for field in ("value", "lower", "upper"):
            if not isinstance(getattr(self, field), (int, float, np.integer, np.floating)) or \
                    isinstance(getattr(self, field), bool):
                raise ParameterError(f"design parameter {self.name!r}: {field}={getattr(self, field)!r} is not a number")
        if not math.isfinite(self.value):
            raise ParameterError(f"design parameter {self.name!r}: value={self.value!r} must be finite")
        if not self.lower <= self.value <= self.upper:
            raise ParameterError(f"design parameter {self.name!r}: value={self.value!r} outside its bounds "
                                 f"[{self.lower!r}, {self.upper!r}]")

    @property
    def size(self) -> float:
        """The parameter's typical size [its unit] (``scale``, or the default of the class notes)."""
        if self.scale is not None and self.scale != 0:
            return abs(self.scale)
        span = self.upper - self.lower
        scale = max(abs(self.value), span / 100.0 if math.isfinite(span) else 0.0)
        return scale if scale > 0.0 else 1.0

    @property
    def step(self) -> float:
        """The build's central-difference step [the parameter's unit] (`RELATIVE_STEP` x `size`)."""
        return RELATIVE_STEP * self.size


@attrs.frozen
class Design:
    """``build(p) -> flexmb.Mechanism`` over the named `Parameter` s (``p``: a dict name -> float).

    The build must give the same topology for every ``p`` (element counts, node numbering); it
    may read only the parameters' values."""

    build: Callable = attrs.field()
    parameters: tuple = attrs.field(converter=tuple)

    @build.validator
    def _callable(self, _, value):
        if not callable(value):
            raise ParameterError(f"Design: build must be a function p -> Mechanism, got {type(value).__name__}")

    def __attrs_post_init__(self):
        names = [q.name for q in self.parameters]
        if len(set(names)) != len(names):
            raise ParameterError(f"Design: parameter names repeat: {names}")
        if not all(isinstance(q, Parameter) for q in self.parameters):
            raise ParameterError("Design: parameters must be flexmb.design.Parameter s")

    @property
    def names(self) -> tuple:
        """The parameters' names, in order."""
        return tuple(q.name for q in self.parameters)

    @property
    def values(self) -> dict:
        """The parameters' values ``{name: value}``."""
        return {q.name: float(q.value) for q in self.parameters}

    @property
    def bounds(self) -> list:
        """``[(lower, upper), ...]`` in the parameters' order."""
        return [(q.lower, q.upper) for q in self.parameters]

    def at(self, p: Mapping) -> Design:
        """The same design at other values ``p`` (a dict over some or all names; unknown names and
        non-finite values are refused naming them)."""
        p = _checked_values(self.names, p, partial=True)
        return attrs.evolve(self, parameters=tuple(attrs.evolve(q, value=p.get(q.name, q.value))
                                                   for q in self.parameters))

    def mechanism(self, p: Mapping | None = None):
        """``build(p)`` (the design's own values where ``p`` is None), checked to be a mechanism."""
        values = self.values if p is None else p
        mech = self.build(dict(values))
        if not hasattr(mech, "compile") or not hasattr(mech, "graph"):
            raise ParameterError(f"Design: build(p) must return a flexmb.Mechanism, got {type(mech).__name__}")
        return mech


def _checked_values(names, p, partial: bool = False) -> dict:
    """``p`` as {name: float}: every key a parameter of the design, every value finite."""
    if not isinstance(p, Mapping):
        raise ParameterError(f"design parameters must be a dict name -> float, got {type(p).__name__}")
    unknown = [k for k in p if k not in names]
    if unknown:
        raise ParameterError(f"unknown design parameter(s) {unknown}; the design's parameters: {list(names)}")
    missing = [k for k in names if k not in p]
    if missing and not partial:
        raise ParameterError(f"design parameter(s) {missing} not given; the design's parameters: {list(names)}")
    out = {}
    for k, x in p.items():
        try:
            out[k] = float(x)
        except (TypeError, ValueError):
            raise ParameterError(f"design parameter {k!r}={x!r} is not a real number") from None
        if isinstance(x, bool) or not math.isfinite(out[k]):
            raise ParameterError(f"design parameter {k!r}={x!r} must be a finite real number")
    return out


def as_design(build, p: Mapping | None = None, bounds: Mapping | None = None) -> Design:
    """A `Design` from a `Design` (at ``p`` if given) or from a function ``build`` and values ``p``
    (``bounds``: ``{name: (lower, upper)}`` for some of them)."""
    if isinstance(build, Design):
        return build if p is None else build.at(p)
    if p is None:
        raise ParameterError("design parameters p are needed with a build function (a dict name -> float)")
    bounds = dict(bounds or {})
    values = _checked_values(tuple(p), p)
    stray = [k for k in bounds if k not in values]
    if stray:
        raise ParameterError(f"bounds for unknown design parameter(s) {stray}; parameters: {list(values)}")
    return Design(build, [Parameter(k, x, *bounds.get(k, (-math.inf, math.inf))) for k, x in values.items()])


# -- the compiled model's numbers ----------------------------------------------------------------
def _problem(compiled):
    problem = compiled.problem
    if not hasattr(getattr(problem, "model", None), "elements"):
        raise UnsupportedStrategyError("design gradients need the finite-element model (method 'conventional' or "
                                       "'ksd-full'); the closed-form model of method 'newton' has none")
    if problem.model.hinges is not None:
        raise UnsupportedStrategyError(
            f"design gradients of mechanisms with ideal joints (flexmb.Hinge: {', '.join(problem.model.hinges.names)}) "
            "are not available: their constraint rows are not differentiated with respect to the design")
    return problem


def model_numbers(compiled, field: str) -> np.ndarray:
    """One of `MODEL_FIELDS` of a compiled finite-element model, as a float array."""
    problem = _problem(compiled)
    model, el, loads = problem.model, problem.model.elements, problem.loads
    rigid = model.rigid_masses
    if field == "rho_A":
        from ..sections import section_values

        rho, A = section_values(el.sections, ("density", "A"))
        return rho * A
    if field == "local_mass":
        from ..fe.mass import local_mass

        return local_mass(el.sections, el.L0, model.dim)
    if field.startswith("rigid_"):
        if rigid is None:
            return np.zeros((0,))
        return np.asarray({"rigid_mass": rigid.mass, "rigid_inertia": rigid.inertia,
                           "rigid_offset": rigid.offset}[field], dtype=float)
    if field.startswith("load_"):
        return np.asarray(getattr(loads, field[5:]), dtype=float)
    if field == "points":
        pts = [offset for _, offset in compiled.points.values()]
        return np.array(pts, dtype=float).reshape(len(pts), model.dim)
    if field == "values":
        return np.asarray(problem.values, dtype=float)
    if field == "chains":  # the rotation vectors of prescribed chains of rotations, flattened
        return np.concatenate([np.asarray(w, dtype=float).ravel() for _, w in problem.rotation_paths] + [np.zeros(0)])
    if field in ("x0", "point_offset"):
        return np.asarray(getattr(model, field), dtype=float)
    value = getattr(el, field)
    return np.zeros(0) if value is None else np.asarray(value, dtype=float)


def structure(compiled) -> dict:
    """What must not change with the design (`model_rates` compares it between builds)."""
    problem = _problem(compiled)
    model, loads = problem.model, problem.loads
    rigid = model.rigid_masses
    return {"dimension": model.dim, "nodes": model.n_nodes, "DOFs": model.n_dofs,
            "element ends": model.elements.ends, "point masters": model.point_master,
            "prescribed DOFs": problem.prescribed, "load nodes": loads.node,
            "rigid-mass nodes": np.zeros(0) if rigid is None else rigid.node,
            "links": tuple(compiled.link_node.items()),
            "joints' elements": tuple((k, tuple(v)) for k, v in compiled.joint_elements.items()),
            "named points": tuple((k, link) for k, (link, _) in compiled.points.items()),
            "rotation chains": tuple((tuple(d), len(w)) for d, w in problem.rotation_paths)}


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.shape(a) == np.shape(b) and bool(np.array_equal(a, b))
    return a == b


def check_structure(reference: dict, other: dict, name: str, value: float) -> None:
    """Refuse a build whose structure differs from ``reference`` (`TopologyError` naming ``name``)."""
    changed = [k for k in reference if not _same(reference[k], other[k])]
    if changed:
        raise TopologyError(f"design parameter {name!r}: the build at {name}={value!r} changes the model's topology "
                            f"({', '.join(changed)}); a design's element counts and numbering must not depend on "
                            "its parameters (fix the mesh sizes, e.g. elements_per_leaf, outside p)")


def numbers_field(nums: dict, field: str, dim: int) -> np.ndarray:
    """One of `MODEL_FIELDS` from `flexmb.fe.build.numbers` of a (complex) mechanism, as
    `model_numbers` reads it from a compiled model (complex where the numbers are)."""
    rigid, loads = nums["rigid"], nums["loads"]
    if field == "rho_A":
        from ..sections import section_values

        rho, A = section_values(nums["sections"], ("density", "A"))
        return rho * A
    if field == "local_mass":
        from ..fe.mass import local_mass

        return local_mass(nums["sections"], nums["L0"], dim)
    if field.startswith("rigid_"):
        return np.zeros((0,)) if rigid is None else np.asarray(getattr(rigid, field[6:]))
    if field.startswith("load_"):
        return np.asarray(getattr(loads, field[5:]))
    if field == "points":
        pts = [offset for _, offset in nums["points"].values()]
        return np.array(pts, dtype=_dtype(pts)).reshape(len(pts), dim)
    if field == "values":
        return np.asarray(nums["values"])
    if field == "chains":
        ws = [np.asarray(w).ravel() for _, w in nums["chains"]]
        return np.concatenate(ws + [np.zeros(0)])
    if field == "point_offset":
        return nums["point_x0"] - nums["x0"][nums["point_master"]]
    value = nums[field]
    return np.zeros(0) if value is None else np.asarray(value)


def _dtype(values) -> type:
    return complex if any(np.iscomplexobj(x) for x in values) else float


def numbers_structure(nums: dict, dim: int, link_node: dict, links: tuple) -> dict:
    """`structure` of `flexmb.fe.build.numbers`' output (``links``: the build's link names)."""
    rigid, loads = nums["rigid"], nums["loads"]
    ndof = 3 if dim == 2 else 6
    return {"dimension": dim, "nodes": len(nums["x0"]), "DOFs": len(nums["x0"]) * ndof, "element ends": nums["ends"],
            "point masters": nums["point_master"], "prescribed DOFs": nums["prescribed"], "load nodes": loads.node,
            "rigid-mass nodes": np.zeros(0) if rigid is None else rigid.node,
            "links": tuple((n, link_node.get(n)) for n in links),
            "joints' elements": tuple((k, tuple(v)) for k, v in nums["joint_elements"].items()),
            "named points": tuple((k, link) for k, (link, _) in nums["points"].items()),
            "rotation chains": tuple((tuple(d), len(w)) for d, w in nums["chains"])}


class ModelRates:
    """The rates of change of the compiled model's numbers with each parameter, at fixed topology.

    ``rate(field)`` (K, *shape of the field) for ``K`` parameters, read from each parameter's
    `flexmb.design.builds.ParameterBuild` (the complex step through the build, or central
    differences where it cannot pass: `flexmb.design.builds`), computed on first use and kept.
    ``methods``: per parameter ``(method, reason)``."""

    def __init__(self, design: Design, compiled, builds: list):
        self.design, self.compiled = design, compiled
        self.names = design.names
        self._builds = builds
        self._cache = {}
        #: the check's direction (K,) and its real builds ((weight, mechanism), ...), or None
        #: (`flexmb.design.builds`; a ``configure`` step is checked along it too)
        self.direction = None
        #: ``k -> ParameterBuild`` of central differences (real builds) for parameter ``k``, made on
        #: first use: where ``configure`` cannot carry a complex step (`flexmb.design.evaluate`)
        self.fallback = None

    @property
    def methods(self) -> tuple:
        """Per parameter ``(method, reason)``: ``"complex step"`` (reason ``""``) or ``"central
        differences"`` with why its complex step could not be used (`flexmb.design.builds`)."""
        return tuple((b.method, b.reason) for b in self._builds)

    def rate(self, field: str) -> np.ndarray:
        """d(field)/dp (K, *shape) [field unit per parameter unit]."""
        if field not in MODEL_FIELDS:
            raise ParameterError(f"no model field {field!r}; fields: {', '.join(MODEL_FIELDS)}")
        if field not in self._cache:
            base = self.compiled_numbers(field)
            dim = self.compiled.problem.model.dim
            out = np.zeros((len(self.names),) + base.shape)
            for k, b in enumerate(self._builds):
                out[k] = b.field(field, dim)
            out.flags.writeable = False
            self._cache[field] = out
        return self._cache[field]

    def build(self, k: int):
        """Parameter ``k``'s `flexmb.design.builds.ParameterBuild`."""
        return self._builds[k]

    @property
    def shared(self) -> dict:
        """Where derived data that do not depend on the configuration are kept (the responses'
        own model fields, e.g. `flexmb.design.stress`'s stress fields)."""
        return self._cache

    def compiled_numbers(self, field: str) -> np.ndarray:
        """The field's value in the compiled model the rates are taken about (`model_numbers`)."""
        key = ("value", field)
        if key not in self._cache:
            self._cache[key] = model_numbers(self.compiled, field)
        return self._cache[key]

    def kind(self, k: int) -> str:
        """What parameter ``k`` changes, for messages: "joint dimension or material" (beam elements'
        stiffness, lengths or mass), "placement" (reference positions and frames only), "mass"
        (the links' rigid masses), "load", "prescribed motion"; joined by "and" where it changes several."""
        groups = (("joint dimension or material", ("S", "L0", "rho_A")),
                  ("placement", ("point_offset", "x0", "ny0", "nz0", "alpha0", "points")),
                  ("mass", ("rigid_mass", "rigid_inertia", "rigid_offset")),
                  ("load", ("load_offset", "load_force", "load_moment")), ("prescribed motion", ("values", "chains")))
        kinds = [name for name, fields in groups if any(np.any(self.rate(f)[k] != 0.0) for f in fields)]
        if kinds and kinds[0] == "joint dimension or material":
            kinds = [k for k in kinds if k != "placement"]  # a joint's length moves its nodes too
        return " and ".join(kinds) or "nothing"

    def touched(self, k: int) -> bool:
        """Whether parameter ``k`` changes any model number at all."""
        return any(np.any(self.rate(f)[k] != 0.0) for f in MODEL_FIELDS if f != "local_mass")
