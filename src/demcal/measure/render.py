"""Pictures of simulated heaps as a camera would take them: orthographic projection of
the spheres, a z-buffer and Lambert shading, a light wall behind and a grey base plate.

Used to check that the photo path and the heap-outline path agree, and for "simulated
next to measured" figures. The view convention is :mod:`demcal.measure.heap`'s: the
image's horizontal axis is ``u = x cos(phi) + y sin(phi)``; the camera looks along
``w = -x sin(phi) + y cos(phi)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RenderedHeap:
    """A rendered picture: ``image`` (rows, cols, 3) uint8, the scale ``mm_per_px``
    and the row of the base line ``base_row`` [px]."""

    image: np.ndarray
    mm_per_px: float
    base_row: float


def render_heap(positions, radii, view_deg: float = 0.0, base_z: float = 0.0, axis_xy=None,
                pixel: float | None = None, margin_px: int = 40, seed: int = 0) -> RenderedHeap:
    """Render a heap of spheres.

    Parameters
    ----------
    positions, radii : sphere centres (n, 3) and radii (n,) [m].
    view_deg : view direction around the vertical axis [deg].
    base_z : base plate height [m]; the plate is drawn below it.
    axis_xy : centre of the picture (default the centroid).
    pixel : pixel size [m] (default a third of the smallest radius).
    margin_px : wall visible around the heap [px].
    seed : per-particle colour variation.
    """
    pos = np.asarray(positions, dtype=float)
    rad = np.broadcast_to(np.asarray(radii, dtype=float), pos.shape[:1])
    axis_xy = pos[:, :2].mean(axis=0) if axis_xy is None else np.asarray(axis_xy, float)
    pixel = pixel or rad.min() / 3.0
    phi = np.radians(view_deg)
    rel = pos[:, :2] - axis_xy
    u = rel[:, 0] * np.cos(phi) + rel[:, 1] * np.sin(phi)
    w = -rel[:, 0] * np.sin(phi) + rel[:, 1] * np.cos(phi)
    z = pos[:, 2]
    u0 = (u - rad).min() - margin_px * pixel
    top = (z + rad).max() + margin_px * pixel
    plate_px = 12
    cols = int(np.ceil(((u + rad).max() + margin_px * pixel - u0) / pixel))
    base_row = (top - base_z) / pixel
    rows = int(np.ceil(base_row)) + plate_px + margin_px
    # every (sphere, pixel) pair in the sphere's bounding box
    c_lo = np.floor((u - rad - u0) / pixel).astype(int)
    r_lo = np.floor((top - z - rad) / pixel).astype(int)
    k = int(np.ceil(2 * rad.max() / pixel)) + 2
    di, dj = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    rr = (r_lo[:, None] + di.ravel()[None, :])
    cc = (c_lo[:, None] + dj.ravel()[None, :])
    du = (u0 + (cc + 0.5) * pixel) - u[:, None]
    dz = (top - (rr + 0.5) * pixel) - z[:, None]
    h2 = rad[:, None] ** 2 - du**2 - dz**2
    ok = (h2 > 0) & (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
    sphere = np.broadcast_to(np.arange(pos.shape[0])[:, None], ok.shape)[ok]
    h = np.sqrt(h2[ok])
    depth = w[sphere] - h
    flat = rr[ok] * cols + cc[ok]
    order = np.lexsort((depth, flat))  # nearest first within each pixel
    flat, first = flat[order], np.r_[True, flat[order][1:] != flat[order][:-1]]
    sel = order[first]
    normal = np.stack([du[ok][sel], -h[sel], dz[ok][sel]], 1) / rad[sphere[sel], None]
    light = np.array([-0.45, -0.75, 0.5])
    shade = 0.35 + 0.65 * np.clip(normal @ (light / np.linalg.norm(light)), 0, None)
    tint = 1 + 0.12 * np.random.default_rng(seed).uniform(-1, 1, pos.shape[0])
    colour = np.array([0.47, 0.35, 0.24])[None, :] * (shade * tint[sphere[sel]])[:, None]
    img = np.empty((rows * cols, 3))
    img[:] = (0.86, 0.85, 0.82)
    plate = np.zeros((rows, cols), bool)
    plate[int(np.ceil(base_row)):int(np.ceil(base_row)) + plate_px] = True
    img[plate.ravel()] = (0.55, 0.56, 0.6)
    img[flat[first]] = colour
    image = (np.clip(img.reshape(rows, cols, 3), 0, 1) * 255 + 0.5).astype(np.uint8)
    return RenderedHeap(image, pixel * 1e3, float(base_row))
