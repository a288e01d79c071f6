"""Walls the particles collide with, their prescribed motion, and the distance kernels.

* :mod:`demcal.geometry.kernels` -- numba point-to-surface distance kernels per wall kind;
* :mod:`demcal.geometry.walls` -- wall descriptions (plane, disk, cylinder, cone, funnel,
  rectangle, box, triangle mesh / STL);
* :mod:`demcal.geometry.motion` -- static, translation, rotation, function-of-time motions;
* :mod:`demcal.geometry.wallset` -- :class:`WallSet`, the arrays the engine reads.
"""

from demcal.geometry.kernels import (
    CONE,
    CYLINDER,
    DISK,
    PARAM_WIDTH,
    PLANE,
    RECT,
    TRIANGLE,
    wall_distance,
)
from demcal.geometry.motion import FunctionMotion, Motion, Rotation, Static, Translation
from demcal.geometry.walls import (Box, Cone, Cylinder, Disk, Funnel, Plane, Rect, TriangleMesh, Wall,
                                   closed_drum)
from demcal.geometry.wallset import WallSet

__all__ = [
    "PLANE", "DISK", "CYLINDER", "CONE", "RECT", "TRIANGLE", "PARAM_WIDTH", "wall_distance",
    "Motion", "Static", "Translation", "Rotation", "FunctionMotion",
    "Wall", "Plane", "Disk", "Cylinder", "Cone", "Funnel", "Rect", "Box", "TriangleMesh",
    "WallSet", "closed_drum",
]
