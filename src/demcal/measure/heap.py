"""Angle of repose of a simulated heap, measured the way a camera sees it.

The heap is the largest cluster of touching particles that stands on the base
(particles in flight or rolled away are separate clusters and are left out). It is
viewed from several directions around the vertical (``z``) axis: in each view the
spheres are projected orthographically on a vertical plane and the outline is the
upper envelope of their discs, evaluated exactly at pixel columns one
:data:`PIXELS_PER_RADIUS`-th of the smallest radius wide:
``z(u) = max_i (z_i + sqrt(r_i^2 - (u - u_i)^2))`` -- the topmost occupied point of
each column of the silhouette a camera would see. Each outline goes through
:func:`demcal.measure.flank.fit_outline`, the same code that measures lab photos, so
lab and simulation are judged alike. Views ``phi = k * 180 deg / views`` cover all
distinct silhouettes (the view from ``phi + 180 deg`` is the mirror image).

Two other common measures are reported for comparison:

* ``atan(2 H / D)``: heap height over base radius, with ``D`` the silhouette's base
  width averaged over the views (sensitive to a spread foot);
* ``atan(4 z_com / R)``: a solid cone of height ``H`` and base radius ``R`` has its
  centre of mass at ``H / 4`` above the base, so ``tan(alpha) = 4 z_com / R``, with
  ``R = D / 2`` and ``z_com`` the mass-weighted (``r^3``) mean height of the heap's
  particle centres above the base.

Units: positions and radii in metres; angles in degrees.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from demcal.errors import DataError, DemcalError
from demcal.measure.flank import DEFAULT_BAND, FlankFit, OutlineFit, fit_outline

#: Raster pixel size is the smallest radius divided by this.
PIXELS_PER_RADIUS = 4.0
#: Largest raster width; a wider scene gets coarser pixels.
MAX_COLUMNS = 4000
#: A heap lower than this many mean particle diameters is a flat layer.
MIN_HEIGHT_DIAMETERS = 2.0


@dataclass(frozen=True)
class ViewMeasurement:
    """Flank fits of one view.

    Attributes
    ----------
    view_deg : direction of the image's horizontal axis, ``u = x cos(phi) + y sin(phi)``
        [deg].
    fit : both flanks (``fit.left``, ``fit.right``), height and apex.
    diameter : base width of the silhouette [m].
    u, z : the outline (pixel-column centres and envelope heights) [m].
    """

    view_deg: float
    fit: OutlineFit
    diameter: float
    u: np.ndarray = field(repr=False)
    z: np.ndarray = field(repr=False)

    @property
    def left(self) -> FlankFit:
        return self.fit.left

    @property
    def right(self) -> FlankFit:
        return self.fit.right


@dataclass(frozen=True)
class HeapMeasurement:
    """Angle of repose of one heap, over all flanks and views.

    Attributes
    ----------
    angle_deg : mean flank angle over both flanks of every view [deg].
    spread_deg : sample standard deviation of those flank angles [deg].
    r2 : mean R^2 of the flank fits; ``r2_min`` the worst.
    height : heap height above the base, top of the highest kept particle [m].
    diameter : silhouette base width averaged over views [m].
    h_over_d_angle_deg : ``atan(2 H / D)`` [deg].
    com_cone_angle_deg : ``atan(4 z_com / R)``, ``R = D / 2`` [deg].
    n_particles : particles in the heap (the largest touching cluster on the base).
    n_dropped : particles left out (below the base, in flight, rolled away).
    views : per-view results.
    band : height fractions used.
    png : the picture written, if any.
    """

    angle_deg: float
    spread_deg: float
    r2: float
    r2_min: float
    height: float
    diameter: float
    h_over_d_angle_deg: float
    com_cone_angle_deg: float
    n_particles: int
    n_dropped: int
    views: tuple[ViewMeasurement, ...]
    band: tuple[float, float]
    png: str | None = None

    @property
    def flank_angles_deg(self) -> np.ndarray:
        """Every flank angle, ``[view0 left, view0 right, view1 left, ...]`` [deg]."""
        return np.array([a for v in self.views for a in (v.left.angle_deg, v.right.angle_deg)])

    def to_dict(self) -> dict:
        return {
            "angle_deg": self.angle_deg,
            "spread_deg": self.spread_deg,
            "r2": self.r2,
            "r2_min": self.r2_min,
            "height_m": self.height,
            "diameter_m": self.diameter,
            "h_over_d_angle_deg": self.h_over_d_angle_deg,
            "com_cone_angle_deg": self.com_cone_angle_deg,
            "n_particles": self.n_particles,
            "n_dropped": self.n_dropped,
            "band": list(self.band),
            "views": [
                {"view_deg": v.view_deg, "left": v.left.to_dict(), "right": v.right.to_dict()}
                for v in self.views
            ],
            "png": self.png,
        }


def measure_heap(positions, radii, base_z: float = 0.0, axis_xy=None, views: int = 8,
                 band: tuple[float, float] = DEFAULT_BAND, plate_radius: float | None = None,
                 png: str | Path | None = None, title: str | None = None) -> HeapMeasurement:
    """Measure the angle of repose of a heap of spheres.

    Parameters
    ----------
    positions : (n, 3) sphere centres [m], ``z`` up.
    radii : (n,) sphere radii [m].
    base_z : height of the base plate's surface [m]. Particles whose centre lies below
        it (fallen off the plate) are left out.
    axis_xy : (x, y) of the heap's vertical axis [m], used for ``R`` and the plate
        check; default the mass-weighted centroid of the particles on the base.
    views : number of view directions, evenly spaced over 180 deg.
    band : height fractions between which each flank is fitted.
    plate_radius : radius of a round base plate centred on the axis [m]; if given, a
        heap whose flank (above ``band[0]`` of its height) reaches the plate's edge is
        refused, because its angle is cut short by the edge.
    png : write a picture of the first view's silhouette with the fitted lines here.
    title : title of the picture.

    Raises
    ------
    DemcalError
        No particles, a flat layer instead of a heap, a heap that reaches the plate
        edge, or a flank that cannot be fitted.
    """
    pos = np.asarray(positions, dtype=float).reshape(-1, 3)
    rad = np.broadcast_to(np.asarray(radii, dtype=float), pos.shape[:1]).copy()
    if views < 1:
        raise DemcalError(f"views must be at least 1, got {views}.")
    on_base = np.all(np.isfinite(pos), axis=1) & (pos[:, 2] >= base_z) & (rad > 0)
    n_total = pos.shape[0]
    pos, rad = pos[on_base], rad[on_base]
    if pos.shape[0] == 0:
        raise DemcalError(
            f"there is no heap to measure: none of the {n_total} particles lies on the base "
            f"(z >= {base_z:g} m)."
        )
    keep = heap_members(pos, rad, base_z)
    pos, rad = pos[keep], rad[keep]
    n_dropped = n_total - int(keep.sum())
    mass = rad**3
    if axis_xy is None:
        axis_xy = (pos[:, :2] * mass[:, None]).sum(axis=0) / mass.sum()
    axis_xy = np.asarray(axis_xy, dtype=float)
    rel = pos[:, :2] - axis_xy
    pixel = _pixel_size(rel, rad)

    height = float((pos[:, 2] + rad).max() - base_z)
    if height < MIN_HEIGHT_DIAMETERS * 2 * rad.mean():
        raise DemcalError(
            f"there is no heap to measure: the particles form a flat layer "
            f"{height / (2 * rad.mean()):.1f} particle diameters high."
        )
    if plate_radius is not None:
        rho = np.hypot(rel[:, 0], rel[:, 1])
        at_edge = rho + rad >= plate_radius - 0.25 * rad
        high = pos[:, 2] + rad > base_z + band[0] * height
        if np.any(at_edge & high):
            raise DemcalError(
                f"the heap reaches the edge of the base plate (radius {plate_radius:g} m) "
                f"above {band[0]:.0%} of its height, so its flanks are cut short; "
                "use a larger plate or fewer particles."
            )

    results = []
    for k in range(views):
        phi = np.pi * k / views
        view_deg = float(np.degrees(phi))
        u = rel[:, 0] * np.cos(phi) + rel[:, 1] * np.sin(phi)
        cu, cz = _envelope(u, pos[:, 2], rad, pixel)
        try:
            fit = fit_outline(cu, cz, base_z=base_z, band=band)
        except DataError as exc:
            raise DemcalError(f"the heap cannot be measured in the view at {view_deg:.1f} deg: {exc}") from None
        results.append(ViewMeasurement(view_deg, fit, float(np.ptp(cu) + pixel), cu, cz))

    angles = np.array([a for v in results for a in (v.left.angle_deg, v.right.angle_deg)])
    r2s = np.array([a for v in results for a in (v.left.r2, v.right.r2)])
    diameter = float(np.mean([v.diameter for v in results]))
    z_com = float((mass * (pos[:, 2] - base_z)).sum() / mass.sum())
    measurement = HeapMeasurement(
        angle_deg=float(angles.mean()),
        spread_deg=float(angles.std(ddof=1)),
        r2=float(r2s.mean()),
        r2_min=float(r2s.min()),
        height=height,
        diameter=diameter,
        h_over_d_angle_deg=float(np.degrees(np.arctan(2 * height / diameter))),
        com_cone_angle_deg=float(np.degrees(np.arctan(4 * z_com / (diameter / 2)))),
        n_particles=int(pos.shape[0]),
        n_dropped=n_dropped,
        views=tuple(results),
        band=(float(band[0]), float(band[1])),
        png=str(png) if png is not None else None,
    )
    if png is not None:
        plot_heap(measurement, pos, rad, axis_xy, base_z, png, title=title)
    return measurement


def _pixel_size(rel_xy, radii) -> float:
    """Column width: the smallest radius over :data:`PIXELS_PER_RADIUS`, coarser if the
    heap would need more than :data:`MAX_COLUMNS` columns."""
    span = 2 * np.hypot(rel_xy[:, 0], rel_xy[:, 1]).max() + 4 * radii.max()
    return max(radii.min() / PIXELS_PER_RADIUS, span / MAX_COLUMNS)


def _pairs(u, r, pixel, pad=0.0):
    """(sphere index, column index, column centre) of every column a disc covers."""
    lo = np.floor((u - r - pad) / pixel).astype(np.int64)
    hi = np.floor((u + r + pad) / pixel).astype(np.int64)
    count = hi - lo + 1
    idx = np.repeat(np.arange(u.size), count)
    col = lo[idx] + (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count))
    return idx, col, (col + 0.5) * pixel


def heap_members(positions, radii, base_z=0.0, gap=0.1) -> np.ndarray:
    """Mask of the particles that form the heap: the largest cluster of particles in
    contact (gap below ``gap`` times the smaller radius) among the clusters that
    touch the base. Particles in flight or rolled away are separate clusters."""
    tree = cKDTree(positions)
    pairs = tree.query_pairs(2 * (1 + gap) * radii.max(), output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    dist = np.linalg.norm(positions[i] - positions[j], axis=1)
    touch = dist <= radii[i] + radii[j] + gap * np.minimum(radii[i], radii[j])
    n = positions.shape[0]
    graph = coo_matrix((np.ones(int(touch.sum())), (i[touch], j[touch])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    on_base = positions[:, 2] - radii <= base_z + gap * radii
    if not on_base.any():
        on_base = np.ones(n, dtype=bool)
    sizes = np.bincount(label, weights=radii**3)
    standing = np.unique(label[on_base])
    return label == standing[np.argmax(sizes[standing])]


def _envelope(u, z, r, pixel):
    """Exact upper envelope of the discs at the centres of the pixel columns."""
    by_u = np.argsort(u)
    u, z, r = u[by_u], z[by_u], r[by_u]
    idx, col, uc = _pairs(u, r, pixel)
    top = z[idx] + np.sqrt(np.maximum(r[idx] ** 2 - (uc - u[idx]) ** 2, 0.0))
    order = np.argsort(col, kind="stable")  # nearly sorted already: fast
    col, top = col[order], top[order]
    starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
    return (col[starts] + 0.5) * pixel, np.maximum.reduceat(top, starts)


def upper_envelope(u, z, r, pixel):
    """The top outline of discs at ``u`` (projected position), ``z`` (height), radii
    ``r``: ``(column centres, top height)`` at columns ``pixel`` wide."""
    return _envelope(u, z, r, pixel)


def silhouette(u, z, r, pixel, base_z=0.0):
    """Boolean raster of the projected discs (rows from ``base_z`` up) and its extent
    ``(u_min, u_max, z_min, z_max)``; for pictures."""
    idx, col, uc = _pairs(u, r, pixel)
    half = np.sqrt(np.maximum(r[idx] ** 2 - (uc - u[idx]) ** 2, 0.0))
    row_lo = np.maximum(np.floor((z[idx] - half - base_z) / pixel).astype(np.int64), 0)
    row_hi = np.maximum(np.floor((z[idx] + half - base_z) / pixel).astype(np.int64), row_lo)
    col0 = col.min()
    ncol = int(col.max() - col0 + 1)
    nrow = int(row_hi.max() + 2)
    flat = np.concatenate([row_lo * ncol + (col - col0), (row_hi + 1) * ncol + (col - col0)])
    weight = np.concatenate([np.ones(idx.size), -np.ones(idx.size)])
    diff = np.bincount(flat, weights=weight, minlength=(nrow + 1) * ncol).reshape(nrow + 1, ncol)
    mask = np.cumsum(diff, axis=0)[:nrow] > 0.5
    extent = (col0 * pixel, (col0 + ncol) * pixel, base_z, base_z + nrow * pixel)
    return mask, extent


def plot_heap(m: HeapMeasurement, positions, radii, axis_xy, base_z, path, title=None) -> None:
    """Write the first view's silhouette with the fitted flank lines (cf. the
    reference paper's Figs. 2 and 7) to ``path`` (PNG)."""
    from matplotlib.figure import Figure

    from demcal.measure.plotting import draw_flanks

    view = m.views[0]
    phi = np.radians(view.view_deg)
    rel = np.asarray(positions)[:, :2] - axis_xy
    u = rel[:, 0] * np.cos(phi) + rel[:, 1] * np.sin(phi)
    pixel = _pixel_size(rel, np.asarray(radii))
    mask, (u0, u1, z0, z1) = silhouette(u, np.asarray(positions)[:, 2], np.asarray(radii), pixel, base_z)
    mm = 1e3
    fig = Figure(figsize=(8, 4.2), dpi=110)
    ax = fig.add_subplot()
    ax.imshow(mask, origin="lower", extent=(u0 * mm, u1 * mm, z0 * mm, z1 * mm), cmap="Greys",
              vmin=0, vmax=1.6, interpolation="nearest")
    ax.axhline(base_z * mm, color="0.3", lw=1)
    draw_flanks(ax, view.fit, scale=mm, base=base_z * mm)
    ax.set_xlabel("u [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_aspect("equal")
    ax.set_title(title or (
        f"angle of repose {m.angle_deg:.2f} ± {m.spread_deg:.2f}° over {len(m.views)} views "
        f"(R² {m.r2:.3f}); atan(2H/D) {m.h_over_d_angle_deg:.1f}°, "
        f"atan(4z/R) {m.com_cone_angle_deg:.1f}°"), fontsize=9)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    from demcal._files import save_figure

    save_figure(fig, path)
