"""Tutorial: a bistable switch (two inclined leaves, mm, N, MPa) traced through its snap.

Two spring-steel leaves (50 x 0.2 mm) rise at 10 deg from the ground to a shuttle guided along y. Pushed down, the
shuttle's force rises, the leaves buckle sideways (a bifurcation), the force falls through zero
(an unstable equilibrium) to a negative minimum and comes back to zero at the second stable
position. `flexmb.trace` follows that path by arc length, locates the critical points and the
zero crossings. Printed beside the inextensible elastica of the same leaves, solved by shooting
(tests/test_snap.py, `InclinedLeaf`).
Run: python examples/tutorial_bistable.py [--quick]   (the same numbers either way)
"""

from __future__ import annotations

import math
from pathlib import Path

import flexmb
from flexmb.studies import example_arguments

#: the shooting elastica of two such leaves (Euler-Bernoulli, inextensible; tests/test_snap.py
#: `InclinedLeaf(L=50, t=0.2, w=10, E=196500, alpha=10 deg).curve()`, two leaves): snap force,
#: minimum force [N], the middle (unstable) and the second stable position [mm]
ELASTICA = {"snap": 7.172610, "minimum": -2.415210, "middle": 8.682409, "second": 13.478741}

# --8<-- [start:switch]
L, RISE = 50.0, math.radians(10.0)         # leaf length [mm], angle to the ground
LEAF = dict(length=L, thickness=0.2, width=10.0, material="spring_steel", elements=24)


def switch() -> flexmb.Mechanism:
    m = flexmb.Mechanism(dim=2, units="mm-N-MPa")
    apex = L * math.sin(RISE)
    m.add_link("left", (-L * math.cos(RISE), 0.0), fixed=True)
    m.add_link("right", (L * math.cos(RISE), 0.0), fixed=True)
    m.add_link("shuttle", (0.0, apex))
    for side, x, angle in (("left", -L * math.cos(RISE), RISE), ("right", L * math.cos(RISE), math.pi - RISE)):
        m.add_joint(side, "shuttle", "leaf_spring", name=f"{side} leaf", origin=(x, 0.0), rotation=angle, **LEAF)
    m.prescribe("shuttle", x=0.0, y=-2 * apex, rotation=0.0)   # pushed down 2 x the rise at load factor 1
    return m
# --8<-- [end:switch]


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Trace the push; print the critical points and the zero crossings beside the elastica;
    nothing is written, ``quick`` changes nothing."""
    # --8<-- [start:trace]
    path = flexmb.trace(switch(), max_load_factor=0.8, steps=200, progress=False)   # 1.6 x the rise
    push = [-c.solution.reaction("shuttle")[1] for c in path.critical]           # [N]
    zeros = path.crossings(lambda s: s.reaction("shuttle")[1])                  # force = 0
    stroke = [-s.displacement("shuttle")[1] for s in zeros]                      # [mm]
    # --8<-- [end:trace]
    print(f"stable throughout: {bool(path.stable.all())}, snaps: {path.snap is not None}")
    print(f"{'critical point':16} {'kind':>12} {'x':>2} {'force [N]':>10} {'elastica':>9}")
    for label, c, f in zip(("snap force", "minimum force"), path.critical, push):
        ref = ELASTICA["snap" if label == "snap force" else "minimum"]
        print(f"{label:16} {c.kind:>12} {c.multiplicity:2d} {f:10.4f} {ref:9.4f}")
    print(f"{'zero force at':16} {'stroke [mm]':>26} {'elastica':>9}")
    for label, s, ref in zip(("rest", "middle", "second stable"), stroke, (0.0, ELASTICA["middle"],
                                                                          ELASTICA["second"])):
        print(f"{label:16} {abs(s) if label == 'rest' else s:26.4f} {ref:9.4f}")
    return {"path": path, "push": push, "stroke": stroke}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
