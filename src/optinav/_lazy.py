"""Packages whose public names load on first use (PEP 562), so that a command reports a bad input file before
numba and scipy are imported (issue 17: a bad-file error within 1 s of start)."""

from __future__ import annotations

import importlib
import sys
import types


def lazy_package(name: str, exports: dict[str, str]) -> None:
    """Make the package ``name`` resolve each attribute of ``exports`` (attribute → its module, relative to the
    package) when it is first read. A submodule that shares its name with a function the package exports
    (``optinav.multipos.calibrate``, ``optinav.attitude.simulate``) does not replace that function when the
    submodule is imported, so the package attribute is the function, as with eager imports."""

    class LazyPackage(types.ModuleType):
        def __getattr__(self, attr):
            module = exports.get(attr)
            if module is None:
                raise AttributeError(f"module {name!r} has no attribute {attr!r}")
            value = getattr(importlib.import_module(module, name), attr)
            types.ModuleType.__setattr__(self, attr, value)
            return value

        def __setattr__(self, attr, value):
            if attr in exports and isinstance(value, types.ModuleType) and value.__name__ == f"{name}.{attr}":
                return  # the import system binding the submodule: keep the exported function
            types.ModuleType.__setattr__(self, attr, value)

        def __dir__(self):
            return sorted(set(super().__dir__()) | set(exports))

    sys.modules[name].__class__ = LazyPackage
