"""Angle of repose from lab photos of heaps.

One photo is measured in these steps (all automatic; ``roi`` and ``base_y`` help where
automation is not enough):

1. **Load** with :func:`skimage.io.imread`; grey or RGB(A), any bit depth; scaled to 0..1.
2. **Region of interest** ``(x0, y0, x1, y1)`` [px], if given: everything else is ignored.
3. **Channel**: of luminance, red, green, blue and chroma (``max - min`` of RGB, which
   separates a coloured heap from a grey wall and its shadow), each smoothed by a
   Gaussian of 1 px, the one whose Otsu threshold separates best (largest ratio of
   between-class to total variance; Otsu 1979, doi:10.1109/TSMC.1979.4310076) among
   those whose two classes differ by at least :data:`MIN_CONTRAST`.
   Before the choice each channel is divided by its lighting, a quadratic surface in
   (x, y) fitted robustly to the whole photo (the heap and plate are rejected as
   outliers), which removes uneven lighting and vignetting.
4. **Lighting again**: the surface is refitted to the background pixels of this first
   segmentation only, divided out, and Otsu is applied again.
5. **Polarity**: the class that fills the top rows of the image is the background, so a
   front-lit heap darker than the wall, a back-lit black silhouette and a light heap on
   a dark cloth are all handled.
6. **Clean-up**: a morphological opening (5 x 5 px square) removes noise and specks; the
   largest connected piece that reaches the base line is the heap (with its plate).
7. **Outline**: the topmost heap pixel of every column, refined to a fraction of a
   pixel where the smoothed channel crosses the threshold.
8. **Base line**: row ``base_y`` if given; otherwise the lowest point of the outline
   away from the photo's side edges -- the top of the plate or table the heap stands on,
   or the heap's foot if the plate is not seen.
9. **Fit**: :func:`demcal.measure.flank.fit_outline`, the same fit as for simulated
   heaps, between 10 % and 90 % of the heap height by default.

A slightly tilted camera tilts the base line too: the left flank reads steeper by the
tilt and the right flank shallower by the same amount, so the **mean** of the two -- the
reported angle -- does not depend on a small tilt. No tilt correction is applied;
``(left - right) / 2`` estimates the tilt for a symmetric heap.

Lengths are converted with ``mm_per_px`` (the angle does not depend on it).
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import ndimage

from demcal.errors import DataError
from demcal.measure.flank import DEFAULT_BAND, OutlineFit, fit_outline
from demcal.measure.lab import Summary, summarize

#: Outliers of a batch: modified z-score ``0.6745 |x - median| / MAD`` above this
#: (Iglewicz and Hoaglin 1993, "How to Detect and Handle Outliers", ASQC).
OUTLIER_Z = 3.5
#: A channel whose Otsu classes differ by less than this (intensity 0..1) is not used
#: while another one separates the heap by more.
MIN_CONTRAST = 0.08
_SMOOTH_PX = 1.0
_OPEN_RADIUS = 2


@dataclass(frozen=True)
class PhotoMeasurement:
    """Angle of repose from one photo.

    Attributes
    ----------
    photo : file name (or ``"<array>"``).
    angle_deg, left_deg, right_deg : mean, left and right flank angles [deg].
    r2 : mean R^2 of the two flank fits.
    height, width : heap height and base width, in ``unit``.
    unit : ``"mm"`` with ``mm_per_px``, else ``"px"``.
    base_row : image row of the base line [px].
    channel, polarity : the channel used, and whether the heap lies ``"below"`` or
        ``"above"`` the threshold in it (a dark or a bright heap).
    fit : the flank fits, in ``unit`` with z up from the base line and x from the
        region's left edge.
    png : the annotated picture, if written.
    """

    photo: str
    angle_deg: float
    left_deg: float
    right_deg: float
    r2: float
    height: float
    width: float
    unit: str
    base_row: float
    channel: str
    polarity: str
    fit: OutlineFit = field(repr=False)
    png: str | None = None

    def to_dict(self) -> dict:
        return {
            "photo": self.photo,
            "angle_deg": self.angle_deg,
            "left_deg": self.left_deg,
            "right_deg": self.right_deg,
            "r2": self.r2,
            "height": self.height,
            "width": self.width,
            "unit": self.unit,
            "base_row": self.base_row,
            "channel": self.channel,
            "polarity": self.polarity,
            "png": self.png,
        }


def load_photo(path) -> np.ndarray:
    """Read an image as float RGB in 0..1, shape (rows, cols, 3).

    Raises
    ------
    DataError
        Missing or unreadable file.
    """
    from skimage import io

    path = Path(path)
    if not path.is_file():
        raise DataError(f"photo '{path}' does not exist; check the path.")
    try:
        image = io.imread(path)
    except Exception as exc:  # skimage/imageio raise many kinds
        raise DataError(f"cannot read photo '{path}' as an image ({type(exc).__name__}); "
                        "use a PNG, JPEG or TIFF file.") from None
    return _as_rgb(image, str(path))


def _as_rgb(image, name) -> np.ndarray:
    image = np.asarray(image)
    if image.dtype.kind not in "uif" or image.ndim not in (2, 3) or min(image.shape[:2]) < 16:
        raise DataError(f"photo '{name}' is not a usable image (shape {image.shape}); "
                        "use a grey or colour picture at least 16 px wide and high.")
    if image.dtype.kind in "ui":
        scale = float(np.iinfo(image.dtype).max)
    else:
        scale = 1.0
    img = image.astype(float) / scale
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    elif img.shape[2] == 4:
        img = img[..., :3]
    elif img.shape[2] == 2:
        img = np.repeat(img[..., :1], 3, axis=2)
    elif img.shape[2] != 3:
        raise DataError(f"photo '{name}' has {img.shape[2]} channels; use a grey or RGB picture.")
    return img


def _otsu(values: np.ndarray) -> tuple[float, float, float]:
    """Otsu threshold of ``values``, its separability (between-class over total
    variance) and the difference of the two class means."""
    hist, edges = np.histogram(values, bins=256)
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(hist).astype(float)
    w1 = w0[-1] - w0
    m = np.cumsum(hist * centres)
    mu0 = m / np.maximum(w0, 1)
    mu1 = (m[-1] - m) / np.maximum(w1, 1)
    between = w0 * w1 * (mu0 - mu1) ** 2 / w0[-1] ** 2
    k = int(np.argmax(between[:-1]))
    total = values.var()
    eta = float(between[k] / total) if total > 0 else 0.0
    return float(edges[k + 1]), eta, float(mu1[k] - mu0[k])


def _channels(img: np.ndarray) -> dict[str, np.ndarray]:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    lum = 0.2125 * r + 0.7154 * g + 0.0721 * b
    chroma = np.maximum(np.maximum(r, g), b) - np.minimum(np.minimum(r, g), b)
    return {"luminance": lum, "red": r, "green": g, "blue": b, "chroma": chroma}


def _background_model(values: np.ndarray, use: np.ndarray | None = None,
                      step: int = 10, rounds: int = 3) -> np.ndarray:
    """Smooth lighting: a quadratic surface in (x, y) fitted to ``values`` on a grid of
    every ``step``-th pixel, where ``use`` is true, refitted ``rounds`` times without
    the points farther than 2.5 robust sd from it (the heap, the plate, shadows)."""
    rows, cols = values.shape
    gy = (np.arange(0, rows, step) / rows - 0.5)[:, None]
    gx = (np.arange(0, cols, step) / cols - 0.5)[None, :]
    one = np.ones_like(gy * gx)
    design = np.stack([one, gx * one, gy * one, (gx * gx) * one, gx * gy, (gy * gy) * one], -1)
    design = design.reshape(-1, 6)
    target = values[::step, ::step].ravel()
    keep = np.ones(target.size, bool) if use is None else use[::step, ::step].ravel().copy()
    for _ in range(rounds):
        if keep.sum() < 12:
            break
        coef = np.linalg.lstsq(design[keep], target[keep], rcond=None)[0]
        if use is not None:
            break
        resid = target - design @ coef
        mad = np.median(np.abs(resid - np.median(resid)))
        keep = np.abs(resid - np.median(resid)) <= 2.5 * 1.4826 * max(mad, 1e-6)
    gy = (np.arange(rows) / rows - 0.5)[:, None]
    gx = (np.arange(cols) / cols - 0.5)[None, :]
    return (coef[0] + coef[1] * gx + coef[3] * gx * gx) + (coef[2] * gy + coef[5] * gy * gy) \
        + coef[4] * gx * gy


def _flatten(values: np.ndarray, use: np.ndarray | None = None):
    """``values`` divided by their lighting model, and the model's median (the scale
    of the flattened values); unchanged where the model is not positive."""
    model = _background_model(values, use)
    if np.all(model > 1e-3):
        return values / model, float(np.median(model))
    return values, 1.0


def segment(img: np.ndarray, top_rows: int | None = None):
    """Foreground mask of a heap photo (before choosing the heap piece).

    Raises :class:`DataError` when no channel has :data:`MIN_CONTRAST`.
    Returns ``(mask, channel_values, threshold, channel_name, polarity)``: the
    foreground is ``channel_values < threshold`` when ``polarity`` is ``"below"`` and
    ``>`` when ``"above"`` (``channel_values`` is the smoothed, lighting-flattened
    channel).
    """
    rows = img.shape[0]
    top_rows = top_rows or max(2, rows // 30)
    best = None
    channels = _channels(img)
    for name, values in channels.items():
        # the choice is made at half resolution
        small = ndimage.gaussian_filter(values[::2, ::2], _SMOOTH_PX)
        flat, scale = _flatten(small)
        t, eta, contrast = _otsu(flat.ravel())
        score = (contrast * scale >= MIN_CONTRAST, eta)  # a faint channel (chroma of grey) loses
        if best is None or score > best[1]:
            best = (name, score, contrast * scale)
    name, _, contrast = best
    smooth = ndimage.gaussian_filter(channels[name], _SMOOTH_PX)
    if contrast < MIN_CONTRAST:
        raise DataError(f"nothing stands out from the background (contrast {contrast:.3f} "
                        f"< {MIN_CONTRAST} in every channel)")
    values = _flatten(smooth)[0]
    t = _otsu(values[::2, ::2].ravel())[0]
    below = np.mean(values[:top_rows] > t) > 0.5  # the background fills the top rows
    fg = values < t if below else values > t
    # lighting again, now fitted to the background class only, and a final threshold
    bg = ndimage.maximum_filter(fg.view(np.uint8), size=7) == 0
    if bg.sum() > 100:
        values = _flatten(smooth, bg)[0]
        t = _otsu(values[::2, ::2].ravel())[0]
        below = np.mean(values[:top_rows] > t) > 0.5
        fg = values < t if below else values > t
    return fg, values, t, name, "below" if below else "above"


def measure_photo(photo, roi=None, base_y: float | None = None, mm_per_px: float | None = None,
                  band: tuple[float, float] = DEFAULT_BAND, png: str | Path | None = None,
                  name: str | None = None) -> PhotoMeasurement:
    """Measure the angle of repose in one photo.

    Parameters
    ----------
    photo : path of an image file, or an image array (grey or RGB).
    roi : ``(x0, y0, x1, y1)`` region of interest [px] (x = column, y = row).
    base_y : row of the base line [px], in the full photo.
    mm_per_px : scale [mm/px] for heights and widths.
    band : height fractions between which each flank is fitted.
    png : write the annotated photo here.
    name : name to report (default: the file name).

    Raises
    ------
    DataError
        Unreadable file, no heap, a heap touching the photo's (or region's) border, or
        flanks that cannot be fitted; the sentence names the photo.
    """
    if isinstance(photo, (str, os.PathLike)):
        name = name or str(photo)
        full = load_photo(photo)
    else:
        name = name or "<array>"
        full = _as_rgb(photo, name)
    x0, y0, x1, y1 = _check_roi(roi, full.shape, name)
    img = full[y0:y1, x0:x1]
    rows, cols = img.shape[:2]
    if base_y is not None and not y0 < base_y <= y1:
        raise DataError(f"base line row {base_y} is outside the photo or region of interest "
                        f"(rows {y0}..{y1}) of '{name}'.")
    try:
        fg, values, t, channel, polarity = segment(img)
    except DataError as exc:
        raise DataError(f"no heap found in photo '{name}': {exc}.") from None
    base_local = None if base_y is None else float(base_y) - y0
    if base_local is not None:
        fg[int(np.ceil(base_local)) + 1:] = False
    size = 2 * _OPEN_RADIUS + 1  # opening with a square: separable, fast
    fg = ndimage.maximum_filter(ndimage.minimum_filter(fg.view(np.uint8), size), size).astype(bool)
    labels, n = ndimage.label(fg, structure=np.ones((3, 3)))
    if n == 0:
        raise DataError(f"no heap found in photo '{name}': nothing stands out from the background.")
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    if base_local is not None:
        near = labels[max(int(base_local) - 3, 0):int(base_local) + 1]
        candidates = np.unique(near[near > 0])
        if candidates.size == 0:
            raise DataError(f"no heap found on the base line (row {base_y}) of photo '{name}'; "
                            "check --base-y.")
        heap_label = candidates[np.argmax(sizes[candidates])]
    else:
        heap_label = int(np.argmax(sizes))
    if sizes[heap_label] < 0.002 * rows * cols:
        raise DataError(f"no heap found in photo '{name}': the largest object covers only "
                        f"{sizes[heap_label]} px.")
    heap = labels == heap_label
    if heap[0].any():
        raise DataError(f"the heap touches the top border of photo '{name}'; "
                        "frame the whole heap or give a larger --roi.")

    # outline: first heap row of each column, refined where the channel crosses t
    has = heap.any(axis=0)
    col = np.flatnonzero(has)
    row = np.argmax(heap, axis=0)[has].astype(float)
    r = row.astype(int)
    above = np.maximum(r - 1, 0)
    v0, v1 = values[above, col], values[r, col]
    ok = (r > 0) & ((v0 - t) * (v1 - t) < 0)
    frac = np.where(ok, (t - v0) / np.where(ok, v1 - v0, 1.0), 0.5)
    edge = r - 1 + frac
    if base_local is None:
        inner = (col >= col[0] + 0.02 * cols) & (col <= col[-1] - 0.02 * cols)
        base_local = float(edge[inner].max() if inner.any() else edge.max())
    height_px = base_local - edge.min()
    if height_px < max(10.0, 0.03 * rows):
        raise DataError(f"no heap found in photo '{name}': the tallest object is only "
                        f"{height_px:.0f} px high.")
    low = base_local - band[0] * height_px
    for border, c in (("left", 0), ("right", cols - 1)):
        at = edge[col == c]
        if at.size and at[0] < low:
            raise DataError(f"the heap touches the {border} border of photo '{name}'; "
                            "frame the whole heap or give a larger --roi.")
    scale = mm_per_px or 1.0
    try:
        fit = fit_outline(col * scale, (base_local - edge) * scale, base_z=0.0, band=band)
    except DataError as exc:
        raise DataError(f"photo '{name}': {exc}") from None
    standing = edge < base_local - 0.5
    width_px = float(np.ptp(col[standing]) + 1) if standing.any() else 0.0
    m = PhotoMeasurement(
        photo=name,
        angle_deg=fit.angle_deg,
        left_deg=fit.left.angle_deg,
        right_deg=fit.right.angle_deg,
        r2=fit.r2,
        height=float(height_px * scale),
        width=width_px * scale,
        unit="mm" if mm_per_px else "px",
        base_row=float(base_local + y0),
        channel=channel,
        polarity=polarity,
        fit=fit,
        png=str(png) if png is not None else None,
    )
    if png is not None:
        plot_photo(full, m, (x0, y0, x1, y1), scale, png)
    return m


def _check_roi(roi, shape, name):
    rows, cols = shape[:2]
    if roi is None:
        return 0, 0, cols, rows
    try:
        x0, y0, x1, y1 = (int(round(float(v))) for v in roi)
    except (TypeError, ValueError):
        raise DataError(f"region of interest {roi!r} must be four numbers x0,y0,x1,y1 [px].") from None
    if not (0 <= x0 < x1 <= cols and 0 <= y0 < y1 <= rows) or x1 - x0 < 16 or y1 - y0 < 16:
        raise DataError(f"region of interest {x0},{y0},{x1},{y1} does not fit photo '{name}' "
                        f"({cols} x {rows} px); give x0 < x1 <= {cols} and y0 < y1 <= {rows}.")
    return x0, y0, x1, y1


def plot_photo(full: np.ndarray, m: PhotoMeasurement, roi, scale: float, path) -> None:
    """Write the photo with the base line (yellow), the region of interest (yellow box),
    the fitted edge points (blue left, red right; rejected ones orange) and the fitted
    lines from the base to the apex height. Drawn straight into the pixels, which is
    fast; the angles are in the table and the JSON."""
    from PIL import Image
    from skimage.draw import line, rectangle_perimeter

    img = (np.clip(full, 0, 1) * 255).astype(np.uint8).copy()
    rows, cols = img.shape[:2]
    x0, y0, x1, y1 = roi
    yellow, orange = (255, 220, 0), (255, 140, 0)
    if (x0, y0, x1, y1) != (0, 0, cols, rows):
        rr, cc = rectangle_perimeter((y0, x0), (y1 - 1, x1 - 1), shape=img.shape[:2])
        img[rr, cc] = yellow
    b = int(round(m.base_row))
    if 0 <= b < rows:
        img[b, ::4] = yellow
    for flank, colour in ((m.fit.left, (40, 110, 255)), (m.fit.right, (255, 40, 40))):
        px = np.round(x0 + flank.x / scale).astype(int)
        pz = np.round(m.base_row - flank.z / scale).astype(int)
        ok = (px >= 0) & (px < cols) & (pz >= 0) & (pz < rows)
        img[pz[ok & flank.inlier], px[ok & flank.inlier]] = colour
        img[pz[ok & ~flank.inlier], px[ok & ~flank.inlier]] = orange
        zs = np.array([0.0, m.fit.height])
        xs = (zs - flank.intercept) / flank.slope if flank.slope else flank.x[[0, -1]]
        c = np.round(x0 + xs / scale).astype(int)
        r = np.round(m.base_row - zs / scale).astype(int)
        for dr in (-1, 0, 1):
            rr, cc = line(r[0] + dr, c[0], r[1] + dr, c[1])
            ok = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
            img[rr[ok], cc[ok]] = colour
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(path, format="PNG", compress_level=1)  # level 6 costs ~1 s


@dataclass(frozen=True)
class PhotoBatch:
    """Many photos of one sample.

    Attributes
    ----------
    measurements : the photos that could be measured, in the order given.
    failures : ``(photo, sentence)`` of each photo that could not.
    table : one row per photo (failed ones with their error), column ``outlier``
        flags angles whose modified z-score exceeds :data:`OUTLIER_Z`.
    summary : mean, sd, n and 95 % CI of the angles of all measured photos
        (outliers flagged, not removed).
    """

    measurements: tuple[PhotoMeasurement, ...]
    failures: tuple[tuple[str, str], ...]
    table: pd.DataFrame
    summary: Summary | None

    def to_dict(self) -> dict:
        records = self.table.replace({np.nan: None}).to_dict(orient="records")
        return {
            "photos": records,
            "summary": None if self.summary is None else {
                **self.summary.to_dict(),
                "outliers": [r["photo"] for r in records if r.get("outlier")],
                "failed": [p for p, _ in self.failures],
            },
        }


def flag_outliers(values, z: float = OUTLIER_Z) -> np.ndarray:
    """Modified z-score outliers (Iglewicz and Hoaglin 1993): ``0.6745 |x - median|
    / MAD > z``; nothing is flagged when the MAD is zero."""
    values = np.asarray(values, dtype=float)
    if values.size < 3:
        return np.zeros(values.size, dtype=bool)
    mad = np.median(np.abs(values - np.median(values)))
    if mad == 0:
        return np.zeros(values.size, dtype=bool)
    return 0.6745 * np.abs(values - np.median(values)) / mad > z


def _measure_one(args):
    path, kwargs = args
    try:
        return measure_photo(path, **kwargs)
    except DataError as exc:
        return str(exc)


def measure_photos(photos, roi=None, base_y=None, mm_per_px=None, band=DEFAULT_BAND,
                   out_dir: str | Path | None = None, workers: int = 1) -> PhotoBatch:
    """Measure a batch of photos; a bad photo is reported and the batch goes on.

    ``out_dir`` receives one annotated PNG per photo (``<stem>.png``). ``workers > 1``
    measures photos in that many processes.
    """
    photos = [str(p) for p in photos]
    jobs = []
    for p in photos:
        kw = {"roi": roi, "base_y": base_y, "mm_per_px": mm_per_px, "band": band}
        if out_dir is not None:
            kw["png"] = str(Path(out_dir) / f"{Path(p).stem}.png")
        jobs.append((p, kw))
    if workers > 1 and len(jobs) > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            results = list(pool.map(_measure_one, jobs))
    else:
        results = [_measure_one(j) for j in jobs]
    good = tuple(r for r in results if isinstance(r, PhotoMeasurement))
    failures = tuple((p, r) for p, r in zip(photos, results) if isinstance(r, str))
    rows = []
    for p, r in zip(photos, results):
        if isinstance(r, PhotoMeasurement):
            rows.append({"photo": p, "angle_deg": r.angle_deg, "left_deg": r.left_deg,
                         "right_deg": r.right_deg, "r2": r.r2, "height": r.height,
                         "unit": r.unit, "png": r.png, "error": None})
        else:
            rows.append({"photo": p, "angle_deg": np.nan, "left_deg": np.nan,
                         "right_deg": np.nan, "r2": np.nan, "height": np.nan,
                         "unit": None, "png": None, "error": r})
    table = pd.DataFrame(rows)
    measured = table["error"].isna().to_numpy()
    outlier = np.zeros(len(table), dtype=bool)
    outlier[measured] = flag_outliers(table.loc[measured, "angle_deg"])
    table["outlier"] = outlier
    summary = summarize([m.angle_deg for m in good]) if good else None
    return PhotoBatch(good, failures, table, summary)
