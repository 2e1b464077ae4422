"""Parameter study: rotational stiffness and support of a cross flexure over leaf thickness x leaf angle.

Every design is one `flexmb.joint_characteristics.joint_characteristics` call (the Table 1 cross flexure of
Dwarshuis et al. 2020 with the thickness and the leaf angle changed, 3 elements per leaf, at
20 deg of rotation): the rotational stiffness [N m/rad] condensed onto node B, the weakest
support ratio of z and the two tilts (`flexmb.joint_characteristics.support_ratios`; x and y are left out:
with the rotation free, a force at B turns the pivot about the leaves' crossing, D0/2 below B,
so their ratio is about (D0 / (D0/2))^2 = 4 whatever the design) and the peak stress. The designs run in an embedded local process pool and, with
``--dask``, on a dask.distributed LocalCluster (the same code drives a real cluster: pass
``Client("scheduler-address").get_executor()``); both give the serial numbers exactly.

Run: python examples/stiffness_map.py [--out figures] [--dask] [--quick]
Writes stiffness_map.csv and stiffness_map.png to --out.
"""

from __future__ import annotations

import functools
import time
from pathlib import Path

import numpy as np

from flexmb.joint_characteristics import joint_characteristics
from flexmb.studies import example_arguments
from flexmb.study import grid, parameter_study

DESIGN = functools.partial(joint_characteristics, "cross_flexure", rotation=np.radians(20.0), elements_per_leaf=3)


def designs(quick: bool = False) -> list[dict]:
    n = 3 if quick else 6
    return grid(thickness=np.linspace(0.1e-3, 0.4e-3, n), angle=np.radians(np.linspace(20.0, 70.0, n)))


def main(out: Path | None = None, quick: bool = False, use_dask: bool = False) -> dict:
    """Run the study serially, in a process pool and (``use_dask``) on a dask LocalCluster, print
    it and write ``stiffness_map.csv`` and ``.png`` into ``out`` (None: no files); ``quick``: a
    3 x 3 grid instead of 6 x 6."""
    cases = designs(quick)
    results, times = {}, {}
    runs = [("serial", "serial"), ("process pool", None)]
    if use_dask:
        from distributed import Client, LocalCluster

        cluster = LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0")
        client = Client(cluster)
        runs.append(("dask LocalCluster", client.get_executor()))
    try:
        for name, executor in runs:
            t = time.perf_counter()
            results[name] = parameter_study(DESIGN, cases, executor=executor)
            times[name] = time.perf_counter() - t
    finally:
        if use_dask:
            client.close()
            cluster.close()
    table = results["serial"]
    support = np.min([table[k] for k in ("z", "tilt_x", "tilt_y")], axis=0)
    print(f"{len(cases)} designs of the cross flexure at 20 deg (3 el./leaf):")
    print(f"{'t [mm]':>7s} {'angle [deg]':>11s} {'k [N m/rad]':>12s} {'min support':>12s} {'stress [MPa]':>13s}")
    for i in range(table.n_rows):
        print(f"{table['thickness'][i] * 1e3:7.3f} {np.degrees(table['angle'][i]):11.1f} {table['k_rotation'][i]:12.5f}"
              f" {support[i]:12.1f} {table['stress'][i] / 1e6:13.1f}")
    for name, seconds in times.items():
        same = all(np.array_equal(results[name][k], table[k]) for k in table)
        print(f"{name:>18s}: {seconds:6.2f} s, numbers {'identical to' if same else 'DIFFERENT from'} the serial run")
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "stiffness_map.csv")
        try:
            from flexmb import plot

            ax = plot.plot_map(table, "thickness", "angle", "k_rotation", label="k_rotation [N m/rad]", log=True)
            ax.set_xlabel("leaf thickness [m]")
            ax.set_ylabel("leaf angle [rad]")
            ax.set_title("Cross flexure at 20 deg: rotational stiffness")
            plot.save(ax, out / "stiffness_map.png")
            print(f"figure: {out / 'stiffness_map.png'}; table: {out / 'stiffness_map.csv'}")
        except ImportError:
            print("(no figure: install the plot extra)")
    return {"results": results, "times": times}


if __name__ == "__main__":
    main(*example_arguments(__doc__, flags={"--dask": "also run on a dask.distributed LocalCluster"}))
