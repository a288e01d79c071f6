"""Static sliding friction angle from inclined-plane ruler readings.

The plate is raised until the bottomless container and its material start to slide;
the height ``H`` of the container's starting point above the base is read, and with
``L`` the distance from that point to the spindle (300 mm in the reference paper),

    theta = arcsin(H / L)                      (IJABE 2020, Eq. 5)

A point at distance ``L`` from the spindle's axis stands ``H0 + L sin(theta)`` above the
base, where ``H0`` is its height with the plate level. Eq. 5 is therefore the plate's
tilt only when ``H0`` is 0 (the spindle's axis level with the base it is measured
from); otherwise ``theta = arcsin((H - H0) / L)``, and Eq. 5 reads every angle high by
a constant in sine (``H0 / L``: 7 % of ``L`` adds 4.6 deg at 26.6 deg;
docs/validation-incline.md, "The reading: late onsets and the height in Eq. 5"). ``H0``
defaults to 0, the paper's formula.

The paper runs 10 groups of 3 repeats and reports the mean +- sd
(25.42 +- 2.6 deg and 30.46 +- 3.2 deg, Section 3.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from demcal.errors import DataError
from demcal.measure.summary import Summary, summarize


@dataclass(frozen=True)
class InclineMeasurement:
    """Sliding angles of an inclined-plane test.

    Attributes
    ----------
    angles_deg : theta of every reading, in the order given [deg].
    mean_deg, sd_deg, n : headline mean +- sd: over the group means when the readings
        come in groups of ``repeats`` (the paper's 10 groups x 3), else over all
        readings.
    group_means_deg : mean angle of each group (``None`` without ``repeats``).
    summary : :class:`Summary` behind the headline figures (with a 95 % CI).
    L_mm : arm length used [mm].
    H0_mm : height of the starting point above the base with the plate level [mm].
    """

    angles_deg: np.ndarray
    mean_deg: float
    sd_deg: float
    n: int
    group_means_deg: np.ndarray | None
    summary: Summary
    L_mm: float
    H0_mm: float = 0.0

    def to_dict(self) -> dict:
        return {
            "angles_deg": self.angles_deg.tolist(),
            "group_means_deg": None if self.group_means_deg is None else self.group_means_deg.tolist(),
            "mean_deg": self.mean_deg,
            "sd_deg": self.sd_deg,
            "n": self.n,
            "ci95_deg": [self.summary.ci_low, self.summary.ci_high],
            "L_mm": self.L_mm,
            "H0_mm": self.H0_mm,
        }


def sliding_angle(H_mm, L_mm: float = 300.0, H0_mm: float = 0.0) -> np.ndarray:
    """``theta = arcsin((H - H0) / L)`` [deg] for each reading ``H`` [mm] (Eq. 5 with
    ``H0 = 0``).

    Raises
    ------
    DataError
        ``L`` not positive, ``H0`` negative, or a reading below ``H0`` or at or above
        ``H0 + L`` (a plate at 90 deg or beyond: no sliding angle).
    """
    H = np.atleast_1d(np.asarray(H_mm, dtype=float))
    if not np.isfinite(L_mm) or L_mm <= 0:
        raise DataError(f"the arm length L = {L_mm} mm must be a positive number.")
    if not np.isfinite(H0_mm) or H0_mm < 0:
        raise DataError(f"the level height H0 = {H0_mm} mm must be 0 or more (the starting point's "
                        f"height above the base with the plate level).")
    if H.size == 0:
        raise DataError("there are no inclined-plane readings H to convert.")
    with np.errstate(over="ignore", invalid="ignore"):
        bad = ~np.isfinite(H) | (H < H0_mm) | ~(H - H0_mm < L_mm)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        span = "0 and L" if H0_mm == 0 else f"H0 and H0 + L ({H0_mm:g} and {H0_mm + L_mm:g} mm)"
        raise DataError(f"reading {i + 1}: H = {H[i]} mm is impossible with L = {L_mm} mm; "
                        f"each H must lie between {span}, {'L' if H0_mm == 0 else 'H0 + L'} excluded (a plate "
                        "at 90 deg has no sliding angle).")
    return np.degrees(np.arcsin((H - H0_mm) / L_mm))


def measure_incline(H_mm, L_mm: float = 300.0, repeats: int | None = None,
                    H0_mm: float = 0.0) -> InclineMeasurement:
    """Convert readings to angles and summarise them.

    Parameters
    ----------
    H_mm : readings [mm], flat in group order (group 1's repeats, then group 2's ...),
        or a (groups, repeats) array.
    L_mm : distance from the container's starting point to the spindle [mm].
    repeats : readings per group; if given (or ``H_mm`` is 2-D), the headline mean +- sd
        is over the group means.
    H0_mm : the starting point's height above the base with the plate level [mm]
        (0: the paper's Eq. 5).
    """
    H = np.asarray(H_mm, dtype=float)
    if H.ndim == 2:
        repeats = H.shape[1]
    angles = sliding_angle(H.ravel(), L_mm, H0_mm)
    groups = None
    if repeats is not None:
        if repeats < 1 or angles.size % repeats:
            raise DataError(f"{angles.size} readings cannot be split into groups of {repeats} repeats.")
        groups = angles.reshape(-1, repeats).mean(axis=1)
    summary = summarize(angles if groups is None else groups)
    return InclineMeasurement(angles, summary.mean, summary.sd, summary.n, groups, summary, float(L_mm),
                              float(H0_mm))
