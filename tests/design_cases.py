"""Designs shared by the design-gradient tests: builds a user would write, deformed >= 0.3 rad."""

from __future__ import annotations

import numpy as np

import flexmb


def pivot(p: dict, dim: int = 2) -> flexmb.Mechanism:
    """A cross-flexure pivot turned 0.4 rad (prescribed), a dead force at an offset point of the
    turned link, the block's mass: joint dimensions (L, a, t), material (E), placement (x), mass (m)
    and load (F) as parameters."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=(0.0, p["L"] * np.sin(p["a"]), 0.0)[:dim], mass=p["m"])
    m.add_joint("A", "B", "cross_flexure", length=p["L"], angle=p["a"], thickness=p["t"], E=p["E"],
                elements_per_leaf=5, origin=(p["x"], 0.0, 0.0)[:dim])
    m.prescribe("B", rotation=0.4 if dim == 2 else (0.0, 0.0, 0.4))
    m.apply_force("B", (p["F"], -2.0, 0.0)[:dim], point=(0.02, 0.05, 0.0)[:dim])
    return m


PIVOT = dict(L=0.1, a=np.pi / 4, t=1e-3, E=200e9, m=1.0, x=0.0, F=3.0)
PIVOT_BOUNDS = {"x": (-0.01, 0.01)}


def spatial(p: dict) -> flexmb.Mechanism:
    """A genuinely spatial case: a leaf spring placed turned about x by ``phi``, its free link
    turned about a skew axis (prescribed rotation vector with a parameter in it, 0.45 rad), a dead
    force at an offset out of the plane and a dead moment (a non-symmetric tangent), and a second
    leaf from the turned link to a free link B loaded sideways."""
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("C", position=(p["L"], 0.0, 0.0))
    m.add_link("B", position=(2 * p["L"], 0.0, 0.0), mass=p["m"])
    m.add_joint("A", "C", "leaf_spring", length=p["L"], thickness=p["t"], width=p["w"], elements=6,
                rotation=(p["phi"], 0.0, 0.0), name="leaf1")
    m.add_joint("C", "B", "leaf_spring", length=p["L"], thickness=p["t"], width=0.01, E=p["E"], elements=6,
                origin=(p["L"], 0.0, 0.0), name="leaf2")
    m.prescribe("C", rotation=(0.1, p["ry"], 0.4))
    m.apply_force("B", (0.3, p["F"], -0.5), point=(2 * p["L"] + 0.01, 0.0, 0.02))
    m.apply_moment("B", (0.0, 0.02, 0.01))
    m.add_point("B", "tip", (2 * p["L"] + 0.02, 0.005, 0.0))
    return m


SPATIAL = dict(L=0.08, t=8e-4, w=0.02, phi=0.2, E=200e9, ry=-0.15, m=0.5, F=1.5)
