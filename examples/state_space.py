"""A state-space model of a cross-flexure pivot carrying a block, at a turned configuration.

A user's case beyond the papers: the Table 1 cross flexure (5 el./leaf, 3D) with a 0.2 kg steel
block on link B, turned by a 1.5 N m moment about the pivot axis. A voice coil pushes the block
along y at a point 30 mm from B ("tip"); a sensor reads the tip's y displacement and the block's
rotation. `flexmb.state_space` gives (A, B, C, D) with 6 modes and 1 % modal damping; its static
gain is `flexmb.compliance` and its poles `flexmb.modes` (printed side by side), and its Bode plot
is written (``state_space_bode.png``: the figure of ``docs/state-space.md``).
Run: python examples/state_space.py [--out FOLDER] [--quick]   (--quick: 3 modes)
"""

from __future__ import annotations

import numpy as np

import flexmb
from flexmb.studies import example_arguments

BLOCK_MASS, BLOCK_SIZE = 0.2, (0.06, 0.02, 0.02)  # [kg], [m]: a steel block 60 x 20 x 20 mm


def pivot_with_block(moment: float = 1.5) -> flexmb.Mechanism:
    """The pivot, its block B (inertia of a cuboid about its centre, 15 mm above B) and the preload."""
    joint = flexmb.CrossFlexure(elements_per_leaf=5)
    m = flexmb.Mechanism(dim=3, units="SI")
    a, b, c = BLOCK_SIZE
    inertia = BLOCK_MASS / 12 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    B = joint.interface_b(3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=B, mass=BLOCK_MASS, inertia=inertia, center=(0.0, 0.015, 0.0))
    m.add_joint("A", "B", joint, name="pivot")
    m.add_point("B", "tip", B + (0.03, 0.0, 0.0))
    m.apply_moment("B", (0.0, 0.0, moment))
    return m


def main(out=None, quick: bool = False) -> dict:
    n = 3 if quick else 6
    sol = flexmb.solve(pivot_with_block())
    ss = flexmb.state_space(sol, [("force", "B", "y", "tip")],
                            [("displacement", "B", "y", "tip"), ("displacement", "B", "rz")], n_modes=n, damping=0.01)
    C = flexmb.compliance(sol, "B", point="tip")
    f = flexmb.modes(sol, n_modes=n).frequencies
    gain = ss.static_gain()
    print(f"pivot turned {np.degrees(sol.rotation_vector('B')[2]):.2f} deg by 1.5 N m; {n} modes, 1 % damping")
    print(f"static gain tip y / force y: {gain[0, 0]:.6e} m/N (flexmb.compliance: {C[1, 1]:.6e})")
    print("mode  f [Hz]    pole [rad/s]")
    poles = ss.poles()
    for k, fk in enumerate(f):
        p = poles[np.argmin(np.abs(poles - 2j * np.pi * fk))]
        print(f"{k + 1:4d}  {fk:8.2f}  {p.real:+.3f} {p.imag:+.3f}i")
    if out is not None:
        try:
            mag, _ = ss.plot()
        except flexmb.MissingExtraError:
            print("(no figure: pip install 'flexmb[plot]')")
        else:
            mag.set_title("Cross-flexure pivot with a block, turned by 1.5 N m")
            from pathlib import Path

            Path(out).mkdir(parents=True, exist_ok=True)
            mag.figure.savefig(Path(out) / "state_space_bode.png", dpi=110)
    return {"state_space": ss, "compliance": C, "frequencies": f, "solution": sol}


if __name__ == "__main__":
    out, quick = example_arguments(__doc__)
    main(out, quick)
