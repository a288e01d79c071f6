"""One simulated heap, measured two ways: the silhouette flanks (what the repose benches
report) and the photo path of ``demcal measure`` applied to rendered pictures of it.

The lab measured its heaps from photos (paper §2.1: camera, Matlab edge extraction, a
least-squares fit of the boundary points). The benches fit the flanks of the heap's exact
silhouette. This script tells what the difference of method is worth on demcal's own heaps:
for each ``heap_spheres.npz`` (written by ``demcal bench repose-funnel --out DIR``) it
renders ``--views`` pictures around the heap (:func:`demcal.measure.render.render_heap`:
orthographic, shaded spheres before a light wall, a grey plate) and measures each with
:func:`demcal.measure.photo.measure_photo`, and measures the silhouette with
:func:`demcal.measure.heap.measure_heap` in the same views and flank band.

    python benchmarks/heap_photo_path.py DIR [DIR ...] [--views 8] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def measure_both(folder: Path, views: int, band=(0.1, 0.9)) -> dict:
    from demcal.io.spheres import SPHERES_FILE, read_spheres
    from demcal.measure.heap import measure_heap
    from demcal.measure.photo import measure_photo
    from demcal.measure.render import render_heap

    sph = read_spheres(folder / SPHERES_FILE)
    plate = None if not np.isfinite(sph.plate_radius) else sph.plate_radius
    outline = measure_heap(sph.positions, sph.radii, base_z=sph.base_z, axis_xy=(0.0, 0.0), views=views,
                           band=band, plate_radius=plate)
    # the particles that fell off the plate lie below it: out of the picture, as in the lab
    on = sph.positions[:, 2] >= sph.base_z
    photo = []
    for k in range(views):
        view = 180.0 * k / views
        picture = render_heap(sph.positions[on], sph.radii[on], view_deg=view, base_z=sph.base_z,
                              axis_xy=(0.0, 0.0), seed=k)
        photo.append(measure_photo(picture.image, mm_per_px=picture.mm_per_px, band=band).angle_deg)
    return {"heap": str(folder), "views": views, "band": list(band),
            "silhouette_deg": float(outline.angle_deg), "photo_deg": float(np.mean(photo)),
            "photo_views_deg": [float(a) for a in photo],
            "photo_minus_silhouette_deg": float(np.mean(photo) - outline.angle_deg)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--views", type=int, default=8)
    ap.add_argument("--json", action="store_true", help="one JSON line per heap")
    args = ap.parse_args(argv)
    for folder in args.folders:
        row = measure_both(folder, args.views)
        if args.json:
            print(json.dumps(row), flush=True)
        else:
            print(f"{folder}: silhouette {row['silhouette_deg']:.2f} deg, photo path {row['photo_deg']:.2f} deg "
                  f"({row['photo_minus_silhouette_deg']:+.2f})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
