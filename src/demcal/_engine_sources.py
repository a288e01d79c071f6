"""The engine's compiled sources and their hash, without importing the engine.

numba's ``cache=True`` keys each cached function on the file that defines it (numba
0.68 hashes that file's bytes), not on the kernels it inlines: a driver in
``dem/forces.py`` inlines ``dem/contact/*.py`` and ``geometry/kernels.py``. demcal
therefore keys its whole engine cache on :func:`digest` of every file listed here
(``demcal.__init__`` puts the cache in a folder named after it, and
``demcal.dem._cache.guard`` clears a cache the user placed when the hash changes).
This module imports nothing heavy, so ``demcal/__init__`` can use it before numba is
imported.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_DEM = _PACKAGE / "dem"


def sources() -> list[Path]:
    """The modules holding compiled code, the constants they import, and the named
    tuples the compiled step loop takes (numba's cache index pickles their classes by
    name: an index naming a class that is gone cannot even be read)."""
    return [_DEM / "forces.py", _DEM / "integrator.py", _DEM / "neighbours.py",
            _DEM / "stepper.py", _DEM / "storage.py", _DEM / "walltable.py",
            _DEM / "backend.py",
            *sorted((_DEM / "contact").glob("*.py")),
            _PACKAGE / "geometry" / "kernels.py",
            _PACKAGE / "geometry" / "placement.py",
            _PACKAGE / "particles" / "materials.py"]


def digest(paths=None) -> str:
    """A 16-hex-digit hash of the files' names and bytes (missing files are skipped)."""
    h = hashlib.sha256()
    for p in sorted(sources() if paths is None else paths):
        if p.exists():
            h.update(p.name.encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:16]
