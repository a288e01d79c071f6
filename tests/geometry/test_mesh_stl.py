"""Triangle meshes from arrays and from ASCII and binary STL files."""

import numpy as np
import pytest
from stl import Mode
from stl import mesh as stl_mesh

from demcal.errors import ConfigError, DataError
from demcal.geometry import Box, Rotation, TriangleMesh, Translation, WallSet
from demcal.geometry.kernels import wall_distance


def _cube_triangles(lo=0.0, hi=1.0):
    v = np.array([[x, y, z] for x in (lo, hi) for y in (lo, hi) for z in (lo, hi)], float)
    # vertex index = 4 x + 2 y + z (x, y, z in {0, 1})
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = []
    for a, b, c, d in quads:
        faces += [(a, b, c), (a, c, d)]
    return v, np.array(faces)


def _min_distance(ws, x):
    return min(wall_distance(ws.kind[w], ws.params[w], *x)[0] for w in range(len(ws)))


def test_cube_mesh_matches_box():
    v, f = _cube_triangles()
    mesh = WallSet([TriangleMesh(v, f, name="cube")])
    box = WallSet([Box((0, 0, 0), (1, 1, 1))])
    assert len(mesh) == 12 and mesh.names == ["cube"] and set(mesh.group) == {0}
    rng = np.random.default_rng(1)
    for x in rng.uniform(-0.5, 1.5, (100, 3)):
        assert _min_distance(mesh, x) == pytest.approx(_min_distance(box, x), abs=1e-12)
    assert mesh.aabb[:, :3].min(axis=0) == pytest.approx([0, 0, 0])
    assert mesh.aabb[:, 3:].max(axis=0) == pytest.approx([1, 1, 1])
    _assert_triangle_aabbs(mesh)


def test_moved_mesh_aabbs_hold_their_triangles():
    """After a rotation plus translation each triangle row's AABB is still the box of its
    three moved vertices (WallSet.aabb carries no margin: the neighbour search adds the
    skin)."""
    v, f = _cube_triangles()
    motion = Rotation(point=(0.5, 0.5, 0.0), axis=(1, 2, 3), angular_speed=0.7)
    ws = WallSet([TriangleMesh(v, f, motion=motion)])
    t = 2.0
    ws.update(t)
    _assert_triangle_aabbs(ws)
    rot, trans = motion.transform(t)
    moved = v[f] @ rot.T + trans
    assert ws.aabb[:, :3] == pytest.approx(moved.min(axis=1), abs=1e-12)
    assert ws.aabb[:, 3:] == pytest.approx(moved.max(axis=1), abs=1e-12)


def _assert_triangle_aabbs(ws, tol=1e-12):
    """Each triangle row's vertices and centroid lie inside that row's AABB, and the box
    is the vertices' box (tight: no margin in WallSet.aabb)."""
    for w in range(len(ws)):
        tri = ws.params[w, 0:9].reshape(3, 3)
        pts = np.vstack([tri, tri.mean(axis=0)])
        lo, hi = ws.aabb[w, :3], ws.aabb[w, 3:]
        assert np.all(pts >= lo - tol) and np.all(pts <= hi + tol), f"triangle row {w}"
        assert lo == pytest.approx(tri.min(axis=0), abs=tol)
        assert hi == pytest.approx(tri.max(axis=0), abs=tol)


@pytest.mark.parametrize("mode", [Mode.ASCII, Mode.BINARY])
def test_from_stl_ascii_and_binary(tmp_path, mode):
    v, f = _cube_triangles(0.0, 10.0)  # millimetres, as CAD exports
    m = stl_mesh.Mesh(np.zeros(len(f), dtype=stl_mesh.Mesh.dtype))
    m.vectors[:] = v[f]
    path = tmp_path / f"cube_{mode.name.lower()}.stl"
    m.save(str(path), mode=mode)
    if mode == Mode.ASCII:
        assert path.read_text().startswith("solid")
    wall = TriangleMesh.from_stl(path, scale=0.001, translate=(0, 0, 0.5), material=1)
    assert wall.name == path.stem and wall.material == 1
    ws = WallSet([wall])
    assert len(ws) == 12
    assert _min_distance(ws, [0.005, 0.005, 0.5 + 0.013]) == pytest.approx(0.003, abs=1e-9)
    assert _min_distance(ws, [0.005, 0.002, 0.505]) == pytest.approx(0.002, abs=1e-9)  # inside


def test_moving_mesh():
    v, f = _cube_triangles()
    ws = WallSet([TriangleMesh(v, f, motion=Translation((1.0, 0, 0)))])
    ws.update(2.0)
    assert _min_distance(ws, [2.5, 0.5, 1.25]) == pytest.approx(0.25)
    assert np.all(ws.velocity == [1.0, 0, 0])


def test_degenerate_triangles_dropped_and_errors(tmp_path):
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [1, 1, 1], [2, 2, 2]]], float)
    mesh = TriangleMesh.from_triangles(tri)
    assert mesh.dropped == 1 and len(mesh.faces) == 1
    with pytest.raises(ConfigError, match="only 3 vertices"):
        TriangleMesh(np.zeros((3, 3)), [[0, 1, 3]])
    with pytest.raises(DataError, match="does not exist"):
        TriangleMesh.from_stl(tmp_path / "missing.stl")
    bad = tmp_path / "bad.stl"
    bad.write_bytes(b"\x00" * 10)
    with pytest.raises(DataError, match="cannot read|no triangles"):
        TriangleMesh.from_stl(bad)
