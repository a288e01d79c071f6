"""Packages whose public names are imported on first use.

``demcal --help`` and the light sub-commands must not pay for numpy, scipy and pandas
just because a package ``__init__`` re-exports its submodules' names. A package
declares where each name lives and gets a module ``__getattr__`` (PEP 562) that
imports the submodule the first time the name is used::

    __getattr__, __dir__ = lazy_exports(__name__, {"design": ["Design"], ...})
"""

from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, where: dict[str, list[str]]):
    """``(__getattr__, __dir__)`` for ``package``: each name in ``where[submodule]`` is
    imported from ``package.submodule`` when first asked for, then kept."""
    home = {name: module for module, names in where.items() for name in names}

    def __getattr__(name: str):
        if name not in home:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{home[name]}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(home))

    return __getattr__, __dir__
