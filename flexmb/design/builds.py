"""The builds of a design that its model numbers' rates are read from, one `ParameterBuild` per parameter.

The rule (``docs/design-loops.md``, "How the build is differentiated"):

1. **Complex step** (Squire & Trapp 1998; Martins, Sturdza & Alonso 2003): one build per
   parameter at ``p_k + i h`` (``h`` = `flexmb.design.parameters.H` times its scale), its model
   numbers (`flexmb.fe.build.numbers`) carry ``N(p) + i h N'(p)``: exact to round-off, one build.
2. **Central differences of the build where the complex step cannot pass**: a build, a joint
   plugin or a validator that refuses complex numbers (``TypeError`` of ``float(complex)``,
   ``math.sin``, a comparison or ``max()`` on ``p``; numpy's ``ComplexWarning``, an error here; a
   ``ValueError``, ``AttributeError`` or any `flexmb.FlexmbError` of the complex build) falls
   back, for that parameter, to central differences of real builds (two builds; one-sided of
   second order at a bound; a kink at the design refused naming the parameter). `ParameterBuild.reason` says why (the joint or line).
3. **A check for silent drops** (``abs()``, ``np.linalg.norm``, ``.real`` of ``p``'s numbers give a
   real number without error): the complex-step rates along one direction of all parameters
   (random signs, each parameter's difference step) are compared with central differences of two
   real builds along it (`DIRECTION_AGREEMENT`); where they disagree, each complex-step parameter
   is compared with its own central differences and those that disagree fall back (rule 2).

So a derivative is never silently wrong beyond `DIRECTION_AGREEMENT` of a field's rate; the
cost is one build per parameter plus two, or two per parameter that falls back.
"""

from __future__ import annotations

import contextlib
import warnings

import attrs
import numpy as np

from .. import _validate as v
from ..errors import FlexmbError, ParameterError
from .parameters import H, ModelRates, check_structure, numbers_field, numbers_structure, structure

__all__ = ["model_rates", "ParameterBuild", "compiled_numbers", "agrees", "COMPLEX_STEP", "CENTRAL", "DIRECTION_AGREEMENT"]

COMPLEX_STEP, CENTRAL = "complex step", "central differences"

#: Agreement (relative to a field's largest rate along the check's direction) of the complex-step
#: rates with central differences of the build along one direction: the differences' truncation
#: is ~(step / scale)^2 = 1e-10 and their round-off ~eps / 1e-5 = 2e-11 of the field.
DIRECTION_AGREEMENT = 1e-6

#: Model fields the check compares (``local_mass`` follows from the sections and L0: ``S`` and
#: ``rho_A`` carry its numbers).
_CHECKED = ("point_offset", "L0", "S", "ny0", "nz0", "alpha0", "rho_A", "x0", "rigid_mass", "rigid_inertia",
            "rigid_offset", "load_offset", "load_force", "load_moment", "values", "chains", "points")

#: A complex build's failures that mean "the complex step cannot pass here" (rule 2).
_NOT_COMPLEX = (TypeError, ValueError, AttributeError, ArithmeticError, np.exceptions.ComplexWarning,
                FlexmbError)


@attrs.frozen(eq=False)
class ParameterBuild:
    """How one parameter's model-number rates are read.

    ``method``: `COMPLEX_STEP` (``points``: one ``(None, mechanism, numbers)`` of the complex build;
    a rate is ``Im(N) / h``) or `CENTRAL` (``points``: ``(weight, mechanism, numbers)`` of real
    builds; a rate is ``sum(weight N) / h``); ``reason``: why the parameter fell back (empty for
    the complex step)."""

    method: str
    points: tuple
    h: float
    reason: str = ""

    def combine(self, read) -> np.ndarray:
        """The rate of ``read(mechanism, numbers)`` (an array) [its unit per the parameter's unit]."""
        if self.method == COMPLEX_STEP:
            ((_, mech, nums),) = self.points
            value = read(mech, nums)
            return np.imag(value) / self.h if np.iscomplexobj(value) else np.zeros(np.shape(value))
        return sum(w * np.real(read(mech, nums)) for w, mech, nums in self.points) / self.h

    def field(self, field: str, dim: int) -> np.ndarray:
        """The rate of one of `flexmb.design.parameters.MODEL_FIELDS`."""
        return self.combine(lambda _, nums: numbers_field(nums, field, dim))


def _build(design, p: dict, link_node: dict, complex_step: bool = False):
    """``(mechanism, numbers)`` of ``design`` at ``p`` (numpy's ``ComplexWarning`` an error for a complex step)."""
    from ..fe.build import numbers

    with warnings.catch_warnings(), (v.complex_step() if complex_step else contextlib.nullcontext()):
        if complex_step:
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
        mech = design.mechanism(p)
        if getattr(mech, "joint_points", None) and not complex_step:  # refined meshes: from the compiled model
            return mech, compiled_numbers(mech.compile("fe_model"))
        return mech, numbers(mech, link_node)


def compiled_numbers(compiled) -> dict:
    """`flexmb.fe.build.numbers`' dict read from a compiled model (a mechanism with points inside
    joints, `flexmb.Mechanism.add_joint_point`, whose refined mesh only `Mechanism.compile` makes)."""
    problem = compiled.problem
    model, el = problem.model, problem.model.elements
    return {"x0": model.x0, "point_x0": model.point_x0, "point_master": model.point_master, "L0": el.L0, "S": el.S,
            "ny0": el.ny0, "nz0": el.nz0, "alpha0": el.alpha0, "sections": el.sections, "ends": el.ends,
            "rigid": model.rigid_masses, "prescribed": problem.prescribed, "values": problem.values,
            "loads": problem.loads, "chains": problem.rotation_paths, "points": compiled.points,
            "joint_elements": compiled.joint_elements}


def _complex(design, q, link_node: dict, check) -> ParameterBuild | str:
    """Parameter ``q``'s complex-step build, or the reason it cannot pass (rule 2)."""
    h = H * q.size
    p = design.values
    p[q.name] = complex(q.value, h)
    try:
        mech, nums = _build(design, p, link_node, complex_step=True)
    except _NOT_COMPLEX as exc:
        return f"its complex step does not pass {culprit(exc)} ({type(exc).__name__}: {exc})"
    check(nums, mech, q.name, q.value)
    return ParameterBuild(COMPLEX_STEP, ((None, mech, nums),), h)


def _stencil(q) -> tuple:
    """Offsets from the value and weights of ``q``'s central difference, or one-sided of second
    order where a bound is nearer than the step; and the step."""
    h = q.step
    if q.value - h >= q.lower and q.value + h <= q.upper:
        return ((-h, -0.5), (h, 0.5)), h
    if q.value + 2 * h <= q.upper:
        return ((0.0, -1.5), (h, 2.0), (2 * h, -0.5)), h
    if q.value - 2 * h >= q.lower:
        return ((0.0, 1.5), (-h, -2.0), (-2 * h, 0.5)), h
    raise ParameterError(f"design parameter {q.name!r}: its bounds [{q.lower!r}, {q.upper!r}] are narrower than the "
                         f"build's difference step {h:g}; give the parameter a smaller scale")


def _central(design, q, link_node: dict, check, base, dim: int, reason: str) -> ParameterBuild:
    """Parameter ``q``'s real builds for central differences (rule 2), kinks at the design refused."""
    stencil, h = _stencil(q)
    points = []
    for offset, w in stencil:
        if offset == 0.0:
            points.append((w, *base()))
            continue
        p = design.values
        p[q.name] = q.value + offset
        try:
            mech, nums = _build(design, p, link_node)
        except FlexmbError as exc:
            raise type(exc)(f"design parameter {q.name!r}: the build at {q.name}={p[q.name]!r} (the gradient's "
                            f"difference step) fails: {exc}") from exc
        check(nums, mech, q.name, p[q.name])
        points.append((w, mech, nums))
    if len(points) == 2:  # central: the base build tells a kink in build(p)
        _check_smooth(q.name, points, base()[1], h, dim)
    return ParameterBuild(CENTRAL, tuple(points), h, reason)


#: The largest difference of a model number's forward and backward differences about the design,
#: relative to the field's largest rate, that passes as smooth: a smooth build differs by ~(step /
#: scale) (p N''/N') ~ 1e-5; a kink (max(), a branch, a rounding) by order 1.
KINK = 1e-3


def _check_smooth(name: str, points, base_nums: dict, h: float, dim: int) -> None:
    """Refuse (`ParameterError`) a build whose model numbers have a kink at the design in parameter
    ``name``: forward and backward differences disagree by more than `KINK` of the field's largest
    rate, where a central difference would silently average two slopes."""
    for field in _CHECKED:
        base = np.real(numbers_field(base_nums, field, dim))
        if base.size == 0:
            continue
        minus, plus = (np.real(numbers_field(nums, field, dim)) for _, _, nums in points)
        fwd, bwd = (plus - base) / h, (base - minus) / h
        scale = max(float(np.max(np.abs(fwd))), float(np.max(np.abs(bwd))))
        floor = 1e3 * np.finfo(float).eps * float(np.max(np.abs(base))) / h  # round-off of the differences
        worst = float(np.max(np.abs(fwd - bwd)))
        if worst > KINK * scale + floor:
            raise ParameterError(f"design parameter {name!r}: build(p) is not smooth in it at the design (the "
                                 f"model's {field} changes at different rates above and below it: {worst:.3g} against "
                                 f"{scale:.3g}); a max(), a rounding or a branch on the parameter in build(p) has no "
                                 "derivative there")


def culprit(exc: BaseException) -> str:
    """The joint (its kind and class: a plugin's module) or the line of the build where ``exc``
    arose: the innermost joint's frame, else the innermost frame outside flexmb."""
    from ..joints._base import Joint

    tb, joint, user = exc.__traceback__, None, None
    while tb is not None:
        frame = tb.tb_frame
        me = frame.f_locals.get("self", frame.f_locals.get("cls"))
        cls = type(me) if isinstance(me, Joint) else me if isinstance(me, type) and issubclass(me, Joint) else None
        module = frame.f_globals.get("__name__", "")
        if cls is not None:
            joint = f"joint {cls.kind!r} ({cls.__module__}.{cls.__qualname__}, line {tb.tb_lineno})"
        elif module != "flexmb" and not module.startswith("flexmb."):
            user = f"{frame.f_code.co_filename}, line {tb.tb_lineno} (in {frame.f_code.co_name})"
        tb = tb.tb_next
    return joint or user or "flexmb's build"


def _context(design, compiled) -> tuple:
    """``(check, base)``: the topology check of a build against ``compiled`` (`flexmb.TopologyError`
    naming the parameter) and the design's own real build ``(mechanism, numbers)``, made on first use."""
    reference = structure(compiled)
    dim, link_node = compiled.problem.model.dim, compiled.link_node
    cache = {}

    def check(nums, mech, name, value):
        check_structure(reference, numbers_structure(nums, dim, link_node, tuple(mech.links)), name, value)

    def base():
        if "base" not in cache:
            cache["base"] = _build(design, design.values, link_node)
        return cache["base"]

    return check, base


def _direction(design, builds) -> tuple[np.ndarray, tuple]:
    """The check's direction (per parameter, its difference step times a random sign; 0 for the
    parameters that fell back, and for one with no room for two steps inside its bounds) and
    its stencil ``((t, weight), ...)``: central, or one-sided of second order (signs pointing inward)
    when a parameter lies within a step of a bound."""
    rng = np.random.default_rng(20261129)
    d = np.zeros(len(builds))
    central = True
    for k, (q, b) in enumerate(zip(design.parameters, builds)):
        if b.method != COMPLEX_STEP:
            continue
        s = q.step
        d[k] = s * rng.choice((-1.0, 1.0))
        if not (q.lower <= q.value - s and q.value + s <= q.upper):
            central = False
            d[k] = s if q.value + 2 * s <= q.upper else -s if q.value - 2 * s >= q.lower else 0.0
    if central:
        return d, ((-1.0, -0.5), (1.0, 0.5))
    # one-sided: the parameters with room both ways keep their random sign (2 steps fit or they are left out)
    for k, q in enumerate(design.parameters):
        if d[k] != 0.0 and not (q.lower <= q.value + 2 * d[k] <= q.upper):
            d[k] = 0.0
    return d, ((0.0, -1.5), (1.0, 2.0), (2.0, -0.5))


def _direction_check(design, rates: ModelRates, check, base) -> dict:
    """Rule 3: ``{k: reason}`` for the complex-step parameters whose rates disagree with central
    differences of the build (empty when the rates along the check's direction agree)."""
    builds, compiled = rates._builds, rates.compiled
    dim, link_node = compiled.problem.model.dim, compiled.link_node
    d, stencil = _direction(design, builds)
    if not np.any(d):
        return {}
    names = design.names
    points = []
    for t, w in stencil:
        if t == 0.0:
            points.append((w, *base()))
            continue
        p = {n: x + t * dk for (n, x), dk in zip(design.values.items(), d)}
        try:
            mech, nums = _build(design, p, link_node)
        except FlexmbError as exc:
            raise type(exc)(f"design parameters {[n for n, dk in zip(names, d) if dk]}: the build a difference step "
                            f"away ({p}: the check of the gradient's complex step) fails: {exc}") from exc
        check(nums, mech, "(the check's direction)", p)
        points.append((w, mech, nums))
    ref = base()[1]
    rates.direction = (d, tuple((w, mech) for w, mech, _ in points))  # configure's check (evaluate)
    bad = [f for f in _CHECKED
           if not agrees(sum(w * np.real(numbers_field(n, f, dim)) for w, _, n in points),
                         np.tensordot(d, rates.rate(f), axes=1), magnitude(ref, f, dim))]
    if not bad:
        return {}
    return _culprits(design, builds, link_node, check, base, dim, bad)


def magnitude(ref: dict, field: str, dim: int) -> float:
    """The size of a field's numbers in ``ref`` (`flexmb.fe.build.numbers`) that sets its differences'
    round-off (point offsets: the positions they are differences of)."""
    values = np.real(numbers_field(ref, "x0" if field == "point_offset" else field, dim))
    return float(np.abs(values).max(initial=0.0))


def agrees(fd: np.ndarray, cs, size: float, agreement: float = DIRECTION_AGREEMENT) -> bool:
    """Whether a field's rate ``cs`` agrees with its differences ``fd`` (both per unit of the
    stencil's step), within ``agreement`` of the larger plus the differences' round-off (numbers of
    magnitude ``size``)."""
    cs = np.zeros(np.shape(fd)) if np.isscalar(cs) else cs
    if np.size(fd) == 0:
        return True
    floor = 1e3 * np.finfo(float).eps * size
    larger = max(float(np.abs(fd).max()), float(np.abs(cs).max()))
    return float(np.abs(fd - cs).max()) <= agreement * larger + floor


def _culprits(design, builds, link_node, check, base, dim, fields) -> dict:
    """Each complex-step parameter's rates against its own central differences in ``fields``:
    ``{k: reason}`` for those that disagree (all of them if none does alone)."""
    out = {}
    ks = [k for k, b in enumerate(builds) if b.method == COMPLEX_STEP]
    for k in ks:
        q = design.parameters[k]
        fd = _central(design, q, link_node, check, base, dim, "")
        for f in fields:
            a, b = fd.field(f, dim), builds[k].field(f, dim)
            if not agrees(q.step * a, q.step * b, magnitude(base()[1], f, dim)):
                err = float(np.abs(a - b).max())
                out[k] = (f"its complex step is dropped silently on the way into the model's {f} (its rate is "
                          f"{err:.3g} off central differences of the build: abs(), np.linalg.norm or .real of "
                          "p's numbers in the build or a joint plugin)")
                break
    if not out:
        out = {k: "the complex-step rates disagree with central differences of the build along the check's "
                  f"direction in {', '.join(fields)}" for k in ks}
    return out


def model_rates(design, compiled) -> ModelRates:
    """The `flexmb.design.parameters.ModelRates` about ``compiled`` (the compiled model of
    ``design.mechanism()``) by the module's rule: one complex-step build per parameter, central
    differences where it cannot pass or drops it silently; the topology checked at every build
    (`flexmb.TopologyError` naming the parameter); a parameter that changes no model number is
    refused naming it."""
    check, base = _context(design, compiled)
    link_node, dim = compiled.link_node, compiled.problem.model.dim
    builds = []
    for q in design.parameters:
        b = _complex(design, q, link_node, check)
        builds.append(b if isinstance(b, ParameterBuild) else _central(design, q, link_node, check, base, dim, b))
    rates = ModelRates(design, compiled, builds)
    failed = _direction_check(design, rates, check, base)
    if failed:
        direction = rates.direction
        for k, message in failed.items():
            builds[k] = _central(design, design.parameters[k], link_node, check, base, dim, message)
        rates = ModelRates(design, compiled, builds)
        rates.direction = direction
    central = {}

    def fallback(k: int) -> ParameterBuild:
        if builds[k].method == CENTRAL:
            return builds[k]
        if k not in central:
            central[k] = _central(design, design.parameters[k], link_node, check, base, dim,
                                  "configure cannot carry its complex step")
        return central[k]

    rates.fallback = fallback
    for k, q in enumerate(design.parameters):
        if not rates.touched(k):
            raise ParameterError(f"design parameter {q.name!r} changes nothing in the model: no joint, link, placement, "
                                 "load or prescribed motion of the build depends on it")
    return rates
