"""The conformance kit's KSD data (`flexmb.testing`): the shape with a trained joint database its
KSD checks run on, the one the kit trains into a temporary folder or one the author names
(`KSDShape`), and the checks' tolerances (`flexmb.testing.check_ksd` compares the strategies).

A joint that offers a database (`flexmb.Joint.database_key`) is checked on that shape: its
database matches its finite-element model (`flexmb.database.verify`), KSD-full reaches the
conventional solution (`KSD_FULL_TOLERANCE`) and KSD-reduced stays within `KSD_REDUCED_TOLERANCE`
of it, each under the intended motion and a load, anywhere it is placed. A missing, stale or
foreign database is a failure here, never a skip: the kit trained the data or the author named
them.
"""

from __future__ import annotations

import atexit
import math
import shutil
import tempfile

import attrs
import numpy as np

__all__ = ["KSDShape", "trained_shape", "check_ksd_database", "KSD_FULL_TOLERANCE", "KSD_REDUCED_TOLERANCE",
           "KSD_REDUCED_REACTION", "ksd_motion"]

#: KSD-full against the conventional method: node positions within this fraction of the joint's
#: size and reactions within it of the load scale. Both solve the same equations (step 5 is the
#: conventional Newton from KSD's start); measured 1e-14 to 1e-13 (notch hinge, cross flexure,
#: 2D and 3D, B loaded to move 5 % of the size), the solves' own tolerance leaves ~1e-10.
KSD_FULL_TOLERANCE = 1e-8
#: KSD-reduced against the conventional method: B's position within this fraction of the joint's
#: size (`KSD_REDUCED_TOLERANCE`) and the reaction on A within `KSD_REDUCED_REACTION` of the load
#: scale (forces, and moments over the joint's size): the EOB's error (Dwarshuis et al. 2020,
#: Sec. 3) under the kit's load, a random wrench that moves B 1 % of its size beyond the intended
#: motion. Measured worst (4 wrenches, 1-2 motions each): positions 5.6e-6 (cross flexure 2D at
#: 0.8 rad), 4.3e-6 (three_x_infinity), 3.2e-6 (notch hinge t/R = 0.4); reactions 1.3e-3 (notch
#: t/R = 0.4, 3D), 9.6e-4 (three_x_infinity), 1.7e-4 (cross flexure); the same in SI and mm-N-MPa.
KSD_REDUCED_TOLERANCE = 1e-4
KSD_REDUCED_REACTION = 1e-2


@attrs.frozen
class KSDShape:
    """A joint and the folder holding its trained database (None: `flexmb.database.search_path`,
    the user's and the shipped data) on which the kit runs its KSD checks; ``trained``: the
    kit trained it (`trained_shape`)."""

    joint: object
    folder: str | None = None
    trained: bool = False


_TRAINED: dict = {}
_FOLDERS: list = []


def _cleanup() -> None:
    for folder in _FOLDERS:
        shutil.rmtree(folder, ignore_errors=True)


atexit.register(_cleanup)


def trained_shape(joint, dim: int) -> KSDShape:
    """``joint``'s database trained with its own settings (`flexmb.Joint.training`) in ``dim``
    into a temporary folder (kept for the process, removed at exit; never the user's data
    folder). Trained once per joint value and dimension."""
    from .database import train, write

    key = (joint, dim) if _hashable(joint) else None
    if key is not None and key in _TRAINED:
        return _TRAINED[key]
    folder = tempfile.mkdtemp(prefix="flexmb-kit-")
    _FOLDERS.append(folder)
    data = train(joint, dim)
    write(data, folder)  # named by the design (flexmb.database.store.design_file_name)
    shape = KSDShape(joint, folder, trained=True)
    if key is not None:
        _TRAINED[key] = shape
    return shape


def _hashable(joint) -> bool:
    from ._validate import hashable

    return hashable(joint)


def ksd_motion(shape: KSDShape, dim: int, motion: float) -> float:
    """``motion`` [rad] moved inside the shape's trained range (at most 90 % of its nearer end),
    at least 0.05 rad (or 40 % of the range) in size: KSD is displacement controlled."""
    from .database import shipped

    lo, hi = shipped(shape.joint, dim, shape.folder).range
    least = min(0.05, 0.4 * min(-lo, hi))
    m = motion if abs(motion) >= least else math.copysign(least, motion or 1.0)
    return float(np.clip(m, 0.9 * lo, 0.9 * hi))


def check_ksd_database(shape: KSDShape, dim: int):
    """The shape's database is found, valid and describes the joint: `flexmb.database.verify` (the
    store's checks plus the finite-element model re-run at three trained rotations). A
    `DatabaseError` becomes the check's failure."""
    from .database import verify
    from .errors import DatabaseError

    try:
        return verify(shape.joint, dim, shape.folder)
    except DatabaseError as exc:
        raise AssertionError(f"{shape.joint.kind} {dim}D: the KSD checks' database: {exc}") from None
