"""Distance kernels from a point to a wall surface.

Every wall row is an integer ``kind`` plus ``PARAM_WIDTH`` float64 parameters in the
WORLD frame at the current time (the layouts below; :mod:`demcal.geometry.wallset`
packs the rows of many walls into arrays). One kernel per kind and a
dispatcher :func:`wall_distance`; each is a pure scalar function (no allocation, no
globals but module constants) so the same source compiles with ``numba.njit`` for the
CPU and with ``numba.cuda.jit(device=True)`` for the GPU.

Each kernel returns ``(d, nx, ny, nz)``: the distance ``d >= 0`` [m] from the nearest
surface point to the query point and the unit normal pointing from that surface point
towards the query point. The surfaces are two-sided (a particle may touch a cylinder
from inside or outside), except :data:`PLANE`, which is an infinite half-space boundary:
``d`` is the signed distance along its normal and ``d < 0`` means behind the plane.
When the query point lies exactly on a surface (``d == 0``) the normal is the surface
normal as stored (plane/disk/rect/triangle normal, cylinder/cone outward normal).

Parameter layouts (unused slots are zero):

========  ==================================================================
kind      params
========  ==================================================================
PLANE     0:3 point on the plane, 3:6 unit normal
DISK      0:3 centre, 3:6 unit normal, 6 outer radius, 7 inner radius (annulus)
CYLINDER  0:3 centre of the base circle, 3:6 unit axis (base -> top),
          6 radius, 7 length
CONE      0:3 centre of the first end circle, 3:6 unit axis (first -> second end),
          6 radius r1 at the first end, 7 radius r2 at the second end, 8 length
RECT      0:3 centre, 3:6 half-extent edge vector u, 6:9 half-extent edge vector v
          (u orthogonal to v), 9:12 unit normal u x v / |u x v|, 12 |u|^2, 13 |v|^2
TRIANGLE  0:3 vertex a, 3:6 vertex b, 6:9 vertex c, 9:12 unit normal
          (b - a) x (c - a) normalised
========  ==================================================================

The closest point on a triangle follows C. Ericson, *Real-Time Collision Detection*,
Morgan Kaufmann 2005, section 5.1.5 (Voronoi-region test).
"""

from __future__ import annotations

import math

from numba import njit

PLANE = 0
DISK = 1
CYLINDER = 2
CONE = 3
RECT = 4
TRIANGLE = 5

#: Number of float64 parameters per wall row.
PARAM_WIDTH = 16

#: Distance returned when a kind is unknown (never in contact).
FAR = 1e30

KIND_NAMES = ("plane", "disk", "cylinder", "cone", "rect", "triangle")

_TINY = 1e-300


@njit(cache=True)
def perpendicular(ax, ay, az):
    """A unit vector perpendicular to the unit vector ``(ax, ay, az)``."""
    # cross with the coordinate axis least aligned with a
    if abs(ax) <= abs(ay) and abs(ax) <= abs(az):
        # e_x x a = (0, -az, ay)
        px, py, pz = 0.0, -az, ay
    elif abs(ay) <= abs(az):
        # e_y x a = (az, 0, -ax)
        px, py, pz = az, 0.0, -ax
    else:
        # e_z x a = (-ay, ax, 0)
        px, py, pz = -ay, ax, 0.0
    inv = 1.0 / math.sqrt(px * px + py * py + pz * pz)
    return px * inv, py * inv, pz * inv


@njit(cache=True)
def _to_point(x, y, z, qx, qy, qz, fx, fy, fz):
    """Distance and unit direction from surface point q to (x, y, z).

    ``(fx, fy, fz)`` is the fallback normal used when the point lies on the surface.
    """
    dx = x - qx
    dy = y - qy
    dz = z - qz
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d > 1e-14 * (1.0 + abs(qx) + abs(qy) + abs(qz)):
        inv = 1.0 / d
        return d, dx * inv, dy * inv, dz * inv
    return d, fx, fy, fz


@njit(cache=True)
def _clamp(v, lo, hi):
    """``v`` limited to ``[lo, hi]`` (``lo <= hi``)."""
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


@njit(cache=True)
def _to_point_sided(x, y, z, qx, qy, qz, nx, ny, nz, side):
    """:func:`_to_point` with the fallback normal ``n`` turned towards the query point's
    ``side`` of a two-sided flat surface (``-n`` where ``side < 0``)."""
    if side < 0.0:
        return _to_point(x, y, z, qx, qy, qz, -nx, -ny, -nz)
    return _to_point(x, y, z, qx, qy, qz, nx, ny, nz)


@njit(cache=True)
def _axial_coordinates(cx, cy, cz, ax, ay, az, x, y, z):
    """Coordinates of (x, y, z) about the axis through ``c`` along the unit vector ``a``.

    Returns the axial coordinate ``h``, the distance ``rho`` from the axis and the unit
    radial direction ``u`` (any unit vector perpendicular to the axis when on it).
    """
    wx = x - cx
    wy = y - cy
    wz = z - cz
    h = wx * ax + wy * ay + wz * az
    qx = wx - h * ax
    qy = wy - h * ay
    qz = wz - h * az
    rho = math.sqrt(qx * qx + qy * qy + qz * qz)
    if rho > _TINY:
        return h, rho, qx / rho, qy / rho, qz / rho
    ux, uy, uz = perpendicular(ax, ay, az)
    return h, rho, ux, uy, uz


@njit(cache=True)
def _from_meridian(dr, dh, tol, fr, fh, ux, uy, uz, ax, ay, az):
    """Distance and world normal from the offset ``(dr, dh)`` (radial, axial) from a
    surface of revolution about the unit axis ``a`` to the query point in its meridian
    half-plane with radial direction ``u``. Within ``tol`` of the surface the normal is
    the meridian vector ``(fr, fh)``, normalised."""
    d = math.sqrt(dr * dr + dh * dh)
    if d > tol:
        nr = dr / d
        nh = dh / d
    else:
        inv = 1.0 / math.sqrt(fr * fr + fh * fh)
        nr = fr * inv
        nh = fh * inv
    return d, nr * ux + nh * ax, nr * uy + nh * ay, nr * uz + nh * az


@njit(cache=True)
def plane_distance(p, x, y, z):
    """Signed distance to an infinite plane (point ``p[0:3]``, unit normal ``p[3:6]``)."""
    nx = p[3]
    ny = p[4]
    nz = p[5]
    d = (x - p[0]) * nx + (y - p[1]) * ny + (z - p[2]) * nz
    return d, nx, ny, nz


@njit(cache=True)
def disk_distance(p, x, y, z):
    """Distance to a flat disk or annulus (two-sided, including its rims)."""
    cx, cy, cz, ax, ay, az, r_out, r_in = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    h, rho, ux, uy, uz = _axial_coordinates(cx, cy, cz, ax, ay, az, x, y, z)
    rc = _clamp(rho, r_in, r_out)
    return _to_point_sided(x, y, z, cx + rc * ux, cy + rc * uy, cz + rc * uz, ax, ay, az, h)


@njit(cache=True)
def cone_distance(p, x, y, z):
    """Distance to a finite conical frustum shell (open ends, two-sided).

    The surface is the set ``c1 + t a + r(t) u`` with ``r(t) = r1 + (r2 - r1) t / L``,
    ``0 <= t <= L`` and ``u`` any unit vector perpendicular to ``a``. In the meridian
    half-plane of the query point the surface is the segment (r1, 0) -> (r2, L) in
    (radial, axial) coordinates; the nearest point is the nearest point on that segment.
    """
    ax, ay, az, r1, r2, length = p[3], p[4], p[5], p[6], p[7], p[8]
    h, rho, ux, uy, uz = _axial_coordinates(p[0], p[1], p[2], ax, ay, az, x, y, z)
    gr = r2 - r1
    gh = length
    t = _clamp(((rho - r1) * gr + h * gh) / (gr * gr + gh * gh), 0.0, 1.0)
    sr = r1 + t * gr
    sh = t * gh
    tol = 1e-14 * (1.0 + abs(sr) + abs(sh))
    return _from_meridian(rho - sr, h - sh, tol, gh, -gr, ux, uy, uz, ax, ay, az)


@njit(cache=True)
def cylinder_distance(p, x, y, z):
    """Distance to a finite cylindrical shell (open ends, two-sided, with rims)."""
    ax, ay, az, radius, length = p[3], p[4], p[5], p[6], p[7]
    h, rho, ux, uy, uz = _axial_coordinates(p[0], p[1], p[2], ax, ay, az, x, y, z)
    hc = _clamp(h, 0.0, length)
    tol = 1e-14 * (1.0 + radius + abs(hc))
    return _from_meridian(rho - radius, h - hc, tol, 1.0, 0.0, ux, uy, uz, ax, ay, az)


@njit(cache=True)
def rect_distance(p, x, y, z):
    """Distance to a finite rectangle (two-sided, with edges and corners)."""
    cx, cy, cz, ux, uy, uz, vx, vy, vz = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8]
    nx, ny, nz, uu, vv = p[9], p[10], p[11], p[12], p[13]
    wx = x - cx
    wy = y - cy
    wz = z - cz
    s = _clamp((wx * ux + wy * uy + wz * uz) / uu, -1.0, 1.0)
    t = _clamp((wx * vx + wy * vy + wz * vz) / vv, -1.0, 1.0)
    sx = cx + s * ux + t * vx
    sy = cy + s * uy + t * vy
    sz = cz + s * uz + t * vz
    return _to_point_sided(x, y, z, sx, sy, sz, nx, ny, nz, wx * nx + wy * ny + wz * nz)


@njit(cache=True)
def triangle_closest_point(p, x, y, z):
    """Closest point to (x, y, z) on the triangle ``p[0:9]`` (Ericson 2005, 5.1.5)."""
    ax_ = p[0]
    ay_ = p[1]
    az_ = p[2]
    abx = p[3] - ax_
    aby = p[4] - ay_
    abz = p[5] - az_
    acx = p[6] - ax_
    acy = p[7] - ay_
    acz = p[8] - az_
    apx = x - ax_
    apy = y - ay_
    apz = z - az_
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax_, ay_, az_  # vertex a
    bpx = x - p[3]
    bpy = y - p[4]
    bpz = z - p[5]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return p[3], p[4], p[5]  # vertex b
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)  # edge ab
        return ax_ + v * abx, ay_ + v * aby, az_ + v * abz
    cpx = x - p[6]
    cpy = y - p[7]
    cpz = z - p[8]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return p[6], p[7], p[8]  # vertex c
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)  # edge ac
        return ax_ + w * acx, ay_ + w * acy, az_ + w * acz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))  # edge bc
        return (
            p[3] + w * (p[6] - p[3]),
            p[4] + w * (p[7] - p[4]),
            p[5] + w * (p[8] - p[5]),
        )
    denom = 1.0 / (va + vb + vc)  # interior
    v = vb * denom
    w = vc * denom
    return (
        ax_ + abx * v + acx * w,
        ay_ + aby * v + acy * w,
        az_ + abz * v + acz * w,
    )


@njit(cache=True)
def triangle_distance(p, x, y, z):
    """Distance to one triangle (two-sided, with edges and vertices)."""
    nx, ny, nz = p[9], p[10], p[11]
    side = (x - p[0]) * nx + (y - p[1]) * ny + (z - p[2]) * nz
    sx, sy, sz = triangle_closest_point(p, x, y, z)
    return _to_point_sided(x, y, z, sx, sy, sz, nx, ny, nz, side)


@njit(cache=True, inline="always")
def wall_distance(kind, p, x, y, z):
    """Distance ``d`` [m] and unit normal from wall row ``(kind, p)`` to ``(x, y, z)``.

    Parameters
    ----------
    kind : int
        One of PLANE, DISK, CYLINDER, CONE, RECT, TRIANGLE.
    p : float64[PARAM_WIDTH]
        The row's world-frame parameters (layouts in the module docstring).
    x, y, z : float
        Query point [m].

    Returns
    -------
    d, nx, ny, nz : float
        Distance from the nearest surface point (signed for PLANE) and the unit normal
        from that point towards the query point. Unknown kinds return ``d = 1e30``.
    """
    if kind == PLANE:
        return plane_distance(p, x, y, z)
    elif kind == DISK:
        return disk_distance(p, x, y, z)
    elif kind == CYLINDER:
        return cylinder_distance(p, x, y, z)
    elif kind == CONE:
        return cone_distance(p, x, y, z)
    elif kind == RECT:
        return rect_distance(p, x, y, z)
    elif kind == TRIANGLE:
        return triangle_distance(p, x, y, z)
    return FAR, 0.0, 0.0, 1.0
