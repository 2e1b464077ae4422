"""Newton-Raphson on the closed-form linkage model with the closed-form tangent [``newton``].

Cammarata et al. (2022), Algorithm 1 and Sec. 5.3: ``q <- q - K_T^-1 R(w, q)`` with

* ``tangent="full"``: ``K_T = K^I + K^II (+ K^III)`` (Eq. 26), updated every iteration;
* ``tangent="first-term"``: only ``K^I`` (Eq. 27a), updated every iteration (Fig. 12);
* ``tangent="constant"``: ``K_T`` at the undeformed configuration, factorised once (Fig. 11).

No load stepping (as Algorithm 1): the whole load is applied from the start configuration;
`flexmb.sweep` with ``start="previous"`` gives the continuation of Fig. 12. The constant tangent
converges only while K_T(q_hat) stays close to K_T (spectral radius of I - K0^-1 K below 1): on
the gripper up to 74 uN; on stiff straight leaves (axial stiffness 1e4 x the bending one) it
diverges once the links turn by a few hundredths of a radian.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import attrs
import numpy as np
import scipy.linalg as sla

from ..closed_form.problem import LinkageProblem
from .. import _validate as v
from .. import jit
from ..errors import ConvergenceError
from .._timing import Stopwatch
from ..fe.model import State
from ..results import Solution

__all__ = ["Newton", "TANGENTS", "ForceSweep"]

TANGENTS = ("full", "first-term", "constant")


@attrs.frozen(kw_only=True)
class Newton:
    """Newton-Raphson with the closed-form tangent stiffness (planar closed-form joints only).

    Parameters
    ----------
    tangent
        ``"full"``, ``"first-term"`` or ``"constant"`` (see the module docstring).
    tol
        Convergence threshold on the 2-norm of the free residual (5e-7, as the conventional method).
    max_iter
        Iterations before giving up (converged=False, the residual history kept).
    divergence
        Give up when the residual exceeds this factor times the starting residual.
    raise_on_failure
        Raise `ConvergenceError` instead of returning ``converged=False``.
    """

    name: ClassVar[str] = "newton"
    capability: ClassVar[str] = "closed_form"
    #: joint capabilities every joint must offer, and the mechanism dimensions handled
    needs: ClassVar[tuple[str, ...]] = ("closed_form",)
    dims: ClassVar[tuple[int, ...]] = (2,)
    tangent: str = attrs.field(default="full", validator=v.choice_option(TANGENTS))
    tol: float = attrs.field(default=5e-7, validator=v.positive_option)
    max_iter: int = attrs.field(default=100, validator=v.count_option)
    divergence: float = attrs.field(default=1e8, validator=v.above_one_option)
    raise_on_failure: bool = attrs.field(default=False, validator=v.flag_option)

    def solve(self, compiled, *, state: State | None = None) -> Solution:
        """Equilibrium of ``compiled`` (a closed-form `Compiled`), from ``state`` (default undeformed)."""
        watch = Stopwatch({"assemble": 0.0, "solve": 0.0})
        problem: LinkageProblem = compiled.problem
        model, free = problem.model, problem.free
        ixf = np.ix_(free, free)
        start = problem.prescribed_state(model.initial_state() if state is None else state)
        if jit.enabled():
            return self._finish(compiled, start, *self.run_compiled(problem, start), watch)
        lu = None
        if self.tangent == "constant":
            with watch.adding("assemble"):
                K = self.constant_tangent(problem)
            with watch.adding("solve"):
                lu = sla.lu_factor(K, check_finite=False) if len(free) else None
        history: list[float] = []
        cur = start
        status, first = "", None
        for it in range(self.max_iter + 1):
            with watch.adding("assemble"):
                r, terms = problem.evaluate(cur, tangent=lu is None)
            rf = r[free]
            res = float(np.sqrt(rf @ rf))
            if it > 0:
                history.append(res)
            first = res if first is None else first
            if res < self.tol:
                status = "converged"
            elif not np.isfinite(res) or res > self.divergence * max(first, self.tol):
                status = "diverged"
            elif it == self.max_iter:
                status = "max_iter"
            if status:
                break
            with watch.adding("solve"):
                try:
                    if lu is not None:
                        dq = sla.lu_solve(lu, -r[free], check_finite=False)
                    else:
                        K = terms["I"] if self.tangent == "first-term" else sum(terms.values())
                        dq = np.linalg.solve(K[ixf], -r[free])
                except np.linalg.LinAlgError:
                    status = "singular"
                    break
            du = np.zeros(model.n_dofs)
            du[free] = dq
            cur = model.apply_increment(cur, du)
        watch.total()
        return self._finish(compiled, start, status == "converged", self._message(status, it, res, first),
                            np.array(history), cur, r, watch.times, None)

    def run_compiled(self, problem: LinkageProblem, start: State, K0: np.ndarray | None = None):
        """The iterations of `solve` as one numba loop (`flexmb.closed_form.linkage_jit.newton`)
        from the prescribed ``start``; ``K0`` the constant tangent if already known. Returns
        (converged, message, history, final state, last residual, wall times)."""
        from ..closed_form import linkage_jit

        free = problem.free
        if self.tangent == "constant" and K0 is None:
            K0 = self.constant_tangent(problem)
        pos = np.array(start.positions, dtype=float)
        ang = np.array(start.rotations, dtype=float)
        history, r = np.empty(self.max_iter), np.empty(problem.model.n_dofs)
        mode = TANGENTS.index(self.tangent)
        status, it, res, first = linkage_jit.newton(
            pos, ang, np.ascontiguousarray(free, dtype=np.int64), *problem.compiled_arrays(), mode,
            np.ascontiguousarray(K0 if K0 is not None else np.zeros((1, 1))), self.tol, self.max_iter,
            self.divergence, history, r)
        message = self._message(linkage_jit.STATUS[status], it, res, first)
        return status == 0, message, history[:it].copy(), State(pos, ang), r, {}

    def sweep_forces(self, compiled, values: np.ndarray, warm: bool, loads_at) -> ForceSweep:
        """Solve ``compiled`` at each actuation force of ``values`` [N] with the compiled Newton loop
        (`flexmb.sweep`'s path when the kernels are compiled), from the last converged solution if
        ``warm`` (Fig. 12) or the undeformed configuration. ``loads_at(value)`` gives the loads of a
        value (for the Solutions, built on demand). A failed solve is kept (``converged=False``),
        also with ``raise_on_failure``, as `flexmb.sweep` keeps it. Nothing that stays the same is rebuilt per value:
        the flexure and load arrays are made once, only the actuation force changes."""
        from ..closed_form import linkage_jit

        problem: LinkageProblem = compiled.problem
        row, direction = compiled.actuation
        consts = problem.compiled_arrays()
        lforce = consts[-2].copy()
        consts = consts[:-2] + (lforce,) + consts[-1:]
        free = np.ascontiguousarray(problem.free, dtype=np.int64)
        mode = TANGENTS.index(self.tangent)
        offset = bool(np.any(problem.loads.offset[row] != 0.0))  # its load stiffness enters K_T(q_hat)
        K0 = self.constant_tangent(problem) if self.tangent == "constant" else np.zeros((1, 1))
        rest = problem.prescribed_state(problem.model.initial_state())
        last = rest
        n = len(values)
        out = (np.zeros(n, bool), [""] * n, [None] * n, np.empty((n,) + rest.positions.shape),
               np.empty((n,) + rest.rotations.shape), np.empty((n, problem.model.n_dofs)), np.empty(n))
        starts = []
        history = np.empty(self.max_iter)
        dir_c = complex(direction[0], direction[1])
        for k, value in enumerate(values):
            watch = Stopwatch()
            lforce[row] = float(value) * dir_c
            if mode == 2 and offset:
                K0 = self.constant_tangent(problem.with_loads(loads_at(float(value))))
            start = last if warm else rest
            pos, ang = start.positions.copy(), start.rotations.copy()
            status, it, res, first = linkage_jit.newton(pos, ang, free, *consts, mode, K0, self.tol, self.max_iter,
                                                        self.divergence, history, out[5][k])
            ok = status == 0
            out[0][k], out[1][k], out[2][k] = ok, self._message(linkage_jit.STATUS[status], it, res, first), \
                history[:it].copy()
            starts.append(start)
            if ok:
                last = State(pos, ang)
            out[3][k], out[4][k] = (pos, ang) if ok else (start.positions, start.rotations)
            out[6][k] = watch.total()
        return ForceSweep(self, compiled, values, loads_at, starts, out)

    def constant_tangent(self, problem: LinkageProblem) -> np.ndarray:
        """K_T(q_hat) on the free DOFs: the tangent at the undeformed configuration (Fig. 11)."""
        _, terms = problem.evaluate(problem.model.initial_state())
        return sum(terms.values())[np.ix_(problem.free, problem.free)]

    def _message(self, status: str, it: int, res: float, first: float) -> str:
        if status == "converged":
            return f"converged: residual {res:.3g} < tol {self.tol:.3g} in {it} iterations (tangent={self.tangent})"
        if status == "diverged":
            return (f"not converged: diverged at iteration {it} (residual {res:.3g}, started at {first:.3g}; "
                    f"tangent={self.tangent})")
        if status == "max_iter":
            return (f"not converged: residual {res:.3g} above tol {self.tol:.3g} after max_iter={self.max_iter} "
                    f"iterations (tangent={self.tangent})")
        return f"not converged: singular tangent at iteration {it} (tangent={self.tangent})"

    def _finish(self, compiled, start, converged, message, history, cur, r, times, watch) -> Solution:
        """The `Solution` of a finished loop (the start state and its residual when not converged)."""
        problem = compiled.problem
        final = cur if converged else start
        r = r if converged else problem.evaluate(start, tangent=False)[0]
        if watch is not None:  # started by the caller: the total includes the numba loop's set-up
            times["total"] = watch.total()
        sol = Solution(method=self.name, converged=converged, iterations=len(history),
                       residual_history=history, load_factor=1.0 if converged else 0.0,
                       steps=1 if converged else 0, rejected_steps=0, wall_time=times, message=message,
                       state=final, residual=r, compiled=compiled, tolerance=self.tol, stable=None)
        if self.raise_on_failure and not converged:
            raise ConvergenceError(message, sol)
        return sol


class ForceSweep(Sequence):
    """The solutions of a closed-form force sweep run as compiled Newton loops
    (`Newton.sweep_forces`): the results are kept as arrays and each `Solution` is built on
    first access (its per-value problem included), so the sweep itself costs only the loops.

    ``positions`` (n, N, 2) [m], ``rotations`` (n, N) [rad], ``iterations``, ``converged`` (n,).
    """

    def __init__(self, strategy, compiled, values, loads_at, start_state, results):
        self._strategy, self._compiled, self._loads_at = strategy, compiled, loads_at
        self.values = values
        self._starts = start_state  # per value: the prescribed start state
        (self.converged, self._messages, self._histories, self.positions, self.rotations, self._residuals,
         self._times) = results
        self.iterations = np.array([len(h) for h in self._histories])
        self._built: dict[int, Solution] = {}

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        k = range(len(self))[k]  # negative indices; IndexError beyond the end
        if k not in self._built:
            c = self._compiled
            problem = c.problem.with_loads(self._loads_at(float(self.values[k])))
            state = State(self.positions[k].copy(), self.rotations[k].copy())
            strategy = attrs.evolve(self._strategy, raise_on_failure=False)
            self._built[k] = strategy._finish(attrs.evolve(c, problem=problem), self._starts[k],
                                              bool(self.converged[k]), self._messages[k], self._histories[k], state,
                                              self._residuals[k], {"total": self._times[k]}, None)
        return self._built[k]
