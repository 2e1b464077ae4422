"""The peak von Mises stress as a smooth aggregate: the Kreisselmeier-Steinhauser (KS) function.

``KS(sigma) = (s / rho) ln sum_i exp(rho sigma_i / s)`` over the von Mises stress ``sigma_i`` at
fixed perimeter points of every element end (`flexmb.fe.stress`: Saint-Venant torsion, Jourawski
shear, normal stress from N, My, Mz; ``points`` of its `PERIMETER_POINTS` per section, the corners
included). ``s`` [Pa] is a fixed stress scale (default: the sections' yield stress) so that ``rho``
is dimensionless; ``max_i sigma_i <= KS <= max_i sigma_i + s ln(n) / rho`` for ``n`` points
(Kreisselmeier & Steinhauser 1979; Martins & Poon 2005). The exact peak over all perimeter points
(`flexmb.Solution.stresses`, not differentiable where the peak moves between points) is reported
beside it (`report`). The KS value is a smooth function of the state and the model numbers: its
derivative is exact (complex step through the element kernels and the stress fields).
"""

from __future__ import annotations

import functools
import types

import attrs
import numpy as np

from ..errors import ModelError, ParameterError
from ..fe.stress import PERIMETER_POINTS, TORSION_TERMS
from .base import Response
from .partials import H, _element_hits, _elements

__all__ = ["stress", "stress_units", "DEFAULT_RHO"]

#: Softmax weights below this (relative to their sum, 1) leave an element out of the derivative:
#: its stresses would change the aggregate's derivative by less than 1e-20 of their own.
WEIGHT_FLOOR = 1e-20

#: KS parameter: the aggregate exceeds the sampled maximum by at most s ln(n) / 50 (n = 2560 points
#: of a 10-element leaf: 16 % of s; ~2 % above the peak when the peak region spans ~50 points).
DEFAULT_RHO = 50.0

#: The section numbers `section_units` reads (with the shape's name).
_SHAPE_NUMBERS = ("ymax", "zmax", "A", "It", "Iy", "Iz")


def stress_units(model, points: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Per element the unit stress fields at ``points`` perimeter points (E, points, 8): ``z/Iy``,
    ``y/Iz`` (normal stress per unit My, Mz) and the shear vectors per unit T, Vy, Vz; and ``1/A`` (E,).
    Each distinct section's fields are `section_units` (the sampled points alone), kept per its numbers."""
    sections = model.elements.sections
    out, inv_A = [], []
    for s in sections:
        if s.shape is None:
            raise ModelError("the stress response needs every section's shape (flexmb.rectangle or flexmb.circle)")
        out.append(_kept_units(s.shape, *(float(getattr(s, a)) for a in _SHAPE_NUMBERS), points))
        inv_A.append(1.0 / s.A)
    return np.array(out).reshape(len(sections), -1, 8), np.array(inv_A)


@functools.lru_cache(maxsize=256)
def _kept_units(shape: str, ymax: float, zmax: float, A: float, It: float, Iy: float, Iz: float, points: int):
    """`section_units` of a float section given by its numbers (read-only, kept: a design's
    configurations and its re-evaluations share them)."""
    out = section_units(types.SimpleNamespace(shape=shape, ymax=ymax, zmax=zmax, A=A, It=It, Iy=Iy, Iz=Iz), points)
    out.flags.writeable = False
    return out


def section_units(section, points: int = 64) -> np.ndarray:
    """`stress_units`' fields (points, 8) of one section at every ``PERIMETER_POINTS // points``-th
    perimeter point, evaluated at those points alone and in complex arithmetic where the section's
    numbers are complex (a complex-step build: their derivatives in the imaginary parts). The same
    closed forms as `flexmb.fe.stress` (Timoshenko & Goodier 1970, Sec. 109: the rim's series of
    Prandtl's stress function; Jourawski's parabola; the circle's closed forms), with the
    modulus replaced by its analytic continuation on the rim (``|x| = sign(Re x) x``)."""
    n, stride = PERIMETER_POINTS, PERIMETER_POINTS // points
    idx = np.arange(0, n, stride)
    ymax, zmax, A, It = section.ymax, section.zmax, section.A, section.It
    if section.shape == "circle":
        th = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)[idx]
        c, s_ = np.cos(th), np.sin(th)
        t = np.stack([-s_, c], axis=1)
        yz = ymax * np.stack([c, s_], axis=1)
        tT, tVy, tVz = (ymax / It) * t, (-(4.0 / (3.0 * A)) * s_)[:, None] * t, ((4.0 / (3.0 * A)) * c)[:, None] * t
    else:
        u = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, n // 4 + 1)[:-1]))
        one = np.ones_like(u)
        fy = np.concatenate([one, 1 - 2 * u, -one, 2 * u - 1])[idx]  # the points as fractions of ymax, zmax
        fz = np.concatenate([2 * u - 1, one, 1 - 2 * u, -one])[idx]
        side, corner = idx // (n // 4), idx % (n // 4) == 0  # sides: y = +ymax, z = +zmax, y = -ymax, z = -zmax
        y, z = ymax * fy, zmax * fz
        if np.real(ymax) <= np.real(zmax):
            tp, tq = _rim(fy, fz, ymax, zmax, side % 2 == 0, corner)
            tT = np.stack([tp, tq], axis=1)
        else:
            tp, tq = _rim(fz, fy, zmax, ymax, side % 2 == 1, corner)
            tT = -np.stack([tq, tp], axis=1)
        tT = tT / It
        zero = np.zeros_like(fy)
        tVy = np.stack([1.5 / A * (1.0 - fy**2), zero], axis=1)
        tVz = np.stack([zero, 1.5 / A * (1.0 - fz**2)], axis=1)
        yz = np.stack([y, z], axis=1)
    return np.column_stack([yz[:, 1] / section.Iy, yz[:, 0] / section.Iz, tT, tVy, tVz])


def _units(sections, points: int, table: dict) -> tuple[np.ndarray, np.ndarray]:
    """`section_units` (E, points, 8) and ``1/A`` (E,) of a mesh's ``sections`` (each distinct one
    evaluated once, kept in ``table``; complex where a section's numbers are)."""
    for s in sections:
        if id(s) not in table:
            numbers = [getattr(s, a) for a in _SHAPE_NUMBERS]
            real = not any(np.iscomplexobj(x) for x in numbers)  # a section the step leaves: its kept fields
            units = _kept_units(s.shape, *map(float, numbers), points) if real else section_units(s, points)
            table[id(s)] = (s, units, 1.0 / s.A)  # s kept: its id stays its own
    rows = [table[id(s)] for s in sections]
    units = np.array([r[1] for r in rows]).reshape(len(sections), -1, 8)
    return units, np.array([r[2] for r in rows])


def _rim(fp, fq, a, b, long, corner):
    """Saint-Venant shear per unit ``G theta`` (tau_p, tau_q) at rim points ``(fp a, fq b)`` of the
    rectangle ``|p| <= a <= b``: on the long sides (``long``: ``|p| = a``) ``tau_q = sign(p) (2a -
    16a/pi^2 sum 1/n^2 cosh(n pi q/2a)/cosh(n pi b/2a))``, on the short ones ``tau_p = -sign(q) 16a/
    pi^2 sum (-1)^((n-1)/2)/n^2 tanh(n pi b/2a) cos(n pi p/2a)``, nil at the corners (as
    `flexmb.fe.stress`); complex ``a``, ``b`` carried analytically."""
    n = np.arange(1, 2 * TORSION_TERMS, 2, dtype=float)[:, None]
    sgn = np.where(((n - 1) / 2) % 2 == 0, 1.0, -1.0)
    k = n * np.pi / (2.0 * a)
    c = 16.0 * a / np.pi**2
    dt = np.result_type(a, b, float)
    tau_p, tau_q = np.zeros(len(fp), dtype=dt), np.zeros(len(fp), dtype=dt)
    on = long & ~corner
    d = np.abs(fq[on]) * b  # |q| (fractions real: the modulus continued as sign(Re q) q)
    x, X = k * d, k * b
    exp, tanh, cos = _first_order(a, b) or (np.exp, np.tanh, np.cos)
    ch = exp(x - X) / (1.0 + exp(-2.0 * X)) * (1.0 + exp(-2.0 * x))
    tau_q[on] = np.sign(fp[on]) * (2.0 * a - c * np.sum(ch / n**2, axis=0))
    on = ~long & ~corner
    g = c * np.sum(sgn / n**2 * tanh(k * b) * cos(k * np.abs(fp[on]) * a), axis=0)
    tau_p[on] = -np.sign(fq[on]) * g
    return tau_p, tau_q


#: Imaginary parts below this (absolute) make ``exp``, ``tanh``, ``cos`` of ``u + i v`` their first
#: order in ``v`` exactly in double precision (``cos v = 1 - v^2/2``, ``sin v = v - v^3/6``): a complex
#: step's ``v`` is ~1e-30 of the numbers.
FIRST_ORDER = 1e-9


def _first_order(a, b):
    """``(exp, tanh, cos)`` of complex arrays to first order in their imaginary parts (one real
    function each instead of the complex one), for a complex step's section numbers ``a``, ``b``
    (their imaginary parts below `FIRST_ORDER` relative to the real ones); None otherwise."""
    if not (np.iscomplexobj(a) or np.iscomplexobj(b)):
        return None
    if max(abs(np.imag(a)) / abs(np.real(a)), abs(np.imag(b)) / abs(np.real(b))) >= FIRST_ORDER:
        return None
    return (lambda z: np.exp(z.real) * (1.0 + 1j * z.imag), _tanh_first_order,
            lambda z: np.cos(z.real) - 1j * z.imag * np.sin(z.real))


def _tanh_first_order(z):
    """``tanh(u + i v) = tanh u + i v sech^2 u`` to first order in ``v``, ``sech^2 u = 4 e^-2|u| /
    (1 + e^-2|u|)^2`` (no overflow for large ``|u|``)."""
    e = np.exp(-2.0 * np.abs(z.real))
    return np.tanh(z.real) + 1j * z.imag * (4.0 * e / (1.0 + e) ** 2)


def _resultants(e, sig, L0, dim) -> np.ndarray:
    """The section resultants (B, 8) ``[N, T, Vy, Vz, My_p, My_q, Mz_p, Mz_q]`` of B elements from their
    deformations, generalised stresses and lengths (`flexmb.fe.stress.section_resultants`);
    complex-safe."""
    l = L0 + e[:, 0]
    r = np.zeros((len(L0), 8), dtype=np.result_type(e, sig, L0))
    r[:, 0] = sig[:, 0]
    if dim == 2:
        r[:, 2] = L0 * (sig[:, 1] - sig[:, 2]) / l
        r[:, 6:8] = L0[:, None] * sig[:, 1:3]
    else:
        r[:, 1], r[:, 2], r[:, 3] = L0 * sig[:, 1], L0 * (sig[:, 4] - sig[:, 5]) / l, L0 * (sig[:, 3] - sig[:, 2]) / l
        r[:, 4:6], r[:, 6:8] = L0[:, None] * sig[:, 2:4], L0[:, None] * sig[:, 4:6]
    return r


def _stress_parts(r, units, inv_A):
    """The normal stress ``sx`` and the shear vector ``(t0, t1)`` (B, 2, P) at the points of both ends
    from the resultants ``r`` (B, 8) (`_resultants`) and the unit fields."""
    u = units[:, None]  # (B, 1, P, 8)
    c = lambda j: r[:, j, None, None]
    sx = (r[:, 0] * inv_A)[:, None, None] + r[:, 4:6, None] * u[..., 0] - r[:, 6:8, None] * u[..., 1]
    t0 = c(1) * u[..., 2] + c(2) * u[..., 4] + c(3) * u[..., 6]
    t1 = c(1) * u[..., 3] + c(2) * u[..., 5] + c(3) * u[..., 7]
    return sx, t0, t1


def _von_mises(e, sig, L0, units, inv_A, dim):
    """von Mises stress (B, 2, P) at the points of both ends from deformations, generalised
    stresses and lengths of B elements (`flexmb.fe.stress.section_resultants`); complex-safe."""
    sx, t0, t1 = _stress_parts(_resultants(e, sig, L0, dim), units, inv_A)
    return np.sqrt(sx * sx + 3.0 * (t0 * t0 + t1 * t1))


def _aggregate_rates(r, units, inv_A, w):
    """The weighted sum ``J = sum_i w_i sigma_i``'s partial derivatives (the weights held) with respect
    to the resultants (B, 8), the unit fields (B, P, 8) and ``1/A`` (B,) of B elements: the chain
    rule through ``sigma = sqrt(sx^2 + 3 (t0^2 + t1^2))`` (`_stress_parts`: linear in each), exact.
    A point at zero stress (no derivative of the root) adds nothing."""
    sx, t0, t1 = _stress_parts(r, units, inv_A)
    vm = np.sqrt(sx * sx + 3.0 * (t0 * t0 + t1 * t1))
    k = np.divide(w, vm, out=np.zeros_like(vm), where=vm > 0.0)
    gx, g0, g1 = k * sx, 3.0 * k * t0, 3.0 * k * t1  # (B, 2, P)
    dr = np.zeros_like(r)
    dr[:, 0] = inv_A * gx.sum(axis=(1, 2))
    dr[:, 4:6] = np.einsum("bep,bp->be", gx, units[..., 0])
    dr[:, 6:8] = -np.einsum("bep,bp->be", gx, units[..., 1])
    for j, (a, b) in enumerate(((2, 3), (4, 5), (6, 7))):
        dr[:, 1 + j] = np.einsum("bep,bp->b", g0, units[..., a]) + np.einsum("bep,bp->b", g1, units[..., b])
    du = np.zeros_like(units)
    du[..., 0] = np.einsum("bep,be->bp", gx, r[:, 4:6])
    du[..., 1] = -np.einsum("bep,be->bp", gx, r[:, 6:8])
    G0, G1 = g0.sum(axis=1), g1.sum(axis=1)  # (B, P): the shear's resultants are the same at both ends
    for j, (a, b) in enumerate(((2, 3), (4, 5), (6, 7))):
        du[..., a], du[..., b] = G0 * r[:, 1 + j, None], G1 * r[:, 1 + j, None]
    return dr, du, r[:, 0] * gx.sum(axis=(1, 2))


@attrs.frozen
class _Stress(Response):
    scale: float | None = None
    rho: float = DEFAULT_RHO
    joint: str | None = None
    points: int = 64

    def __attrs_post_init__(self):
        if not (isinstance(self.rho, (int, float)) and self.rho > 0):
            raise ParameterError(f"stress: rho={self.rho!r} must be > 0")
        if self.scale is not None and not self.scale > 0:
            raise ParameterError(f"stress: scale={self.scale!r} [Pa] must be > 0")
        if self.points not in (16, 32, 64, 128, 256):
            raise ParameterError(f"stress: points={self.points!r}; valid: 16, 32, 64, 128, 256")

    @property
    def name(self) -> str:
        return f"stress(KS rho={self.rho:g}{'' if self.joint is None else ', ' + self.joint})"

    def _rows(self, solution) -> np.ndarray:
        el = solution.compiled.problem.model.elements
        if self.joint is None:
            return np.arange(len(el.L0))
        try:
            return np.asarray(solution.compiled.joint_elements[self.joint])
        except KeyError:
            raise ModelError(f"stress: no joint named {self.joint!r}; joints: "
                             f"{', '.join(solution.compiled.joint_elements)}") from None

    def _scale(self, model, rows) -> float:
        if self.scale is not None:
            return float(self.scale)
        ys = {getattr(model.elements.sections[i], "yield_stress", None) for i in rows}
        if None in ys or not ys:
            raise ParameterError("stress: give scale= [Pa] (e.g. the material's yield stress): not every section "
                                 "states a yield_stress")
        return float(min(ys))

    def _sigma(self, solution):
        model = solution.compiled.problem.model
        rows = self._rows(solution)
        units, inv_A = stress_units(model, self.points)
        e, sig = model.stresses(solution.state)
        vm = _von_mises(e[rows], sig[rows], model.elements.L0[rows], units[rows], inv_A[rows], model.dim)
        return model, rows, vm, units, inv_A

    def _ks(self, vm, s):
        m = float(np.max(vm.real))
        return m + (s / self.rho) * np.log(np.sum(np.exp(self.rho * (vm - m) / s)))

    def value(self, solution) -> float:
        model, rows, vm, *_ = self._sigma(solution)
        return float(self._ks(vm, self._scale(model, rows)).real)

    def report(self, solution) -> dict:
        """The KS value, the largest sampled stress, the exact peak (`Solution.stresses`) [Pa] and
        the bound ``s ln(n) / rho`` on KS minus the sampled maximum."""
        model, rows, vm, *_ = self._sigma(solution)
        s = self._scale(model, rows)
        exact = float(np.max(solution.stresses().von_mises[rows]))
        return {"ks": float(self._ks(vm, s).real), "sampled_max": float(vm.max()), "max": exact,
                "bound": s * np.log(vm.size) / self.rho}

    def partials(self, sens):
        model, rows, vm, units, inv_A = self._sigma(sens.solution)
        s = self._scale(model, rows)
        ks = self._ks(vm, s)
        w = np.exp(self.rho * (vm - ks) / s)  # d KS / d sigma_i (sums to 1)
        # elements whose every weight is below WEIGHT_FLOOR add nothing at double precision: left out
        keep = w.reshape(len(rows), -1).max(axis=1) > WEIGHT_FLOOR
        rows, w = rows[keep], w[keep]
        el = model.elements
        e, sig = model.stresses(sens.solution.state)
        e, S, L0 = e[rows], el.S[rows], el.L0[rows]
        # KS's partials with respect to each element's resultants, unit fields and 1/A (analytic)
        dr, dunit, dinv_A = _aggregate_rates(_resultants(e, sig[rows], L0, model.dim), units[rows], inv_A[rows], w)
        # the state: dKS/du = (D T)^T g per element, g = dKS/de = dr . d(resultants)/de (complex step over the
        # deformations: sigma = S e and the chord l = L0 + e_1 move with them), D = de/dq from the kernel's twin
        nm = e.shape[1]
        ec = np.repeat(e, nm, axis=0) + (1j * H) * np.tile(np.eye(nm), (len(rows), 1))
        rr = np.repeat(np.arange(len(rows)), nm)
        rc = _resultants(ec, np.einsum("bij,bj->bi", S[rr], ec), L0[rr], model.dim)
        g = np.einsum("bj,bj->b", rc.imag / H, dr[rr]).reshape(len(rows), nm)
        DT = _deformation_gradient(model, sens.state, rows)  # (B, modes, 2 ndof) in master DOFs
        dJ_du = np.zeros(model.n_dofs)
        np.add.at(dJ_du, model.element_dofs[rows], np.einsum("bm,bmj->bj", g, DT))
        # the model numbers: the stress fields' rates, and the elements' data and offsets per parameter
        moved, du_units, dinv = self._field_rates(sens, rows)
        dJ_dN = np.zeros(len(sens.names))
        dJ_dN[moved] = np.einsum("kbpj,bpj->k", du_units, dunit) + dinv @ dinv_A
        cols, sub = np.nonzero(_element_hits(model, sens.rates, None)[:, rows])
        if len(cols):
            e, sig, L0 = _element_stresses(sens, cols, rows[sub])
            rc = _resultants(e, sig, L0, model.dim)
            np.add.at(dJ_dN, cols, np.einsum("bj,bj->b", rc.imag / H, dr[sub]))
        return dJ_du, dJ_dN

    def _field_rates(self, sens, rows):
        """The parameters that move the stress fields (indices, k) and their rates (k, B, P, 8) and
        (k, B) at elements ``rows``: `section_units` of the sections of each parameter's builds
        (`flexmb.design.builds.ParameterBuild.combine`: the imaginary parts of its complex-step
        build, or central differences); the other parameters' are nil."""
        key = ("stress_units", self.points)
        cache = sens.rates.shared
        if key not in cache:
            base_u, base_a = stress_units(sens.rates.compiled.problem.model, self.points)
            du = np.zeros((len(sens.names),) + base_u.shape)
            da = np.zeros((len(sens.names),) + base_a.shape)
            for k in range(len(sens.names)):
                b, table = sens.rates.build(k), {}
                if _real_shapes(b):  # the fields are real: their rates are nil
                    continue
                du[k] = b.combine(lambda _, nums, table=table: _units(nums["sections"], self.points, table)[0])
                da[k] = b.combine(lambda _, nums, table=table: _units(nums["sections"], self.points, table)[1])
            moved = np.flatnonzero(np.any(du != 0.0, axis=(1, 2, 3)) | np.any(da != 0.0, axis=1))
            cache[key] = (moved, du[moved], da[moved])
        moved, du, da = cache[key]
        return moved, du[:, rows], da[:, rows]


def _real_shapes(build) -> bool:
    """Whether a parameter's complex-step build leaves every section's shape numbers real (`section_units`
    of them real: the stress fields' rates are nil); False for a build by central differences."""
    from .builds import COMPLEX_STEP

    if build.method != COMPLEX_STEP:
        return False
    ((_, _, nums),) = build.points
    return not any(np.iscomplexobj(getattr(s, a)) for s in {id(s): s for s in nums["sections"]}.values()
                   for a in _SHAPE_NUMBERS)


def stress(scale: float | None = None, rho: float = DEFAULT_RHO, joint: str | None = None, points: int = 64):
    """The peak von Mises stress [Pa] of the beams (of ``joint`` only, if given) as the KS aggregate
    over ``points`` perimeter points per element end (module notes: ``rho`` dimensionless with the
    stress ``scale`` [Pa], default the sections' yield stress); ``report(solution)`` gives the exact
    peak beside it."""
    return _Stress(scale, rho, joint, points)


def _element_stresses(sens, cols, rows):
    """The complex deformations, stresses and lengths of the (direction, element) pairs ``cols``,
    ``rows`` along the model numbers' rates: read from the residual rates' rows where the
    sensitivity kept them (`flexmb.design.adjoint.Sensitivity.element_rows`), else evaluated."""
    sens.residual_rates  # noqa: B018 - fills sens.element_rows
    kept = getattr(sens, "element_rows", None) or {}
    if "e" in kept:
        at = np.full((len(sens.names), len(sens.model.elements.L0)), -1)
        at[kept["cols"], kept["rows"]] = np.arange(len(kept["rows"]))
        i = at[cols, rows]
        if np.all(i >= 0):
            return kept["e"][i], kept["sigma"][i], kept["L0"][i]
    return _elements(sens.model, sens.state, sens.rates, cols, rows, None, tangent=False, stresses=True)


def _deformation_gradient(model, state, rows) -> np.ndarray:
    """``de/du`` (B, modes, 2 ndof) of elements ``rows`` in their master nodes' DOFs: the kernel's
    ``D`` (`flexmb.fe.beam3d.numpy_deformation_gradient`) times the rigid levers of the end offsets."""
    from ..fe import beam2d, beam3d

    el, nd = model.elements, model.ndof
    m = model.point_master[el.ends[rows]]
    d = model.offsets(state, m.ravel(), model.point_offset[el.ends[rows]].reshape(-1, model.dim))
    x = (state.positions[m.ravel()] + d).reshape(-1, 2, model.dim)
    if model.dim == 2:
        th = state.rotations[m]
        _, D = beam2d.numpy_deformation_gradient(x[:, 0], x[:, 1], th[:, 0], th[:, 1], el.alpha0[rows], el.L0[rows])
    else:
        R = state.rotations[m]
        _, D = beam3d.numpy_deformation_gradient(x[:, 0], x[:, 1], R[:, 0], R[:, 1], el.ny0[rows], el.nz0[rows],
                                                 el.L0[rows])
    Tb = model._lever(d).reshape(len(rows), 2, nd, nd)
    T = np.zeros((len(rows), 2 * nd, 2 * nd))
    T[:, :nd, :nd], T[:, nd:, nd:] = Tb[:, 0], Tb[:, 1]
    return D @ T
