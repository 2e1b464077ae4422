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

import time
from typing import ClassVar

import attrs
import numpy as np
import scipy.linalg as sla

from ..closed_form.problem import LinkageProblem
from .. import _validate as v
from ..errors import ConvergenceError
from ..fe.model import State
from ..results import Solution
from .conventional import above_one, boolean, positive_float, positive_int

__all__ = ["Newton", "TANGENTS"]

TANGENTS = ("full", "first-term", "constant")


def _tangent_choice(instance, attribute, value):
    v.choice("newton", attribute.name, value, TANGENTS)


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
    tangent: str = attrs.field(default="full", validator=_tangent_choice)
    tol: float = attrs.field(default=5e-7, validator=positive_float)
    max_iter: int = attrs.field(default=100, validator=positive_int)
    divergence: float = attrs.field(default=1e8, validator=above_one)
    raise_on_failure: bool = attrs.field(default=False, validator=boolean)

    def solve(self, compiled, *, state: State | None = None) -> Solution:
        """Equilibrium of ``compiled`` (a closed-form `Compiled`), from ``state`` (default undeformed)."""
        t0 = time.perf_counter()
        problem: LinkageProblem = compiled.problem
        model, free = problem.model, problem.free
        ixf = np.ix_(free, free)
        start = problem.prescribed_state(model.initial_state() if state is None else state)
        times = {"assemble": 0.0, "solve": 0.0}
        lu = None
        if self.tangent == "constant":
            t = time.perf_counter()
            _, terms = problem.evaluate(model.initial_state())  # K_T(q_hat): the undeformed configuration
            K = sum(terms.values())[ixf]
            times["assemble"] += time.perf_counter() - t
            t = time.perf_counter()
            lu = sla.lu_factor(K, check_finite=False) if len(free) else None
            times["solve"] += time.perf_counter() - t
        history: list[float] = []
        cur = start
        converged, message = False, ""
        first = None
        for it in range(self.max_iter + 1):
            t = time.perf_counter()
            r, terms = problem.evaluate(cur, tangent=lu is None)
            times["assemble"] += time.perf_counter() - t
            rf = r[free]
            res = float(np.sqrt(rf @ rf))
            if it > 0:
                history.append(res)
            first = res if first is None else first
            if res < self.tol:
                converged = True
                message = f"converged: residual {res:.3g} < tol {self.tol:.3g} in {it} iterations (tangent={self.tangent})"
                break
            if not np.isfinite(res) or res > self.divergence * max(first, self.tol):
                message = (f"not converged: diverged at iteration {it} (residual {res:.3g}, started at {first:.3g}; "
                           f"tangent={self.tangent})")
                break
            if it == self.max_iter:
                message = (f"not converged: residual {res:.3g} above tol {self.tol:.3g} after max_iter={self.max_iter} "
                           f"iterations (tangent={self.tangent})")
                break
            t = time.perf_counter()
            try:
                if lu is not None:
                    dq = sla.lu_solve(lu, -r[free], check_finite=False)
                else:
                    K = terms["I"] if self.tangent == "first-term" else sum(terms.values())
                    dq = np.linalg.solve(K[ixf], -r[free])
            except np.linalg.LinAlgError:
                message = f"not converged: singular tangent at iteration {it} (tangent={self.tangent})"
                break
            finally:
                times["solve"] += time.perf_counter() - t
            du = np.zeros(model.n_dofs)
            du[free] = dq
            cur = model.apply_increment(cur, du)
        times["total"] = time.perf_counter() - t0
        final = cur if converged else start
        r = r if converged else problem.evaluate(start, tangent=False)[0]
        sol = Solution(method=self.name, converged=converged, iterations=len(history),
                       residual_history=np.array(history), load_factor=1.0 if converged else 0.0,
                       steps=1 if converged else 0, rejected_steps=0, wall_time=times, message=message,
                       state=final, residual=r, compiled=compiled, tolerance=self.tol, stable=None)
        if self.raise_on_failure and not converged:
            raise ConvergenceError(message, sol)
        return sol
