"""Pictures a flexure designer reads (issue 22, item 9), written to ``docs/``:

* ``three_x_infinity_plates.png``: a ``three_x_infinity`` joint turned 30 deg, its leaves drawn as
  plates of their real width and thickness (`flexmb.plot.plot_mechanism` in 3D);
* ``cross_flexure_mode.png``: the first parasitic mode of the Table 1 cross flexure (Dwarshuis et
  al. 2020; block B of 1 kg, diag(1e-3) kg m^2, as ``examples/cross_flexure_modes.py``) turned 30
  deg, B's turn held (`flexmb.plot.plot_mode`);
* ``cross_flexure_frequencies.png``: its first four frequencies over the stroke 0 ... 75 deg (the
  figure of Naves et al. 2017; `flexmb.sweep(..., properties=)`, `flexmb.plot.plot_frequencies`);

and the mode as ``cross_flexure_mode.vtu`` in the current folder (ParaView: Warp By Vector on
``mode_scaled``; `flexmb.export.write_mode`). Run: python examples/mode_pictures.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexmb
from flexmb import export, plot

DOCS = Path(__file__).resolve().parents[1] / "docs"
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


def run(docs: Path = DOCS, vtu: Path | None = Path("cross_flexure_mode.vtu")) -> dict:
    """Write the three figures (and the mode's ``.vtu``); returns the numbers they show."""
    out = {}
    sol = three_x_infinity()
    plot.save(plot.plot_mechanism(sol, undeformed=False), docs / "three_x_infinity_plates.png")

    pivot = cross_flexure()
    pivot.prescribe("B", rotation=(0.0, 0.0, np.radians(30.0)))
    at30 = flexmb.solve(pivot)
    modes = flexmb.modes(at30, n=4, held=[("B", "rz")])
    plot.save(plot.plot_mode(modes, 0), docs / "cross_flexure_mode.png")
    out["f_30deg"] = modes.frequencies
    if vtu is not None:
        export.write_mode(modes, 0, vtu)

    stroke = np.radians(STROKE_DEG)
    pivot = cross_flexure()
    pivot.prescribe("B", rotation=(0.0, 0.0, 0.0))
    over = flexmb.sweep(pivot, np.column_stack([0 * stroke, 0 * stroke, stroke]), motion=("B", "rotation"),
                        properties={"which": ("modes",), "n_modes": 4, "held": [("B", "rz")]})
    table = over.table()
    ax = plot.plot_frequencies(table, "B.rotation_z", xlabel="B turned about z [deg]", degrees=True)
    ax.set_title("Table 1 cross flexure, B's turn held (5 el./leaf)")
    plot.save(ax, docs / "cross_flexure_frequencies.png")
    out["stroke_f"] = {c: np.asarray(table[c]) for c in ("f1", "f2", "f3", "f4")}
    return out


if __name__ == "__main__":
    res = run()
    print("f1..f4 at 30 deg [Hz]:", res["f_30deg"].round(1))
    for c, f in res["stroke_f"].items():
        print(c, "over", STROKE_DEG, "deg [Hz]:", f.round(1))
