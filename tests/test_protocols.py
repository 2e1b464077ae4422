"""The contracts of `flexmb.protocols` and the one linearisation hook (issue 27 item 1).

`flexmb.modes`, `flexmb.buckling` and `flexmb.compliance` read a solution only through
`flexmb.Solution.linearisation`: a third strategy registered here, which those modules have never
heard of, gets all three; one with its own solution kind (its own `Linearisation`) too. No
property module tests a strategy's name (a scan of the package's source).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import ClassVar

import attrs
import numpy as np
import pytest

import flexmb
from flexmb import protocols
from flexmb.linearisation import FELinearisation
from flexmb.models import cross_flexure_pivot, fourbar, gripper
from flexmb.results import Solution
from flexmb.solvers import STRATEGIES, Conventional

ROOT = Path(flexmb.__file__).resolve().parent


@attrs.frozen(kw_only=True)
class PlainNewton:
    """A third strategy [``toy-newton``]: full Newton on the whole model in ``steps`` equal load
    steps, absolute tolerance ``tol`` (5e-7, the paper's); no step control, no continuation (not flexmb's code)."""

    name: ClassVar[str] = "toy-newton"
    capability: ClassVar[str] = "fe_model"
    needs: ClassVar[tuple[str, ...]] = ("fe_model",)
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    steps: int = 8
    tol: float = 5e-7  # the paper's [N, N m]

    def solve(self, compiled) -> Solution:
        problem = compiled.problem
        model, free = problem.model, problem.free
        state, history = model.initial_state(), []
        for k in range(self.steps):
            lam0, lam = k / self.steps, (k + 1) / self.steps
            du_p = problem.prescribed_increment(lam - lam0, lam0)
            r, Kff, Kfp, _ = problem.evaluate(state, lam)
            du = problem.full_increment(problem.solve_linear(Kff, -(r[free] + Kfp @ du_p)), du_p)
            state = model.apply_increment(state, du)
            for _ in range(30):
                r, Kff, _, _ = problem.evaluate(state, lam)
                history.append(float(np.linalg.norm(r[free])))
                if history[-1] < self.tol:
                    break
                du = problem.full_increment(problem.solve_linear(Kff, -r[free]), np.zeros(len(problem.prescribed)))
                state = model.apply_increment(state, du)
        return Solution(method=self.name, converged=history[-1] < self.tol, iterations=len(history),
                        residual_history=np.array(history), load_factor=1.0, steps=self.steps, rejected_steps=0,
                        wall_time={}, message="toy", state=state, residual=r, compiled=compiled, tolerance=self.tol)


class ScaledLinearisation:
    """A solution kind's own `Linearisation`: the full model's free DOFs in another basis, a
    scaled permutation ``Z`` (dense), written here apart from flexmb's. Every property is
    invariant under the change of basis, so each must equal the full model's: a check that the
    property code reads ``K``, ``M``, ``Z``, ``place``/``expand`` and ``solve`` as the protocol says."""

    dense = True

    def __init__(self, solution, held, *, modal=False, owner="linearisation"):
        full = FELinearisation(solution, held, owner=owner)
        if full.Z is not None:
            raise flexmb.UnsupportedStrategyError(f"{owner}: the toy basis takes no hinges")
        self.solution, self.compiled, self.state, self.problem = solution, full.compiled, full.state, full.problem
        self.model, self.held, self.free, self.size = full.model, full.held, full.free, full.size
        n = len(self.free)
        rng = np.random.default_rng(7)
        self.Z = np.zeros((n, n))
        self.Z[rng.permutation(n), np.arange(n)] = 10.0 ** rng.uniform(-1, 1, n)  # u_free = Z q
        self._full = full
        self.K = self.Z.T @ full.K.toarray() @ self.Z
        self.M = self.Z.T @ full.M.toarray() @ self.Z

    def material_tangent(self, base=None):
        return self.Z.T @ self._full.material_tangent(base).toarray() @ self.Z

    def solve(self, b, transpose=False):
        return np.linalg.solve(self.K.T if transpose else self.K, b)

    def place(self, q):
        out = np.zeros((self.size, np.shape(q)[1] if np.ndim(q) > 1 else 1))
        out[self.free] = self.Z @ np.asarray(q).reshape(len(self.free), -1)
        return out

    def expand(self, v):
        return np.array(v)


@attrs.frozen(eq=False)
class ScaledSolution(Solution):
    """The toy solution kind: linearised by `ScaledLinearisation`."""

    def linearisation(self, held="prescribed", *, modal=False, owner="linearisation"):
        return ScaledLinearisation(self, held, modal=modal, owner=owner)


@attrs.frozen(kw_only=True)
class ScaledNewton:
    """A fourth strategy [``toy-scaled``]: the conventional solve, returned as a `ScaledSolution`."""

    name: ClassVar[str] = "toy-scaled"
    capability: ClassVar[str] = "fe_model"
    needs: ClassVar[tuple[str, ...]] = ("fe_model",)
    dims: ClassVar[tuple[int, ...]] = (2, 3)

    def solve(self, compiled) -> Solution:
        sol = Conventional().solve(compiled)
        fields = {f.name: getattr(sol, f.name) for f in attrs.fields(Solution)}
        return ScaledSolution(**{**fields, "method": self.name})


@pytest.fixture
def toys(monkeypatch):
    """The two toy strategies registered by name, as a plugin would."""
    monkeypatch.setitem(STRATEGIES, PlainNewton.name, PlainNewton)
    monkeypatch.setitem(STRATEGIES, ScaledNewton.name, ScaledNewton)


def _pushed_pivot():
    """A planar Table 1 cross flexure (4 el./leaf) turned 0.3 rad and pushed along its axis by
    20 N: stresses and loads for buckling, a turned state for the modes (not a paper case)."""
    m = cross_flexure_pivot(4, dim=2, rotation=0.3)
    m.apply_force("B", [0.0, -20.0])
    return m


@pytest.mark.parametrize("build", [_pushed_pivot, lambda: fourbar(2, displacement=0.1)], ids=["pivot", "fourbar"])
def test_a_third_strategy_gets_modes_buckling_and_compliance(toys, build):
    """A strategy flexmb's property modules do not know (its own Newton loop, a plain `Solution`)
    gets `modes`, `buckling` and `compliance` through the full model's linearisation: equal to
    the conventional solution's to the two solves' difference (1e-7 relative; both converge the
    same equilibrium, the toy to its 5e-7 N)."""
    m = build()
    toy, ref = flexmb.solve(m, "toy-newton"), flexmb.solve(m)
    assert toy.converged and toy.method == "toy-newton"
    link = "B" if "B" in toy.compiled.link_node else "top"
    for held in ("prescribed", "fixed"):
        np.testing.assert_allclose(flexmb.modes(toy, n_modes=4, held=held).frequencies,
                                   flexmb.modes(ref, n_modes=4, held=held).frequencies, rtol=1e-7)
        np.testing.assert_allclose(flexmb.buckling(toy, n_buckling=2, held=held), flexmb.buckling(ref, n_buckling=2, held=held),
                                   rtol=1e-7)
        C = flexmb.compliance(ref, link, held=held)
        np.testing.assert_allclose(flexmb.compliance(toy, link, held=held), C, rtol=1e-7, atol=1e-9 * np.abs(C).max())


@pytest.mark.parametrize("build", [_pushed_pivot, lambda: fourbar(2, displacement=0.1)], ids=["pivot", "fourbar"])
def test_a_solution_kind_with_its_own_linearisation_gets_the_properties(toys, build):
    """A solution kind whose `Linearisation` is written in another basis (a scaled permutation
    ``Z``, dense matrices): the properties are invariant under it, so they equal the full
    model's (frequencies and buckling multipliers to 1e-9, mode shapes on the
    nodes to 1e-7 of their largest component, the sign convention included; the toy solves in a
    basis scaled by 0.1-10, so compliance to 1e-8 and 1e-11 of its largest entry)."""
    m = build()
    toy, ref = flexmb.solve(m, "toy-scaled"), flexmb.solve(m)
    assert isinstance(toy.linearisation(), protocols.Linearisation)
    link = "B" if "B" in toy.compiled.link_node else "top"
    for held in ("prescribed", "fixed"):
        a, b = flexmb.modes(toy, n_modes=4, held=held), flexmb.modes(ref, n_modes=4, held=held)
        np.testing.assert_allclose(a.frequencies, b.frequencies, rtol=1e-9)
        np.testing.assert_allclose(a.shapes, b.shapes, rtol=0, atol=1e-7 * np.abs(b.shapes).max())
        np.testing.assert_allclose(a.link_shapes[link], b.link_shapes[link], rtol=0,
                                   atol=1e-7 * np.abs(b.shapes).max())
        np.testing.assert_allclose(flexmb.buckling(toy, n_buckling=2, held=held), flexmb.buckling(ref, n_buckling=2, held=held),
                                   rtol=1e-9)
        C = flexmb.compliance(ref, link, held=held)
        np.testing.assert_allclose(flexmb.compliance(toy, link, held=held), C, rtol=1e-8, atol=1e-11 * np.abs(C).max())


def test_the_linearisation_exposes_what_a_derivative_needs():
    """The full model's linearisation: ``K``, ``M`` sparse on the free DOFs equal to the full
    tangent's and mass's free blocks; ``solve`` with ``K`` and ``K^T`` (one factorisation kept)
    to 1e-12 relative residual; ``place`` and ``expand`` put coordinates back on the model's DOFs
    (held DOFs 0). On a 3D four-bar with a dead moment (a non-symmetric tangent), 2 el./leaf
    (dense factor) and 5 (sparse solve: 3D, above `SPARSE_FROM` free DOFs)."""
    from flexmb.linearisation import SPARSE_FROM, stiffness_and_mass

    for n in (2, 5):
        m = fourbar(n, displacement=0.1)
        m.apply_moment("top", [0.0, 3.0, 0.0])
        sol = flexmb.solve(m)
        lin = sol.linearisation(held="fixed")
        assert isinstance(lin, protocols.Linearisation) and not lin.dense and lin.Z is None
        assert (lin.K.shape[0] >= SPARSE_FROM) == (n == 5)
        K, M = stiffness_and_mass(sol)
        f = lin.free
        assert abs(lin.K - K[f][:, f]).max() == 0.0 and abs(lin.M - M[f][:, f]).max() == 0.0
        asymmetry = abs(lin.K - lin.K.T).max()
        assert asymmetry > 0.0  # the dead moment's -1/2 skew(m) at the top link's rotation DOFs
        b = np.random.default_rng(1).standard_normal((len(f), 2))
        for transpose in (False, True, False):
            x = lin.solve(b, transpose)
            A = lin.K.T if transpose else lin.K
            # backward error at roundoff; the other matrix would leave ~asymmetry |x|
            assert np.linalg.norm(A @ x - b) <= 1e-13 * abs(A).max() * np.linalg.norm(x) < 1e-2 * asymmetry * \
                np.linalg.norm(x)
        u = lin.expand(lin.place(x))
        assert u.shape == (sol.compiled.problem.model.n_dofs, 2) and not u[lin.held].any()
        np.testing.assert_array_equal(u[f], x)


def test_ksd_reduced_linearisation_is_its_reduced_mechanism():
    """KSD-reduced's solution kind linearises on the reduced mechanism: dense, ``K`` on the links'
    free DOFs (statics) or with the joints' modal coordinates (``modal=True``, whose extra
    coordinates do not couple to the links' in ``K``: the same static compliance); buckling has
    no material tangent there and says why."""
    sol = flexmb.solve(fourbar(3, displacement=0.1), method="ksd-reduced")
    static, modal = sol.linearisation(), sol.linearisation(modal=True)
    assert static.dense and modal.dense and static.Z is None
    nl = static.K.shape[0]
    assert modal.K.shape[0] > nl and np.array_equal(modal.K[:nl, :nl], static.K)
    assert not modal.K[:nl, nl:].any()
    assert modal.expand(modal.place(np.eye(modal.K.shape[0])[:, :2])).shape == (sol.compiled.problem.model.n_dofs, 2)
    with pytest.raises(flexmb.UnsupportedStrategyError, match="no honest geometric stiffness"):
        static.material_tangent()


def test_the_built_in_parts_keep_the_protocols():
    """Every built-in strategy is a `Strategy`; the FE and closed-form problems and models are
    `Problem`s and `Model`s; the design layer's response base is a `Response`."""
    from flexmb.design.base import Response

    assert isinstance(Response(), protocols.Response)
    for cls in STRATEGIES.values():
        assert isinstance(cls(), protocols.Strategy), cls
    for sol in (flexmb.solve(cross_flexure_pivot(2, dim=2, rotation=0.1)),
                flexmb.solve(gripper(force=10.0), method="newton")):
        assert isinstance(sol.compiled.problem, protocols.Problem)
        assert isinstance(sol.compiled.problem.model, protocols.Model)


def test_no_property_module_tests_a_strategys_name():
    """The package's source names the KSD-reduced strategy only where it is registered (its class
    and the front door's documentation): no property dispatches on ``method == "ksd-reduced"``
    (issue 27). The paper studies (never imported by the library) may."""
    found = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("studies/"):
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if re.search(r"['\"]ksd-reduced['\"]", line):
                found.append(f"{rel}:{k}")
    assert [f.split(":")[0] for f in found] == ["solvers/__init__.py", "solvers/ksd.py"], found
