"""Angle of repose from lab photos of heaps.

One photo is measured in these steps (all automatic; ``roi`` and ``base_y`` help where
automation is not enough):

1. **Load**: 8-bit PNG and JPEG with Pillow, other files with :func:`skimage.io.imread`;
   grey or RGB(A), any bit depth; intensities relative to the full scale of the type.
2. **Region of interest** ``(x0, y0, x1, y1)`` [px], if given: everything else is ignored.
3. **Channel**: of luminance, red, green, blue and chroma (``max - min`` of RGB, which
   separates a coloured heap from a grey wall and its shadow), the one whose Otsu
   threshold separates best (largest ratio of between-class to total variance; Otsu
   1979, doi:10.1109/TSMC.1979.4310076) among those whose two classes differ by at least
   :data:`MIN_CONTRAST`. The choice is made on a thumbnail of block means (about
   :data:`_THUMB_PX` px on the short side, e.g. 4 x 4 px blocks of a 800 x 600 photo),
   which also smooths the noise.
   Before the choice each channel is divided by its lighting, a quadratic surface in
   (x, y) fitted robustly to the thumbnail (the heap and plate are rejected as
   outliers), which removes uneven lighting and vignetting.
4. **Lighting again**: the surface is refitted to the background blocks of the
   thumbnail's segmentation only; the chosen channel at full resolution, smoothed by a
   Gaussian of 1 px, is divided by it and Otsu is applied again.
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
10. **Check**: a fit whose mean R² (of the two flanks) is below :data:`MIN_R2` did not
    find a heap's straight flanks (a picture of noise reads about 0.4 to 0.9): the
    photo is an error, not an angle.

A slightly tilted camera tilts the base line too: the left flank reads steeper by the
tilt and the right flank shallower by the same amount, so the **mean** of the two -- the
reported angle -- does not depend on a small tilt. No tilt correction is applied;
``(left - right) / 2`` estimates the tilt for a symmetric heap.

Lengths are converted with ``mm_per_px`` (the angle does not depend on it).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from scipy import ndimage

from demcal.errors import ConfigError, DataError
from demcal.measure.flank import DEFAULT_BAND, OutlineFit, fit_outline
from demcal.measure.summary import Summary, summarize

#: Outliers of a batch: modified z-score ``0.6745 |x - median| / MAD`` above this
#: (Iglewicz and Hoaglin 1993, "How to Detect and Handle Outliers", ASQC).
OUTLIER_Z = 3.5
#: A channel whose Otsu classes differ by less than this (intensity 0..1) is not used
#: while another one separates the heap by more.
MIN_CONTRAST = 0.08
#: A photo (or region of interest) whose block means (the thumbnail of step 3) span less
#: than this (intensity 0..1) in red, green and blue alike is uniform: blank, fully
#: over- or under-exposed, or a region with no heap in it.
UNIFORM_SPREAD = MIN_CONTRAST / 2
#: A photo whose two flank fits have a mean R² below this is refused (``--min-r2``): a
#: heap's flank is a straight line over most of its height, so real and synthetic heaps
#: fit with R² above 0.98 (``benchmarks/photos.py``: 0.998 and more), while the outline
#: traced in a picture of random noise fits with about 0.4 to 0.9.
MIN_R2 = 0.9
#: The most pixels demcal decodes of one photo: 80 megapixels, above a lab camera's 12 to 60
#: and below the 89 at which Pillow suspects a decompression bomb; a larger image (or a
#: small file that declares a huge one) is refused before it is decoded.
MAX_PHOTO_PIXELS = 80_000_000
#: Annotated pictures of a batch are named ``<stem><FIT_SUFFIX>`` (never the photo's own
#: name, so a picture written next to its photo cannot replace it).
FIT_SUFFIX = "_fit.png"
#: Columns of a batch's table (:attr:`PhotoBatch.rows`, ``table.csv``).
TABLE_COLUMNS = ("photo", "angle_deg", "left_deg", "right_deg", "r2", "height", "unit", "png",
                 "error", "outlier")
_SMOOTH_PX = 1.0
#: Luminance weights of linear RGB (ITU-R BT.709, as skimage.color.rgb2gray).
_LUMA = np.array([0.2125, 0.7154, 0.0721])
#: The channel choice and the lighting model use block means down to about this many
#: pixels on the short side.
_THUMB_PX = 150
#: The lighting model is fitted to one block about every this many pixels.
_LIGHT_STEP_PX = 20
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
    outline : the detected outline in the full photo's pixels, ``(columns, rows)``: the
        heap's upper edge in every column it covers, to a fraction of a pixel.
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
    outline: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """Every attribute but ``fit`` and ``outline``."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("fit", "outline")}


def load_photo(path) -> np.ndarray:
    """Read an image as float RGB in 0..1, shape (rows, cols, 3).

    Raises
    ------
    DataError
        Missing or unreadable file.
    """
    return _as_rgb(_read(path), str(path))


def _read(path) -> np.ndarray:
    """The pixels of an image file as stored (8-bit PNG and JPEG straight from Pillow,
    everything else through :func:`skimage.io.imread`, which gives the same arrays);
    files above :data:`demcal._checks.MAX_PHOTO_BYTES` are refused unread."""
    from demcal._checks import MAX_PHOTO_BYTES, format_bytes

    path = Path(path)
    if path.is_dir():
        raise DataError(f"'{path}' is a folder, not a photo; give the photos in it, e.g. "
                        f"{Path(path) / ('*' + _common_suffix(path))}.")
    if not path.exists():
        raise DataError(f"photo '{path}' does not exist; check the path.")
    if not path.is_file():
        raise DataError(f"photo '{path}' is not a regular file (a device, pipe or socket); give an image file.")
    if path.stat().st_size > MAX_PHOTO_BYTES:
        raise DataError(f"photo '{path}' holds {format_bytes(path.stat().st_size)}, more than the "
                        f"{format_bytes(MAX_PHOTO_BYTES)} demcal reads for a photo; check that it is the right file.")
    import warnings

    from PIL import Image

    # Pillow warns from 89 megapixels on; every such image is refused below, in one sentence
    warnings.filterwarnings("ignore", category=Image.DecompressionBombWarning)
    try:
        with open(path, "rb") as fh:  # the file's own trouble (permission), apart from its contents'
            try:
                with Image.open(fh) as im:
                    if im.width * im.height > MAX_PHOTO_PIXELS:
                        raise DataError(_too_large(path, im.width * im.height, f"{im.width} x {im.height} px, "))
                    if (im.format in ("PNG", "JPEG") and im.mode in ("L", "LA", "RGB", "RGBA")
                            and getattr(im, "n_frames", 1) == 1):
                        return np.asarray(im)
            except Image.DecompressionBombError as exc:  # over twice Pillow's limit: not opened at all
                found = re.search(r"\((\d+) pixels\)", str(exc))
                raise DataError(_too_large(path, int(found.group(1)) if found else None)) from None
            except MemoryError:
                raise DataError(_too_large(path, None)) from None
            except DataError:
                raise
            except Exception:  # not for Pillow: skimage says what is wrong
                pass
    except OSError as exc:
        reason = "permission denied" if isinstance(exc, PermissionError) else (exc.strerror or str(exc)).lower()
        fix = ("give yourself read access (chmod u+r) or copy the photo" if isinstance(exc, PermissionError)
               else "check the file")
        raise DataError(f"cannot read photo '{path}': {reason}; {fix}.") from None

    from skimage import io

    try:
        with warnings.catch_warnings():
            # imageio tries its plugins in turn on a file it cannot place (an empty one, a
            # text file); the deprecated DICOM plugin warns on the way, which says nothing
            # about the photo: the error below does
            warnings.filterwarnings("ignore", message=".*DICOM.*", category=DeprecationWarning)
            return io.imread(path)
    except MemoryError:
        raise DataError(_too_large(path, None)) from None
    except Exception as exc:  # skimage/imageio raise many kinds
        raise DataError(f"cannot read photo '{path}' as an image ({type(exc).__name__}); "
                        "use a PNG, JPEG or TIFF file.") from None


def check_options(mm_per_px=None, band=DEFAULT_BAND, base_y=None, min_r2: float = MIN_R2) -> None:
    """Refuse, before any photo is read, a scale ``mm_per_px`` that is not a positive
    number [mm/px], a ``band`` that is not two fractions 0 <= low < high <= 1 of the
    heap height, a ``base_y`` row that is not a number >= 0 [px] or a ``min_r2`` outside
    [0, 1) (a :class:`ConfigError` naming the parameter and its range)."""
    if mm_per_px is not None and not (math.isfinite(mm_per_px) and mm_per_px > 0):
        raise ConfigError(f"mm_per_px must be a positive number of mm per pixel, got {mm_per_px}.")
    low, high = (float(b) for b in band)
    if not 0 <= low < high <= 1:
        raise ConfigError(f"the height band ({low:g}, {high:g}) must be two fractions of the heap height with "
                          "0 <= low < high <= 1, e.g. (0.1, 0.9).")
    if base_y is not None and not (math.isfinite(base_y) and base_y >= 0):
        raise ConfigError(f"base_y must be a row of the photo, a number of pixels >= 0, got {base_y}.")
    if not 0 <= min_r2 < 1:
        raise ConfigError(f"min_r2 must lie in [0, 1) (e.g. 0.9), got {min_r2}.")


def _too_large(path, pixels: int | None, size: str = "") -> str:
    """The sentence refusing photo ``path`` of ``pixels`` (``size``: its width x height;
    None: one that did not fit in memory)."""
    held = (f"is {size}{pixels / 1e6:,.0f} megapixels, more than the {MAX_PHOTO_PIXELS / 1e6:.0f} megapixels "
            "demcal reads for a photo" if pixels else "is too large to decode in the memory at hand")
    return f"photo '{path}' {held}; crop it to the heap or scale it down."


def _common_suffix(folder: Path) -> str:
    """The most common image suffix among the first files of ``folder`` (``.jpg`` if none)."""
    import itertools

    counts: dict[str, int] = {}
    try:
        with os.scandir(folder) as entries:
            for entry in itertools.islice(entries, 1000):
                suffix = Path(entry.name).suffix
                if suffix.lower() in (".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp"):
                    counts[suffix] = counts.get(suffix, 0) + 1
    except OSError:
        pass
    return max(counts, key=counts.get) if counts else ".jpg"


def _as_rgb(image, name) -> np.ndarray:
    pixels, full_scale = _pixels(image, name)
    return pixels / full_scale


def _pixels(image, name) -> tuple[np.ndarray, float]:
    """An image as stored, viewed as (rows, cols, 3) (grey repeated, alpha dropped;
    no copy), and the value of full intensity (the dtype's maximum, 1 for floats)."""
    image = np.asarray(image)
    if image.dtype.kind not in "uif" or image.ndim not in (2, 3) or min(image.shape[:2]) < 16:
        raise DataError(f"photo '{name}' is not a usable image (shape {image.shape}); "
                        "use a grey or colour picture at least 16 px wide and high.")
    full_scale = float(np.iinfo(image.dtype).max) if image.dtype.kind in "ui" else 1.0
    if image.ndim == 2:
        image = image[..., None]
    elif image.shape[2] in (2, 4):
        image = image[..., :1] if image.shape[2] == 2 else image[..., :3]
    elif image.shape[2] != 3:
        raise DataError(f"photo '{name}' has {image.shape[2]} channels; use a grey or RGB picture.")
    return np.broadcast_to(image, image.shape[:2] + (3,)), full_scale


def _otsu(values: np.ndarray) -> tuple[float, float, float]:
    """Otsu threshold of ``values`` (:func:`skimage.filters.threshold_otsu`, 256 bins),
    its separability (between-class over total variance, Otsu's eta) and the difference
    of the two class means; ``(max, 0, 0)`` for values that are all (nearly) the same,
    which cannot be split into 256 bins.

    scikit-image returns the centre of the last bin of the lower class; the split it
    chose lies at that bin's upper edge, which is the threshold returned here (the lower
    class is ``values < threshold``, exactly the bins Otsu's criterion put below).
    """
    from skimage.filters import threshold_otsu

    low, high = float(values.min()), float(values.max())
    if not high - low > 1e-6 * max(1.0, abs(high)):  # also false for NaN
        return high, 0.0, 0.0
    centre = float(threshold_otsu(values, nbins=256))
    edges = np.histogram_bin_edges(values, bins=256)  # the bins threshold_otsu used
    t = float(edges[np.searchsorted(edges, centre, side="right")])
    lower = values < t
    n0 = int(np.count_nonzero(lower))
    n1 = values.size - n0
    if n0 == 0 or n1 == 0:
        return t, 0.0, 0.0
    total = float(values.sum(dtype=float))
    mu0 = float(values.sum(where=lower, dtype=float)) / n0
    mu1 = (total - mu0 * n0) / n1
    var = float(values.var())
    eta = n0 * n1 * (mu1 - mu0) ** 2 / values.size ** 2 / var if var > 0 else 0.0
    return t, eta, mu1 - mu0


def _channels(img: np.ndarray, name: str | None = None, full_scale: float = 1.0):
    """The candidate channels (a dict), or only the one named, of RGB pixels of any
    dtype, as floats with full intensity 1 (``full_scale`` in ``img``)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]

    def chroma():  # in the pixels' own dtype, which is fast for 8 bits
        high = np.maximum(r, g)
        np.maximum(high, b, out=high)
        low = np.minimum(r, g)
        np.minimum(low, b, out=low)
        return np.divide(np.subtract(high, low, out=high), full_scale, dtype=float)

    make = {"luminance": lambda: img @ (_LUMA / full_scale),
            "red": lambda: np.divide(r, full_scale, dtype=float),
            "green": lambda: np.divide(g, full_scale, dtype=float),
            "blue": lambda: np.divide(b, full_scale, dtype=float),
            "chroma": chroma}
    if name is not None:
        return make[name]()
    return {key: f() for key, f in make.items()}


def _thumbnail(img: np.ndarray, full_scale: float = 1.0) -> tuple[np.ndarray, int]:
    """Block means of ``f x f`` pixels as floats with full intensity 1, ``f`` chosen so
    that the short side keeps about :data:`_THUMB_PX` pixels; returns them and ``f``."""
    f = max(1, min(img.shape[:2]) // _THUMB_PX)
    if f == 1:
        return img / full_scale, 1
    r, c = img.shape[0] // f * f, img.shape[1] // f * f
    rows = img[0:r:f].astype(float)  # sums of strided slices: far faster than mean(axis=(1, 3))
    for i in range(1, f):
        rows += img[i:r:f]
    out = rows[:, 0:c:f].copy()
    for j in range(1, f):
        out += rows[:, j:c:f]
    return out / (f * f * full_scale), f


def _coords(n: int, f: int, full: int) -> np.ndarray:
    """Normalised positions (-0.5 .. 0.5 over the full image) of the centres of ``n``
    blocks of ``f`` pixels."""
    return (np.arange(n) * f + 0.5 * (f - 1)) / full - 0.5


class _Lighting:
    """Smooth lighting: a quadratic surface in (x, y) over an image of ``shape``,
    fitted to the thumbnail ``values`` (blocks of ``f`` pixels) on every ``step``-th
    block, where ``use`` is true; without ``use`` it is refitted ``rounds`` times
    without the blocks farther than 2.5 robust sd from it (the heap, the plate,
    shadows)."""

    def __init__(self, values, f, shape, use=None, rounds=3):
        step = max(1, round(_LIGHT_STEP_PX / f))
        gy = _coords(values.shape[0], f, shape[0])[::step, None]
        gx = _coords(values.shape[1], f, shape[1])[None, ::step]
        one = np.ones_like(gy * gx)
        design = np.stack([one, gx * one, gy * one, (gx * gx) * one, gx * gy, (gy * gy) * one], -1)
        design = design.reshape(-1, 6)
        target = values[::step, ::step].ravel()
        keep = np.ones(target.size, bool) if use is None else use[::step, ::step].ravel().copy()
        self.coef = None
        for _ in range(rounds):
            if keep.sum() < 12:
                break
            a = design[keep]  # normal equations: six well-scaled columns
            self.coef = np.linalg.solve(a.T @ a, a.T @ target[keep])
            if use is not None:
                break
            resid = target - design @ self.coef
            dev = np.abs(resid - np.median(resid))
            keep = dev <= 2.5 * 1.4826 * max(np.median(dev), 1e-6)
        self.shape = shape

    def at(self, rows: int, cols: int, f: int = 1) -> np.ndarray | None:
        """The model on ``rows x cols`` blocks of ``f`` pixels (``None`` if unfitted)."""
        c = self.coef
        if c is None:
            return None
        gy = _coords(rows, f, self.shape[0])[:, None]
        gx = _coords(cols, f, self.shape[1])[None, :]
        model = np.multiply(c[4] * gy, gx)  # one full-size array, added to in place
        model += c[0] + c[1] * gx + c[3] * gx * gx
        model += c[2] * gy + c[5] * gy * gy
        return model

    def flatten(self, values: np.ndarray, f: int = 1) -> tuple[np.ndarray, np.ndarray | None]:
        """``values`` (blocks of ``f`` pixels) divided by the model, and the model;
        unchanged and ``None`` where the model is not positive."""
        model = self.at(*values.shape[:2], f)
        if model is not None and model.min() > 1e-3:
            return np.divide(values, model), model
        return values, None


def segment(img: np.ndarray, top_rows: int | None = None, full_scale: float = 1.0):
    """Foreground mask of a heap photo (RGB, full intensity ``full_scale``) before
    choosing the heap piece.

    Raises :class:`DataError` when the picture is uniform (:data:`UNIFORM_SPREAD`) or
    no channel has :data:`MIN_CONTRAST`.
    Returns ``(mask, channel_values, threshold, channel_name, polarity)``: the
    foreground is ``channel_values < threshold`` when ``polarity`` is ``"below"`` and
    ``>`` when ``"above"`` (``channel_values`` is the smoothed, lighting-flattened
    channel).
    """
    rows = img.shape[0]
    top_rows = top_rows or max(2, rows // 30)
    thumb, f = _thumbnail(img, full_scale)
    spread = thumb.max(axis=(0, 1)) - thumb.min(axis=(0, 1))
    if not np.any(spread >= UNIFORM_SPREAD):  # NaN pixels count as uniform too
        raise DataError("the picture is uniform; check the exposure and the region of interest")
    top_thumb = max(1, top_rows // f)
    best = None
    for name, values in _channels(thumb).items():
        # the choice and the lighting are made on the thumbnail
        light = _Lighting(values, f, img.shape[:2])
        flat, model = light.flatten(values, f)
        scale = 1.0 if model is None else float(np.median(model))  # of the flat values
        t, eta, contrast = _otsu(flat.ravel())
        score = (contrast * scale >= MIN_CONTRAST, eta)  # a faint channel (chroma of grey) loses
        if best is None or score > best[1]:
            best = (name, score, contrast * scale, light, flat, t, values)
    name, _, contrast, light, flat, t, thumb_values = best
    if contrast < MIN_CONTRAST:
        raise DataError(f"nothing stands out from the background (contrast {contrast:.3f} "
                        f"< {MIN_CONTRAST} in every channel)")
    # lighting again, now fitted to the background class only (grown by a block)
    below = np.mean(flat[:top_thumb] > t) > 0.5  # the background fills the top rows
    fg = flat < t if below else flat > t
    bg = ndimage.maximum_filter(fg.view(np.uint8), size=3) == 0
    if bg.sum() * f * f > 100:
        again = _Lighting(thumb_values, f, img.shape[:2], use=bg)
        if again.coef is not None:
            light = again
    # the final threshold at full resolution
    smooth = ndimage.gaussian_filter(_channels(img, name, full_scale), _SMOOTH_PX)
    values = light.flatten(smooth)[0]
    t = _otsu(values[::2, ::2].ravel())[0]
    below = np.mean(values[:top_rows] > t) > 0.5
    fg = values < t if below else values > t
    return fg, values, t, name, "below" if below else "above"


def measure_photo(photo, roi=None, base_y: float | None = None, mm_per_px: float | None = None,
                  band: tuple[float, float] = DEFAULT_BAND, png: str | Path | None = None,
                  name: str | None = None, save_png=None, min_r2: float = MIN_R2) -> PhotoMeasurement:
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
    save_png : ``save_png(path, rgb)`` writes the annotated pixels (default
        :func:`write_png`; a batch writes in a thread of its own).
    min_r2 : smallest mean R² of the two flank fits (:data:`MIN_R2`).

    Raises
    ------
    ConfigError
        ``mm_per_px``, ``band``, ``base_y`` or ``min_r2`` out of range (:func:`check_options`).
    DataError
        Unreadable file, no heap, a heap touching the photo's (or region's) border,
        flanks that cannot be fitted or fit below ``min_r2``; the sentence names the photo.
    """
    check_options(mm_per_px, band, base_y, min_r2)
    if isinstance(photo, (str, os.PathLike)):
        name = name or str(photo)
        if png is not None and _same_file(png, photo):
            raise DataError(f"the annotated picture '{png}' would overwrite the photo '{photo}'; "
                            "write it to another file or folder.")
        photo = _read(photo)
    else:
        name = name or "<array>"
    pixels, full_scale = _pixels(photo, name)
    x0, y0, x1, y1 = _check_roi(roi, pixels.shape, name)
    img = pixels[y0:y1, x0:x1]
    rows, cols = img.shape[:2]
    if base_y is not None and not y0 < base_y <= y1:
        raise DataError(f"base line row {base_y} is outside the photo or region of interest "
                        f"(rows {y0}..{y1}) of '{name}'.")
    try:
        fg, values, t, channel, polarity = segment(img, full_scale=full_scale)
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
    if not fit.r2 >= min_r2:
        raise DataError(f"no heap found in photo '{name}': its flank fits have R² {fit.r2:.2f} (left "
                        f"{fit.left.r2:.2f}, right {fit.right.r2:.2f}), below the {min_r2:g} of a heap's straight "
                        "flanks; check the photo, its --roi and --base-y (or lower --min-r2).")
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
        outline=(col + float(x0), edge + float(y0)),
    )
    if png is not None:
        picture = pixels if pixels.dtype == np.uint8 else pixels / full_scale
        plot_photo(picture, m, (x0, y0, x1, y1), scale, png, save_png)
    return m


def _file_key(path) -> tuple:
    """What identifies a file: (device, inode) if it exists, else its resolved path."""
    try:
        st = os.stat(path)
        return st.st_dev, st.st_ino
    except OSError:
        return (os.path.normcase(os.path.realpath(path)),)


def _same_file(a, b) -> bool:
    """Whether paths ``a`` and ``b`` name the same file (links and ``..`` followed)."""
    return _file_key(a) == _file_key(b)


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


def plot_photo(full: np.ndarray, m: PhotoMeasurement, roi, scale: float, path,
               save_png=None) -> None:
    """Write the photo (float RGB in 0..1, or 8-bit RGB) with the base line (yellow),
    the region of interest (yellow box), the fitted edge points (blue left, red right;
    rejected ones orange), the fitted lines from the base to the apex height, and the
    left, right and mean angles written in the top-left corner."""
    from skimage.draw import line, rectangle_perimeter

    if full.dtype == np.uint8:
        img = full.copy()
    else:
        img = (np.clip(full, 0, 1) * 255).astype(np.uint8)
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
    img = _label(img, f"left {m.left_deg:.2f}°   right {m.right_deg:.2f}°   "
                      f"angle of repose {m.angle_deg:.2f}°   R^2 {m.r2:.3f}")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    (save_png or write_png)(path, img)


def write_png(path, rgb: np.ndarray) -> None:
    """Write 8-bit RGB pixels as a PNG file (Pillow, fastest zlib level: the annotated
    pictures are for looking at, not for archiving)."""
    import io

    from PIL import Image

    from demcal._files import write_atomic

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(buf, format="PNG", compress_level=1)
    write_atomic(path, buf.getvalue())


def _label(img: np.ndarray, text: str) -> np.ndarray:
    """``img`` with ``text`` written in its top-left corner on a dark band (Pillow's
    built-in font, scaled to the picture)."""
    from PIL import Image, ImageDraw, ImageFont

    picture = Image.fromarray(img)
    size = max(12, img.shape[0] // 30)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: one fixed-size bitmap font
        font = ImageFont.load_default()
    draw = ImageDraw.Draw(picture)
    x0, y0, x1, y1 = draw.textbbox((size // 2, size // 2), text, font=font)
    draw.rectangle((x0 - 4, y0 - 4, x1 + 4, y1 + 4), fill=(0, 0, 0))
    draw.text((size // 2, size // 2), text, fill=(255, 255, 255), font=font)
    return np.asarray(picture)


@dataclass(frozen=True)
class PhotoBatch:
    """Many photos of one sample.

    Attributes
    ----------
    measurements : the photos that could be measured, in the order given.
    failures : ``(photo, sentence)`` of each photo that could not.
    rows : one dict per photo (failed ones with their error and NaN angles): the
        columns of :data:`TABLE_COLUMNS`; ``outlier`` flags angles whose modified
        z-score exceeds :data:`OUTLIER_Z`.
    summary : mean, sd, n and 95 % CI of the angles of all measured photos
        (outliers flagged, not removed).
    """

    measurements: tuple[PhotoMeasurement, ...]
    failures: tuple[tuple[str, str], ...]
    rows: tuple[dict, ...]
    summary: Summary | None

    @property
    def table(self):
        """The rows as a :class:`pandas.DataFrame`."""
        import pandas as pd

        return pd.DataFrame(list(self.rows), columns=list(TABLE_COLUMNS))

    def records(self) -> list[dict]:
        """The rows with ``None`` for NaN (JSON-ready)."""
        return [{k: None if isinstance(v, float) and v != v else v for k, v in r.items()}
                for r in self.rows]

    def write_csv(self, path) -> None:
        """Write the rows as CSV (empty cells for failed photos' NaN angles), atomically:
        to a temporary file in the same folder, then renamed over ``path``, so an
        interrupted write leaves the previous table (or none), never a truncated one."""
        from demcal._files import write_atomic

        write_atomic(path, self.table.to_csv(index=False))

    def to_dict(self) -> dict:
        records = self.records()
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


def _measure_in_threads(jobs, threads: int) -> list:
    """:func:`_measure_one` of each job, ``threads`` photos at a time in this process,
    the pictures written in one more thread (PNG decoding, the image filters and zlib
    let other threads run, so two threads use two cores well)."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    room = threading.BoundedSemaphore(2 * threads)  # pictures waiting in memory
    written = []
    with ThreadPoolExecutor(1) as writer:
        def save(path, rgb):
            room.acquire()
            future = writer.submit(write_png, path, rgb)
            future.add_done_callback(lambda _: room.release())
            written.append(future)

        with ThreadPoolExecutor(threads) as pool:
            jobs = [(p, {**kw, "save_png": save}) for p, kw in jobs]
            results = list(pool.map(_measure_one, jobs))
        for future in written:
            future.result()  # a picture that could not be written fails the batch, as before
    return results


def annotated_paths(photos, out_dir) -> list[Path]:
    """Where :func:`measure_photos` writes the annotated picture of each photo: one
    distinct file per photo in ``out_dir``, ``<stem>_fit.png``; photos of the same stem
    (from different folders) get their folder's name in front, ``<folder>_<stem>_fit.png``,
    and a name still taken (by another picture or by a photo of the batch) a counter,
    ``<stem>_2_fit.png``.

    Raises
    ------
    DataError
        A picture would be written over one of the photos (e.g. a hard link to it).
    """
    out_dir = Path(out_dir)
    photos = [Path(p) for p in photos]
    stems = [p.stem for p in photos]
    count: dict[str, int] = {}
    for stem in stems:
        count[stem.casefold()] = count.get(stem.casefold(), 0) + 1
    # names compared case-blind: two pictures must differ on any file system
    taken = {os.path.realpath(p).casefold() for p in photos}
    out = []
    for p, stem in zip(photos, stems):
        base = stem if count[stem.casefold()] == 1 else f"{Path(os.path.realpath(p)).parent.name}_{stem}"
        png, k = out_dir / f"{base}{FIT_SUFFIX}", 2
        while os.path.realpath(png).casefold() in taken:
            png, k = out_dir / f"{base}_{k}{FIT_SUFFIX}", k + 1
        taken.add(os.path.realpath(png).casefold())
        out.append(png)
    inputs = {_file_key(p): p for p in photos}
    for p, png in zip(photos, out):
        if _file_key(png) in inputs:
            raise DataError(f"the annotated picture of '{p}' would overwrite the photo "
                            f"'{inputs[_file_key(png)]}' (the same file as '{png}'); "
                            "choose another output folder.")
    return out


def measure_photos(photos, roi=None, base_y=None, mm_per_px=None, band=DEFAULT_BAND,
                   out_dir: str | Path | None = None, workers: int = 1, min_r2: float = MIN_R2) -> PhotoBatch:
    """Measure a batch of photos; a bad photo is reported and the batch goes on.

    ``out_dir`` receives one annotated PNG per photo, named by :func:`annotated_paths`
    (``<stem>_fit.png``; never one of the photos). ``workers > 1`` measures photos in
    that many processes; otherwise two threads of this process measure them (one on a
    single-core machine).

    Raises
    ------
    ConfigError
        An option out of range (:func:`check_options`), before any photo is read.
    DataError
        An annotated picture would be written over one of the photos (nothing is
        measured or written then).
    """
    check_options(mm_per_px, band, base_y, min_r2)
    photos = [str(p) for p in photos]
    pngs = annotated_paths(photos, out_dir) if out_dir is not None else [None] * len(photos)
    jobs = []
    for p, png in zip(photos, pngs):
        kw = {"roi": roi, "base_y": base_y, "mm_per_px": mm_per_px, "band": band, "min_r2": min_r2}
        if png is not None:
            kw["png"] = str(png)
        jobs.append((p, kw))
    if workers > 1 and len(jobs) > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=workers) as pool:
            results = list(pool.map(_measure_one, jobs))
    else:
        results = _measure_in_threads(jobs, min(2, os.cpu_count() or 1))
    good = tuple(r for r in results if isinstance(r, PhotoMeasurement))
    failures = tuple((p, r) for p, r in zip(photos, results) if isinstance(r, str))
    outlier = iter(flag_outliers([m.angle_deg for m in good]))
    rows = []
    for p, r in zip(photos, results):
        if isinstance(r, PhotoMeasurement):
            rows.append({"photo": p, **{k: getattr(r, k) for k in TABLE_COLUMNS[1:-2]},
                         "error": None, "outlier": bool(next(outlier))})
        else:
            rows.append({"photo": p, **dict.fromkeys(TABLE_COLUMNS[1:6], float("nan")),
                         "unit": None, "png": None, "error": r, "outlier": False})
    summary = summarize([m.angle_deg for m in good]) if good else None
    return PhotoBatch(good, failures, tuple(rows), summary)
