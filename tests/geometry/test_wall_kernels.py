"""Point-to-wall distance kernels against analytic values and brute-force sampling.

For every kind the kernel's nearest point ``q = x - d n`` must lie on the surface
(so ``d`` is at least the true distance) and ``d`` must not exceed the distance to any
of a dense set of surface samples (so ``d`` is at most the true distance plus nothing):
together they pin ``d`` to the exact distance within the sample spacing.
"""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from demcal.geometry import Cone, Cylinder, Disk, Plane, Rect, TriangleMesh
from demcal.geometry import kernels as K
from demcal.geometry.kernels import wall_distance

RNG_SEED = 20260322


def _row(wall):
    kinds, params = wall.rows()
    return int(kinds[0]), np.ascontiguousarray(params[0])


def _frame(a):
    e1 = np.array(K.perpendicular(*a))
    return e1, np.cross(a, e1)


def _query(kind, p, pts):
    out = np.array([wall_distance(kind, p, *x) for x in pts])
    return out[:, 0], out[:, 1:]


def _samples_revolution(c, a, radius_of_h, length, n_h=600, n_phi=720):
    e1, e2 = _frame(a)
    h = np.linspace(0.0, length, n_h)
    phi = np.linspace(0.0, 2 * math.pi, n_phi, endpoint=False)
    H, P = np.meshgrid(h, phi, indexing="ij")
    R = radius_of_h(H)
    return (c + H[..., None] * a + R[..., None] * (np.cos(P)[..., None] * e1 + np.sin(P)[..., None] * e2)).reshape(-1, 3)


def _around_axis(c, a, loc):
    """Points at coordinates ``loc`` (e1, e2, along a) about the axis through ``c``."""
    e1, e2 = _frame(a)
    return c + loc[:, :1] * e1 + loc[:, 1:2] * e2 + loc[:, 2:] * a


def _nearest_axial(kind, p, pts, c, a):
    """Distances of ``pts`` and the axial coordinate and axis distance of each nearest
    point ``q = x - d n`` about the axis through ``c`` along ``a``."""
    d, n = _query(kind, p, pts)
    q = pts - d[:, None] * n
    h = (q - c) @ a
    return d, n, h, np.linalg.norm(q - c - h[:, None] * a, axis=1)


def _min_sample_distance(samples, pts):
    # duplicates (a disk's centre, a cone's apex) make the k-d tree build crawl; the tree
    # built at the sliding midpoint without shrinking its boxes answers the same exact
    # nearest distances ten times sooner on these surface grids (3.6 s -> 0.4 s for the
    # annulus, points off its plane)
    return cKDTree(np.unique(samples, axis=0), balanced_tree=False, compact_nodes=False).query(pts)[0]


def _random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _check_bracketed(d, q_on_surface, d_samples, spacing):
    assert np.all(d >= 0.0)
    assert np.all(q_on_surface)
    assert np.all(d <= d_samples + 1e-12)
    assert np.all(d >= d_samples - spacing)


def test_plane_signed_distance_and_normal():
    kind, p = _row(Plane(point=(1.0, 2.0, 3.0), normal=(0.0, 0.0, 2.0)))
    assert wall_distance(kind, p, 5.0, -7.0, 3.25) == pytest.approx((0.25, 0.0, 0.0, 1.0))
    d, nx, ny, nz = wall_distance(kind, p, 0.0, 0.0, 2.5)
    assert d == pytest.approx(-0.5)  # behind the plane: negative
    rng = np.random.default_rng(RNG_SEED)
    n = _random_unit(rng)
    kind, p = _row(Plane(point=(0.1, 0.2, 0.3), normal=n))
    for _ in range(20):
        x = rng.uniform(-1, 1, 3)
        d, *nn = wall_distance(kind, p, *x)
        assert d == pytest.approx((x - [0.1, 0.2, 0.3]) @ n, abs=1e-14)
        assert np.allclose(nn, n)


def test_disk_and_annulus_random_points():
    rng = np.random.default_rng(RNG_SEED)
    for inner in (0.0, 0.3):
        c = rng.uniform(-1, 1, 3)
        a = _random_unit(rng)
        wall = Disk(centre=c, normal=a, radius=0.8, inner_radius=inner)
        kind, p = _row(wall)
        pts = c + rng.uniform(-1.5, 1.5, (300, 3))
        d, n, h, rho = _nearest_axial(kind, p, pts, c, a)
        on = (np.abs(h) < 1e-12) & (rho <= 0.8 + 1e-12) & (rho >= inner - 1e-12)
        e1, e2 = _frame(a)
        rr, pp = np.meshgrid(np.linspace(inner, 0.8, 400), np.linspace(0, 2 * math.pi, 1440, endpoint=False))
        samples = (c + rr[..., None] * (np.cos(pp)[..., None] * e1 + np.sin(pp)[..., None] * e2)).reshape(-1, 3)
        spacing = math.hypot(0.8 / 400, 0.8 * 2 * math.pi / 1440)
        _check_bracketed(d, on, _min_sample_distance(samples, pts), spacing)
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0)


def test_disk_analytic_cases():
    kind, p = _row(Disk(centre=(0, 0, 0), normal=(0, 0, 1), radius=1.0, inner_radius=0.5))
    # above the annulus face, both sides
    assert wall_distance(kind, p, 0.7, 0.0, 0.2) == pytest.approx((0.2, 0, 0, 1))
    assert wall_distance(kind, p, 0.0, 0.7, -0.2) == pytest.approx((0.2, 0, 0, -1))
    # beyond the outer rim: distance to the rim circle
    d, nx, ny, nz = wall_distance(kind, p, 1.3, 0.0, 0.4)
    assert d == pytest.approx(0.5) and (nx, ny, nz) == pytest.approx((0.6, 0.0, 0.8))
    # over the hole: distance to the inner rim
    d, nx, ny, nz = wall_distance(kind, p, 0.0, 0.2, 0.4)
    assert d == pytest.approx(0.5) and (nx, ny, nz) == pytest.approx((0.0, -0.6, 0.8))
    # on the axis of the hole: every inner-rim point is nearest
    d, *_ = wall_distance(kind, p, 0.0, 0.0, 1.2)
    assert d == pytest.approx(1.3)


def test_cylinder_random_points_both_sides():
    rng = np.random.default_rng(RNG_SEED + 1)
    c = rng.uniform(-1, 1, 3)
    a = _random_unit(rng)
    wall = Cylinder(base=c, axis=a, radius=0.5, length=1.2)
    kind, p = _row(wall)
    # points inside, outside, beyond both ends
    pts = _around_axis(c, a, rng.uniform([-0.9, -0.9, -0.6], [0.9, 0.9, 1.8], (400, 3)))
    d, _, h, rho = _nearest_axial(kind, p, pts, c, a)
    on = (np.abs(rho - 0.5) < 1e-12) & (h >= -1e-12) & (h <= 1.2 + 1e-12)
    samples = _samples_revolution(c, a, lambda H: np.full_like(H, 0.5), 1.2)
    spacing = math.hypot(1.2 / 599, 0.5 * 2 * math.pi / 720)
    _check_bracketed(d, on, _min_sample_distance(samples, pts), spacing)


def test_cylinder_analytic_cases():
    kind, p = _row(Cylinder(base=(0, 0, 0), axis=(0, 0, 1), radius=1.0, length=2.0))
    assert wall_distance(kind, p, 0.25, 0.0, 1.0) == pytest.approx((0.75, -1, 0, 0))  # inside
    assert wall_distance(kind, p, 0.0, 1.5, 1.0) == pytest.approx((0.5, 0, 1, 0))  # outside
    d, nx, ny, nz = wall_distance(kind, p, 1.3, 0.0, 2.4)  # beyond the top rim
    assert d == pytest.approx(0.5) and (nx, ny, nz) == pytest.approx((0.6, 0.0, 0.8))
    d, nx, ny, nz = wall_distance(kind, p, 0.7, 0.0, -0.4)  # below the bottom rim, inside
    assert d == pytest.approx(0.5) and (nx, ny, nz) == pytest.approx((-0.6, 0.0, -0.8))
    d, nx, ny, nz = wall_distance(kind, p, 0.0, 0.0, 1.0)  # on the axis
    assert d == pytest.approx(1.0) and math.hypot(nx, ny) == pytest.approx(1.0) and nz == 0.0


@pytest.mark.parametrize("r1, r2", [(0.2, 0.8), (0.8, 0.2), (0.0, 0.6)])
def test_cone_random_points_both_sides(r1, r2):
    rng = np.random.default_rng(RNG_SEED + 2)
    c = rng.uniform(-1, 1, 3)
    a = _random_unit(rng)
    wall = Cone(base=c, axis=a, r1=r1, r2=r2, length=1.0)
    kind, p = _row(wall)
    pts = _around_axis(c, a, rng.uniform([-1.1, -1.1, -0.6], [1.1, 1.1, 1.6], (400, 3)))
    d, _, h, rho = _nearest_axial(kind, p, pts, c, a)
    on = (np.abs(rho - (r1 + (r2 - r1) * h)) < 1e-12) & (h >= -1e-12) & (h <= 1.0 + 1e-12)
    samples = _samples_revolution(c, a, lambda H: r1 + (r2 - r1) * H, 1.0)
    spacing = math.hypot(math.hypot(1.0, r2 - r1) / 599, max(r1, r2) * 2 * math.pi / 720)
    _check_bracketed(d, on, _min_sample_distance(samples, pts), spacing)


def test_cone_analytic_cases():
    # 45-degree funnel: radius 0.1 at the outlet (z=0), 1.1 at the rim (z=1)
    kind, p = _row(Cone(base=(0, 0, 0), axis=(0, 0, 1), r1=0.1, r2=1.1, length=1.0))
    s = 1 / math.sqrt(2)
    # inside the funnel above the surface point (0.6, 0, 0.5): along the inward normal
    d, nx, ny, nz = wall_distance(kind, p, 0.6 - 0.3 * s, 0.0, 0.5 + 0.3 * s)
    assert d == pytest.approx(0.3) and (nx, ny, nz) == pytest.approx((-s, 0.0, s))
    # outside, below the surface
    d, nx, ny, nz = wall_distance(kind, p, 0.0, 0.6 + 0.2 * s, 0.5 - 0.2 * s)
    assert d == pytest.approx(0.2) and (nx, ny, nz) == pytest.approx((0.0, s, -s))
    # below the outlet on the axis: the outlet rim is nearest
    d, nx, ny, nz = wall_distance(kind, p, 0.0, 0.0, -0.1)
    assert d == pytest.approx(math.hypot(0.1, 0.1))
    # beyond the upper rim
    d, nx, ny, nz = wall_distance(kind, p, 1.1, 0.0, 1.5)
    assert d == pytest.approx(0.5) and (nx, ny, nz) == pytest.approx((0, 0, 1))


def test_rect_random_points():
    rng = np.random.default_rng(RNG_SEED + 3)
    c = rng.uniform(-1, 1, 3)
    n = _random_unit(rng)
    wall = Rect.from_size(c, n, 0.6, 1.0)
    kind, p = _row(wall)
    u, v = wall.u, wall.v
    loc = rng.uniform(-1.5, 1.5, (400, 3))
    pts = c + loc[:, :1] * u + loc[:, 1:2] * v + 0.5 * loc[:, 2:] * n
    d, nn = _query(kind, p, pts)
    q = pts - d[:, None] * nn
    s = (q - c) @ u / (u @ u)
    t = (q - c) @ v / (v @ v)
    on = (np.abs((q - c) @ n) < 1e-12) & (np.abs(s) <= 1 + 1e-12) & (np.abs(t) <= 1 + 1e-12)
    ss, tt = np.meshgrid(np.linspace(-1, 1, 601), np.linspace(-1, 1, 1001))
    samples = (c + ss[..., None] * u + tt[..., None] * v).reshape(-1, 3)
    _check_bracketed(d, on, _min_sample_distance(samples, pts), math.hypot(0.6 / 600, 1.0 / 1000))


def test_rect_analytic_cases():
    kind, p = _row(Rect(centre=(0, 0, 0), u=(1, 0, 0), v=(0, 2, 0)))
    assert wall_distance(kind, p, 0.5, 1.0, 0.3) == pytest.approx((0.3, 0, 0, 1))
    assert wall_distance(kind, p, 0.5, 1.0, -0.3) == pytest.approx((0.3, 0, 0, -1))
    assert wall_distance(kind, p, 1.3, 0.0, 0.4) == pytest.approx((0.5, 0.6, 0, 0.8))  # edge
    d, *nn = wall_distance(kind, p, 2.0, 4.0, 2.0)  # corner (1, 2, 0)
    assert d == pytest.approx(3.0) and nn == pytest.approx([1 / 3, 2 / 3, 2 / 3])
    assert wall_distance(kind, p, 0.2, 0.2, 0.0) == pytest.approx((0.0, 0, 0, 1))  # on it


def test_triangle_random_points_regions():
    rng = np.random.default_rng(RNG_SEED + 4)
    tri = rng.uniform(-1, 1, (3, 3))
    kind, p = _row(TriangleMesh.from_triangles(tri[None]))
    a, b, c = tri
    pts = tri.mean(axis=0) + rng.uniform(-2, 2, (400, 3))
    d, n = _query(kind, p, pts)
    q = pts - d[:, None] * n
    # barycentric coordinates of q
    T = np.stack([b - a, c - a], axis=1)
    lam, res, *_ = np.linalg.lstsq(T, (q - a).T, rcond=None)
    recon = a + (T @ lam).T
    on = (
        (np.linalg.norm(recon - q, axis=1) < 1e-10)
        & (lam[0] >= -1e-10)
        & (lam[1] >= -1e-10)
        & (lam.sum(axis=0) <= 1 + 1e-10)
    )
    uu, vv = np.meshgrid(np.linspace(0, 1, 801), np.linspace(0, 1, 801))
    keep = uu + vv <= 1
    samples = a + uu[keep][:, None] * (b - a) + vv[keep][:, None] * (c - a)
    spacing = (np.linalg.norm(b - a) + np.linalg.norm(c - a)) / 800
    _check_bracketed(d, on, _min_sample_distance(samples, pts), spacing)


def test_triangle_analytic_vertex_edge_face():
    kind, p = _row(TriangleMesh.from_triangles(np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], float)))
    assert wall_distance(kind, p, 0.2, 0.2, 0.5) == pytest.approx((0.5, 0, 0, 1))  # face, front
    assert wall_distance(kind, p, 0.2, 0.2, -0.5) == pytest.approx((0.5, 0, 0, -1))  # face, back
    assert wall_distance(kind, p, -0.3, -0.4, 0.0) == pytest.approx((0.5, -0.6, -0.8, 0))  # vertex a
    assert wall_distance(kind, p, 1.3, -0.4, 0.0) == pytest.approx((0.5, 0.6, -0.8, 0))  # vertex b
    assert wall_distance(kind, p, -0.3, 1.4, 0.0) == pytest.approx((0.5, -0.6, 0.8, 0))  # vertex c
    assert wall_distance(kind, p, 0.5, -0.3, 0.4) == pytest.approx((0.5, 0, -0.6, 0.8))  # edge ab
    assert wall_distance(kind, p, -0.3, 0.5, 0.4) == pytest.approx((0.5, -0.6, 0, 0.8))  # edge ac
    s = 1 / math.sqrt(2)
    d, *nn = wall_distance(kind, p, 0.5 + 0.3 * s, 0.5 + 0.3 * s, 0.4)  # edge bc
    assert d == pytest.approx(0.5) and nn == pytest.approx([0.6 * s, 0.6 * s, 0.8])


def test_unknown_kind_is_far():
    assert wall_distance(99, np.zeros(K.PARAM_WIDTH), 0.0, 0.0, 0.0)[0] == K.FAR
