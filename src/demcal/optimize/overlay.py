"""The part of the design box where every response meets its lab window, as parameter
ranges: Design-Expert's graphical optimisation (the overlay plot), in numbers.

A coded point belongs to the region when each fitted model predicts its response inside
that response's window (``low`` to ``high``: for a calibration, the lab mean ± the lab
sd). With ``level``, a point belongs to it when the model's ``level`` confidence interval
of the mean response there, yhat ± t(1/2 + level/2, df) se(yhat)
(:func:`demcal.rsm.diagnostics.confidence_band`), reaches into the window: the settings
whose simulated mean the fitted runs cannot tell from one inside the window, so the seed
noise the surface averages widens the region where the runs are few or far. (Design-Expert's
overlay can show the same interval the other way round, keeping only points whose whole
interval lies inside the window; that is a region the response is sure to meet, not the
settings a calibration cannot rule out.) The region is sampled with a scrambled Sobol sequence (``scipy.stats.qmc.Sobol``,
seeded) of ``2**m`` points in the coded box ``[-1, 1]^k``; each factor's range is the
smallest and largest level among the points inside. It is an inner estimate: a sliver
thinner than the sample's spacing (about ``2 / 2**(m/k)`` coded units) can be missed, and
the ranges are the region's bounding box, not the region (two factors traded against each
other fill only a band of it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

__all__ = ["Overlay", "interval_half_width", "overlay", "reaches"]


@dataclass(frozen=True)
class Overlay:
    """The region where every window is met.

    Attributes
    ----------
    ranges : factor index -> (low, high) coded levels over the points inside; empty when
        no sampled point meets every window.
    share : the fraction of the box's sampled points inside [-].
    points : the number of points sampled.
    """

    ranges: dict[int, tuple[float, float]]
    share: float
    points: int


def overlay(models: Mapping[str, object], windows: Mapping[str, tuple[float, float]], k: int,
            m: int = 14, seed: int = 0, level: float | None = None) -> Overlay:
    """The region of the coded box ``[-1, 1]^k`` where every model in ``models`` (by
    response, each with ``predict`` of an (n, k) coded array) predicts inside its
    ``windows[response]`` = (low, high); ``2**m`` Sobol points, scrambled with ``seed``.
    With ``level`` (e.g. 0.95), where the model's confidence interval of the mean reaches
    into the window (:func:`interval_half_width`)."""
    from scipy.stats import qmc

    x = 2.0 * qmc.Sobol(d=k, scramble=True, seed=seed).random_base2(m) - 1.0
    inside = np.ones(len(x), dtype=bool)
    for response, (low, high) in windows.items():
        model = models[response]
        y = np.asarray(model.predict(x), dtype=float)
        inside &= reaches(y, 0.0 if level is None else interval_half_width(model, x, level), low, high)
    ranges = {}
    if inside.any():
        kept = x[inside]
        ranges = {j: (float(kept[:, j].min()), float(kept[:, j].max())) for j in range(k)}
    return Overlay(ranges, float(inside.mean()), len(x))


def reaches(y, half, low: float, high: float) -> np.ndarray:
    """Where the interval ``y`` ± ``half`` (``half`` 0: the point ``y``) meets the window
    ``low`` to ``high``."""
    return (y + half >= low) & (y - half <= high)


def interval_half_width(model, x: np.ndarray, level: float) -> np.ndarray | float:
    """Half the ``level`` confidence interval of ``model``'s mean response at the coded
    points ``x``: t(1/2 + level/2, df) se(yhat), from the model's residual mean square and
    the design (:meth:`demcal.rsm.fit.FittedModel.prediction_se`). 0 for a model without
    residual degrees of freedom or standard errors (a saturated fit estimates no noise)."""
    from scipy import stats

    df = getattr(model, "df_residual", 0)
    if not hasattr(model, "prediction_se") or not df or df <= 0:
        return 0.0
    se = np.asarray(model.prediction_se(x), dtype=float)
    if not np.all(np.isfinite(se)):
        return 0.0
    return float(stats.t.ppf(0.5 + level / 2.0, df)) * se
