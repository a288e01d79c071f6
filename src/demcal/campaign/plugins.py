"""Plugins: modules that register extra virtual tests.

A campaign names them in ``[experiment] plugins``; they are only named while the file is
read (:func:`plugin_problem` checks each name), and imported (:func:`import_plugins`) only
when the caller runs simulations (``demcal run``, ``calibrate`` and ``demo``; never
``demcal report`` or ``export``), from the campaign's folder or the installed packages.
"""

from __future__ import annotations

import importlib
import importlib.util
import re
import sys
from pathlib import Path

from demcal.errors import ConfigError

#: A plugin is named as Python imports it: dotted identifiers, no path.
_MODULE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*")


def plugin_problem(module: str) -> str | None:
    """Why ``module`` cannot be a plugin (not a module name, a module of Python's
    standard library), or None."""
    if not isinstance(module, str) or not _MODULE_NAME.fullmatch(module):
        return f"plugin {module!r} is not a module name; give one like 'my_bench' or 'mypackage.benches'"
    top = module.split(".", 1)[0]
    if top in sys.stdlib_module_names or top in sys.builtin_module_names:
        return (f"plugin '{module}' is a module of Python's standard library, not a plugin; name a module "
                "in the campaign folder or an installed package that registers a virtual test")
    return None


def import_plugins(plugins, folder: str | Path) -> None:
    """Import the plugin modules ``plugins`` (which register extra virtual experiments),
    found in ``folder`` (the campaign's folder, added at the end of ``sys.path``, so
    that installed packages come first and spawned workers find it too) or among the
    installed packages.

    Raises
    ------
    ConfigError
        A name that is no plugin (:func:`plugin_problem`), a module that is found nowhere,
        or one that fails while it is imported; the sentence names it.
    """
    folder = str(Path(folder).resolve())
    if folder not in sys.path:
        sys.path.append(folder)
    importlib.invalidate_caches()  # a module written since the folder was last looked at
    for module in plugins:
        problem = plugin_problem(module)
        if problem:
            raise ConfigError(problem + ".")
        top = module.split(".", 1)[0]
        try:
            found = importlib.util.find_spec(top) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            raise ConfigError(f"plugin '{module}' is neither a module in the campaign folder {folder} nor an "
                              "installed package; put it there or install it.")
        try:
            importlib.import_module(module)
        except Exception as exc:  # noqa: BLE001 - a plugin is the user's code; any failure is theirs
            from demcal._checks import printable

            first = printable(str(exc).strip().splitlines()[0] if str(exc).strip() else "", 200)
            raise ConfigError(f"plugin '{module}' failed while being imported "
                              f"({type(exc).__name__}{': ' + first if first else ''}); fix the module.") from None
