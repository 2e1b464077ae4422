"""Pictures a flexure designer reads (issue 22, item 9), written to ``docs/``:

* ``three_x_infinity_plates.png``: a ``three_x_infinity`` joint turned 30 deg, its leaves drawn as
  plates of their real width and thickness (`flexmb.plot.plot_mechanism` in 3D);
* ``cross_flexure_mode.png``: the first parasitic mode of the Table 1 cross flexure (Dwarshuis et
  al. 2020; block B of 1 kg, diag(1e-3) kg m^2, as ``examples/cross_flexure_modes.py``) turned 30
  deg, B's turn held (`flexmb.plot.plot_mode`);
* ``cross_flexure_frequencies.png``: its first four frequencies over the stroke 0 ... 75 deg (the
  figure of Naves et al. 2017; `flexmb.sweep(..., properties=)`, `flexmb.plot.plot_frequencies`);

and the mode as ``cross_flexure_mode.vtu`` (ParaView: Warp By Vector on ``mode_scaled``;
`flexmb.export.write_mode`), all into --out. Run: python examples/mode_pictures.py [--out docs] [--quick]
(--quick: 3 el./leaf and three stroke points)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb import export, plot
from flexmb.studies import example_arguments

STROKE_DEG = np.linspace(0.0, 75.0, 6)


def cross_flexure(elements_per_leaf: int = 5) -> flexmb.Mechanism:
    """The Table 1 cross flexure with block B's mass, A fixed (B's turn prescribed by the caller)."""
    joint = flexmb.CrossFlexure(elements_per_leaf=elements_per_leaf, density=7800.0)
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3), mass=1.0, inertia=1e-3 * np.eye(3))
    m.add_joint("A", "B", joint, name="pivot")
    return m


def three_x_infinity(rotation_deg: float = 30.0) -> flexmb.Solution:
    joint = flexmb.ThreeXInfinity()
    m = flexmb.Mechanism(dim=3)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(3))
    m.add_joint("A", "B", joint, name="joint")
    m.prescribe("B", rotation=(0.0, 0.0, np.radians(rotation_deg)))
    return flexmb.solve(m)


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Write the three figures and the mode's ``.vtu`` into ``out`` (None: the numbers only);
    returns the numbers they show; ``quick``: 3 el./leaf and three points over the stroke."""
    docs, res = (None if out is None else Path(out)), {}
    if docs is not None:
        docs.mkdir(parents=True, exist_ok=True)
    n = 3 if quick else 5
    stroke_deg = STROKE_DEG[::2] if quick else STROKE_DEG
    sol = three_x_infinity()
    if docs is not None:
        plot.save(plot.plot_mechanism(sol, undeformed=False), docs / "three_x_infinity_plates.png")

    pivot = cross_flexure(n)
    pivot.prescribe("B", rotation=(0.0, 0.0, np.radians(30.0)))
    at30 = flexmb.solve(pivot)
    modes = flexmb.modes(at30, n_modes=4, held=[("B", "rz")])
    res["f_30deg"] = modes.frequencies
    if docs is not None:
        plot.save(plot.plot_mode(modes, 0), docs / "cross_flexure_mode.png")
        export.write_mode(modes, 0, docs / "cross_flexure_mode.vtu")

    stroke = np.radians(stroke_deg)
    pivot = cross_flexure(n)
    pivot.prescribe("B", rotation=(0.0, 0.0, 0.0))
    over = flexmb.sweep(pivot, np.column_stack([0 * stroke, 0 * stroke, stroke]), motion=("B", "rotation"),
                        properties={"which": ("modes",), "n_modes": 4, "held": [("B", "rz")]})
    table = over.table()
    res["stroke_f"] = {c: np.asarray(table[c]) for c in ("f1", "f2", "f3", "f4")}
    print("f1..f4 at 30 deg [Hz]:", res["f_30deg"].round(1))
    for c, f in res["stroke_f"].items():
        print(c, "over", stroke_deg, "deg [Hz]:", f.round(1))
    if docs is not None:
        ax = plot.plot_frequencies(table, "B.rotation_z", xlabel="B turned about z [deg]", degrees=True)
        ax.set_title(f"Table 1 cross flexure, B's turn held ({n} el./leaf)")
        plot.save(ax, docs / "cross_flexure_frequencies.png")
    return res


if __name__ == "__main__":
    main(*example_arguments(__doc__, out="docs"))
