"""Prescribed wall motions and WallSet updates: poses, velocities, transformed rows."""

import math

import numpy as np
import pytest

from demcal.errors import ConfigError
from demcal.geometry import (
    Box,
    Cone,
    Cylinder,
    Disk,
    FunctionMotion,
    Funnel,
    Plane,
    Rect,
    Rotation,
    Static,
    Translation,
    TriangleMesh,
    WallSet,
)
from demcal.geometry import kernels as K
from demcal.geometry.kernels import wall_distance
from demcal.geometry.motion import rotation_matrix


def test_static_never_moves():
    m = Static()
    rot, trans = m.transform(12.0)
    assert np.array_equal(rot, np.eye(3)) and np.array_equal(trans, np.zeros(3))
    assert not m.moving and np.array_equal(m.velocity_at(3.0, [1, 2, 3]), np.zeros(3))


def test_translation_start_stop():
    m = Translation(velocity=(0.0, 0.0, 0.02), start=1.0, stop=3.0)
    assert m.pose(0.5, [1, 0, 0]) == pytest.approx([1, 0, 0])
    assert m.pose(2.0, [1, 0, 0]) == pytest.approx([1, 0, 0.02])
    assert m.pose(10.0, [1, 0, 0]) == pytest.approx([1, 0, 0.04])
    assert m.velocity_at(0.5, [0, 0, 0]) == pytest.approx([0, 0, 0])
    assert m.velocity_at(2.0, [5, 5, 5]) == pytest.approx([0, 0, 0.02])
    assert m.velocity_at(3.0, [0, 0, 0]) == pytest.approx([0, 0, 0])
    with pytest.raises(ConfigError, match="stop time"):
        Translation(velocity=(1, 0, 0), start=2.0, stop=1.0)


def test_rotation_about_off_origin_axis():
    m = Rotation(point=(1.0, 0.0, 0.0), axis=(0, 0, 2), angular_speed=math.pi / 2, start=0.0, stop=1.0)
    # a point one metre from the axis turns a quarter turn in one second
    assert m.pose(1.0, [2.0, 0.0, 0.0]) == pytest.approx([1.0, 1.0, 0.0])
    assert m.pose(5.0, [2.0, 0.0, 0.0]) == pytest.approx([1.0, 1.0, 0.0])  # stopped
    assert m.velocity_at(0.0, [2.0, 0.0, 0.0]) == pytest.approx([0.0, math.pi / 2, 0.0])
    assert m.velocity_at(0.3, [1.0, 0.0, 7.0]) == pytest.approx([0, 0, 0])  # on the axis
    assert m.velocity_at(2.0, [2.0, 0.0, 0.0]) == pytest.approx([0, 0, 0])


@pytest.mark.parametrize(
    "motion",
    [
        Translation(velocity=(0.1, -0.2, 0.3)),
        Rotation(point=(0.3, -0.1, 0.2), axis=(1, 2, 3), angular_speed=0.7),
        FunctionMotion(lambda t: (rotation_matrix((0, 1, 1), 0.4 * t * t), np.array([t, 0.0, -t * t]))),
    ],
)
def test_velocity_is_time_derivative_of_pose(motion):
    x_ref = np.array([0.4, -0.7, 1.1])
    t, h = 0.8, 1e-6
    fd = (motion.pose(t + h, x_ref) - motion.pose(t - h, x_ref)) / (2 * h)
    assert motion.velocity_at(t, motion.pose(t, x_ref)) == pytest.approx(fd, abs=1e-6)


def test_function_motion_matches_rotation():
    rot = Rotation(point=(0.0, 1.0, 0.0), axis=(1, 0, 0), angular_speed=0.25)
    fun = FunctionMotion(rot.transform)
    for t in (0.2, 0.5, 3.0):  # away from the start, where the speed jumps
        w1, v1 = rot.twist(t)
        w2, v2 = fun.twist(t)
        assert w2 == pytest.approx(w1, abs=1e-8) and v2 == pytest.approx(v1, abs=1e-8)
    displacement = FunctionMotion(lambda t: [0.0, 0.0, 0.5 * t * t])
    assert displacement.velocity_at(2.0, [3, 3, 3]) == pytest.approx([0, 0, 2.0])


def _all_kinds(motion):
    rng = np.random.default_rng(5)
    return [
        Plane(point=(0, 0, -0.1), normal=(0.1, 0.2, 1), motion=motion, name="plane"),
        Disk(centre=(0.1, 0, 0), normal=(0, 1, 1), radius=0.3, inner_radius=0.1, motion=motion, name="disk"),
        Cylinder(base=(0, 0.2, 0), axis=(1, 0, 1), radius=0.2, length=0.5, motion=motion, name="cyl"),
        Cone(base=(0, 0, 0.3), axis=(0, 0, 1), r1=0.05, r2=0.3, length=0.3, motion=motion, name="cone"),
        Rect.from_size((0.2, 0.2, 0.2), (1, 1, 0), 0.4, 0.2, motion=motion, name="rect"),
        TriangleMesh.from_triangles(rng.uniform(-0.5, 0.5, (4, 3, 3)), motion=motion, name="mesh"),
    ]


def _perp_basis(a):
    """Two unit vectors orthogonal to the unit vector a and to each other."""
    t = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, t)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def surface_points(kind, p, n=24):
    """Points on the surface of one kernel row (world frame, layouts of
    ``demcal.geometry.kernels``): rims, corners and interior samples."""
    phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    s = np.linspace(0.0, 1.0, 5)
    if kind in (K.DISK, K.CYLINDER, K.CONE):
        c, a = p[0:3], p[3:6]
        e1, e2 = _perp_basis(a)
        ring = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
        if kind == K.DISK:
            rho = p[7] + s * (p[6] - p[7])                 # inner to outer radius
            return (c + rho[:, None, None] * ring).reshape(-1, 3)
        if kind == K.CYLINDER:
            r1 = r2 = p[6]
            length = p[7]
        else:
            r1, r2, length = p[6], p[7], p[8]
        r = r1 + s * (r2 - r1)
        return (c + (s * length)[:, None, None] * a + r[:, None, None] * ring).reshape(-1, 3)
    if kind == K.RECT:
        al, be = np.meshgrid(np.linspace(-1, 1, 5), np.linspace(-1, 1, 5))
        return p[0:3] + al.reshape(-1, 1) * p[3:6] + be.reshape(-1, 1) * p[6:9]
    if kind == K.TRIANGLE:
        a, b, c = p[0:3], p[3:6], p[6:9]
        bary = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0.5, 0.5, 0), (0, 0.5, 0.5), (0.2, 0.3, 0.5)]
        return np.array([u * a + v * b + w * c for u, v, w in bary])
    raise AssertionError(f"no surface sampler for kind {kind}")


def assert_aabb_holds_surface(ws, tol=1e-12):
    """Every sampled surface point of each bounded row lies on the row (d = 0) and inside
    its AABB. The AABB carries no margin of its own (``WallSet.aabb``: xmin..zmax; the
    neighbour search adds the skin), so the tolerance is round-off only."""
    for w in range(len(ws)):
        if ws.kind[w] == K.PLANE:
            assert np.all(np.isinf(ws.aabb[w]))
            continue
        pts = surface_points(ws.kind[w], ws.params[w])
        for x in pts:
            assert wall_distance(ws.kind[w], ws.params[w], *x)[0] == pytest.approx(0.0, abs=1e-9)
        lo, hi = ws.aabb[w, :3], ws.aabb[w, 3:]
        assert np.all(pts >= lo - tol) and np.all(pts <= hi + tol), (
            f"row {w} ({K.KIND_NAMES[ws.kind[w]]}): surface outside its AABB")


def test_moved_rows_give_moved_distances():
    """A rigid motion of wall and point together leaves d unchanged and rotates n, and
    each moved row's AABB still holds its whole surface (rims, corners, interior)."""
    motion = Rotation(point=(0.2, -0.3, 0.1), axis=(1, -1, 2), angular_speed=0.9)
    moving = WallSet(_all_kinds(motion))
    fixed = WallSet(_all_kinds(None))
    assert moving.moving and not fixed.moving
    t = 1.3
    moving.update(t)
    rot, trans = motion.transform(t)
    rng = np.random.default_rng(11)
    for x in rng.uniform(-0.6, 0.6, (30, 3)):
        y = rot @ x + trans
        for w in range(len(fixed)):
            d0, *n0 = wall_distance(fixed.kind[w], fixed.params[w], *x)
            d1, *n1 = wall_distance(moving.kind[w], moving.params[w], *y)
            assert d1 == pytest.approx(d0, abs=1e-12)
            assert np.array(n1) == pytest.approx(rot @ np.array(n0), abs=1e-9)
    assert_aabb_holds_surface(moving)  # bounding boxes contain the moved geometry
    assert_aabb_holds_surface(fixed)


def test_wallset_velocity_at_contact_point():
    motion = Rotation(point=(0.0, 0.0, 0.5), axis=(0, 1, 0), angular_speed=2.0, start=0.1)
    ws = WallSet([Rect.from_size((0.3, 0, 0.5), (0, 0, 1), 0.2, 0.2, motion=motion, name="flap")])
    t = 0.4
    ws.update(t)
    xc = ws.params[0, 0:3] + np.array([0.05, 0.02, 0.0])
    v = ws.velocity[0] + np.cross(ws.omega[0], xc - ws.origin[0])
    assert v == pytest.approx(motion.velocity_at(t, xc))
    assert ws.origin[0] == pytest.approx([0, 0, 0.5])


def test_translation_moves_origin_and_aabb():
    ws = WallSet([Cylinder(radius=0.05, length=0.1, motion=Translation((0, 0, 0.01), start=1.0), name="tube")])
    assert ws.aabb[0] == pytest.approx([-0.05, -0.05, 0, 0.05, 0.05, 0.1])
    ws.update(3.0)
    assert ws.aabb[0] == pytest.approx([-0.05, -0.05, 0.02, 0.05, 0.05, 0.12])
    assert ws.velocity[0] == pytest.approx([0, 0, 0.01]) and ws.origin[0] == pytest.approx([0, 0, 0.07])


def test_wallset_groups_names_and_sums():
    walls = [
        Plane(name="floor", material=1),
        Box((0, 0, 0), (1, 2, 3), open_top=True),
        Funnel(outlet=(0, 0, 1), outlet_length=0.02),
        Cylinder(radius=1, length=1, bottom=True, top=True),
    ]
    ws = WallSet(walls)
    assert ws.names == ["floor", "box1", "funnel2", "cylinder3"]
    assert ws.kind.tolist() == [0, 4, 4, 4, 4, 4, 2, 3, 2, 1, 1]
    assert ws.group.tolist() == [0, 1, 1, 1, 1, 1, 2, 2, 3, 3, 3]
    assert ws.material.tolist() == [1] + [0] * 10
    assert ws.params.shape == (11, 16) and ws.params.dtype == np.float64
    assert ws.kind.dtype == np.int32 and ws.group.dtype == np.int32 and ws.material.dtype == np.int32
    assert np.all(np.isinf(ws.aabb[0]))
    assert ws.rows_of("box1") == slice(1, 6)
    forces = np.arange(33.0).reshape(11, 3)
    sums = ws.sum_by_group(forces)
    assert sums[1] == pytest.approx(forces[1:6].sum(axis=0))
    with pytest.raises(ConfigError, match="named"):
        WallSet([Plane(name="a"), Plane(name="a")])
    with pytest.raises(ConfigError, match="no wall named"):
        ws.rows_of("lid")


def test_box_faces_point_inwards_and_bound_the_box():
    ws = WallSet([Box((0, 0, 0), (1, 2, 3))])
    inside = np.array([0.5, 1.0, 1.5])
    for w in range(6):
        d, *n = wall_distance(ws.kind[w], ws.params[w], *inside)
        assert np.dot(n, ws.params[w, 9:12]) == pytest.approx(1.0)  # stored normal faces in
    dists = sorted(wall_distance(ws.kind[w], ws.params[w], 0.1, 0.2, 0.3)[0] for w in range(6))
    assert dists[:3] == pytest.approx([0.1, 0.2, 0.3])


def test_triangulate_counts():
    ws = WallSet([Plane(), Disk(radius=1), Cylinder(), Cone(), Rect(), Box((0, 0, 0), (1, 1, 1), open_top=True)])
    pts, tris, group = ws.triangulate(resolution=16)
    assert len(tris) == 2 + 16 + 32 + 32 + 2 + 10
    assert tris.max() < len(pts) and group.tolist().count(5) == 10


def test_bad_wall_input_is_explained():
    with pytest.raises(ConfigError, match="inner_radius"):
        Disk(radius=1.0, inner_radius=1.0)
    with pytest.raises(ConfigError, match="cylinder radius"):
        Cylinder(radius=-1.0)
    with pytest.raises(ConfigError, match="orthogonal"):
        Rect(u=(1, 0, 0), v=(1, 1, 0))
    with pytest.raises(ConfigError, match="upper corner"):
        Box((0, 0, 0), (1, 0, 1))
    with pytest.raises(ConfigError, match="non-zero direction"):
        Plane(normal=(0, 0, 0))
    with pytest.raises(ConfigError, match="a wall must be"):
        WallSet(["floor"])


def test_empty_wallset():
    ws = WallSet([])
    assert len(ws) == 0 and ws.names == [] and not ws.moving
    assert ws.params.shape == (0, 16) and ws.aabb.shape == (0, 6) and ws.kind.dtype == np.int32
    ws.update(1.0)
    pts, tris, group = ws.triangulate()
    assert len(tris) == 0
