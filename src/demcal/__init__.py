"""demcal: calibrate DEM contact parameters from bench tests.

Importing demcal picks where numba keeps the engine's compiled kernels, so that every
way of running it (``make``, a bare ``.venv/bin/demcal``, a script, the campaign
workers, which inherit the environment) finds the same cache and compiles only once:
``NUMBA_CACHE_DIR`` when it is set, else a folder of :func:`numba_cache_dir` named
after the hash of the engine's sources (:func:`engine_cache_dir`), so that code of two
versions of the engine never shares cached kernels. It also keeps numba from vectorising
transcendental functions with Intel's SVML (:func:`_no_svml`), whose results depend on
the instruction set.
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


#: folders of other engine versions are removed once unused this long [s] (a process
#: of an older version may still be running and writing to its own folder)
STALE_ENGINE_CACHE_S = 24 * 3600


def engine_cache_dir(base: str) -> str:
    """``<base>/engine-<hash of the engine's sources>``; removes the folders of other
    engine versions under ``base`` that nothing has written to for
    :data:`STALE_ENGINE_CACHE_S` (best effort)."""
    import shutil
    import time

    from demcal import _engine_sources

    name = "engine-" + _engine_sources.digest()
    try:
        os.utime(os.path.join(base, name))   # in use: not stale for the versions to come
    except OSError:
        pass
    try:
        for entry in os.scandir(base):
            if (entry.is_dir() and entry.name.startswith("engine-") and entry.name != name
                    and time.time() - entry.stat().st_mtime > STALE_ENGINE_CACHE_S):
                shutil.rmtree(entry.path, ignore_errors=True)
    except OSError:
        pass
    return os.path.join(base, name)


def _choose_numba_cache() -> None:
    """Set ``NUMBA_CACHE_DIR`` to :func:`engine_cache_dir` of :func:`numba_cache_dir`
    unless the user set it; before numba is imported (or, if it already is, make it read
    the variable again before the engine's functions are defined). Processes started
    from this one (campaign workers) inherit the variable, and with it the folder."""
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    folder = numba_cache_dir()
    if folder is None:
        return
    folder = engine_cache_dir(folder)
    os.environ["NUMBA_CACHE_DIR"] = folder
    numba = sys.modules.get("numba")
    if numba is not None:
        numba.core.config.reload_config()


def _no_svml() -> None:
    """Set ``NUMBA_DISABLE_INTEL_SVML=1`` unless the user set it, before numba is
    imported: where Intel's SVML library is installed (the ``icc_rt`` package) and
    llvmlite supports it, numba vectorises ``math.sin``, ``math.pow`` and the like with
    SVML, whose last bits depend on the vector width the compile target has. The
    engine's results then differ between CPUs (docs/performance.md, "Portable bits").
    :func:`demcal.dem._cache.ensure` says so if numba was imported first with SVML."""
    os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")


_choose_numba_cache()
_no_svml()
