"""The spheres of a run's final state as a small compressed file (``heap_spheres.npz``).

The repose tests write it next to their heap picture (:mod:`demcal.bench.repose`), so a
heap can be drawn again or measured again later without the VTK series (which is
written only on request). The file holds

=================  ===========  ============================================
array              shape        meaning
=================  ===========  ============================================
``positions``      (n, 3)       sphere centres [m], single precision
``radii``          (n,)         sphere radii [m], single precision
``base_z``         ()           height of the base plate's top [m]
``plate_radius``   ()           base plate radius [m]; NaN when there is none
=================  ===========  ============================================

Single precision keeps the file small (12 + 4 bytes a sphere before compression) and is
exact to about 0.1 um at 1 m, far below any sphere radius.
"""

from __future__ import annotations

import io
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from demcal.errors import DataError

#: File name of the final spheres in a run's artifact folder.
SPHERES_FILE = "heap_spheres.npz"


@dataclass(frozen=True)
class Spheres:
    """Sphere centres ``positions`` (n, 3) [m] and ``radii`` (n,) [m] with the base plate's
    height ``base_z`` [m] and radius ``plate_radius`` [m] (None: no plate)."""

    positions: np.ndarray
    radii: np.ndarray
    base_z: float = 0.0
    plate_radius: float | None = None


def write_spheres(path, positions, radii, base_z: float = 0.0, plate_radius: float | None = None) -> Path:
    """Write spheres to ``path`` (compressed ``.npz``, whole or not at all:
    :func:`demcal._files.write_atomic`); returns the path."""
    from demcal._files import write_atomic

    pos = np.asarray(positions, dtype=np.float32).reshape(-1, 3)
    rad = np.asarray(radii, dtype=np.float32).reshape(-1)
    if rad.shape[0] != pos.shape[0]:
        raise ValueError(f"{pos.shape[0]} sphere positions but {rad.shape[0]} radii.")
    buf = io.BytesIO()
    np.savez_compressed(buf, positions=pos, radii=rad, base_z=np.float64(base_z),
                        plate_radius=np.float64(math.nan if plate_radius is None else plate_radius))
    return write_atomic(path, buf.getvalue())


def read_spheres(path) -> Spheres:
    """Read a file of :func:`write_spheres` (positions and radii as float64).

    Raises
    ------
    DataError
        The file is missing, not such a file, or its arrays do not fit together.
    """
    try:
        with np.load(path, allow_pickle=False) as data:
            pos = np.asarray(data["positions"], dtype=float)
            rad = np.asarray(data["radii"], dtype=float)
            base_z = float(data["base_z"])
            plate = float(data["plate_radius"])
    except FileNotFoundError:
        raise DataError(f"the spheres file '{path}' does not exist.") from None
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise DataError(f"'{path}' is not a spheres file of demcal ({exc}); run the test again.") from None
    if pos.ndim != 2 or pos.shape[1] != 3 or rad.shape != (pos.shape[0],):
        raise DataError(f"'{path}' holds {pos.shape} positions and {rad.shape} radii, not (n, 3) and (n,); "
                        "run the test again.")
    return Spheres(pos, rad, base_z, None if math.isnan(plate) else plate)
