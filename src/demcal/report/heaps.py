"""Pictures of heaps for the report: a simulated heap in 3-D and a lab photo as measured.

* :func:`heap_3d_figure` -- the final spheres of a run (:mod:`demcal.io.spheres`) in an
  orthographic 3-D view: every sphere drawn to scale (its radius in the axes' millimetres),
  coloured by the height of its centre, the axes equally scaled.
* :func:`photo_figure` -- a lab photo with what :func:`demcal.measure.photo.measure_photo`
  found in it: the detected outline, the base line, the band's edge points and the flank
  lines fitted to them (:func:`demcal.measure.plotting.draw_flanks`, as in the simulated
  heap's picture) and the angles; axes in millimetres above the base line when the
  photo's scale is known, else in pixels.

Both return a :class:`matplotlib.figure.Figure`; the report embeds it and writes it at
300 dpi (:class:`demcal.report.html.HtmlReport`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

#: View of the 3-D heap: elevation and azimuth [deg] (matplotlib's convention).
VIEW_ELEVATION_DEG = 28.0
VIEW_AZIMUTH_DEG = -60.0


def heap_3d_figure(spheres, title: str | None = None) -> Figure:
    """The heap's spheres in 3-D, each drawn to scale and coloured by height.

    Parameters
    ----------
    spheres : :class:`demcal.io.spheres.Spheres`
        Centres and radii [m] and the base plate's height [m] (and radius: its rim is
        drawn when it lies inside the heap's square footprint).
    title : figure title (default: how many spheres are shown).

    The spheres drawn are those of the heap that the measurement measures
    (:func:`demcal.measure.heap.heap_members`); particles that rolled away are counted
    in the title, not drawn, so they do not shrink the heap to a dot. The projection is
    orthographic with equal scaling on the three axes, so one millimetre is the same
    length on screen in every direction; each sphere's marker is the diameter of the
    sphere at that scale.
    """
    from matplotlib.ticker import MaxNLocator
    from mpl_toolkits.mplot3d import proj3d

    from demcal.measure.heap import heap_members

    mm = 1e3
    pos = np.asarray(spheres.positions, dtype=float)
    rad = np.asarray(spheres.radii, dtype=float)
    base = float(spheres.base_z)
    keep = heap_members(pos, rad, base) if len(pos) > 1 else np.ones(len(pos), dtype=bool)
    away = int(np.count_nonzero(~keep))
    pos, rad, base = pos[keep] * mm, rad[keep] * mm, base * mm
    fig = Figure(figsize=(6.4, 4.6), dpi=110)
    ax = fig.add_axes((0.0, 0.0, 0.8, 0.88), projection="3d")
    cax = fig.add_axes((0.87, 0.2, 0.025, 0.55))
    ax.set_proj_type("ortho")
    if len(pos):
        lo = (pos - rad[:, None]).min(axis=0)
        hi = (pos + rad[:, None]).max(axis=0)
    else:
        lo, hi = np.zeros(3), np.ones(3)
    lo[2] = min(lo[2], base)
    centre, half = 0.5 * (lo[:2] + hi[:2]), 0.5 * float(np.max(hi[:2] - lo[:2]))
    lo[:2], hi[:2] = centre - half, centre + half  # a square footprint
    hi[2] = max(hi[2], lo[2] + 1e-3)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
    ax.set_box_aspect(tuple(hi - lo), zoom=0.88)  # equal scaling: the box has the data's proportions
    ax.view_init(elev=VIEW_ELEVATION_DEG, azim=VIEW_AZIMUTH_DEG)
    if spheres.plate_radius is not None and float(spheres.plate_radius) * mm <= half:
        t = np.linspace(0.0, 2.0 * np.pi, 181)
        r = float(spheres.plate_radius) * mm
        ax.plot(r * np.cos(t), r * np.sin(t), np.full_like(t, base), color="0.45", lw=0.8)
    # points per millimetre on screen: project a horizontal segment across the view
    fig.draw_without_rendering()
    azim = np.radians(VIEW_AZIMUTH_DEG)
    a = np.array([centre[0], centre[1], lo[2]])
    b = a + 2.0 * half * np.array([-np.sin(azim), np.cos(azim), 0.0])
    ends = [ax.transData.transform(proj3d.proj_transform(*p, ax.get_proj())[:2]) for p in (a, b)]
    points_per_mm = float(np.hypot(*(ends[1] - ends[0]))) / (2.0 * half) * 72.0 / fig.dpi
    scatter = ax.scatter(pos[:, 0], pos[:, 1], pos[:, 2], s=(2.0 * rad * points_per_mm) ** 2,
                         c=pos[:, 2] - base, cmap="viridis", depthshade=False,
                         edgecolors=(0.0, 0.0, 0.0, 0.35), linewidths=0.2)
    fig.colorbar(scatter, cax=cax, label="height of sphere centre above the plate [mm]")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.zaxis.set_major_locator(MaxNLocator(4))
    shown = f"{len(pos)} spheres of the heap" + (f" ({away} off the heap, not shown)" if away else "")
    ax.set_title(f"{title}\n{shown}" if title else shown, fontsize=9)
    return fig


def photo_figure(image, measurement, roi=None, mm_per_px: float | None = None,
                 title: str | None = None) -> Figure:
    """A lab photo with its measurement drawn on it.

    Parameters
    ----------
    image : (rows, cols, 3) RGB photo (:func:`demcal.measure.photo.load_photo`).
    measurement : :class:`demcal.measure.photo.PhotoMeasurement` of that photo, made
        with ``roi`` and ``mm_per_px``.
    roi : the region of interest ``(x0, y0, x1, y1)`` [px] it was measured in.
    mm_per_px : the photo's scale [mm/px]; axes in pixels without it.
    title : figure title (default: the photo's name and the angles).

    The axes are ``x`` along the photo and the height above the detected base line, in
    mm (or px), the image drawn to the same scale on both.
    """
    from demcal.measure.plotting import draw_flanks

    m = measurement
    scale = float(mm_per_px) if mm_per_px else 1.0
    unit = "mm" if mm_per_px else "px"
    rows, cols = image.shape[:2]
    base = float(m.base_row)
    fig = Figure(figsize=(6.4, 5.0), dpi=110)
    ax = fig.add_subplot()
    ax.imshow(image, origin="upper", interpolation="antialiased",
              extent=(-0.5 * scale, (cols - 0.5) * scale, (base - rows + 0.5) * scale, (base + 0.5) * scale))
    if m.outline is not None:
        x, row = m.outline
        ax.plot(np.asarray(x) * scale, (base - np.asarray(row)) * scale, "-", color="yellow", lw=0.7,
                label="detected outline")
    ax.axhline(0.0, color="yellow", lw=0.8, ls="--", label="base line")
    x0 = 0 if roi is None else int(round(float(roi[0])))
    draw_flanks(ax, m.fit, scale=1.0, x_origin=x0 * scale)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    ax.set_xlabel(f"x along the photo [{unit}]")
    ax.set_ylabel(f"height above the base line [{unit}]")
    ax.set_title(title or (f"{Path(m.photo).name}: angle of repose {m.angle_deg:.2f}° (left {m.left_deg:.2f}°, "
                           f"right {m.right_deg:.2f}°), R² {m.r2:.3f}"), fontsize=9)
    fig.tight_layout()
    return fig


def lab_photo_figure(path, photos=None, title: str | None = None) -> Figure:
    """:func:`photo_figure` of the photo file ``path``, measured by
    :func:`demcal.measure.photo.measure_photo` as the lab targets are: with the region,
    base line and scale of the lab record's ``photos`` (a
    :class:`demcal.measure.lab.PhotoSet`; defaults without one).

    Raises
    ------
    DataError
        The photo cannot be read or measured (the sentence names it and why).
    """
    from demcal.measure.photo import load_photo, measure_photo

    roi = photos.roi if photos is not None else None
    mm_per_px = photos.mm_per_px if photos is not None else None
    m = measure_photo(path, roi=roi, base_y=photos.base_y if photos is not None else None, mm_per_px=mm_per_px)
    return photo_figure(load_photo(path), m, roi, mm_per_px, title)
