"""Recording the warnings one thread raises, while other threads of the process keep theirs:
what a study's design, `flexmb.joint_characteristics.joint_characteristics` and a sweep's values record.

`warnings.catch_warnings` swaps the process's warning state and restores it on exit, so two
threads recording at once (a dask worker running two designs) take each other's warnings or
lose them. Here the process's state is swapped once, while any thread records: every warning
then goes to the list of the thread that raised it (`recording`), or, from a thread that does
not record, where it went before.
"""

from __future__ import annotations

import contextlib
import importlib
import sys
import threading
import warnings

__all__ = ["recording", "current", "adopt", "as_text", "raise_again", "SEPARATOR", "deprecated", "renamed", "renamed_keyword", "moved_module"]

#: The release that renamed the names `deprecated` warns about; they go in the one after.
RENAMED_IN = "0.2"

#: Joins the warnings of one design or value as text
SEPARATOR = " | "

_LOCAL = threading.local()  # .records: the list the current thread's warnings go to
_LOCK = threading.Lock()
_STATE = {"active": 0, "context": None, "show": None}


def _show(message, category, filename, lineno, file=None, line=None) -> None:
    records = getattr(_LOCAL, "records", None)
    if records is not None:
        records.append(warnings.WarningMessage(message, category, filename, lineno, file, line))
    else:  # a thread that does not record: as before the recording began
        _STATE["show"](message, category, filename, lineno, file, line)


@contextlib.contextmanager
def recording():
    """Record the warnings this thread raises, every one (filter ``"always"``), into the list of
    `warnings.WarningMessage` yielded, instead of showing them. Nested: an inner recording takes
    its thread's warnings until it ends (`raise_again` hands them to the outer one)."""
    with _LOCK:
        if _STATE["active"] == 0:
            ctx = warnings.catch_warnings()
            ctx.__enter__()
            _STATE["show"] = warnings.showwarning
            warnings.simplefilter("always")
            warnings.showwarning = _show
            _STATE["context"] = ctx
        _STATE["active"] += 1
    previous = getattr(_LOCAL, "records", None)
    _LOCAL.records = records = []
    try:
        yield records
    finally:
        _LOCAL.records = previous
        with _LOCK:
            _STATE["active"] -= 1
            if _STATE["active"] == 0:
                _STATE["context"].__exit__(None, None, None)
                _STATE["context"] = _STATE["show"] = None


def current():
    """The list the current thread records into, or None: handed to a thread a design starts
    (`adopt`)."""
    return getattr(_LOCAL, "records", None)


def adopt(records) -> None:
    """Record this thread's warnings into ``records`` (another thread's `current` list)."""
    _LOCAL.records = records


def as_text(records) -> str:
    """``"Category: message"`` of each distinct warning, joined by `SEPARATOR` (``""``: none)."""
    return SEPARATOR.join(dict.fromkeys(f"{w.category.__name__}: {' '.join(str(w.message).split())}"
                                        for w in records))


def raise_again(records) -> None:
    """Raise the recorded warnings again, where they were first raised (an outer recording, or
    the display, gets them)."""
    for w in records:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def deprecated(old: str, new: str, detail: str = "") -> None:
    """A ``FutureWarning`` that ``old`` is now ``new`` (kept one release: `RENAMED_IN`), pointing at
    the first caller outside flexmb (so Python's once-per-location filter shows it per user line)."""
    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] == "flexmb":
        frame, level = frame.f_back, level + 1
    warnings.warn(f"{old} is deprecated since flexmb {RENAMED_IN}: use {new}{detail} (CHANGELOG.md)",
                  FutureWarning, stacklevel=level)


def renamed(module: str, names: dict):
    """A module ``__getattr__`` for ``module``: each old name of ``names`` (old -> the new object's
    qualified name, e.g. ``"flexmb.path.EquilibriumPath"``) warns (`deprecated`) and returns the
    new object; any other name raises AttributeError as usual."""
    def __getattr__(name):
        if name not in names:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        target = names[name]
        deprecated(f"{module}.{name}", target)
        where, _, attribute = target.rpartition(".")
        return getattr(importlib.import_module(where), attribute)
    return __getattr__


def renamed_keyword(owner: str, old: str, old_value, new: str, new_value, default):
    """The value of keyword ``new`` where a caller may still give it as ``old`` (deprecated: a
    `deprecated` warning; ``old_value`` None when not given). Both given, ``new`` not its
    ``default``: `flexmb.ParameterError` (which one was meant is not for flexmb to guess)."""
    if old_value is None:
        return new_value
    if new_value is not default and new_value != default:
        from .errors import ParameterError
        raise ParameterError(f"{owner}: {old}={old_value!r} and {new}={new_value!r} given; {old}= is the deprecated "
                             f"name of {new}=: give {new}= only")
    deprecated(f"{owner}({old}=)", f"{new}=")
    return old_value


def moved_module(old: str, new: str, names: dict | None = None):
    """The ``__getattr__`` of a deprecated module ``old`` renamed ``new``: every public name is
    read from ``new`` (``names``: old -> new where the name changed too) with a `deprecated`
    warning; a dunder or a name ``new`` lacks raises AttributeError."""
    names = dict(names or {})

    def __getattr__(name):
        if name.startswith("__"):
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        target = importlib.import_module(new)
        attribute = names.get(name, name)
        if not hasattr(target, attribute):
            raise AttributeError(f"module {old!r} (now {new!r}) has no attribute {name!r}")
        deprecated(f"{old}.{name}", f"{new}.{attribute}")
        return getattr(target, attribute)
    return __getattr__
