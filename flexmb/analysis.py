"""Deprecated since flexmb 0.2: the joint characteristics are `flexmb.joint_characteristics`
(``joint_properties`` is `flexmb.joint_characteristics.joint_characteristics`). Every name read
here warns (FutureWarning) and is the new one; the module goes in the next release."""

from ._warnings import moved_module

__all__: list = []
__getattr__ = moved_module("flexmb.analysis", "flexmb.joint_characteristics",
                           {"joint_properties": "joint_characteristics"})
