"""Prescribed DOFs and dead point loads of a mechanism, numbered for a model's link nodes.

Shared by the builders (`flexmb.fe.build`, `flexmb.closed_form.build`): both number one node per
link first, so the links' boundary conditions and loads read the same in either model.
"""

from __future__ import annotations

import numpy as np

from .errors import ModelError
from .problem import PointLoads
from .rotations import chain_rotation, logm_so3

__all__ = ["boundary", "actuation_row", "motion_paths"]

_COMPONENT = {"x": 0, "y": 1, "z": 2}


def boundary(mechanism, link_node: dict, links: dict | None = None):
    """Prescribed DOFs (sorted), their values at load factor 1, the `PointLoads` and the rotation
    chains of ``mechanism`` for links numbered by ``link_node`` (3 DOFs per link in 2D, 6 in 3D)."""
    links = mechanism.links if links is None else links
    dim = mechanism.dim
    ndof = 3 if dim == 2 else 6
    pres, vals, paths = [], [], []
    for n, lk in links.items():
        base = link_node[n] * ndof
        if lk.fixed:
            pres.extend(range(base, base + ndof))
            vals.extend([0.0] * ndof)
            continue
        for key, val in mechanism.prescribed(n).items():
            if key == "path":  # the way there (`motion_paths`), not a DOF
                continue
            if key == "rotation":
                pres.extend(range(base + dim, base + ndof))
                if np.ndim(val) == 2:  # a chain of rotations: its product, and the path to it
                    paths.append((np.arange(base + dim, base + ndof), np.array(val)))
                    val = logm_so3(chain_rotation(val))
                vals.extend(np.atleast_1d(val))
            else:
                pres.append(base + _COMPONENT[key])
                vals.append(val)
    pres = np.array(pres, dtype=np.int64)
    order = np.argsort(pres)
    nrot = ndof - dim
    rows = list(mechanism.loads)
    act = mechanism.actuation
    if act is not None:  # the last row, so that sweeps can replace it
        rows.append((act["link"], act["offset"], act["value"] * act["direction"], np.zeros(nrot)))
    loads = PointLoads(
        node=np.array([link_node[n] for n, *_ in rows], dtype=np.int64),
        offset=np.array([o for _, o, _, _ in rows]).reshape(-1, dim),
        force=np.array([f for *_, f, _ in rows]).reshape(-1, dim),
        moment=np.array([m for *_, m in rows]).reshape(-1, nrot),
    )
    dt = complex if any(np.iscomplexobj(x) for x in vals) else float  # complex: the complex step (flexmb.design)
    return pres[order], np.array(vals, dtype=dt)[order], loads, paths


def motion_paths(mechanism, link_node: dict, links: dict | None = None) -> tuple:
    """The curved prescribed motions of ``mechanism`` (`Mechanism.prescribe`'s ``path``) as
    `flexmb.problem.StaticProblem` ``motion_paths``: (the link's translation DOFs, its waypoints)."""
    links = mechanism.links if links is None else links
    ndof = 3 if mechanism.dim == 2 else 6
    out = []
    for n in links:
        motion = {} if links[n].fixed else mechanism.prescribed(n)
        path = motion.get("path")
        if path is None:
            continue
        end = [motion.get(k) for k in "xyz"[:mechanism.dim]]
        if any(e is None for e in end):
            raise ModelError(f"link {n!r}: a prescribed path needs all of {', '.join('xyz'[:mechanism.dim])} "
                             f"prescribed (its end); given: {', '.join(k for k in motion if k in 'xyz') or 'none'}")
        end = np.array(end)
        if np.abs(path[-1] - end).max() > 1e-9 * max(np.abs(path).max(), 1e-300):
            raise ModelError(f"link {n!r}: the prescribed path ends at {np.real(path[-1]).tolist()}, not at the "
                             f"prescribed displacement {np.real(end).tolist()}")
        out.append((link_node[n] * ndof + np.arange(mechanism.dim), np.array(path)))
    return tuple(out)


def actuation_row(mechanism, loads: PointLoads) -> tuple | None:
    """(row of the actuation in ``loads``, its unit direction), or None without an actuation."""
    act = mechanism.actuation
    return None if act is None else (len(loads.node) - 1, act["direction"])
