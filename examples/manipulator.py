"""The three_x_infinity joint and the spatial manipulator (Dwarshuis et al. 2020, Sec. 4.4).

Prints the joint's characteristics over its range (rotational stiffness, support ratios, peak
stress), then the conventional method against KSD at seven positions of both cases, and saves
three_x_infinity.png and manipulator_fig15.png into --out (matplotlib).
Run: python examples/manipulator.py [--out figures] [--quick]   (--quick: -45, 0, 45 deg)
"""

from pathlib import Path

import numpy as np

import flexmb
from flexmb.studies import example_arguments
from flexmb.studies import manipulator as mc
from flexmb.joint_characteristics import support_ratios

def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print the joint's characteristics and the method comparison, write the figures into
    ``out`` (None: no figures); ``quick``: three positions instead of seven."""
    joint = flexmb.ThreeXInfinity()
    print(f"three_x_infinity: {joint.flexible_elements} flexible elements, D0 = {joint.interface_b(3)[2]*1e3:.0f} mm")
    print(f"{'rotation':>8s} {'k_rot [N m/rad]':>15s} {'x':>7s} {'y':>7s} {'z':>7s} {'tilt_x':>7s} {'tilt_y':>7s} "
          f"{'stress [MPa]':>12s}")
    for deg in (-45, -30, -15, 0, 15, 30, 45):
        r = support_ratios(joint, np.radians(deg))
        print(f"{deg:8d} {r['k_rotation']:15.4f} " + " ".join(f"{r[k]:7.0f}" for k in ("x", "y", "z", "tilt_x", "tilt_y"))
              + f" {r['stress']/1e6:12.0f}")
    print("(support ratios: k D0^2 / k_rot for translations, k / k_rot for tilts)\n")

    rows = mc.study((-45, 0, 45) if quick else tuple(range(-45, 46, 15)), repeats=1)
    print(f"{'case':>8s} {'deg':>4s} {'method':>12s} {'iterations':>10s} {'time [ms]':>10s} {'speed-up':>8s}")
    for r in rows:
        print(f"{r['case']:>8s} {r['rotation']:4d} {r['method']:>12s} {r['iterations']:10d} {r['time']*1e3:10.1f} "
              f"{r['speedup']:7.0f}x")
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        try:
            mc.plot_joint(joint, out / "three_x_infinity.png", rotation=np.radians(45))
            mc.plot_study(rows, out / "manipulator_fig15.png")
            print(f"\nfigures: {out / 'three_x_infinity.png'}, {out / 'manipulator_fig15.png'}")
        except ImportError:
            print("\n(no figures: install the plot extra)")
    return {"joint": joint, "rows": rows}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
