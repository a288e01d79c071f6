"""File output: VTK PolyData (.vtp) particles and walls and ParaView (.pvd) time series;
the final spheres of a run as a compressed ``.npz`` (:mod:`demcal.io.spheres`); particle
files (CSV, one row per body) to save a packing and load it back
(:mod:`demcal.io.particles`)."""

from demcal.io.spheres import SPHERES_FILE, Spheres, read_spheres, write_spheres
from demcal.io.vtk import (STATE_FIELDS, VtkSeries, particle_fields, read_pvd, read_vtp, write_particles,
                           write_pvd, write_triangles, write_walls)

__all__ = ["SPHERES_FILE", "STATE_FIELDS", "Spheres", "VtkSeries", "particle_fields", "read_pvd", "read_spheres",
           "read_vtp", "write_particles", "write_pvd", "write_spheres", "write_triangles", "write_walls"]
