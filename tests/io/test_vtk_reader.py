"""The VTK frames open in VTK's own XML reader (``vtkXMLPolyDataReader``), with every
field of :data:`demcal.io.vtk.STATE_FIELDS`.

VTK is a test extra (``pip install -e '.[test]'``); without it these tests are skipped.
The file format is VTK's "XML File Formats" (PolyData, ``header_type="UInt64"``, inline
binary and ascii arrays), https://docs.vtk.org/en/latest/design_documents/VTKFileFormats.html.
"""

from dataclasses import dataclass

import numpy as np
import pytest

from demcal.io import STATE_FIELDS, VtkSeries, read_pvd

vtk = pytest.importorskip("vtk")
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402


@dataclass
class _State:
    """The fields of :class:`demcal.dem.State` a frame reads: three particles, the first
    a clump of two spheres."""

    sphere_positions: np.ndarray
    radii: np.ndarray
    sphere_body: np.ndarray
    velocities: np.ndarray
    omegas: np.ndarray
    quaternions: np.ndarray
    forces: np.ndarray
    materials: np.ndarray


def _state(seed=0):
    rng = np.random.default_rng(seed)
    quat = rng.normal(size=(3, 4))
    return _State(sphere_positions=rng.uniform(-0.1, 0.1, (4, 3)),
                  radii=np.array([0.002, 0.0025, 0.003, 0.004]),
                  sphere_body=np.array([0, 0, 1, 2]),
                  velocities=rng.normal(size=(3, 3)),
                  omegas=rng.normal(size=(3, 3)) * 50.0,
                  quaternions=quat / np.linalg.norm(quat, axis=1, keepdims=True),
                  forces=rng.normal(size=(3, 3)) * 1e-3,
                  materials=np.array([0, 2, 1], dtype=np.int32))


def _read(path):
    """The PolyData of ``path`` read by VTK, and the names of its point arrays."""
    reader = vtk.vtkXMLPolyDataReader()
    assert reader.CanReadFile(str(path))
    reader.SetFileName(str(path))
    reader.Update()
    data = reader.GetOutput()
    points = data.GetPointData()
    names = [points.GetArrayName(i) for i in range(points.GetNumberOfArrays())]
    return data, names


def _array(data, name):
    return vtk_to_numpy(data.GetPointData().GetArray(name))


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_vtk_reads_every_state_field(tmp_path, encoding):
    st = _state()
    series = VtkSeries(tmp_path, name="run", encoding=encoding)
    series.write_state(0.125, st)
    (time, file, part), = read_pvd(series.pvd_path)
    data, names = _read(tmp_path / file)

    assert data.GetNumberOfPoints() == 4 and data.GetNumberOfVerts() == 4
    assert np.array_equal(vtk_to_numpy(data.GetPoints().GetData()), st.sphere_positions)
    assert sorted(names) == sorted(name for name, *_ in STATE_FIELDS)
    for name, components, *_ in STATE_FIELDS:
        a = data.GetPointData().GetArray(name)
        assert (a.GetNumberOfTuples(), a.GetNumberOfComponents()) == (4, components), name
    body = st.sphere_body
    assert np.array_equal(_array(data, "radius"), st.radii)
    assert np.array_equal(_array(data, "id"), np.arange(4))
    assert np.array_equal(_array(data, "body_id"), body)
    assert np.array_equal(_array(data, "velocity"), st.velocities[body])
    assert np.array_equal(_array(data, "angular_velocity"), st.omegas[body])
    assert np.array_equal(_array(data, "orientation"), st.quaternions[body])
    assert np.array_equal(_array(data, "force"), st.forces[body])
    assert np.array_equal(_array(data, "material"), [0, 0, 2, 1])
    # the two spheres of the clump carry its values
    assert np.array_equal(_array(data, "orientation")[0], _array(data, "orientation")[1])
    assert data.GetPointData().GetScalars().GetName() == "radius"
    assert data.GetPointData().GetVectors().GetName() == "velocity"
    t = data.GetFieldData().GetArray("TimeValue")
    assert t.GetValue(0) == time == 0.125


def test_vtk_reads_the_walls(tmp_path):
    from demcal.geometry import Cylinder, Plane, WallSet

    walls = WallSet([Plane(name="floor", material=1), Cylinder(radius=0.05, length=0.1, material=2)])
    series = VtkSeries(tmp_path, name="run", resolution=12)
    series.write_state(0.0, _state(), walls=walls)
    wall_file = [f for _, f, part in read_pvd(series.pvd_path) if part == 1][0]
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(tmp_path / wall_file))
    reader.Update()
    data = reader.GetOutput()
    pts, tri, group = walls.triangulate(resolution=12)
    assert data.GetNumberOfPolys() == len(tri) and data.GetNumberOfPoints() == len(pts)
    cells = data.GetCellData()
    assert np.array_equal(vtk_to_numpy(cells.GetArray("group")), group)
    assert np.array_equal(vtk_to_numpy(cells.GetArray("material")), np.array([1, 2])[group])


def test_engine_reporter_frames_open_in_vtk(tmp_path):
    """A real run: the engine's VTKReporter writes what VTK reads, with the run's state."""
    from demcal.dem import Simulation
    from demcal.dem.reporters import VTKReporter
    from demcal.particles.materials import soil, soil_interaction
    from demcal.particles.templates import two_sphere_paper

    sim = Simulation([soil()], soil_interaction(), contact_model="hysteretic_spring")
    sim.add_particles(two_sphere_paper(), [[0.0, 0.0, 0.02], [0.03, 0.0, 0.02]],
                      velocities=[[0.1, 0.0, 0.0], [0.0, 0.0, 0.0]],
                      angular_velocities=[[0.0, 0.0, 3.0], [1.0, 0.0, 0.0]])
    reporter = VTKReporter(tmp_path, interval=5, name="pair", walls=False)
    sim.run(steps=5, reporters=[reporter])
    (time, file, _), = read_pvd(reporter.pvd_path)
    data, names = _read(tmp_path / file)
    st = sim.state
    body = st.sphere_body
    assert time == pytest.approx(sim.time)
    assert data.GetNumberOfPoints() == st.radii.size == 4
    assert sorted(names) == sorted(name for name, *_ in STATE_FIELDS)
    assert np.array_equal(_array(data, "velocity"), st.velocities[body])
    assert np.array_equal(_array(data, "angular_velocity"), st.omegas[body])
    assert np.array_equal(_array(data, "orientation"), st.quaternions[body])
    assert np.array_equal(_array(data, "force"), st.forces[body])
    assert np.allclose(np.linalg.norm(_array(data, "orientation"), axis=1), 1.0)
    # gravity is part of the force (free flight, no contact)
    assert np.allclose(_array(data, "force")[:, 2], -9.81 * st.masses[body])
