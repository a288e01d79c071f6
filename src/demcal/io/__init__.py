"""File output: VTK PolyData (.vtp) particles and walls and ParaView (.pvd) time series."""

from demcal.io.vtk import (STATE_FIELDS, VtkSeries, particle_fields, read_pvd, read_vtp, write_particles,
                           write_pvd, write_triangles, write_walls)

__all__ = ["STATE_FIELDS", "VtkSeries", "particle_fields", "read_pvd", "read_vtp", "write_particles",
           "write_pvd", "write_triangles", "write_walls"]
