"""Walls, motions and STL files refuse bad input in one sentence naming the problem."""

import struct

import numpy as np
import pytest
from stl import Mode
from stl import mesh as stl_mesh

from demcal.errors import ConfigError, DataError
from demcal.geometry import Cylinder, Disk, FunctionMotion, Plane, Rotation, TriangleMesh, WallSet
from demcal.geometry.motion import rotation_matrix

from sentences import one_sentence


# ---------------------------------------------------------------- wall materials --
@pytest.mark.parametrize("material", ["", " ", float("nan"), float("inf"), 1.5, -1, True, None, [1]])
def test_wall_material_must_be_a_name_or_an_index(material):
    msg = one_sentence(lambda: Plane(material=material))
    assert "material" in msg and ("index" in msg or "name" in msg)


def test_wall_material_name_is_kept_for_the_simulation_to_resolve():
    assert Disk(radius=0.1, material="steel").material == "steel"


@pytest.mark.parametrize("material", [0, 2, np.int64(3), 1.0])
def test_wall_material_index_accepted(material):
    assert Plane(material=material).material == int(material)


@pytest.mark.parametrize(
    "call, word",
    [
        (lambda: Plane(point="origin"), "plane point"),
        (lambda: Cylinder(radius="big"), "cylinder radius"),
        (lambda: Disk(radius=None), "disk radius"),
        (lambda: Rotation(angular_speed="fast"), "angular_speed"),
    ],
)
def test_non_numeric_wall_parameters_are_one_sentence(call, word):
    assert word in one_sentence(call)


# ---------------------------------------------------------------- function motions --
def _transform(motion, t=0.3):
    return motion.transform(t)


@pytest.mark.parametrize("dt", [0, -1e-6, float("nan"), float("inf"), "small"])
def test_function_motion_dt_must_be_positive(dt):
    assert "dt" in one_sentence(lambda: FunctionMotion(lambda t: np.zeros(3), dt=dt))


def test_function_motion_without_time_argument():
    msg = one_sentence(lambda: FunctionMotion(lambda: np.zeros(3)))
    assert "time" in msg


def test_function_motion_needs_a_callable():
    assert "function" in one_sentence(lambda: FunctionMotion(np.zeros(3)))


def test_callable_wall_motion_without_time_argument():
    assert "time" in one_sentence(lambda: Plane(motion=lambda: np.zeros(3)))


@pytest.mark.parametrize(
    "out",
    [
        (np.eye(2), np.zeros(3)),
        (np.eye(3).ravel(), np.zeros(3)),
        (np.eye(3), np.zeros(2)),
        (np.eye(3), np.zeros((3, 3))),
        (np.full((3, 3), np.nan), np.zeros(3)),
        (np.eye(3), np.array([0.0, np.nan, 0.0])),
        ("R", np.zeros(3)),
    ],
)
def test_function_motion_wrong_shapes(out):
    m = FunctionMotion(lambda t: out)
    msg = one_sentence(lambda: _transform(m))
    assert "FunctionMotion" in msg


@pytest.mark.parametrize(
    "rot",
    [2.0 * np.eye(3), np.diag([1.0, 1.0, -1.0]), np.eye(3) + 1e-6, np.zeros((3, 3))],
)
def test_function_motion_rotation_must_be_a_rotation(rot):
    m = FunctionMotion(lambda t: (rot, np.zeros(3)))
    msg = one_sentence(lambda: _transform(m))
    assert "rotation" in msg


def test_function_motion_good_rotation_and_displacement_unchanged():
    r = rotation_matrix((0, 1, 1), 0.7)
    m = FunctionMotion(lambda t: (r, np.array([t, 0.0, 0.0])))
    rot, trans = m.transform(2.0)
    assert np.array_equal(rot, r) and np.array_equal(trans, [2.0, 0.0, 0.0])
    d = FunctionMotion(lambda t: (0.0, 0.0, t))
    rot, trans = d.transform(0.5)
    assert np.array_equal(rot, np.eye(3)) and np.array_equal(trans, [0.0, 0.0, 0.5])
    assert "displacement" in one_sentence(lambda: FunctionMotion(lambda t: (0.0, 1.0, 2.0, 3.0)).transform(0.0))


def test_bad_function_motion_is_caught_by_the_wallset():
    bad = FunctionMotion(lambda t: (2.0 * np.eye(3), np.zeros(3)))
    assert "rotation" in one_sentence(lambda: WallSet([Plane(motion=bad)]))


# ---------------------------------------------------------------- STL files --
def _triangles(n=3):
    return np.array([[[0, 0, k], [1, 0, k], [0, 1, k]] for k in range(n)], float)


def _save(path, tri, mode):
    m = stl_mesh.Mesh(np.zeros(len(tri), dtype=stl_mesh.Mesh.dtype))
    m.vectors[:] = tri
    m.save(str(path), mode=mode)
    return path


def test_ascii_stl_with_a_bad_facet_is_one_sentence(tmp_path):
    good = _save(tmp_path / "good.stl", _triangles(), Mode.ASCII).read_text().splitlines()
    # drop the third vertex of the second facet (lines: solid, then 7 per facet)
    lines = list(good)
    del lines[1 + 7 + 4]
    bad = tmp_path / "bad.stl"
    bad.write_text("\n".join(lines) + "\n")
    msg = one_sentence(lambda: TriangleMesh.from_stl(bad), DataError)
    assert "File too large" not in msg and "triangles which" not in msg
    assert "not a valid ASCII STL file" in msg and "should start with b'vertex'" in msg


def test_ascii_stl_with_a_non_number_is_one_sentence(tmp_path):
    text = _save(tmp_path / "good.stl", _triangles(), Mode.ASCII).read_text()
    lines = text.splitlines()
    assert lines[1 + 14 + 3].strip().startswith("vertex")
    lines[1 + 14 + 3] = "    vertex 1 abc 2"
    bad = tmp_path / "bad.stl"
    bad.write_text("\n".join(lines) + "\n")
    msg = one_sentence(lambda: TriangleMesh.from_stl(bad), DataError)
    assert "not a valid ASCII STL file" in msg and "abc" in msg


def test_truncated_ascii_stl_is_refused(tmp_path):
    text = _save(tmp_path / "good.stl", _triangles(), Mode.ASCII).read_text()
    bad = tmp_path / "cut.stl"
    bad.write_text("\n".join(text.splitlines()[:12]) + "\n")
    msg = one_sentence(lambda: TriangleMesh.from_stl(bad), DataError)
    assert "not a valid ASCII STL file" in msg


def test_truncated_binary_stl_is_refused(tmp_path):
    path = _save(tmp_path / "good.stl", _triangles(), Mode.BINARY)
    data = path.read_bytes()
    cut = tmp_path / "cut.stl"
    cut.write_bytes(data[:-60])
    msg = one_sentence(lambda: TriangleMesh.from_stl(cut), DataError)
    assert "3 triangles" in msg and "truncated" in msg


def test_binary_stl_promising_too_many_triangles_is_refused(tmp_path):
    path = _save(tmp_path / "good.stl", _triangles(), Mode.BINARY)
    data = bytearray(path.read_bytes())
    data[80:84] = struct.pack("<I", 170926129)
    liar = tmp_path / "liar.stl"
    liar.write_bytes(bytes(data))
    msg = one_sentence(lambda: TriangleMesh.from_stl(liar), DataError)
    assert "170926129 triangles" in msg and "truncated" in msg


def test_binary_stl_with_trailing_bytes_is_refused(tmp_path):
    path = _save(tmp_path / "good.stl", _triangles(), Mode.BINARY)
    extra = tmp_path / "extra.stl"
    extra.write_bytes(path.read_bytes() + b"\x00" * 50)
    msg = one_sentence(lambda: TriangleMesh.from_stl(extra), DataError)
    assert "3 triangles" in msg


def test_binary_stl_whose_header_starts_with_solid(tmp_path):
    path = _save(tmp_path / "good.stl", _triangles(), Mode.BINARY)
    data = bytearray(path.read_bytes())
    data[0:80] = b"solid exported by a CAD program".ljust(80, b" ")
    solid = tmp_path / "solid_header.stl"
    solid.write_bytes(bytes(data))
    mesh = TriangleMesh.from_stl(solid)
    assert np.array_equal(mesh.triangles(), _triangles())


def test_stl_with_two_solids_keeps_both(tmp_path):
    text = _save(tmp_path / "one.stl", _triangles(), Mode.ASCII).read_text()
    two = tmp_path / "two.stl"
    two.write_text(text + text.replace("solid ", "solid other", 1))
    mesh = TriangleMesh.from_stl(two)
    assert len(mesh.faces) == 6


@pytest.mark.parametrize("mode", [Mode.ASCII, Mode.BINARY])
def test_valid_stl_reads_as_numpy_stl_does(tmp_path, mode):
    rng = np.random.default_rng(4)
    tri = rng.uniform(-50, 50, (40, 3, 3))
    path = _save(tmp_path / f"r_{mode.name}.stl", tri, mode)
    ref = np.asarray(stl_mesh.Mesh.from_file(str(path)).vectors, dtype=float)
    mesh = TriangleMesh.from_stl(path)
    assert np.array_equal(mesh.triangles(), ref)


def test_empty_stl_file_is_refused(tmp_path):
    empty = tmp_path / "empty.stl"
    empty.write_bytes(b"")
    assert "empty" in one_sentence(lambda: TriangleMesh.from_stl(empty), DataError)
