"""Every public name of every flexmb module (its ``__all__``), and the public methods and
properties of its classes, have a docstring (an override may inherit its base class's)."""

import importlib
import inspect
import pkgutil

import flexmb


def _public():
    for info in pkgutil.walk_packages(flexmb.__path__, "flexmb."):
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if inspect.isclass(obj) or inspect.isfunction(obj) or inspect.ismodule(obj):
                yield f"{info.name}.{name}", obj
                if inspect.isclass(obj):
                    for attr, member in vars(obj).items():
                        if not attr.startswith("_") and (inspect.isfunction(member) or isinstance(member, property)):
                            yield f"{info.name}.{name}.{attr}", member if isinstance(member, property) else getattr(obj, attr)


def test_every_public_name_has_a_docstring():
    # an override without its own docstring documents itself through the base class (inspect.getdoc)
    missing = sorted({where for where, obj in _public() if not (inspect.getdoc(obj) or "").strip()})
    assert not missing, f"{len(missing)} public names without a docstring: {', '.join(missing)}"
