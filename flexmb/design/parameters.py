"""Design parameters: a design is ``build(p) -> Mechanism`` over named floats with bounds.

`Parameter` and `Design` are data; `model_rates` turns a design at ``p`` into the rates of
change of its compiled model's numbers (`MODEL_FIELDS`) per parameter, the one piece of the
gradient that differentiates the user's build. That piece is a central difference of the
*build* (the model's reference numbers: no solve, no state; smooth closed forms of the
parameters, e.g. ``Iz = w t^3 / 12``, a placement's ``origin + R s``); everything downstream
of the model numbers is exact (complex step through the numpy element kernels,
`flexmb.design.partials`; linear algebra, `flexmb.design.adjoint`). Complex step or automatic
differentiation through the build would need every validator, joint plugin and builder to
carry complex numbers, and a plugin that drops an imaginary part gives a silently zero
derivative; the difference of the build's numbers has a bounded error, measured in
tests/test_design_parameters.py (relative 1e-10 on the cantilever's closed forms).

The topology must not depend on ``p``: the structure of the compiled model (element ends, node
and point numbering, DOF layout, prescribed DOFs, load and mass rows) is compared between the
builds, and a change is refused (`flexmb.TopologyError` naming the parameter). Nor may the numbers
have a kink at the design (a ``max()``, a rounding, a branch on ``p`` in the build): the builds at
``p + h``, ``p`` and ``p - h`` tell it (forward and backward differences disagree), and it is
refused naming the parameter rather than averaged into a wrong gradient.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import attrs
import numpy as np

from ..errors import FlexmbError, ParameterError, TopologyError, UnsupportedStrategyError

__all__ = ["Parameter", "Design", "as_design", "ModelRates", "model_rates", "model_numbers", "MODEL_FIELDS",
           "RELATIVE_STEP"]

#: Relative step of the central difference of the build (times the parameter's scale): truncation
#: ~ step^2 and round-off ~ eps / step balance near 1e-5 (errors ~1e-10 relative on smooth builds).
RELATIVE_STEP = 1e-5

#: The numbers of a compiled finite-element model that a parameter can change (what the residual,
#: tangent and mass depend on besides the state): point offsets from their master nodes, element
#: lengths, stiffness, frames and mass per length, the nodes' reference positions, the links' rigid
#: masses, the loads, the prescribed values and the named points' offsets.
MODEL_FIELDS = ("point_offset", "L0", "S", "ny0", "nz0", "alpha0", "rho_A", "local_mass", "x0", "rigid_mass",
                "rigid_inertia", "rigid_offset", "load_offset", "load_force", "load_moment", "values", "chains", "points")


@attrs.frozen
class Parameter:
    """A named design parameter: ``value`` within [``lower``, ``upper``] (its unit is the build's).

    ``scale``: the parameter's typical size, for the build's difference step
    (`RELATIVE_STEP` times it); default ``max(|value|, (upper - lower) / 100)``, 1 where both are 0
    or unbounded."""

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
    def step(self) -> float:
        """The build's central-difference step [the parameter's unit]."""
        if self.scale is not None:
            return RELATIVE_STEP * abs(self.scale)
        span = self.upper - self.lower
        scale = max(abs(self.value), span / 100.0 if math.isfinite(span) else 0.0)
        return RELATIVE_STEP * (scale if scale > 0.0 else 1.0)


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
        from ..sections import properties

        rho, A = properties(el.sections, ("density", "A"))
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


class ModelRates:
    """The rates of change of the compiled model's numbers with each parameter, at fixed topology.

    ``rate(field)`` (K, *shape of the field) for ``K`` parameters, by central differences of the
    build (one-sided second order at a bound), computed on first use and kept."""

    def __init__(self, design: Design, compiled, builds: list, mechanisms: list | None = None):
        self.design, self.compiled = design, compiled
        self.names = design.names
        self._builds = builds  # per parameter: ((weight, compiled or None: the base), ...) and the step
        self._mechanisms = mechanisms or []  # per parameter: ((weight, mechanism or None), ...)
        self._cache = {}

    def rate(self, field: str) -> np.ndarray:
        """d(field)/dp (K, *shape) [field unit per parameter unit]."""
        if field not in MODEL_FIELDS:
            raise ParameterError(f"no model field {field!r}; fields: {', '.join(MODEL_FIELDS)}")
        if field not in self._cache:
            base = model_numbers(self.compiled, field)
            out = np.zeros((len(self.names),) + base.shape)
            for k, (stencil, h) in enumerate(self._builds):
                values = [(w, model_numbers(c, field) if c is not None else base) for w, c in stencil]
                out[k] = sum(w * v for w, v in values) / h
                if len(values) == 2:  # central: the base build tells a kink in build(p) (module notes)
                    _check_smooth(self.names[k], field, base, values[1][1], values[0][1], h)
            out.flags.writeable = False
            self._cache[field] = out
        return self._cache[field]

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
        return any(np.any(self.rate(f)[k] != 0.0) for f in MODEL_FIELDS)


#: The largest difference of a model number's forward and backward differences about the design,
#: relative to the field's largest rate, that passes as smooth: a smooth build differs by ~(step /
#: scale) (p N''/N') ~ 1e-5; a kink (max(), a branch, a rounding) by order 1.
KINK = 1e-3


def _check_smooth(name: str, field: str, base: np.ndarray, plus: np.ndarray, minus: np.ndarray, h: float) -> None:
    """Refuse (`ParameterError`) a build whose model numbers have a kink at the design in parameter
    ``name``: their forward and backward differences (builds at ``p + h``, ``p``, ``p - h``)
    disagree by more than `KINK` of the field's largest rate, where a central difference would
    silently average two slopes."""
    if base.size == 0:
        return
    fwd, bwd = (plus - base) / h, (base - minus) / h
    scale = max(float(np.max(np.abs(fwd))), float(np.max(np.abs(bwd))))
    floor = 1e3 * np.finfo(float).eps * float(np.max(np.abs(base))) / h  # round-off of the differences
    worst = float(np.max(np.abs(fwd - bwd)))
    if worst > KINK * scale + floor:
        raise ParameterError(f"design parameter {name!r}: build(p) is not smooth in it at the design (the model's "
                             f"{field} changes at different rates above and below it: {worst:.3g} against {scale:.3g}); "
                             "a max(), a rounding or a branch on the parameter in build(p) has no derivative there")


def _stencil(q: Parameter) -> tuple:
    """Points (offsets from the value) and weights of the build's difference for ``q``: central,
    or one-sided of second order where a bound is nearer than the step."""
    h = q.step
    if q.value - h >= q.lower and q.value + h <= q.upper:
        return ((-h, -0.5), (h, 0.5)), h
    if q.value + 2 * h <= q.upper:
        return ((0.0, -1.5), (h, 2.0), (2 * h, -0.5)), h
    if q.value - 2 * h >= q.lower:
        return ((0.0, 1.5), (-h, -2.0), (-2 * h, 0.5)), h
    raise ParameterError(f"design parameter {q.name!r}: its bounds [{q.lower!r}, {q.upper!r}] are narrower than the "
                         f"build's difference step {h:g}; give the parameter a smaller scale")


def model_rates(design: Design, compiled) -> ModelRates:
    """Build the design at the difference points of every parameter, check the topology, and return
    the `ModelRates` about ``compiled`` (the compiled model of ``design.mechanism()``)."""
    reference = structure(compiled)
    values = design.values
    builds, mechanisms = [], []
    for q in design.parameters:
        stencil, h = _stencil(q)
        points, mechs = [], []
        for offset, w in stencil:
            if offset == 0.0:
                points.append((w, None))
                mechs.append((w, None))
                continue
            p = dict(values)
            p[q.name] = q.value + offset
            try:
                mech = design.mechanism(p)
                other = mech.compile("fe_model")
            except FlexmbError as exc:
                raise type(exc)(f"design parameter {q.name!r}: the build at {q.name}={p[q.name]!r} (the gradient's "
                                f"difference step) fails: {exc}") from exc
            check_structure(reference, structure(other), q.name, p[q.name])
            points.append((w, other))
            mechs.append((w, mech))
        builds.append((tuple(points), h))
        mechanisms.append(tuple(mechs))
        _check_touched(q, compiled, points)
    return ModelRates(design, compiled, builds, mechanisms)


def _check_touched(q: Parameter, compiled, points) -> None:
    """Refuse a parameter that changes no model number (no joint, link, placement, load or
    prescribed motion reads it: a misspelt or unused name)."""
    fields = [f for f in MODEL_FIELDS if f != "local_mass"]  # local_mass follows L0 and the sections (rho_A)
    others = [c if c is not None else compiled for _, c in points]
    for f in fields:
        base = model_numbers(compiled, f)
        if any(not np.array_equal(base, model_numbers(c, f)) for c in others):
            return
    raise ParameterError(f"design parameter {q.name!r} changes nothing in the model: no joint, link, placement, load "
                         "or prescribed motion of the build depends on it")
