"""Where a KSD solve's joint data came from: per joint, the database file read and
whether it lay in the ``database=`` folder, the user's data folder or the shipped data
(`flexmb.database.store.source`). A KSD `Solution` carries it as ``stages["setup"]["files"]``."""

from __future__ import annotations

from ..database.store import source

__all__ = ["files"]


def files(red) -> dict:
    """``{joint name: {"path": file [str], "source": "database=" | "user" | "shipped"}}`` for the
    joints of the reduced mechanism ``red`` (`flexmb.ksd.reduced.ReducedMechanism`), in its joint
    order; a fresh dict per call (the set-up keeps its own: worked out once per set-up, a
    ``stat`` per folder)."""
    kept = vars(red).get("_provenance")
    if kept is None:
        kept = {}
        for tpl, _, idx in red.groups:
            path = tpl.data.path
            entry = {"path": path, "source": "memory" if path is None else source(path, red.folder)}
            for j in idx:
                kept[red.joint_names[j]] = entry
        kept = red._provenance = {name: kept[name] for name in red.joint_names}
    return {name: dict(entry) for name, entry in kept.items()}
