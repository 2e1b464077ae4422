"""The compiled complex-step rows (`flexmb.fe.beam_step_jit`, issue 28's per-configuration cost):
their imaginary parts are the directional derivatives of the float element rows (central
differences in deformed states, >= 0.3 rad), their real parts the float rows, and they equal the
numpy complex path of `flexmb.design.partials` (which FLEXMB_KERNELS=numpy runs), in 2D and 3D."""

from __future__ import annotations

import types

import numpy as np
import pytest
from design_cases import PIVOT, pivot
from test_kernels import _batch2d, _batch3d

import flexmb
from flexmb import jit
from flexmb.design import DesignPoint, partials
from flexmb.design.partials import H
from flexmb.fe import beam2d, beam3d
from flexmb.fe.model import FEModel
from flexmb.rotations import expm_so3, rot2, skew

pytestmark = pytest.mark.skipif(not jit.enabled(), reason="the compiled rows need numba (FLEXMB_KERNELS != numpy)")


def _rel(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


def _rows(dim, rng, n=24, turn=0.5):
    """A batch of deformed rows: element data from test_kernels' batches (their ends as master
    positions), master rotations turned ~``turn`` rad, end offsets of a few mm, and random rates."""
    if dim == 3:
        xp, xq, Rp, Rq, ny0, nz0, L0, S = _batch3d(rng, n=n, turn=turn)
        R = np.stack([Rp, Rq], axis=1)
        s = 3e-3 * rng.normal(size=(n, 2, 3))
        x = np.stack([xp, xq], axis=1) - np.einsum("bkij,bkj->bki", R, s)  # the ends where the batch has them
        base = dict(x=x, R=R, s=s, ny0=ny0, nz0=nz0, L0=L0, S=S)
    else:
        xp, xq, thp, thq, a0, L0, S = _batch2d(rng, n=n, turn=turn)
        th = np.stack([thp, thq], axis=1)
        s = 3e-3 * rng.normal(size=(n, 2, 2))
        x = np.stack([xp, xq], axis=1) - np.einsum("bkij,bkj->bki", rot2(th), s)
        base = dict(x=x, th=th, s=s, alpha0=a0, L0=L0, S=S)
    rate = {k: rng.normal(size=np.shape(v)) * (np.abs(v) + 1e-3 * np.abs(v).max()) for k, v in base.items()
            if k not in ("x", "R", "th")}
    du = rng.normal(size=(n, 2, 6 if dim == 3 else 3)) * np.repeat([1e-3, 0.3], 3 if dim == 3 else (2, 1))
    return base, rate, du


def _compiled(dim, base, rate, du, tangent=True, material=False):
    from flexmb.fe import beam_step_jit

    if dim == 3:
        return beam_step_jit.rows_3d(base["x"], base["R"], du, base["s"], rate["s"], base["ny0"], rate["ny0"],
                                     base["nz0"], rate["nz0"], base["L0"], rate["L0"], base["S"], rate["S"], H,
                                     tangent, material)
    return beam_step_jit.rows_2d(base["x"], base["th"], du, base["s"], rate["s"], base["alpha0"], rate["alpha0"],
                                 base["L0"], rate["L0"], base["S"], rate["S"], H, tangent, material)


def _reference(dim, base, material=False):
    """The rows by the numpy kernels and `FEModel`'s transfer (float or complex inputs): point ends at
    ``x + R s``, the element, the wrenches moved to the masters, ``T^T K T`` plus the offsets' blocks."""
    nd, cplx = 3 * (dim - 1), np.iscomplexobj(base["s"])
    model = types.SimpleNamespace(dim=dim, ndof=nd)
    if dim == 3:
        R = base["R"]
        d = np.einsum("bkij,bkj->bki", R, base["s"])
        xe = base["x"] + d
        F, K, e, sig = beam3d.numpy_internal_force_and_tangent(
            xe[:, 0], xe[:, 1], R[:, 0], R[:, 1], base["ny0"], base["nz0"], base["L0"], base["S"],
            geometric_stress=np.zeros_like if material else None)
    else:
        d = np.einsum("bkij,bkj->bki", rot2(base["th"]), base["s"])
        xe = base["x"] + d
        F, K, e, sig = beam2d.numpy_internal_force_and_tangent(
            xe[:, 0], xe[:, 1], base["th"][:, 0], base["th"][:, 1], base["alpha0"], base["L0"], base["S"],
            geometric_stress=np.zeros_like if material else None)
    n = len(base["L0"])
    Fm, G = FEModel.transfer(model, F.reshape(-1, nd), d.reshape(-1, dim))
    lever = partials._lever(d.reshape(-1, dim), nd) if cplx else FEModel._lever(model, d.reshape(-1, dim))
    T = np.zeros((n, 2 * nd, 2 * nd), dtype=lever.dtype)
    T[:, :nd, :nd], T[:, nd:, nd:] = lever.reshape(n, 2, nd, nd)[:, 0], lever.reshape(n, 2, nd, nd)[:, 1]
    K = np.swapaxes(T, 1, 2) @ K @ T
    if not material:
        G = G.reshape(n, 2, nd - dim, nd - dim)
        K[:, dim:nd, dim:nd] += G[:, 0]
        K[:, nd + dim:, nd + dim:] += G[:, 1]
    return Fm.reshape(n, 2 * nd), K, e, sig


def _moved(dim, base, rate, du, h):
    """The rows' data moved by ``h`` along the direction: master translations ``+ h dx``, rotations
    ``exp(h skew(dphi)) R`` (2D: ``theta + h dtheta``), every number by ``h`` times its rate."""
    out = {k: (v + h * rate[k] if k in rate else v) for k, v in base.items()}
    out["x"] = base["x"] + h * du[..., :dim]
    if dim == 3:
        out["R"] = np.einsum("bkij,bkjl->bkil", expm_so3(h * du[..., 3:].reshape(-1, 3)).reshape(-1, 2, 3, 3),
                             base["R"])
    else:
        out["th"] = base["th"] + h * du[..., 2]
    return out


def _complex_rows(dim, base, rate, du):
    """The rows' data as partials' numpy path moves them: ``+ i H`` times each rate, the master nodes'
    translations, rotations ``R + i H skew(dphi) R`` (2D: ``theta + i H dtheta``)."""
    cplx = {k: (v + 1j * H * rate[k] if k in rate else v.astype(complex)) for k, v in base.items()}
    cplx["x"] = base["x"] + 1j * H * du[..., :dim]
    if dim == 3:
        w = du[..., 3:].reshape(-1, 3)
        cplx["R"] = base["R"] + 1j * H * (skew(w) @ base["R"].reshape(-1, 3, 3)).reshape(base["R"].shape)
    else:
        cplx["th"] = base["th"] + 1j * H * du[..., 2]
    return cplx


@pytest.mark.parametrize("material", [False, True])
@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_rows_are_the_central_differences_of_the_float_rows(dim, material):
    base, rate, du = _rows(dim, np.random.default_rng(dim))
    F, K, e, sig = _compiled(dim, base, rate, du, material=material)
    ref = _reference(dim, base, material)
    valid = ~np.isnan(ref[2]).any(axis=1)
    assert valid.sum() >= 15 and np.array_equal(np.isnan(e.real).any(axis=1), ~valid)
    h = 1e-6
    plus, minus = (_reference(dim, _moved(dim, base, rate, du, s * h), material) for s in (1.0, -1.0))
    for got, r, p, m in zip((F, K, e, sig), ref, plus, minus):
        assert _rel(got.real[valid], r[valid]) < 1e-13  # the real parts: the float rows
        fd = (p - m)[valid] / (2 * h)
        assert _rel(got.imag[valid] / H, fd) < 1e-6


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_rows_equal_the_numpy_complex_path(dim):
    base, rate, du = _rows(dim, np.random.default_rng(10 + dim), n=30, turn=0.6)
    cplx = _complex_rows(dim, base, rate, du)
    for material in (False, True):
        got, ref = _compiled(dim, base, rate, du, material=material), _reference(dim, cplx, material)
        valid = ~np.isnan(ref[2].real).any(axis=1)
        for a, b in zip(got, ref):
            assert _rel(a.real[valid], b.real[valid]) < 1e-13 and _rel(a.imag[valid], b.imag[valid]) < 1e-12
    F, K, e, sig = _compiled(dim, base, rate, du, tangent=False)
    assert K is None and _rel(F[valid], _reference(dim, cplx)[0][valid]) < 1e-12


def _float_mass(dim, base):
    """`flexmb.fe.mass.element_mass` of the rows (each on nodes of its own; float or complex)."""
    from flexmb.fe.mass import element_mass
    from flexmb.fe.model import State

    n = len(base["local"])
    el = types.SimpleNamespace(ends=np.arange(2 * n).reshape(-1, 2), ny0=base.get("ny0"), L0=np.ones(n))
    view = partials._RowModel(dim, base["s"].reshape(-1, dim), el)
    rot = base["R"].reshape(-1, 3, 3) if dim == 3 else base["th"].reshape(-1)
    return element_mass(view, State(base["x"].reshape(-1, dim), rot), base["local"])


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_mass_rows_are_the_derivatives_of_the_element_mass(dim):
    from flexmb.fe import beam_step_jit
    from flexmb.fe.mass import local_mass
    from flexmb.sections import rectangle

    rng = np.random.default_rng(20 + dim)
    base, rate, du = _rows(dim, rng, n=20, turn=0.5)
    n = len(base["L0"])
    base["local"] = local_mass([rectangle(0.01, 5e-4, 200e9, 77e9, density=7800.0)] * n, base["L0"], dim)
    rate["local"] = rng.normal(size=base["local"].shape) * np.abs(base["local"])
    args = (base["x"], base["R"] if dim == 3 else base["th"], du, base["s"], rate["s"])
    if dim == 3:
        M = beam_step_jit.mass_rows_3d(*args, base["ny0"], rate["ny0"], base["local"], rate["local"], H)
    else:
        M = beam_step_jit.mass_rows_2d(*args, base["local"], rate["local"], H)
    assert _rel(M.real, _float_mass(dim, base)) < 1e-13
    h = 1e-6
    fd = (_float_mass(dim, _moved(dim, base, rate, du, h)) - _float_mass(dim, _moved(dim, base, rate, du, -h))) / (2 * h)
    assert _rel(M.imag / H, fd) < 1e-6
    ref = _float_mass(dim, _complex_rows(dim, base, rate, du))  # the numpy complex path
    assert _rel(M.real, ref.real) < 1e-13 and _rel(M.imag, ref.imag) < 1e-12
    # the rows' forms V^T M W without the blocks
    V, W = rng.normal(size=(n, M.shape[1], 2)), rng.normal(size=(n, M.shape[1], 3))
    args = args[:5] + ((base["ny0"], rate["ny0"]) if dim == 3 else ()) + (base["local"], rate["local"], H, V, W)
    forms = (beam_step_jit.mass_rows_3d if dim == 3 else beam_step_jit.mass_rows_2d)(*args)
    expected = np.einsum("bia,bij,bjc->bac", V, M, W)
    assert _rel(forms.real, expected.real) < 1e-13 and _rel(forms.imag, expected.imag) < 1e-12


def _mm_leaf(p: dict) -> flexmb.Mechanism:
    """A leaf spring in mm-N-MPa (no paper's case): 40 mm long, 0.3 mm thick, steel (E in MPa),
    its free end turned 0.5 rad about a skew axis, a 2 N dead load at an offset point."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(p["L"], 0.0, 0.0))
    m.add_joint("A", "B", "leaf_spring", length=p["L"], thickness=p["t"], width=8.0, E=p["E"], G=p["E"] / 2.6,
                elements=6)
    m.prescribe("B", rotation=(0.1, -0.2, 0.45))
    m.apply_force("B", (0.5, 2.0, -0.3), point=(p["L"] + 3.0, 1.0, 0.0))
    return m


@pytest.mark.parametrize("case", ["pivot2", "pivot3", "mm"])
def test_design_rows_equal_under_both_kernels(case):
    # the whole of partials' rows on deformed solutions (rates of every parameter and the state's
    # rates as directions): the compiled rows against the numpy complex path
    build, p = {"pivot2": (lambda q: pivot(q, 2), PIVOT), "pivot3": (lambda q: pivot(q, 3), PIVOT),
                "mm": (_mm_leaf, dict(L=40.0, t=0.3, E=200e3))}[case]
    point = DesignPoint(build, p)
    sol = flexmb.solve(point.design.mechanism())
    assert sol.converged
    rates = point.rates(sol.compiled)
    problem, state, model = sol.compiled.problem, sol.state, sol.compiled.problem.model
    du = np.random.default_rng(0).normal(size=(model.n_dofs, len(point.names)))
    cols, rows = partials._element_rows(model, rates, du)
    assert len(rows) >= len(model.elements.L0)
    results = {}
    for kernels in ("numba", "numpy"):
        previous = jit.use(kernels)
        try:
            results[kernels] = [partials._elements(model, state, rates, cols, rows, du, tangent=True, material=mat)
                                for mat in (False, True)]
            results[kernels].append(partials._elements(model, state, rates, cols, rows, None, tangent=False,
                                                       stresses=True))
            results[kernels].append([b for part in partials.mass_blocks(problem, state, rates, du) for b in part])
            V, W = np.random.default_rng(1).normal(size=(2, model.n_dofs, 2))
            results[kernels].append([partials.mass_forms(problem, state, rates, du, V, W)])
        finally:
            jit.use("numba" if previous else "numpy")
    for a, b in zip(results["numba"], results["numpy"]):
        for x, y in zip(a, b):
            assert _rel(np.real(x), np.real(y)) < 1e-12 and _rel(np.imag(x), np.imag(y)) < 1e-10
