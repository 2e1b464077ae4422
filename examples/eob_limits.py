"""Limits of the Element Orientation based Body, Dwarshuis et al. (2020), Sec. 4.2 (Figs. 7b, 8).

Prints, for a single 3D cross flexure, the moment over M_lin (Eq. 4.3) of the full model and of
the EOB with the default and four times wider outer leaves (the database belongs to the default
joint), and the z displacement and scaled moment under a large force along z on node B.

Run: python examples/eob_limits.py [--out figures]   (writes eob_limits.png with matplotlib)
"""

from pathlib import Path

from flexmb.studies import eob as ec
from flexmb.studies import example_arguments


def main(out: Path | None = None, quick: bool = False) -> dict:
    """Print Figs. 7b and 8 as tables and write ``out/eob_limits.png`` (``out`` None: no figure;
    ``quick`` changes nothing: the study is small)."""
    w = ec.outer_width_study()
    print("Fig. 7b: M / M_lin, 2 el./leaf (database trained with w2 = 0.02 m)")
    print(f"{'deg':>4s}" + "".join(f"{'FE w2=' + str(k):>13s}{'EOB':>9s}{'diff':>8s}" for k in (0.02, 0.08)))
    for i, deg in enumerate(w["degrees"]):
        cells = "".join(f"{w[k]['fe'][i]:13.4f}{w[k]['eob'][i]:9.4f}{100 * (w[k]['eob'][i] / w[k]['fe'][i] - 1):7.2f}%"
                        for k in (0.02, 0.08))
        print(f"{deg:4.0f}{cells}")
    z = ec.z_force_study()
    print("\nFig. 8: force along z on node B, 4 el./leaf; F = L^2 F_z / (2 E I) (Eq. 4.5), M = L M_z / (2 E I) (Eq. 4.6)")
    print(f"{'deg':>4s} {'F':>5s} {'z/L FE':>9s} {'z/L EOB':>9s} {'M FE':>8s} {'M EOB':>8s}")
    for deg in z["degrees"]:
        r = z[deg]
        for k, F in enumerate(z["forces"]):
            print(f"{deg:4.0f} {F:5.1f} {r['z_fe'][k]:9.5f} {r['z_eob'][k]:9.5f} {r['M_fe'][k]:8.4f} {r['M_eob'][k]:8.4f}")
    if out is not None:
        try:
            from flexmb import plot

            ax = None
            for k in (0.02, 0.08):
                ax = plot.plot_force_curve(w["degrees"], w[k]["fe"], reference=w[k]["eob"], label=f"FE, w2 = {k} m",
                                           reference_label=f"EOB, w2 = {k} m", xlabel="rotation [deg]",
                                           ylabel="M / M_lin (Eq. 4.3)", ax=ax)
            ax.set_title("Fig. 7b: EOB of a database trained with w2 = 0.02 m")
            print(f"\nfigure: {plot.save(ax, Path(out) / 'eob_limits.png')}")
        except ImportError:
            print("\n(no figure: install the plot extra)")
    return {"width": w, "z": z}


if __name__ == "__main__":
    main(*example_arguments(__doc__))
