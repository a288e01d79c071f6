"""Summaries of repeated lab measurements: mean, sample sd, count and the confidence
interval of the mean (Student t), as :mod:`demcal.measure.photo` and
:mod:`demcal.measure.incline` report them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from demcal.errors import DataError


@dataclass(frozen=True)
class Summary:
    """Mean, sample standard deviation (ddof = 1), count and two-sided confidence
    interval of the mean (Student t)."""

    mean: float
    sd: float
    n: int
    ci_low: float
    ci_high: float
    confidence: float = 0.95

    def to_dict(self) -> dict:
        return {"mean": self.mean, "sd": self.sd, "n": self.n,
                "ci": [self.ci_low, self.ci_high], "confidence": self.confidence}


def summarize(values, confidence: float = 0.95) -> Summary:
    """:class:`Summary` of ``values`` (NaN ignored); the sd and CI of one value are NaN."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        raise DataError("there are no values to summarise.")
    mean = float(v.mean())
    if v.size < 2:
        return Summary(mean, float("nan"), 1, float("nan"), float("nan"), confidence)
    sd = float(v.std(ddof=1))
    from scipy.special import stdtrit  # Student t quantile, as scipy.stats.t.ppf

    half = float(stdtrit(v.size - 1, 0.5 + confidence / 2) * sd / np.sqrt(v.size))
    return Summary(mean, sd, int(v.size), mean - half, mean + half, confidence)
