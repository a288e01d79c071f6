"""Static sliding friction angle from inclined-plane ruler readings.

The plate is raised until the bottomless container and its material start to slide;
the height ``H`` of the container's starting point above the base is read, and with
``L`` the distance from that point to the spindle (300 mm in the reference paper),

    theta = arcsin(H / L)                      (IJABE 2020, Eq. 5)

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
    """

    angles_deg: np.ndarray
    mean_deg: float
    sd_deg: float
    n: int
    group_means_deg: np.ndarray | None
    summary: Summary
    L_mm: float

    def to_dict(self) -> dict:
        return {
            "angles_deg": self.angles_deg.tolist(),
            "group_means_deg": None if self.group_means_deg is None else self.group_means_deg.tolist(),
            "mean_deg": self.mean_deg,
            "sd_deg": self.sd_deg,
            "n": self.n,
            "ci95_deg": [self.summary.ci_low, self.summary.ci_high],
            "L_mm": self.L_mm,
        }


def sliding_angle(H_mm, L_mm: float = 300.0) -> np.ndarray:
    """``theta = arcsin(H / L)`` [deg] for each reading ``H`` [mm].

    Raises
    ------
    DataError
        ``L`` not positive, or a reading negative or larger than ``L``.
    """
    H = np.atleast_1d(np.asarray(H_mm, dtype=float))
    if not np.isfinite(L_mm) or L_mm <= 0:
        raise DataError(f"the arm length L = {L_mm} mm must be a positive number.")
    if H.size == 0:
        raise DataError("there are no inclined-plane readings H to convert.")
    bad = ~np.isfinite(H) | (H < 0) | (H > L_mm)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(f"reading {i + 1}: H = {H[i]} mm is impossible with L = {L_mm} mm; "
                        f"each H must lie between 0 and L.")
    return np.degrees(np.arcsin(H / L_mm))


def measure_incline(H_mm, L_mm: float = 300.0, repeats: int | None = None) -> InclineMeasurement:
    """Convert readings to angles and summarise them.

    Parameters
    ----------
    H_mm : readings [mm], flat in group order (group 1's repeats, then group 2's ...),
        or a (groups, repeats) array.
    L_mm : distance from the container's starting point to the spindle [mm].
    repeats : readings per group; if given (or ``H_mm`` is 2-D), the headline mean +- sd
        is over the group means.
    """
    H = np.asarray(H_mm, dtype=float)
    if H.ndim == 2:
        repeats = H.shape[1]
    angles = sliding_angle(H.ravel(), L_mm)
    groups = None
    if repeats is not None:
        if repeats < 1 or angles.size % repeats:
            raise DataError(f"{angles.size} readings cannot be split into groups of {repeats} repeats.")
        groups = angles.reshape(-1, repeats).mean(axis=1)
    summary = summarize(angles if groups is None else groups)
    return InclineMeasurement(angles, summary.mean, summary.sd, summary.n, groups, summary, float(L_mm))
