"""Recording the warnings one thread raises, while other threads of the process keep theirs:
what a study's design, `flexmb.analysis.joint_properties` and a sweep's values record.

`warnings.catch_warnings` swaps the process's warning state and restores it on exit, so two
threads recording at once (a dask worker running two designs) take each other's warnings or
lose them. Here the process's state is swapped once, while any thread records: every warning
then goes to the list of the thread that raised it (`recording`), or, from a thread that does
not record, where it went before.
"""

from __future__ import annotations

import contextlib
import threading
import warnings

__all__ = ["recording", "current", "adopt", "as_text", "raise_again", "SEPARATOR"]

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
