"""The numba kernels' switch: numba when it is installed and wanted, the numpy code otherwise
(flexmb says "numba kernel" for these; "compiled" is a mechanism turned into a problem, `flexmb.compiled`).

``FLEXMB_KERNELS`` chooses: ``auto`` (default: numba if importable), ``numba`` (required: an
import failure is an error) or ``numpy`` (never compile). The choice is read once, at import;
`use` switches it in a running session (tests compare both paths on every kernel).

numba is a core dependency where it publishes wheels (CPython on 64-bit x86 and ARM; elsewhere
``pip install "flexmb[fast]"``, or the numpy code runs): the default install is the fast one.
A kernel compiles on its first call, one type specialisation each (seconds of CPU on the
first solve: BENCHMARKS.md, Kernel compile time), and numba caches it on disk (``cache=True``): beside the
installed module where that folder is writable, else in the user's cache folder (numba's
``user_cache_dir``, e.g. ``~/.cache/numba``), or in ``NUMBA_CACHE_DIR`` when set (the test suite
sets it to a temporary folder: it never writes the user's cache). Later sessions load it.
"""

from __future__ import annotations

import importlib.util
import os

import numpy as np

from .errors import MissingExtraError, ParameterError

__all__ = ["enabled", "use", "njit", "run", "CHOICES"]

CHOICES = ("auto", "numba", "numpy")

# numba is optional, and imported only when a kernel module is : `import flexmb` stays light
_AVAILABLE = importlib.util.find_spec("numba") is not None


def _resolve(choice: str) -> bool:
    if choice not in CHOICES:
        raise ParameterError(f"FLEXMB_KERNELS={choice!r}; valid: {', '.join(CHOICES)}")
    if choice == "numba" and not _AVAILABLE:
        raise MissingExtraError("FLEXMB_KERNELS=numba but numba is not installed: pip install 'flexmb[fast]'")
    return choice != "numpy" and _AVAILABLE


_enabled = _resolve(os.environ.get("FLEXMB_KERNELS", "auto").strip().lower() or "auto")


def enabled() -> bool:
    """Whether the numba kernels run (numba importable and not switched off)."""
    return _enabled


def use(choice: str) -> bool:
    """Switch the kernels for this session: ``"auto"``, ``"numba"`` or ``"numpy"``; returns the
    previous state (True: compiled)."""
    global _enabled
    previous, _enabled = _enabled, _resolve(choice)
    return previous


def njit(fn):
    """``numba.njit`` with the options every kernel uses (on-disk cache, numpy's floating-point
    errors: NaN and inf instead of exceptions, as the numpy path gives); ``fn`` unchanged
    without numba."""
    if not _AVAILABLE:  # pragma: no cover - the numpy path is used then
        return fn
    import numba

    return numba.njit(cache=True, error_model="numpy", fastmath=False)(fn)


def run(kernel, arrays, n_dofs: int, n_modes: int, tangent: bool, geometric_stress):
    """Call a compiled beam kernel on ``arrays`` (the element batch, E first): returns ``F``
    (E, n_dofs), ``K`` (E, n_dofs, n_dofs) or None, ``e`` and ``sigma`` (E, n_modes). With a
    ``geometric_stress`` function the kernel runs twice: the geometric stresses depend on sigma."""
    nE = len(arrays[-2])  # L0
    args = [np.ascontiguousarray(a, dtype=float) for a in arrays]
    F, e, sigma = np.empty((nE, n_dofs)), np.empty((nE, n_modes)), np.empty((nE, n_modes))
    K = np.empty((nE if tangent else 1, n_dofs, n_dofs))
    if tangent and geometric_stress is not None:
        kernel(*args, False, False, sigma, F, K, e, sigma)
        sg = np.ascontiguousarray(geometric_stress(sigma.copy()), dtype=float)
        kernel(*args, True, True, sg, F, K, e, sigma)
    else:
        kernel(*args, tangent, False, sigma, F, K, e, sigma)
    return F, (K if tangent else None), e, sigma
