"""Warnings where a returned `Solution` is not what it looks like: a solve
that did not converge, strains a linear-elastic beam model cannot represent, a stress above the
material's given yield stress, and the parasitic shortening the closed-form model leaves out.
"""

from __future__ import annotations

import functools
import warnings
import weakref

import numpy as np

from .closed_form.problem import LinkageProblem
from . import jit
from ._validate import hashable, modulus_units
from .errors import ConvergenceWarning, ModelError, PlausibilityWarning
from .fe.stress import peak_normal_stress, section_table
from .rotations import rot2

__all__ = ["check", "check_mass_units", "STRAIN_LIMIT", "SHORTENING_LIMIT", "WAVE_RATE_RANGE"]

#: Largest peak normal strain (peak normal stress / E) a converged answer may reach without a
#: warning: above the elastic strain of every engineering flexure material (spring steel ~0.75 %,
#: 1.5 GPa / 200 GPa; Ti-6Al-4V ~0.9 %; polymers ~2 %, nylon 70 MPa / 3.8 GPa) and where
#: small-strain beam theory stops being accurate. The paper cases stay below it (measured: cross
#: flexure at 75 deg 1.0 %, manipulator at 45 deg 0.22 %, gripper at 50 uN 0.18 %).
STRAIN_LIMIT = 0.02
#: Closed-form flexures (``method="newton"``): warn when the shortening a straight beam bent by a
#: transverse end deflection d over its length L would have, 0.6 d^2 / L (fixed-guided and
#: end-loaded cantilever alike: (1/2) int w'^2 with the cubic deflection shapes), exceeds this
#: fraction of d, i.e. d > L / 60.
SHORTENING_LIMIT = 0.01
#: Range [1/s] of ``sqrt(E / density) / L``, a joint's material wave speed over its length: the same
#: in every consistent unit system. Engineering materials have wave speeds of 30 m/s (soft
#: elastomers, E = 1 MPa, 1000 kg/m^3) to 13 000 m/s (beryllium), flexure joints lengths of 1 um
#: to 10 m: 3 to 1.3e10. A density in kg/m^3 with lengths in mm and E in MPa gives ~0.1 (steel,
#: 50 mm); one in t/mm^3 in SI ~1e11. Outside the range `flexmb.modes` warns.
WAVE_RATE_RANGE = (1.0, 1e11)


def check(solution, *, stacklevel: int = 3) -> None:
    """Warn about ``solution`` (`ConvergenceWarning`, `PlausibilityWarning`) where it misleads."""
    if not solution.converged:
        warnings.warn(f"{solution.method} did not converge ({solution.message}). The Solution holds the last converged "
                      f"state, at load factor {solution.load_factor:.4g} of 1 (NaN if none): its reactions, "
                      "displacements and stresses are not those of the load asked for", ConvergenceWarning,
                      stacklevel=stacklevel)
        return
    if solution.stable is False:
        warnings.warn(f"{solution.method}: the equilibrium found is UNSTABLE (tangent not positive definite). Where "
                      "the path bifurcates (a perfect-geometry arch or column) several unstable equilibria exist and "
                      "the one a solve lands on depends on its steps: follow the path with flexmb.trace, or solve "
                      "with initial_step < 1 and check the branch", PlausibilityWarning, stacklevel=stacklevel)
    problem = solution.compiled.problem
    if isinstance(problem, LinkageProblem):
        _shortening(solution, stacklevel + 1)
    elif len(getattr(getattr(problem.model, "elements", None), "L0", ())):
        _strains(solution, problem.model, stacklevel + 1)


def _moduli(solution, model, stacklevel: int, tab=None) -> None:
    """A modulus that looks like GPa with lengths in m (`flexmb._validate.modulus_units`), wherever
    it came from: a joint's ``E`` is checked when the joint is made, a `Section`'s only here.
    ``tab``: ``model``'s `section_table` when at hand."""
    tab = section_table(model.elements) if tab is None else tab
    k = _suspect(tab)
    if k >= 0:
        E, L = tab.E, tab.length
        modulus_units(f"{solution.method} ({_where(solution, k)})", float(E[k]), float(L[k]), "joint length",
                      stacklevel=stacklevel + 1)


def _suspect(tab) -> int:
    """The first element whose modulus looks like GPa with lengths in m, or -1; decided once per
    section table (it cannot change)."""
    try:
        return _SUSPECT[tab]
    except KeyError:
        bad = np.flatnonzero((tab.E < 1e3) & (tab.length < 1.0))
        k = _SUSPECT[tab] = int(bad[0]) if len(bad) else -1
        return k


_SUSPECT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # per section table: `_suspect`'s verdict


def check_mass_units(solution, model, stacklevel: int = 3) -> None:
    """Warn (`PlausibilityWarning`) where a section's density does not fit its modulus and its
    joint's length in one unit system (`WAVE_RATE_RANGE`): the modes would be off by orders of
    magnitude, the statics unaffected."""
    tab = section_table(model.elements)
    E, rho, length = tab.E, tab.density, tab.length
    massive = np.flatnonzero(rho > 0)
    if not len(massive):
        return
    rate = np.sqrt(E[massive] / rho[massive]) / length[massive]
    lo, hi = WAVE_RATE_RANGE
    bad = np.flatnonzero((rate < lo) | (rate > hi))
    if not len(bad):
        return
    k = massive[bad[np.argmax(np.abs(np.log10(rate[bad] / np.sqrt(lo * hi))))]]
    r = float(np.sqrt(E[k] / rho[k]) / length[k])
    warnings.warn(f"{solution.method}: density={rho[k]:g} with E={E[k]:g} ({_where(solution, k)}, length "
                  f"{length[k]:.3g}) gives a wave speed over the length sqrt(E/density)/L = {r:.3g} per second, "
                  f"outside [{lo:g}, {hi:g}] for any material and size: the density is in other units than the "
                  "lengths and E (the joints' default 7800 is kg/m^3, SI); give it as mass per length cubed in the "
                  "model's units (N, mm, MPa: t/mm^3, steel 7.8e-9). The frequencies are off by "
                  f"~{abs(np.log10(r / np.sqrt(lo * hi))):.0f} orders of magnitude",
                  PlausibilityWarning, stacklevel=stacklevel)


def peak_stress(model, state) -> np.ndarray:
    """`flexmb.fe.stress.peak_normal_stress` of ``state``; with the numba kernels one pass of
    `flexmb.fe.stress_jit.peak_normal_stress` over `flexmb.fe.model.FEModel.stresses`. `ModelError` for
    sections without extreme-fibre distances, as the numpy function."""
    tab = section_table(model.elements)  # built once per compiled model
    if not jit.enabled() or not tab.has_y or (model.dim == 3 and not tab.has_z):
        return peak_normal_stress(model, state)
    from .fe import stress_jit

    factors = _factors(model, tab)
    sigma = np.empty(len(factors[0]))
    stress_jit.peak_normal_stress(np.ascontiguousarray(model.stresses(state)[1], dtype=float), *factors, model.dim,
                                  sigma)
    return sigma


def _factors(model, tab) -> tuple:
    """`flexmb.fe.stress_jit.peak_normal_stress`'s section arguments ``L0, A, ymax, Iz, zmax/Iy,
    ymax/Iz, circle``, divided as the numpy function divides them; kept per section table."""
    try:
        return _FACTORS[tab]
    except KeyError:
        factors = _FACTORS[tab] = (np.ascontiguousarray(model.elements.L0, dtype=float), tab.A, tab.ymax, tab.Iz,
                                   tab.zmax / tab.Iy, tab.ymax / tab.Iz, tab.circle)
        return factors


_FACTORS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _strains(solution, model, stacklevel: int) -> None:
    try:  # the numba path's plan, kept per model: one lookup
        plan = _PLANS[model] if jit.enabled() else None
    except (KeyError, TypeError):
        plan = None
    if plan is None:
        tab = section_table(model.elements)  # built once per compiled model
        plan = _plan(model, tab)
    else:
        tab = plan[2]
    if plan is None or plan[3] >= 0:  # the plan holds the modulus verdict (`_suspect`)
        _moduli(solution, model, stacklevel + 1, tab)
    if plan is None:  # the numpy path, or a plugin section without extreme-fibre distances
        try:
            sigma = peak_stress(model, solution.state)
        except ModelError:  # a plugin section without extreme-fibre distances: no stresses to check
            return
        strain, over = sigma / tab.E, sigma / tab.yield_stress
        ks, ky = int(np.argmax(strain)), int(np.argmax(over))
    else:  # one numba call: stresses, peak stress and both argmaxes (`flexmb.plausibility_jit`)
        kernel, args = plan[:2]
        state = solution.state
        sigma = np.empty(len(tab.E))
        ks, ky, s, o = kernel(model, state, *args, sigma)
        strain, over = {ks: s}, {ky: o}
    if strain[ks] > STRAIN_LIMIT:
        warnings.warn(f"{solution.method}: peak strain {strain[ks]:.3g} ({_where(solution, ks)}) is beyond the elastic "
                      f"range a linear-elastic beam model represents (limit {STRAIN_LIMIT:g}; peak stress "
                      f"{sigma[ks]:.3g}): the answer is not physical. Check the units (a length in mm where m is "
                      "meant?) and the size of the motion or load", PlausibilityWarning, stacklevel=stacklevel)
    ys = tab.yield_stress
    if over[ky] > 1.0:
        warnings.warn(f"{solution.method}: peak stress {sigma[ky]:.4g} exceeds the yield stress {ys[ky]:.4g} "
                      f"({_where(solution, ky)}): the flexure yields, the linear-elastic answer does not hold there",
                      PlausibilityWarning, stacklevel=stacklevel)


def _plan(model, tab):
    """With the numba kernels and sections with extreme-fibre distances, the kernel of
    `flexmb.plausibility_jit` for ``model``, its model arguments, the section table and its
    `_suspect` modulus, built once per model (kept weakly); None otherwise (the numpy path:
    `peak_stress`)."""
    if not (jit.enabled() and tab.has_y and (model.dim == 2 or tab.has_z) and model.elements.S.ndim == 3):
        return None
    try:
        plan = _PLANS[model]
    except KeyError:
        plan = _PLANS[model] = _build_plan(model, tab)
    except TypeError:  # not weakly referable: no cache
        return _build_plan(model, tab)
    return plan


def _build_plan(model, tab):
    from . import plausibility_jit

    args = (*_factors(model, tab), tab.E, tab.yield_stress)
    return plausibility_jit.strains, args, tab, _suspect(tab)


_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _where(solution, element: int) -> str:
    for name, idx in solution.compiled.joint_elements.items():
        if element in idx:
            return f"joint {name!r}, element {int(np.flatnonzero(idx == element)[0])}"
    return f"element {element}"


def _shortening(solution, stacklevel: int) -> None:
    """The closed-form (constant-stiffness) model has no shortening of a bent straight flexure
    (one whose closed-form end lies on its x axis, unrotated: a leaf spring, not a curved beam)."""
    worst = None
    for name, joint, placement, side_a, side_b in solution.compiled.joints:
        if not _straight(joint):
            continue
        a0 = placement.origin
        b0 = placement.to_global(joint.interface_b(2))
        chord = b0 - a0
        L = float(np.hypot(*chord))
        if not L > 0:
            continue
        (xa, ta), (xb, tb) = solution.pose(side_a), solution.pose(side_b)
        ra, rb = rot2(ta), rot2(tb)
        a = xa + ra @ (a0 - _x0(solution, side_a))
        b = xb + rb @ (b0 - _x0(solution, side_b))
        rel = ra.T @ (b - a) - chord  # B's motion relative to A, in A's (undeformed) axes
        d = abs(chord[0] * rel[1] - chord[1] * rel[0]) / L  # transverse deflection
        if 0.6 * d / L > SHORTENING_LIMIT and (worst is None or d / L > worst[1] / worst[2]):
            worst = (name, d, L)
    if worst is not None:
        name, d, L = worst
        warnings.warn(f"{solution.method}: flexure {name!r} deflects {d:.3g} across its length {L:.3g}; a beam bent "
                      f"that far shortens by about 0.6 d^2/L = {0.6 * d * d / L:.3g}, which the closed-form "
                      "constant-stiffness model leaves out (no parasitic shortening). Use method='conventional' "
                      "where parasitic motions matter", PlausibilityWarning, stacklevel=stacklevel)


def _straight(joint) -> bool:
    """Whether a joint is a straight closed-form flexure (its end on its x axis, unrotated);
    cached per joint value (joints are immutable): `ClosedForm` can cost more than the check."""
    if not hashable(joint):
        return _is_straight(joint)
    return _straight_cached(joint)


def _is_straight(joint) -> bool:
    if "closed_form" not in joint.capabilities:
        return False
    cf = joint.closed_form(2)
    return cf.end_angle == 0.0 and cf.end[1] == 0.0


_straight_cached = functools.lru_cache(maxsize=256)(_is_straight)


def _x0(solution, link: str) -> np.ndarray:
    """A link's reference point in the undeformed configuration."""
    return solution.compiled.problem.model.x0[solution.compiled.link_node[link]]
