"""Tutorial: a compliant four-bar and its pseudo-rigid-body model (hinges with torsional springs).

A four-bar whose pivots are short leaf springs (small-length flexural pivots, Howell 2001) moves
like a rigid four-bar with a torsional spring k = EI/l at the middle of each leaf: its
pseudo-rigid-body (PRB) model, built from `hinge` joints. Both are turned at the crank; printed:
the rocker's angle (beside the rigid four-bar's exact kinematics) and the crank torque (beside
the PRB model's virtual work, sum k_i theta_i dtheta_i/dtheta_2).
Run: python examples/tutorial_prb_linkage.py [--quick]   (the same numbers either way)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb.studies import example_arguments

# --8<-- [start:geometry]
a, b, c, d = 0.04, 0.12, 0.08, 0.10          # crank, coupler, rocker, ground [m]
TH2 = np.radians(60.0)                       # the crank's angle at rest


def rocker_angle(th2: float) -> float:
    """The rigid four-bar's rocker angle [rad] (two circles' intersection, the upper branch)."""
    p1, p3 = a * np.array([np.cos(th2), np.sin(th2)]), np.array([d, 0.0])
    gap = p3 - p1
    dist = np.linalg.norm(gap)
    along = (b**2 - c**2 + dist**2) / (2 * dist)
    p2 = p1 + along * gap / dist + np.sqrt(b**2 - along**2) * np.array([-gap[1], gap[0]]) / dist
    return float(np.arctan2(p2[1], p2[0] - d))


TH4 = rocker_angle(TH2)
P = [np.zeros(2), a * np.array([np.cos(TH2), np.sin(TH2)]),               # the pivots P0...P3
     np.array([d + c * np.cos(TH4), c * np.sin(TH4)]), np.array([d, 0.0])]
PIVOT = dict(length=6e-3, thickness=0.15e-3, width=5e-3, material="spring_steel", elements=8)
E = flexmb.material("spring_steel").E
K = E * PIVOT["width"] * PIVOT["thickness"] ** 3 / 12 / PIVOT["length"]    # EI / l [N m/rad]
# --8<-- [end:geometry]

# which links each pivot joins and the direction its leaf lies along
PIVOTS = (("ground", "crank", P[1] - P[0], P[0]), ("crank", "coupler", P[2] - P[1], P[1]),
          ("coupler", "rocker", P[2] - P[1], P[2]), ("ground", "rocker", P[2] - P[3], P[3]))


# --8<-- [start:build]
def four_bar(prb: bool) -> flexmb.Mechanism:
    """The compliant four-bar (``prb=False``: a short leaf centred on each pivot, along the
    link it turns) or its PRB model (``prb=True``: a hinge with the spring K there)."""
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    for name, at in (("crank", P[0]), ("coupler", P[1]), ("rocker", P[3])):
        m.add_link(name, position=at)
    for i, (link_a, link_b, along, at) in enumerate(PIVOTS):
        if prb:
            m.add_joint(link_a, link_b, "hinge", name=f"P{i}", origin=at, k=K)
        else:
            u = along / np.linalg.norm(along)
            m.add_joint(link_a, link_b, "leaf_spring", name=f"P{i}", origin=at - u * PIVOT["length"] / 2,
                        rotation=np.arctan2(u[1], u[0]), **PIVOT)
    m.prescribe("crank", rotation=0.0)      # the input: the crank's turn
    return m
# --8<-- [end:build]


def prb_torque(turn: float) -> float:
    """The PRB model's crank torque by virtual work: sum k theta_i dtheta_i/dtheta_2 [N m]."""
    def angles(t):
        th4 = rocker_angle(TH2 + t)
        p2 = np.array([d + c * np.cos(th4), c * np.sin(th4)])
        p1 = a * np.array([np.cos(TH2 + t), np.sin(TH2 + t)])
        th3 = np.arctan2(*(p2 - p1)[::-1]) - np.arctan2(*(P[2] - P[1])[::-1])   # the coupler's turn
        return np.array([t, th3 - t, (th4 - TH4) - th3, th4 - TH4])             # the four hinges' angles
    h = 1e-6
    return float(K * angles(turn) @ ((angles(turn + h) - angles(turn - h)) / (2 * h)))


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Both models at five crank turns; nothing is written, ``quick`` changes nothing."""
    # --8<-- [start:solve]
    turns = np.radians([-15.0, -7.5, 7.5, 15.0])
    compliant = flexmb.sweep(four_bar(prb=False), turns, motion=("crank", "rotation"), progress=False)
    prb = flexmb.sweep(four_bar(prb=True), turns, motion=("crank", "rotation"), progress=False)
    # --8<-- [end:solve]
    rows = []
    print(f"K = EI/l = {K:.5f} N m/rad per pivot")
    print(f"{'crank':>6} {'rocker turn [deg]: rigid':>25} {'PRB':>9} {'leaves':>9} {'torque [N m m]: PRB':>20} "
          f"{'virtual work':>13} {'leaves':>9}")
    for t, s_fe, s_prb in zip(turns, compliant, prb):
        exact = np.degrees(rocker_angle(TH2 + t) - TH4)
        row = (exact, np.degrees(s_prb.pose("rocker")[1]), np.degrees(s_fe.pose("rocker")[1]),
               s_prb.reaction("crank")[2] * 1e3, prb_torque(t) * 1e3, s_fe.reaction("crank")[2] * 1e3)
        rows.append(row)
        print(f"{np.degrees(t):6.1f} {row[0]:25.4f} {row[1]:9.4f} {row[2]:9.4f} {row[3]:20.4f} {row[4]:13.4f} "
              f"{row[5]:9.4f}")
    return {"turns": turns, "rows": np.array(rows), "K": K}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
