"""Synthetic heaps of known angle, for testing the measurements.

* :func:`particle_cone` fills a cone of a given angle with spheres (centres and radii),
  the input of :func:`demcal.measure.heap.measure_heap`.
* :func:`synthetic_photo` draws a side photo of a heap of a given angle with the
  disturbances of a real photo: noise, blur, uneven lighting, a cast shadow, a slightly
  tilted camera, a textured background, fines at the foot, front- or back-lit.

Both are pure functions of their arguments and a seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage


def particle_cone(angle_deg: float, base_radius: float = 0.1, radius: float = 0.0025,
                  radius_spread: float = 0.2, seed: int = 0, base_z: float = 0.0,
                  centre_xy=(0.0, 0.0)):
    """Spheres forming a cone of known angle standing on a base plane.

    The surface is a stack of rings of spheres along the cone's generator, ``1.2 r``
    apart along the surface and around each ring (with a random phase per ring), each
    sphere's centre ``r_i`` inside the nominal cone surface
    ``z = (base_radius - rho) tan(angle)`` so that its outer edge touches that surface.
    The inside is filled by a jittered cubic lattice (spacing ``1.8 r``) kept at least
    ``2 r_max`` inside the surface. The lowest ring rests on the base, so the foot
    starts about ``r (1 + cos a) / sin a`` inside ``base_radius``.

    Parameters
    ----------
    angle_deg : cone angle to the base [deg].
    base_radius : radius of the nominal cone's base [m].
    radius : mean sphere radius [m].
    radius_spread : radii are uniform in ``radius * (1 +- radius_spread)``.
    seed : random seed.
    base_z, centre_xy : base plane height and cone axis [m].

    Returns
    -------
    positions : (n, 3) [m]; radii : (n,) [m].
    """
    rng = np.random.default_rng(seed)
    a = np.radians(angle_deg)
    tan, sin, cos = np.tan(a), np.sin(a), np.cos(a)
    height = base_radius * tan
    r_max = radius * (1 + radius_spread)
    spacing = 1.2 * radius
    xs, ys, zs, rs = [], [], [], []
    for t in np.arange(radius * (1 + cos) / sin, base_radius / cos, spacing):
        rho_s, z_s = base_radius - t * cos, t * sin  # point on the nominal surface
        n = max(1, int(np.ceil(2 * np.pi * rho_s / spacing)))
        theta = rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n
        r = radius * (1 + rng.uniform(-radius_spread, radius_spread, n))
        rho_c = np.maximum(rho_s - r * sin, 0.0)
        xs.append(rho_c * np.cos(theta))
        ys.append(rho_c * np.sin(theta))
        zs.append(np.maximum(z_s - r * cos, r))
        rs.append(r)
    # the inside: a jittered lattice well below the surface
    d = 1.8 * radius
    g = np.arange(-base_radius, base_radius + d, d)
    x, y, z = (v.ravel() for v in np.meshgrid(g, g, np.arange(radius, height, d), indexing="ij"))
    x, y = x + rng.uniform(-0.15, 0.15, x.size) * radius, y + rng.uniform(-0.15, 0.15, x.size) * radius
    r = radius * (1 + rng.uniform(-radius_spread, radius_spread, x.size))
    inside = ((base_radius - np.hypot(x, y)) * tan - z) * cos
    keep = inside >= 2 * r_max
    xs.append(x[keep]), ys.append(y[keep]), zs.append(np.maximum(z[keep], r[keep])), rs.append(r[keep])
    pos = np.column_stack([np.concatenate(xs) + centre_xy[0], np.concatenate(ys) + centre_xy[1],
                           np.concatenate(zs) + base_z])
    return pos, np.concatenate(rs)


@dataclass(frozen=True)
class SyntheticPhoto:
    """A drawn heap photo and the truth behind it.

    Attributes
    ----------
    image : (rows, cols, 3) uint8 RGB.
    angle_deg : the flanks' true angle [deg].
    base_row : image row of the base line before any tilt [px].
    apex_col : column of the apex [px].
    height_px : heap height before rounding of the top [px].
    """

    image: np.ndarray
    angle_deg: float
    base_row: float
    apex_col: float
    height_px: float


_SOIL = np.array([0.47, 0.35, 0.24])
_WALL = np.array([0.84, 0.82, 0.78])
_PLATE = np.array([0.56, 0.57, 0.60])
_SAND = np.array([0.88, 0.80, 0.62])
_CLOTH = np.array([0.14, 0.14, 0.16])


def _smooth_noise(rng, shape, sigma, amplitude):
    field = ndimage.gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap")
    return amplitude * field / (field.std() + 1e-12)


def synthetic_photo(angle_deg: float, seed: int = 0, size=(600, 800), half_width: float = 250.0,
                    base_row: float = 470.0, lighting: str = "front", noise: float = 0.03,
                    blur: float = 1.2, gradient: float = 0.3, shadow: bool = False,
                    tilt_deg: float = 0.0, texture: bool = True, fines: bool = True,
                    roughness: float = 1.0, round_top: float = 0.08) -> SyntheticPhoto:
    """Draw a side photo of a heap whose flanks have a known angle.

    The heap's profile is ``z(x) = h - |x - x_c| tan(angle)`` with ``h = half_width
    tan(angle)``, its top rounded by a parabola over the top ``round_top`` of its height,
    a random surface roughness of ``roughness`` px (zero mean, correlated over ~4 px)
    and, with ``fines``, loose grains at the foot, on the plate and stuck to the flanks.
    It stands on a grey base plate wider than the photo.

    Parameters
    ----------
    angle_deg : true flank angle [deg].
    seed : random seed (texture, noise, fines).
    size : (rows, cols) [px].
    half_width, base_row : heap half-width at the base and row of the base line [px].
    lighting : ``"front"`` (brown soil on a light wall), ``"back"`` (black silhouette
        on a light box) or ``"bright"`` (light sand on a dark cloth).
    noise : standard deviation of Gaussian pixel noise (intensity 0..1).
    blur : Gaussian blur of the lens [px].
    gradient : uneven lighting: brightness goes from ``1 - gradient`` on the left to
        ``1 + gradient`` on the right, with a vignette.
    shadow : front light from the left casts the heap's shadow on the wall to its right.
    tilt_deg : camera roll; the whole photo is rotated counter-clockwise by this angle.
    texture : graph-paper wall / cloth weave and grainy soil instead of flat colours.
    """
    if lighting not in ("front", "back", "bright"):
        raise ValueError(f"lighting must be 'front', 'back' or 'bright', not {lighting!r}")
    rng = np.random.default_rng(seed)
    rows, cols = size
    tan = np.tan(np.radians(angle_deg))
    h = half_width * tan
    xc = cols / 2.0 + rng.uniform(-10, 10)
    x = np.arange(cols, dtype=float)
    z = h - np.abs(x - xc) * tan
    w0 = round_top * h / tan  # half-width of the rounded top
    top = np.abs(x - xc) < w0
    z[top] = h - w0 * tan / 2 - tan / (2 * w0) * (x[top] - xc) ** 2
    z += ndimage.gaussian_filter1d(rng.standard_normal(cols), 4.0) * roughness * 2.0
    z = np.maximum(z, 0.0)

    # coverage of each pixel by the heap, anti-aliased along the columns
    row_c = np.arange(rows, dtype=float)[:, None]
    height_above = base_row - row_c  # height of each pixel centre above the base line
    heap = np.clip(z[None, :] - height_above + 0.5, 0.0, 1.0) * (height_above > -0.5)
    if fines:
        heap = np.maximum(heap, _fines(rng, rows, cols, xc, half_width, base_row, tan, h))
    plate = ((row_c >= base_row) & (row_c < base_row + 16)).astype(float) * np.ones((1, cols))
    stand = ((row_c >= base_row + 16) & (np.abs(x - xc)[None, :] < 40)).astype(float)
    solid = np.maximum(plate, stand)

    if lighting == "front":
        wall, soil, plate_colour = _WALL, _SOIL, _PLATE
    elif lighting == "back":
        wall, soil, plate_colour = np.array([0.95, 0.95, 0.95]), np.full(3, 0.07), np.full(3, 0.07)
    else:
        wall, soil, plate_colour = _CLOTH, _SAND, _PLATE * 0.8
    img = np.broadcast_to(wall, (rows, cols, 3)).copy()
    if texture:
        grain = _smooth_noise(rng, (rows, cols), 25, 0.05) + _smooth_noise(rng, (rows, cols), 0.8, 0.03)
        if lighting == "front":  # graph paper: faint lines every 40 px
            lines = np.zeros((rows, cols))
            lines[::40, :] = lines[:, ::40] = 1.0
            grain -= 0.10 * ndimage.gaussian_filter(lines, 0.7) / ndimage.gaussian_filter(lines, 0.7).max()
        img *= (1 + grain)[..., None]
    if shadow and lighting == "front":
        cast = ndimage.shift(heap, (0, 28), order=1, mode="constant")
        cast = ndimage.gaussian_filter(cast, 5.0)
        img *= (1 - 0.35 * cast)[..., None]
    img = img * (1 - solid[..., None]) + plate_colour * solid[..., None]
    soil_img = np.broadcast_to(soil, (rows, cols, 3)).copy()
    if texture and lighting != "back":
        soil_img *= (1 + _smooth_noise(rng, (rows, cols), 1.0, 0.12))[..., None]
    img = img * (1 - heap[..., None]) + soil_img * heap[..., None]

    # uneven lighting and vignette
    xx = (x / cols - 0.5)[None, :]
    yy = (np.arange(rows) / rows - 0.5)[:, None]
    light = (1 + 2 * gradient * xx) * (1 - 0.25 * (xx**2 + yy**2) / 0.5)
    img *= light[..., None]
    if tilt_deg:
        from skimage.transform import rotate

        img = rotate(img, tilt_deg, order=1, mode="edge")
    if blur:
        img = ndimage.gaussian_filter(img, (blur, blur, 0))
    img = img + rng.normal(0, noise, img.shape)
    image = (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8)
    return SyntheticPhoto(image, float(angle_deg), float(base_row), float(xc), float(h))


def _fines(rng, rows, cols, xc, half_width, base_row, tan, h):
    """Loose grains: a scatter at the foot and on the plate, and a few clumps stuck to
    the flanks (outliers for the flank fit)."""
    yy, xx = np.mgrid[0:rows, 0:cols]
    out = np.zeros((rows, cols))
    n = 60
    side = rng.choice([-1.0, 1.0], n)
    gx = xc + side * (half_width + rng.uniform(-30, 45, n))
    gy = base_row - rng.uniform(0.5, 3.0, n)
    gr = rng.uniform(1.0, 3.0, n)
    # three clumps on each flank, between 20 % and 80 % of the height
    for s in (-1.0, 1.0):
        zc = rng.uniform(0.2, 0.8, 3) * h
        gx = np.r_[gx, xc + s * (h - zc) / tan]
        gy = np.r_[gy, base_row - zc]
        gr = np.r_[gr, rng.uniform(3.0, 5.0, 3)]
    for cx, cy, r in zip(gx, gy, gr):
        y0, y1 = int(max(cy - r - 2, 0)), int(min(cy + r + 3, rows))
        x0, x1 = int(max(cx - r - 2, 0)), int(min(cx + r + 3, cols))
        d = np.hypot(xx[y0:y1, x0:x1] - cx, yy[y0:y1, x0:x1] - cy)
        out[y0:y1, x0:x1] = np.maximum(out[y0:y1, x0:x1], np.clip(r - d + 0.5, 0, 1))
    return out
