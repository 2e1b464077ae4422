"""Derivatives of eigenfrequencies, buckling multipliers and compliance entries at deformed
states (issue 28): Taylor test and central differences, closed forms, repeated eigenvalues."""

from __future__ import annotations

import numpy as np
import pytest
from design_cases import PIVOT, PIVOT_BOUNDS, SPATIAL, pivot, spatial

import flexmb
from flexmb.design import evaluate
from flexmb.design import responses as R
from flexmb.design.check import check_gradient

TIGHT = dict(rtol=1e-12)


def test_compliance_at_a_point_in_link_axes():
    resp = R.compliance("B", "y", "x", point=(0.01, 0.08), axes="link")
    c = check_gradient(lambda q: pivot(q, 2), PIVOT, resp, bounds=PIVOT_BOUNDS, **TIGHT)
    assert c.ok, str(c)


@pytest.mark.parametrize("response", [R.frequency(2), R.buckling(1), R.compliance("B", "z", "rx", point="tip"),
                                      R.compliance("B", "y", "y", axes="link"), R.compliance("C", "x", "z", held="fixed")])
def test_spatial_linearisation_gradients(response):
    # non-symmetric tangent (dead moment, loads at offsets): left vectors / K^-T in the derivatives
    c = check_gradient(spatial, SPATIAL, response, **TIGHT)
    assert c.ok, str(c)


def _column(p, dim=2):
    """A slender cantilever (L/t = 100) pushed along its axis by 0.05 % of Euler's load; 40 elements
    (the co-rotational geometric stiffness converges from above as 1/n^2: +0.2 % at 10, +0.007 % at 40)."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(p["L"], 0.0, 0.0)[:dim])
    m.add_joint("A", "B", "leaf_spring", length=p["L"], thickness=p["t"], width=0.02, elements=40)
    m.apply_force("B", (-0.2, 0.0, 0.0)[:dim])
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_euler_buckling_load_scales_with_thickness_cubed(dim):
    # Euler's cantilever (fixed-free): P_cr = pi^2 E I / (4 L^2), I = w t^3 / 12 (Timoshenko & Gere,
    # Theory of Elastic Stability, 1961, Sec. 2.1): d ln P / d ln t = 3, d ln P / d ln L = -2.
    p = {"L": 0.1, "t": 1e-3}
    ev = evaluate(lambda q: _column(q, dim), p, R.buckling(1), **TIGHT)
    mu, g = ev.values[0], ev.gradient(0)
    s = flexmb.rectangle(0.02, 1e-3, 200e9, 76.9e9)
    assert 0.2 * mu == pytest.approx(np.pi**2 * s.E * s.Iz / (4 * 0.1**2), rel=1e-3)
    assert g["t"] * p["t"] / mu == pytest.approx(3.0, abs=1e-3)
    assert g["L"] * p["L"] / mu == pytest.approx(-2.0, abs=1e-3)


def _tip_mass(p, dim=2):
    """A 1 kg block on a massless leaf (one Timoshenko element: exact end stiffness)."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(p["L"], 0.0, 0.0)[:dim], mass=1.0,
               inertia=1e-6 if dim == 2 else np.diag([1e-6, 1e-6, 1e-6]))
    m.add_joint("A", "B", "leaf_spring", length=p["L"], thickness=p["t"], width=0.02, elements=1, density=0.0)
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_tip_mass_frequency_scales_with_thickness_to_one_and_a_half(dim):
    # a mass m on a massless cantilever: f = sqrt(3 E I / (m L^3)) / (2 pi) (Blevins, Formulas for
    # Natural Frequency and Mode Shape, 1979, Table 8-1): d ln f / d ln t = 1.5, d ln f / d ln L = -1.5
    p = {"L": 0.1, "t": 1e-3}
    ev = evaluate(lambda q: _tip_mass(q, dim), p, R.frequency(1), **TIGHT)
    f, g = ev.values[0], ev.gradient(0)
    s = flexmb.rectangle(0.02, 1e-3, 200e9, 76.9e9)
    assert f == pytest.approx(np.sqrt(3 * s.E * s.Iz / 0.1**3) / (2 * np.pi), rel=2e-3)
    assert g["t"] * p["t"] / f == pytest.approx(1.5, abs=1e-3)
    assert g["L"] * p["L"] / f == pytest.approx(-1.5, abs=2e-3)


def _square_wire(p):
    """A square wire (w = t) carrying a block, 3D: its two bending modes are one repeated eigenvalue."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.1, 0.0, 0.0), mass=0.05, inertia=np.diag([1e-6, 1e-6, 1e-6]))
    m.add_joint("A", "B", "leaf_spring", length=0.1, thickness=p["t"], width=p["w"], elements=1, density=0.0)
    return m


def test_repeated_eigenvalue_gives_the_one_sided_derivatives():
    # Seyranian, Lund & Olhoff (1994): the cluster's derivatives along dp are the eigenvalues of
    # Phi^T (dK - lam dM) Phi. Widening the wire (w) stiffens one bending mode much more than the
    # other: f_1's right derivative is the smaller, f_2's the larger; one-sided differences agree.
    p = {"t": 2e-3, "w": 2e-3}
    sol = flexmb.solve(_square_wire(p))
    f = flexmb.modes(sol, n_modes=2).frequencies
    assert abs(f[1] - f[0]) <= 1e-9 * f[0]  # repeated
    ev = evaluate(_square_wire, p, [R.frequency(1), R.frequency(2)], **TIGHT)
    assert np.all(np.isfinite(ev.jacobian))
    h = 1e-9
    fwd = {k: (flexmb.modes(flexmb.solve(_square_wire({**p, k: p[k] + h})), n_modes=2).frequencies - f) / h for k in p}
    for i in range(2):
        for k in p:
            assert ev.gradient(i)[k] == pytest.approx(fwd[k][i], rel=1e-4), (i, k)
    assert ev.gradient(0)["w"] < ev.gradient(1)["w"]  # the cluster splits
    # the mean of the cluster is differentiable: its gradient is the mean of the two
    mean = evaluate(_square_wire, p, R.frequency(1, cluster="mean"), **TIGHT)
    assert mean.gradient(0)["w"] == pytest.approx(0.5 * (ev.gradient(0)["w"] + ev.gradient(1)["w"]), rel=1e-9)
