"""Deprecated since flexmb 0.2: the kernels are `flexmb.ksd.reduced_model_jit`. Every name read
here warns (FutureWarning) and is the new module's; this module goes in the next release."""

from .._warnings import moved_module

__all__: list = []
__getattr__ = moved_module("flexmb.ksd.properties_jit", "flexmb.ksd.reduced_model_jit")
