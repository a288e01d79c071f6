"""Carrying a contact's history vector into the current tangent plane."""

from numba import njit

from .llvm_math import sqrt
from .declare import FASTMATH


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def to_tangent_plane(x, y, z, nx, ny, nz):
    """The vector ``(x, y, z)`` turned into the plane normal to the unit vector ``n``,
    keeping its length: its normal component is removed and the rest rescaled (as the
    tangential history of LAMMPS ``granular``; LIGGGHTS 3.8's ``tangential_model_history.h``
    removes the normal component without rescaling, so its spring shortens as a contact
    turns). A zero vector comes back unchanged; one along ``n`` comes back as its
    tangential remainder, not rescaled."""
    v2 = x * x + y * y + z * z
    if v2 > 0.0:
        vn = x * nx + y * ny + z * nz
        x -= vn * nx
        y -= vn * ny
        z -= vn * nz
        t2 = x * x + y * y + z * z
        if t2 > 0.0:
            sc = sqrt(v2 / t2)
            x *= sc
            y *= sc
            z *= sc
    return x, y, z
