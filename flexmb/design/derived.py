"""Responses derived from another: the reciprocal (a stiffness from a compliance entry)."""

from __future__ import annotations

import hashlib
import weakref

import attrs
import numpy as np

from ..errors import ModelError, ParameterError
from .base import component_index

__all__ = ["reciprocal", "support_stiffness"]


@attrs.frozen
class _Reciprocal:
    response: object

    def __attrs_post_init__(self):
        if not (hasattr(self.response, "value") and hasattr(self.response, "gradient")):
            raise ParameterError(f"reciprocal: {self.response!r} is not a response (flexmb.responses.*)")

    @property
    def name(self) -> str:
        """``1/<the response's name>``."""
        return f"1/{self.response.name}"

    def value(self, solution) -> float:
        """``1 / J`` at the converged ``solution``."""
        x = _inner_value(self.response, solution)
        if x == 0.0:
            raise ModelError(f"reciprocal: {self.response.name} is zero (no finite reciprocal)")
        return 1.0 / x

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        """``d(1/J)/dp = -J' / J^2``."""
        x = _inner_value(self.response, sens.solution)
        if x == 0.0:
            raise ModelError(f"reciprocal: {self.response.name} is zero (no derivative of its reciprocal)")
        return -np.asarray(self.response.gradient(_shared(sens), method), dtype=float) / (x * x)


_MATRICES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _inner_value(response, solution) -> float:
    """The response's value; a compliance entry from its point's whole compliance matrix, kept per
    solution (`flexmb.linearised.compliance` once for a point's several entries)."""
    from .eigen import _Compliance

    if type(response) is not _Compliance or response.axes not in ("global", "link"):
        return float(response.value(solution))
    try:
        kept = _MATRICES.setdefault(solution, {})
    except TypeError:  # not weakly referable
        return float(response.value(solution))
    key = (response.link, response.point if response.point is None or isinstance(response.point, str)
           else tuple(np.ravel(response.point)), response.axes, repr(response.held))
    if key not in kept:
        from ..linearised import compliance

        kept[key] = compliance(solution, response.link, response.point, response.axes, response.held)
    dim = solution.compiled.problem.model.dim
    i, j = (component_index(dim, c, "compliance") for c in (response.row, response.column))
    return float(kept[key][i, j])


class _SharedForms:
    """A `Sensitivity` whose `tangent_forms` are kept per contraction: the support stiffnesses of
    one point along several components contract the tangent's rate with the same ``K^-1 E``
    (``-Y^T dK X`` gives the whole compliance's rate), so one configuration's three support
    stiffnesses cost one complex-step pass over the elements, not three."""

    def __init__(self, sens):
        self._sens, self._forms = sens, {}

    def __getattr__(self, name):
        return getattr(self._sens, name)

    def tangent_forms(self, V, W=None, material: bool = False):
        key = (_digest(V), None if W is None else _digest(W), material)
        if key not in self._forms:
            self._forms[key] = self._sens.tangent_forms(V, W, material=material)
        return self._forms[key]


_SHARED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _shared(sens):
    """The `_SharedForms` of ``sens`` (one per sensitivity, released with it)."""
    try:
        out = _SHARED.get(sens)
    except TypeError:  # not weakly referable: no sharing
        return sens
    if out is None:
        out = _SHARED[sens] = _SharedForms(sens)
    return out


def _digest(a) -> bytes:
    a = np.ascontiguousarray(a)
    return hashlib.blake2b(a.tobytes(), digest_size=16).digest() + str(a.shape).encode()


def reciprocal(response):
    """``1 / response`` with its gradient ``-J' / J^2`` (e.g. a stiffness from a compliance entry)."""
    return _Reciprocal(response)


def support_stiffness(link: str, component: str, point=None, axes: str = "global", held="prescribed"):
    """The support stiffness [N/m or N m/rad] of ``link``'s point along ``component``: the reciprocal
    of the compliance's diagonal entry (`flexmb.responses.compliance`), i.e. the force per unit
    displacement along it with every other component free to follow (not the stiffness matrix's
    entry, which holds them)."""
    from .eigen import compliance

    return _Reciprocal(compliance(link, component, component, point=point, axes=axes, held=held))
