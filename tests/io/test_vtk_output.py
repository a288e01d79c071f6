"""VTK PolyData output: well-formed XML, right counts, values round-trip in both encodings."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from demcal.errors import DataError
from demcal.geometry import Box, Cylinder, Funnel, Plane, Rotation, WallSet
from demcal.io import VtkSeries, read_pvd, read_vtp, write_particles, write_triangles, write_walls


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_particles_round_trip(tmp_path, encoding):
    rng = np.random.default_rng(0)
    n = 257
    pos = rng.uniform(-1, 1, (n, 3))
    rad = rng.uniform(0.001, 0.002, n)
    vel = rng.normal(size=(n, 3))
    body = np.arange(n) // 2
    force = rng.normal(size=(n, 3)).astype(np.float32)
    path = write_particles(
        tmp_path / "p.vtp", pos, rad, vel, body_ids=body, point_data={"force": force, "contacts": np.arange(n) % 5},
        time=0.125, encoding=encoding,
    )
    root = ET.parse(path).getroot()  # valid XML
    assert root.get("type") == "PolyData" and root.get("header_type") == "UInt64"
    data = read_vtp(path)
    assert data["n_points"] == n and data["n_verts"] == n and data["n_polys"] == 0
    assert np.array_equal(data["points"], pos)
    assert np.array_equal(data["point_data"]["radius"], rad)
    assert np.array_equal(data["point_data"]["velocity"], vel)
    assert np.array_equal(data["point_data"]["id"], np.arange(n))
    assert np.array_equal(data["point_data"]["body_id"], body)
    assert np.array_equal(data["point_data"]["force"], force)
    assert data["point_data"]["force"].dtype == np.float32
    assert np.array_equal(data["verts"][0], np.arange(n)) and data["verts"][1][-1] == n
    assert data["field_data"]["TimeValue"][0] == 0.125
    assert not list(tmp_path.glob("*.tmp"))


def test_empty_particle_file(tmp_path):
    data = read_vtp(write_particles(tmp_path / "e.vtp", np.zeros((0, 3)), radius=np.zeros(0)))
    assert data["n_points"] == 0 and data["points"].shape == (0, 3)


def test_walls_surface(tmp_path):
    ws = WallSet([Plane(name="floor"), Box((0, 0, 0), (1, 1, 1), open_top=True, material=2), Funnel(outlet=(0, 0, 1.2), outlet_length=0.1)])
    force = np.array([[0, 0, 1.0], [0, 0, 2.0], [0, 0, 3.0]])
    data = read_vtp(write_walls(tmp_path / "w.vtp", ws, resolution=12, group_data={"force": force}))
    pts, tri, group = ws.triangulate(resolution=12)
    assert data["n_polys"] == len(tri) == 2 + 10 + 24 + 24
    assert np.array_equal(data["polys"][0].reshape(-1, 3), tri)
    assert np.array_equal(data["polys"][1], 3 * np.arange(1, len(tri) + 1))
    assert np.array_equal(data["cell_data"]["group"], group)
    assert set(data["cell_data"]["material"][group == 1]) == {2}
    assert np.array_equal(data["cell_data"]["force"], force[group])


def test_series_and_pvd(tmp_path):
    moving = WallSet([Cylinder(radius=0.1, length=0.2, motion=Rotation(axis=(0, 0, 1), angular_speed=1.0))])
    static = WallSet([Plane()])
    s1 = VtkSeries(tmp_path / "a", name="run")
    s2 = VtkSeries(tmp_path / "b", name="run")
    for k in range(3):
        t = 0.01 * k
        moving.update(t)
        s1.write(t, np.full((4, 3), t), walls=moving, radius=np.ones(4))
        s2.write(t, np.full((4, 3), t), walls=static, radius=np.ones(4))
    e1 = read_pvd(s1.pvd_path)
    assert [e[2] for e in e1] == [0, 1] * 3 and len({e[1] for e in e1}) == 6
    e2 = read_pvd(s2.pvd_path)
    assert len({e[1] for e in e2 if e[2] == 1}) == 1  # static walls written once
    for t, f, _ in e1:
        assert read_vtp(tmp_path / "a" / f)["field_data"]["TimeValue"][0] == pytest.approx(t)
    static_file = [f for _, f, part in e2 if part == 1][0]
    assert "TimeValue" not in read_vtp(tmp_path / "b" / static_file)["field_data"]


def test_bad_input(tmp_path):
    with pytest.raises(DataError, match="has 2 values but there are 3 points"):
        write_particles(tmp_path / "x.vtp", np.zeros((3, 3)), point_data={"a": [1.0, 2.0]})
    with pytest.raises(DataError, match="encoding"):
        write_particles(tmp_path / "x.vtp", np.zeros((3, 3)), encoding="zip")
    with pytest.raises(DataError, match="triangle indices"):
        write_triangles(tmp_path / "t.vtp", np.zeros((3, 3)), [[0, 1, 3]])
    (tmp_path / "bad.vtp").write_text("<VTKFile")
    with pytest.raises(DataError, match="cannot read"):
        read_vtp(tmp_path / "bad.vtp")
