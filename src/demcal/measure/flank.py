"""Flank fitting: the one code path that turns a heap outline into angles of repose.

Both a lab photo (:mod:`demcal.measure.photo`) and a simulated heap
(:mod:`demcal.measure.heap`) are reduced to an *outline*: points ``(x, z)`` of the
heap's upper edge as a camera sees it, ``z`` up, measured from the base line. This
module splits the outline at the apex into a left and a right flank, keeps the points
between two fractions of the heap height (the *band*, default 10 %--90 %, which drops
the rounded top and the spread foot with its fines and the base plate edge), and fits a
straight line to each flank by least squares with robust rejection of outliers, as the
paper does with its photos (Fig. 2 of the IJABE 2020 reference,
doi:10.25165/j.ijabe.20201304.5586: "fitting the boundary points ... by the least
square method").

Robust fit: a Theil--Sen line (median of pairwise slopes; Sen 1968,
doi:10.1080/01621459.1968.10480934) starts an iteration of ordinary least squares on
the points whose vertical residual is within ``k`` robust standard deviations
(``1.4826 * MAD``) of the line; the iteration stops when the set of inliers no longer
changes. Everything is deterministic: the same outline gives the same angle to the
last digit.

Units: ``x`` and ``z`` in any one length unit (metres for simulations, millimetres or
pixels for photos); angles in degrees. An angle is scale-free.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from demcal.errors import DataError

#: Default height band: fit each flank between 10 % and 90 % of the heap height.
DEFAULT_BAND = (0.1, 0.9)
#: Default rejection threshold in robust standard deviations (1.4826 MAD).
DEFAULT_REJECT_SIGMA = 3.0
#: Fewest outline points per flank inside the band for a fit.
MIN_FLANK_POINTS = 5
#: Theil--Sen start uses at most this many points (it costs O(n^2)).
_THEIL_SEN_POINTS = 400


@dataclass(frozen=True)
class FlankFit:
    """A straight line ``z = intercept + slope * x`` fitted to one flank.

    Attributes
    ----------
    side : ``"left"`` or ``"right"``
    angle_deg : inclination of the flank to the base line [deg]; positive for a flank
        that rises towards the apex (``atan(slope)`` on the left, ``atan(-slope)`` on
        the right).
    slope, intercept : the fitted line [-], [length].
    r2 : coefficient of determination of the fit on its inliers [-].
    rms_residual : root-mean-square vertical residual of the inliers [length].
    n_points : outline points in the band.
    n_inliers : points kept after outlier rejection.
    x, z : the points in the band; ``inlier`` marks those kept.
    """

    side: str
    angle_deg: float
    slope: float
    intercept: float
    r2: float
    rms_residual: float
    n_points: int
    n_inliers: int
    x: np.ndarray
    z: np.ndarray
    inlier: np.ndarray

    def line(self, x: np.ndarray) -> np.ndarray:
        """Height of the fitted line at ``x``."""
        return self.intercept + self.slope * np.asarray(x, dtype=float)

    def to_dict(self) -> dict:
        return {
            "angle_deg": self.angle_deg,
            "r2": self.r2,
            "rms_residual": self.rms_residual,
            "n_points": self.n_points,
            "n_inliers": self.n_inliers,
        }


@dataclass(frozen=True)
class OutlineFit:
    """Both flanks of one outline.

    Attributes
    ----------
    left, right : the flank fits.
    height : heap height above the base line [length].
    apex_x : where the outline is split into flanks [length].
    band : the height fractions used.
    """

    left: FlankFit
    right: FlankFit
    height: float
    apex_x: float
    band: tuple[float, float]

    @property
    def angle_deg(self) -> float:
        """Mean of the left and right angles [deg]; a small camera tilt cancels here."""
        return 0.5 * (self.left.angle_deg + self.right.angle_deg)

    @property
    def r2(self) -> float:
        """Mean R^2 of the two flank fits."""
        return 0.5 * (self.left.r2 + self.right.r2)


def fit_line(x, z, side: str = "left", reject_sigma: float = DEFAULT_REJECT_SIGMA,
             max_iter: int = 30) -> FlankFit:
    """Fit ``z = a + b x`` by least squares with iterative rejection of outliers.

    Parameters
    ----------
    x, z : 1-D arrays of outline points of one flank [length].
    side : ``"left"`` (flank rises with x) or ``"right"`` (falls with x); sets the sign
        of the reported angle.
    reject_sigma : points farther than this many robust standard deviations
        (``1.4826 * MAD`` of the vertical residuals) from the line are rejected.
    max_iter : most refits.

    Raises
    ------
    DataError
        Fewer than :data:`MIN_FLANK_POINTS` points, or all points at one ``x``.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', not {side!r}")
    x = np.asarray(x, dtype=float).ravel()
    z = np.asarray(z, dtype=float).ravel()
    finite = np.isfinite(x) & np.isfinite(z)
    x, z = x[finite], z[finite]
    if x.size < MIN_FLANK_POINTS or np.ptp(x) == 0.0:
        raise DataError(
            f"the {side} flank has only {x.size} usable outline points in the height band; "
            "the outline is too short or flat to fit a line (check the base line, the band "
            "or the region of interest)."
        )
    # Robust start: Theil--Sen on an evenly spaced subset.
    step = max(1, x.size // _THEIL_SEN_POINTS)
    from scipy.stats import theilslopes  # Sen 1968; imported here to keep start-up light

    slope, intercept = (float(v) for v in theilslopes(z[::step], x[::step])[:2])
    inlier = np.ones(x.size, dtype=bool)
    floor = 1e-9 * max(np.ptp(z), np.ptp(x), 1e-300)
    for _ in range(max_iter):
        resid = z - (intercept + slope * x)
        mad = np.median(np.abs(resid - np.median(resid[inlier])))
        sigma = max(1.4826 * mad, floor)
        new = np.abs(resid) <= reject_sigma * sigma
        if new.sum() < MIN_FLANK_POINTS or np.ptp(x[new]) == 0.0:
            break
        slope, intercept = np.polyfit(x[new], z[new], 1)
        if np.array_equal(new, inlier):
            break
        inlier = new
    resid = z[inlier] - (intercept + slope * x[inlier])
    ss_res = float(np.sum(resid**2))
    ss_tot = float(np.sum((z[inlier] - z[inlier].mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 0.0
    sign = 1.0 if side == "left" else -1.0
    return FlankFit(
        side=side,
        angle_deg=float(np.degrees(np.arctan(sign * slope))),
        slope=float(slope),
        intercept=float(intercept),
        r2=float(r2),
        rms_residual=float(np.sqrt(ss_res / inlier.sum())),
        n_points=int(x.size),
        n_inliers=int(inlier.sum()),
        x=x,
        z=z,
        inlier=inlier,
    )


def find_apex(x, z, top_fraction: float = 0.03) -> float:
    """``x`` of the heap's apex: the middle of the outline points within
    ``top_fraction`` of the height range below the highest point (a flat or
    rounded top is split in its middle)."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    zmax, zmin = z.max(), z.min()
    near_top = z >= zmax - top_fraction * (zmax - zmin)
    return float(np.median(x[near_top]))


def fit_outline(x, z, base_z: float = 0.0, band: tuple[float, float] = DEFAULT_BAND,
                apex_x: float | None = None,
                reject_sigma: float = DEFAULT_REJECT_SIGMA) -> OutlineFit:
    """Fit both flanks of a heap outline.

    Parameters
    ----------
    x, z : outline points of the upper edge, ``z`` up [length]; any order; NaN ignored.
    base_z : height of the base line [length].
    band : fractions ``(low, high)`` of the heap height ``H = max(z) - base_z``
        between which flank points are fitted (default 0.1--0.9).
    apex_x : where to split the flanks; default :func:`find_apex`.
    reject_sigma : see :func:`fit_line`.

    Raises
    ------
    DataError
        No outline above the base, a bad band, or a flank with too few points.
    """
    lo_f, hi_f = (float(b) for b in band)
    if not 0.0 <= lo_f < hi_f <= 1.0:
        raise DataError(f"height band {band} must satisfy 0 <= low < high <= 1, e.g. (0.1, 0.9).")
    x = np.asarray(x, dtype=float).ravel()
    z = np.asarray(z, dtype=float).ravel()
    keep = np.isfinite(x) & np.isfinite(z)
    x, z = x[keep], z[keep]
    if x.size == 0 or z.max() <= base_z:
        raise DataError("the outline has no point above the base line; there is no heap to fit.")
    height = float(z.max() - base_z)
    if apex_x is None:
        apex_x = find_apex(x, z)
    lo, hi = base_z + lo_f * height, base_z + hi_f * height
    in_band = (z >= lo) & (z <= hi)
    left = in_band & (x < apex_x)
    right = in_band & (x > apex_x)
    return OutlineFit(
        left=fit_line(x[left], z[left], "left", reject_sigma),
        right=fit_line(x[right], z[right], "right", reject_sigma),
        height=height,
        apex_x=float(apex_x),
        band=(lo_f, hi_f),
    )
