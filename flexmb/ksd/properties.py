"""Deprecated since flexmb 0.2: the model a KSD-reduced solution's properties read is
`flexmb.ksd.reduced_model`. Every name read here warns (FutureWarning) and is the new module's;
this module goes in the next release."""

from .._warnings import moved_module

__all__: list = []
__getattr__ = moved_module("flexmb.ksd.properties", "flexmb.ksd.reduced_model")
