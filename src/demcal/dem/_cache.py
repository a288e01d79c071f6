"""Keep numba's on-disk cache of the engine consistent with its sources; pick the
threading layer.

numba's ``cache=True`` only notices changes to the file that defines a function, not to
the kernels it calls (a driver in ``forces.py`` inlines ``contact/*.py`` and
``geometry/kernels.py``). Two things keep a changed kernel out of the cache:

* Where demcal picks the cache folder (``NUMBA_CACHE_DIR`` not set by the user), the
  folder is named after the hash of the engine's sources
  (:mod:`demcal._engine_sources`, ``<numba-cache>/engine-<hash>``), so that code of two
  versions never shares a folder: a process started before the sources changed keeps
  writing the old code into the old folder, where no process of the new sources looks
  (numba 0.68 keys an entry on its defining file's bytes only, so an entry of the
  step loop compiled with old kernels would otherwise be loaded as current).
* In a folder the user named, :func:`guard` deletes the engine's cache files when the
  hash differs from the one recorded there. Cheap (a few ms); :func:`ensure` runs it
  once per process, when the first :class:`~demcal.dem.Simulation` is built
  (importing :mod:`demcal.dem` changes no file). A process that imported the old
  sources and writes after the deletion is not kept out there: give each concurrent
  job its own ``NUMBA_CACHE_DIR`` while sources change (``bench_study.py
  --separate-caches``), or leave the folder to demcal.

When numba has to compile one of the engine's functions (nothing in the cache yet, or
the sources changed), :data:`COMPILING` is printed once per process on standard error,
so that the wait is not silent.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from demcal import _engine_sources

_HERE = Path(__file__).resolve().parent
# the files whose hash keys the engine's cache (see demcal._engine_sources)
_SOURCES = _engine_sources.sources()


def _digest() -> str:
    return _engine_sources.digest(_SOURCES)


def _cache_dirs():
    root = os.environ.get("NUMBA_CACHE_DIR")
    if root:
        base = Path(root)
        if not base.is_dir():
            return base, []
        return base, [d for d in base.iterdir()
                      if d.is_dir() and d.name.split("_")[0] in ("dem", "contact")]
    dirs = [_HERE / "__pycache__", _HERE / "contact" / "__pycache__"]
    return _HERE / "__pycache__", [d for d in dirs if d.is_dir()]


#: Said once per process when numba compiles (rather than loads) an engine function.
COMPILING = ("demcal: compiling the engine for this contact model (once per machine, "
             "under a minute)")
_announced = False
_listening = False


def _announce(event) -> None:
    """Print :data:`COMPILING` at the first compilation of a demcal function."""
    global _announced
    if _announced:
        return
    dispatcher = (event.data or {}).get("dispatcher")
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    if module.split(".")[0] != "demcal":
        return
    _announced = True
    try:
        print(COMPILING, file=sys.stderr, flush=True)
    except (OSError, ValueError):  # no standard error (closed, detached)
        pass


def announce_compilation() -> None:
    """Listen to numba's ``numba:compile`` events (numba fires them only when it
    compiles, not when it loads from the cache) and print :data:`COMPILING` once."""
    global _listening
    if _listening:
        return
    from numba.core import event

    class _FirstCompile(event.Listener):
        def on_start(self, ev):
            _announce(ev)

        def on_end(self, ev):
            pass

    event.register("numba:compile", _FirstCompile())
    _listening = True


def guard() -> None:
    """Delete stale engine cache files when the engine sources changed, and announce
    compilation (:func:`announce_compilation`)."""
    announce_compilation()
    try:
        digest = _digest()
        base, dirs = _cache_dirs()
        stamp = base / "demcal-dem-sources.stamp"
        if stamp.exists() and stamp.read_text().strip() == digest:
            return
        for d in dirs:
            for f in d.iterdir():
                if f.suffix in (".nbi", ".nbc"):
                    f.unlink(missing_ok=True)
        base.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # read-only install: numba falls back to its own checks
        pass


def prefer_openmp() -> None:
    """Let numba try its OpenMP threading layer before TBB (its own order is TBB first).

    The split step loop (``stepper.run_steps_split``) joins its threads twice per step,
    and OpenMP's workers, which spin a moment before they sleep, take those joins
    faster: 5,000 spheres on two threads run 15-25 % faster than on TBB
    (docs/performance.md). Where OpenMP is missing numba falls back to TBB or its
    work queue as before; ``NUMBA_THREADING_LAYER`` or
    ``NUMBA_THREADING_LAYER_PRIORITY`` set by the user win. Only takes effect before
    numba's first parallel call in the process. GNU OpenMP does not survive a ``fork``
    (numba stops a forked child that uses it); demcal's executors spawn their workers,
    and numba would pick OpenMP anyway wherever TBB is not installed.
    """
    import numba

    if ("NUMBA_THREADING_LAYER" in os.environ
            or "NUMBA_THREADING_LAYER_PRIORITY" in os.environ):
        return
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]


#: Said once per process when numba vectorises with Intel's SVML (numba imported, with
#: the library installed, before demcal could switch it off).
SVML = ("demcal: numba uses Intel's SVML here, so results may differ from other CPUs; "
        "import demcal before numba, or set NUMBA_DISABLE_INTEL_SVML=1")


def warn_svml() -> None:
    """Print :data:`SVML` when numba vectorises transcendental functions with SVML
    (``demcal/__init__`` disables it when it is imported before numba)."""
    import numba

    if numba.config.USING_SVML:
        try:
            print(SVML, file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass


_ensured = False


def ensure() -> None:
    """Once per process, before the engine's first compiled call: :func:`guard` the
    cache, :func:`prefer_openmp` and :func:`warn_svml`. Called by the backend a simulation
    builds; code that calls the engine's kernels directly calls it first."""
    global _ensured
    if _ensured:
        return
    _ensured = True
    guard()
    prefer_openmp()
    warn_svml()
