"""demcal: calibrate DEM contact parameters from bench tests.

Importing demcal picks where numba keeps the engine's compiled kernels, so that every
way of running it (``make``, a bare ``.venv/bin/demcal``, a script, the campaign
workers, which inherit the environment) finds the same cache and compiles only once:
``NUMBA_CACHE_DIR`` when it is set, else :func:`numba_cache_dir`.
"""

import os
import sys

__version__ = "0.1.0"


def _writable_folder(path: str) -> bool:
    """Whether ``path`` is a folder this process can write to, or can be created as one."""
    while not os.path.exists(path):
        parent = os.path.dirname(path)
        if parent == path:
            return False
        path = parent
    return os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK)


def numba_cache_dir() -> str | None:
    """The folder for numba's cache of the engine when ``NUMBA_CACHE_DIR`` is not set.

    ``<sys.prefix>/numba-cache``, next to the installed packages (``.venv/numba-cache``
    for the project's virtual environment, the folder ``make`` uses too), when it can be
    written; else the user's cache folder, ``demcal/numba-cache`` in ``$XDG_CACHE_HOME``
    (default ``~/.cache``; ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%`` on
    Windows). ``None`` when neither can be written: numba then uses its own places
    (``__pycache__`` next to the sources, or a per-user folder).
    """
    prefix = os.path.join(sys.prefix, "numba-cache")
    if _writable_folder(prefix):
        return prefix
    home = os.path.expanduser("~")
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.join(home, "AppData", "Local")
    elif sys.platform == "darwin":
        base = os.path.join(home, "Library", "Caches")
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(home, ".cache")
    user = os.path.join(base, "demcal", "numba-cache")
    return user if _writable_folder(user) else None


def _choose_numba_cache() -> None:
    """Set ``NUMBA_CACHE_DIR`` to :func:`numba_cache_dir` unless the user set it; before
    numba is imported (or, if it already is, make it read the variable again before the
    engine's functions are defined)."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    folder = numba_cache_dir()
    if folder is None:
        return
    os.environ["NUMBA_CACHE_DIR"] = folder
    numba = sys.modules.get("numba")
    if numba is not None:
        numba.core.config.reload_config()


_choose_numba_cache()
