"""State-space models at a deformed configuration: ``x' = A x + B u``, ``y = C x + D u``.

`state_space` linearises a converged finite-element equilibrium (``method="conventional"`` or
``"ksd-full"``) as `flexmb.modes` and `flexmb.compliance` do (the full tangent with the dead loads'
stiffness, the consistent mass at the deformed state, ``held`` DOFs held) and keeps ``n`` modes:

* **Inputs**: forces and moments at links or their points (``("force", link, component[, point])``)
  and the prescribed motions of held link DOFs (``("motion", link, component)``).
* **Outputs**: displacements and rotations of links or points (``("displacement", link,
  component[, point])``) and the reactions of held DOFs (``("reaction", link, component)``).
* **State**: two per mode. With mass-normalised shapes ``phi_k`` and ``omega_k`` (`flexmb.modes`)
  and modal damping ratios ``zeta_k``, the modal coordinates obey
  ``eta'' + 2 zeta omega eta' + omega^2 eta = phi^T F - Gamma u''`` (Craig & Kurdila,
  *Fundamentals of Structural Dynamics*, 2nd ed., Secs. 10.4 and 17.7), where the motion inputs'
  quasi-static field ``S u = -K_ff^-1 K_fh u`` takes the free DOFs along exactly and
  ``Gamma = Phi^T M (S + E_h)`` couples the modes to its acceleration. The states are
  ``xi = eta + Gamma u`` and ``psi = xi' - 2 zeta omega Gamma u`` (no derivative of an input
  appears: the model is proper).
* **Static correction** (the mode-acceleration method, Craig & Kurdila Sec. 14.4): the force
  inputs' residual flexibility ``K_ff^-1 - Phi Omega^-2 Phi^T`` enters ``D``, so the static gain
  ``D - C A^-1 B`` is the compliance of the configuration exactly, whatever ``n``.

Poles: ``omega_k (-zeta_k +- i sqrt(1 - zeta_k^2))``, with ``omega_k = 2 pi f_k`` of `flexmb.modes`.
Reaction outputs are the tangent's elastic forces ``K_hf x_f + K_hh u`` (the consistent mass's
coupling to the held DOF, ``M_hf x_f''``, is left out: its motion-input part grows as s^2 and has
no proper state-space form); with hinges the inputs are forces and the outputs displacements.
Units: the mechanism's (`flexmb.units`), seconds; `StateSpace.labels` names them.
"""

from __future__ import annotations

import attrs
import numpy as np
import scipy.linalg as sla

from . import _validate as v
from ._warnings import renamed_keyword
from .errors import MissingExtraError, ModelError, ParameterError, UnsupportedStrategyError, require
from .modal import constrained, held_dofs, modes, solvable_problem, stiffness_and_mass
from .units import label

__all__ = ["StateSpace", "state_space", "COMPONENTS"]

#: Components of inputs and outputs: global axes, ``r*`` rotations (2D: ``"rotation"``).
COMPONENTS = {2: ("x", "y", "rotation"), 3: ("x", "y", "z", "rx", "ry", "rz")}
_ALIASES = {2: {"rz": "rotation"}, 3: {}}


@attrs.frozen(eq=False)
class StateSpace:
    """A linear time-invariant model ``x' = A x + B u``, ``y = C x + D u`` (`state_space`).

    Attributes: ``A`` (2n, 2n), ``B`` (2n, m), ``C`` (p, 2n), ``D`` (p, m), read-only; ``inputs``
    and ``outputs`` (the specifications as given, normalised); ``labels``: per input and output
    its unit label; ``frequencies`` [Hz] and ``damping`` of the modes kept; ``units``: the
    mechanism's unit system name (None: undeclared, SI).
    """

    A: np.ndarray = attrs.field(converter=v.frozen)
    B: np.ndarray = attrs.field(converter=v.frozen)
    C: np.ndarray = attrs.field(converter=v.frozen)
    D: np.ndarray = attrs.field(converter=v.frozen)
    inputs: tuple
    outputs: tuple
    labels: dict
    frequencies: np.ndarray = attrs.field(converter=v.frozen)
    damping: np.ndarray = attrs.field(converter=v.frozen)
    units: str | None = None

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` [rad/s], sorted by imaginary part then real part."""
        p = np.linalg.eigvals(self.A)
        return p[np.lexsort((p.real, p.imag))]

    def static_gain(self) -> np.ndarray:
        """``D - C A^-1 B`` (p, m): the outputs per unit constant input."""
        return self.D - self.C @ np.linalg.solve(self.A, self.B)

    def frequency_response(self, frequencies) -> np.ndarray:
        """``H(i 2 pi f) = C (i 2 pi f I - A)^-1 B + D`` (len(f), p, m), complex, ``frequencies`` [Hz]."""
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
        eye = np.eye(len(self.A))
        return np.array([self.C @ np.linalg.solve(2j * np.pi * x * eye - self.A, self.B) + self.D for x in f])

    def names(self, which: str = "inputs") -> list:
        """``"force B.x"``-style names of the inputs or outputs."""
        return [_name(s) for s in getattr(self, which)]

    def to_control(self):
        """The model as a python-control ``StateSpace`` (the ``control`` extra), inputs and outputs named."""
        control = require("control", "control", "flexmb.StateSpace.to_control")
        return control.ss(np.array(self.A), np.array(self.B), np.array(self.C), np.array(self.D),
                          inputs=[_signal(s) for s in self.inputs], outputs=[_signal(s) for s in self.outputs])

    def plot(self, frequencies=None, *, pairs=None, axes=None):
        """Bode plot (magnitude and phase against frequency [Hz]) of the (output, input) ``pairs``
        (indices; default all), axes labelled with their units; returns the two axes."""
        mfig = require("matplotlib.figure", "plot", "flexmb.StateSpace.plot")
        if frequencies is None:
            fmax = float(self.frequencies.max()) if len(self.frequencies) else 1.0
            frequencies = np.logspace(np.log10(fmax) - 2.5, np.log10(fmax) + 0.7, 600)
        f = np.asarray(frequencies, dtype=float)
        H = self.frequency_response(f)
        pairs = [(i, j) for i in range(H.shape[1]) for j in range(H.shape[2])] if pairs is None else list(pairs)
        if axes is None:
            fig = mfig.Figure(figsize=(6.0, 5.0), layout="constrained")
            axes = fig.subplots(2, 1, sharex=True)
        mag, ph = axes
        for i, j in pairs:
            unit = f"{self.labels[self.outputs[i]]}/{self.labels[self.inputs[j]]}"
            mag.loglog(f, np.abs(H[:, i, j]), label=f"{_name(self.outputs[i])} / {_name(self.inputs[j])} [{unit}]")
            ph.semilogx(f, np.degrees(np.unwrap(np.angle(H[:, i, j]))))
        mag.set_ylabel("magnitude")
        mag.legend(fontsize="small")
        ph.set_ylabel("phase [deg]")
        ph.set_xlabel("frequency [Hz]")
        return axes


def _signal(spec) -> str:
    """A python-control signal name (letters, digits, underscores): ``force_B_x``."""
    import re

    return re.sub(r"\W", "_", _name(spec).replace(" ", "_").replace(".", "_").replace("@", "_at_"))


def _name(spec) -> str:
    kind, link, comp, *point = spec
    return f"{kind} {link}{'@' + str(point[0]) if point and isinstance(point[0], str) else ''}.{comp}"


def state_space(solution, inputs, outputs, *, n_modes: int = 6, damping=0.0, held="prescribed",
                static_correction: bool = True, n: int | None = None) -> StateSpace:
    """The state-space model of ``solution`` (a converged FE equilibrium) with ``n_modes`` modes (see
    the module notes; ``n``: its deprecated name, a FutureWarning). ``inputs``: ``("force", link, component[, point])`` (its share on held DOFs
    goes straight to their reactions) or ``("motion", link, component)`` of held DOFs; ``outputs``: ``("displacement", link, component[, point])`` or
    ``("reaction", link, component)`` of held DOFs; components of `COMPONENTS`; ``point`` a named
    point of the link or its undeformed global position. ``damping``: the modal damping ratio, a
    number in [0, 1) or one per mode. ``held`` as in `flexmb.modes` (default: the prescribed DOFs).
    ``static_correction=False`` leaves the residual flexibility out (a purely modal model).
    """
    problem = solvable_problem(solution, "state_space")
    model = problem.model
    n = renamed_keyword("state_space", "n", n, "n_modes", n_modes, 6)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"state_space: n_modes={n!r} must be a whole number >= 1 (modes kept)")
    zeta = np.broadcast_to(np.asarray(damping, dtype=float), (n,)).copy() if np.ndim(damping) == 0 else \
        np.asarray(damping, dtype=float)
    if zeta.shape != (n,) or not np.all((zeta >= 0) & (zeta < 1)):
        raise ParameterError(f"state_space: damping={damping!r} must be a ratio in [0, 1), or {n} of them")
    ins = [_spec(solution, s, ("force", "motion"), "input") for s in _listed(inputs, "inputs")]
    outs = [_spec(solution, s, ("displacement", "reaction"), "output") for s in _listed(outputs, "outputs")]
    md = modes(solution, n_modes=n, held=held)
    nnd = model.n_node_dofs
    Phi = md.shapes.reshape(n, nnd)  # mass-normalised, zero on held DOFs
    lam = md.eigenvalues
    if not np.all(lam > 0):
        raise ModelError(f"state_space: the configuration has a mode with omega^2 <= 0 ({lam.min():.3g}): it is "
                         "unstable or free to move; hold the free motion (held=...)")
    K, M = stiffness_and_mass(solution)
    held_idx = held_dofs(solution, held, "state_space")
    free = np.setdiff1d(np.arange(model.n_dofs), held_idx)
    fn, Z = constrained(model, free, K, solution.state)
    if Z is not None and any(s[0] in ("motion", "reaction") for s in ins + outs):
        raise UnsupportedStrategyError("state_space: with hinges the inputs are forces and the outputs "
                                       "displacements (motions and reactions of held DOFs: not available)")
    K, M = K.tocsr(), M.tocsr()
    solve = _free_solver(K, fn, Z, nnd)
    X, Gamma, modal, loads = _input_columns(ins, solution, model, K, M, Phi, lam, solve, held_idx, static_correction)
    W, reacting = _output_rows(outs, solution, model, K, held_idx, nnd)
    omega = np.sqrt(lam)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(lam), -np.diag(2 * zeta * omega)]])
    B = np.vstack([(2 * zeta * omega)[:, None] * Gamma,
                   ((1 - 4 * zeta**2) * lam)[:, None] * Gamma + modal])
    C = np.hstack([W @ Phi.T, np.zeros((len(outs), n))])
    D = W @ X - reacting @ loads  # a reaction (residual: internal minus external) takes the load on its DOF
    units = getattr(solution.compiled.units, "name", None)
    labels = {s: _unit(s, units) for s in ins + outs}
    return StateSpace(A, B, C, D, tuple(ins), tuple(outs), labels, md.frequencies, zeta, units)


def _listed(specs, what: str) -> list:
    if isinstance(specs, tuple) and specs and isinstance(specs[0], str):
        specs = [specs]  # one specification
    try:
        out = list(specs)
    except TypeError:
        raise ParameterError(f"state_space: {what}={specs!r} must be a list of specifications") from None
    if not out:
        raise ParameterError(f"state_space: no {what}")
    return out


def _spec(solution, spec, kinds: tuple, what: str) -> tuple:
    """A normalised ``(kind, link, component[, point])``, checked."""
    dim = solution.dim
    if not isinstance(spec, (tuple, list)) or len(spec) not in (3, 4) or spec[0] not in kinds:
        raise ParameterError(f"state_space: {what} {spec!r} must be ({' | '.join(map(repr, kinds))}, link, component"
                             f"[, point])")
    kind, link, comp, *point = spec
    if link not in solution.compiled.link_node:
        raise ModelError(f"state_space: {what} {spec!r}: no link {link!r}; links: "
                         f"{', '.join(solution.compiled.link_node)}")
    comp = _ALIASES[dim].get(comp, comp)
    if comp not in COMPONENTS[dim]:
        raise ParameterError(f"state_space: {what} {spec!r}: component {comp!r}; valid: {', '.join(COMPONENTS[dim])}")
    if point and kind in ("motion", "reaction"):
        raise ParameterError(f"state_space: {what} {spec!r}: a {kind} is of the link's reference point (no point)")
    if point and not isinstance(point[0], str):
        point = [tuple(v.vector(f"state_space {what}", "point", point[0], dim).tolist())]
    return (kind, link, comp, *point)


def _dof(solution, spec) -> int:
    node = solution.compiled.link_node[spec[1]]
    return int(solution.compiled.problem.model.node_dofs[node][COMPONENTS[solution.dim].index(spec[2])])


def _lever_row(solution, spec, nnd: int) -> np.ndarray:
    """The row (nnd,) mapping node motions to the spec's point component (a rigid lever)."""
    model = solution.compiled.problem.model
    node = solution.compiled.link_node[spec[1]]
    dim, nd = model.dim, model.ndof
    T = np.eye(nd)
    if len(spec) == 4:
        if isinstance(spec[3], str):
            owner, offset = solution.compiled.points.get(spec[3], (None, None))
            if owner != spec[1]:
                raise ModelError(f"state_space: link {spec[1]!r} has no point named {spec[3]!r}")
        else:
            offset = np.asarray(spec[3]) - model.x0[node]
        d = model.offsets(solution.state, np.array([node]), np.asarray(offset, dtype=float)[None])[0]
        T = model._lever(d[None])[0]
    row = np.zeros(nnd)
    row[model.node_dofs[node]] = T[COMPONENTS[dim].index(spec[2])]
    return row


def _free_solver(K, fn: np.ndarray, Z, nnd: int):
    """``b (nnd, k) -> x (nnd, k)``: ``K_ff^-1 b_f`` on the free node DOFs (with hinges on the
    motions they allow, ``Z (Z^T K Z)^-1 Z^T``), zero elsewhere; `ModelError` if singular."""
    Kf = K[fn][:, fn]
    Kr = Kf if Z is None else Z.T @ Kf @ Z
    Kr = Kr.toarray() if hasattr(Kr, "toarray") else np.asarray(Kr)
    try:
        lu = sla.lu_factor(Kr, check_finite=True)
    except (ValueError, sla.LinAlgError) as exc:
        raise ModelError("state_space: the tangent on the free DOFs is singular (a free motion): hold it") from exc
    if np.linalg.cond(Kr) > 1e14:
        raise ModelError("state_space: the tangent on the free DOFs is singular (a free motion): hold it")

    def solve(b):
        bf = b[fn]
        x = sla.lu_solve(lu, bf if Z is None else Z.T @ bf)
        out = np.zeros((nnd,) + b.shape[1:])
        out[fn] = x if Z is None else Z @ x
        return out

    return solve


def _input_columns(ins, solution, model, K, M, Phi, lam, solve, held_idx, static_correction):
    """Per input: the node displacements ``x = Phi^T xi + X u`` it adds directly (X column), its
    coupling ``Gamma`` to the modes' acceleration (motions), its modal force and its node loads (forces)."""
    nnd, n = Phi.shape[1], len(lam)
    Knn, Mnn = K[:nnd][:, :nnd], M[:nnd][:, :nnd]
    X, loads = np.zeros((nnd, len(ins))), np.zeros((nnd, len(ins)))
    Gamma, modal = np.zeros((n, len(ins))), np.zeros((n, len(ins)))
    for j, spec in enumerate(ins):
        if spec[0] == "force":
            b = _lever_row(solution, spec, nnd)  # node loads of a unit point load: T^T e
            loads[:, j] = b  # its share on held DOFs moves nothing: their reactions take it
            modal[:, j] = Phi @ b
            if static_correction:
                X[:, j] = solve(b[:, None])[:, 0] - Phi.T @ (modal[:, j] / lam)
        else:
            h = _dof(solution, spec)
            if h not in set(held_idx.tolist()):
                raise ModelError(f"state_space: input {spec!r} is not a held DOF; prescribe it (Mechanism.prescribe) "
                                 "or use a force input")
            e = np.zeros(nnd)
            e[h] = 1.0
            s = -solve((Knn @ e)[:, None])[:, 0]  # the quasi-static field of a unit motion
            Gamma[:, j] = Phi @ (Mnn @ (s + e))
            X[:, j] = e + s - Phi.T @ Gamma[:, j]
    return X, Gamma, modal, loads


def _output_rows(outs, solution, model, K, held_idx, nnd: int) -> np.ndarray:
    """Per output a row on the node DOFs (a lever row for displacements, the held DOF's tangent row
    for reactions) and the row picking a reaction's own DOF (to subtract the load on it)."""
    W, reacting = np.zeros((len(outs), nnd)), np.zeros((len(outs), nnd))
    held = set(held_idx.tolist())
    for i, spec in enumerate(outs):
        if spec[0] == "displacement":
            W[i] = _lever_row(solution, spec, nnd)
        else:
            h = _dof(solution, spec)
            if h not in held:
                raise ModelError(f"state_space: output {spec!r}: the DOF is free, it has no reaction")
            W[i] = K[[h]][:, :nnd].toarray()[0]
            reacting[i, h] = 1.0
    return W, reacting


def _unit(spec, units) -> str:
    kind, comp = spec[0], spec[2]
    rot = comp in ("rotation", "rx", "ry", "rz")
    if kind in ("force", "reaction"):
        return label(units, "moment" if rot else "force")
    return label(units, "angle" if rot else "length")


_ = MissingExtraError  # raised by `require` for the control and plot extras
