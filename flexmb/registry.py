"""Joint plugins discovered through the ``flexmb.joints`` entry-point group (as xarray finds backends)."""

from __future__ import annotations

import functools
import warnings
from importlib.metadata import entry_points

import attrs

from .errors import InvalidJointClassError, ModelError, ParameterError, UnknownJointError
from .joints._base import Joint

__all__ = ["available_joints", "register_joint", "joint", "refresh"]

GROUP = "flexmb.joints"
_session: dict[str, type] = {}


@functools.lru_cache(maxsize=None)
def _installed() -> dict[str, type]:
    found: dict[str, type] = {}
    for ep in entry_points(group=GROUP):
        if ep.name in found:
            warnings.warn(f"joint plugin {ep.name!r} is registered twice; keeping {found[ep.name]!r}",
                          RuntimeWarning, stacklevel=2)
            continue
        try:
            cls = ep.load()
        except Exception as exc:  # a broken third-party plugin must not break flexmb
            warnings.warn(f"joint plugin {ep.name!r} ({ep.value}) failed to load: {exc}", RuntimeWarning,
                          stacklevel=2)
            continue
        if not (isinstance(cls, type) and issubclass(cls, Joint)):
            warnings.warn(f"joint plugin {ep.name!r} ({ep.value}) is not a flexmb.Joint subclass; skipped",
                          RuntimeWarning, stacklevel=2)
            continue
        found[ep.name] = cls
    return found


def refresh() -> None:
    """Forget the cached entry points (after installing a plugin in a running session)."""
    _installed.cache_clear()


def register_joint(name: str, cls: type, *, clobber: bool = False) -> None:
    """Register a `Joint` subclass under ``name`` for this session (tests, notebooks)."""
    if not (isinstance(cls, type) and issubclass(cls, Joint)):
        raise InvalidJointClassError(f"{cls!r} is not a flexmb.Joint subclass; cannot register it as {name!r}")
    if not clobber and name in available_joints():
        raise ModelError(f"a joint named {name!r} is already registered; pass clobber=True to replace it")
    _session[name] = cls


def _shipped() -> dict[str, type]:
    """flexmb's own joints, for an editable install whose entry-point metadata predates one of them."""
    from . import joints

    return {cls.kind: cls for cls in (joints.CrossFlexure, joints.CurvedBeam, joints.Hinge, joints.LeafSpring,
                                      joints.ThreeXInfinity)}


def available_joints() -> dict[str, type]:
    """Registered joint classes by name: installed entry points, then session registrations."""
    return {**_installed(), **_session}


def joint(name: str, **params) -> Joint:
    """Instantiate the registered joint ``name`` with ``params``."""
    known = available_joints()
    if name not in known and isinstance(name, str):
        known = {**_shipped(), **known}
    if name not in known:
        raise UnknownJointError(f"unknown joint {name!r}; known joints: {', '.join(sorted(known)) or 'none'}")
    return joint_from_params(known[name], **params)


def joint_from_params(cls: type, **params) -> Joint:
    """``cls(**params)``, with unknown or missing parameters reported as `ParameterError`."""
    name = getattr(cls, "kind", cls.__name__)
    if attrs.has(cls):
        valid = {a.alias for a in attrs.fields(cls) if a.init}
        unknown = sorted(set(params) - valid)
        if unknown:
            raise ParameterError(f"joint {name!r}: unknown parameter(s) {unknown}; valid: {sorted(valid)}")
    try:
        return cls(**params)
    except TypeError as exc:
        raise ParameterError(f"joint {name!r}: {exc}") from None
