"""The part of the design box where every response meets its lab window, as parameter
ranges: Design-Expert's graphical optimisation (the overlay plot), in numbers.

A coded point belongs to the region when each fitted model predicts its response inside
that response's window (``low`` to ``high``: for a calibration, the lab mean ± the lab
sd). The region is sampled with a scrambled Sobol sequence (``scipy.stats.qmc.Sobol``,
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

__all__ = ["Overlay", "overlay"]


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
            m: int = 14, seed: int = 0) -> Overlay:
    """The region of the coded box ``[-1, 1]^k`` where every model in ``models`` (by
    response, each with ``predict`` of an (n, k) coded array) predicts inside its
    ``windows[response]`` = (low, high); ``2**m`` Sobol points, scrambled with ``seed``."""
    from scipy.stats import qmc

    x = 2.0 * qmc.Sobol(d=k, scramble=True, seed=seed).random_base2(m) - 1.0
    inside = np.ones(len(x), dtype=bool)
    for response, (low, high) in windows.items():
        y = np.asarray(models[response].predict(x), dtype=float)
        inside &= (y >= low) & (y <= high)
    ranges = {}
    if inside.any():
        kept = x[inside]
        ranges = {j: (float(kept[:, j].min()), float(kept[:, j].max())) for j in range(k)}
    return Overlay(ranges, float(inside.mean()), len(x))
