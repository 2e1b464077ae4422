"""The design layer: parameters, differentiable responses, adjoint/direct gradients and the
gradient checker. See `flexmb.design.evaluate` for the entry points."""

from __future__ import annotations

from . import responses
from .evaluate import DesignPoint, Evaluation, evaluate, value_and_grad
from .parameters import Design, Parameter

__all__ = ["responses", "DesignPoint", "Evaluation", "evaluate", "value_and_grad", "Design", "Parameter"]
