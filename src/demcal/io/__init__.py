"""File output: VTK PolyData (.vtp) particles and walls and ParaView (.pvd) time series."""

from demcal.io.vtk import VtkSeries, read_pvd, read_vtp, write_particles, write_pvd, write_triangles, write_walls

__all__ = ["VtkSeries", "read_pvd", "read_vtp", "write_particles", "write_pvd", "write_triangles", "write_walls"]
