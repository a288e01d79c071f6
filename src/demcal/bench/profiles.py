"""Measured bias between bench profiles: what the production profile gives minus the cheap one.

A cheap profile (``quick``) is not a converged proxy of the paper's set-up (``paper``):
at the same contact parameters the two differ by a few degrees (docs/validation.md). The
difference was measured at several design points with several seeds per point
(``benchmarks/profile_bias.py`` writes ``demcal/data/profile_bias.json`` from a bench
study's result files) and is kept here with the profiles, so that

* the report can say what a cheap-profile response means at the production profile, and
* the calibration loop can start from it: the first production run of a two-fidelity
  calibration is placed where the cheap surface *plus the stored bias* meets the target,
  instead of where the cheap surface alone does (``demcal.campaign.loop.Discrepancy``).

The bias holds for the set-up it was measured with: the profiles' own settings, with
only material values (``particle.*``, ``film.*``) changed between points. A campaign
that fixes any other setting (a particle count, a plate, a rolling model) gets no stored
bias (:func:`applies`).
"""

from __future__ import annotations

import importlib.resources
import json
import math
import statistics
from dataclasses import dataclass, field
from typing import Mapping

#: Settings a campaign may fix and still use a stored bias: the material's own values.
MATERIAL_PREFIXES = ("particle.", "film.")


@dataclass(frozen=True)
class ProfileBias:
    """``production - cheap`` of one response of one test, measured at ``points``."""

    test: str
    response: str
    cheap: str
    production: str
    bias: float  #: mean over the points of (production mean - cheap mean)
    se: float  #: its standard error: sd of the points' differences / sqrt(points)
    sd_points: float  #: sd of the points' differences (how far the bias is from constant)
    points: tuple = field(default=())  #: dicts: settings, cheap_mean/sd/n, production_mean/sd/n
    source: str = ""
    measured: str = ""

    def describe(self) -> str:
        return (f"stored {self.cheap} → {self.production} bias {self.bias:+.2f} ± {self.se:.2f}° "
                f"(sd over {len(self.points)} design points {self.sd_points:.2f}°; measured {self.measured})")


def _load() -> list[ProfileBias]:
    path = importlib.resources.files("demcal") / "data" / "profile_bias.json"
    if not path.is_file():
        return []
    rows = json.loads(path.read_text())
    return [ProfileBias(**{**r, "points": tuple(r.get("points", ()))}) for r in rows]


def stored(test: str, response: str, cheap: str, production: str) -> ProfileBias | None:
    """The stored bias for this test, response and pair of profiles, or None."""
    for b in _load():
        if (b.test, b.response, b.cheap, b.production) == (test, response, cheap, production):
            return b
    return None


def applies(fixed: Mapping[str, object]) -> list[str]:
    """The fixed settings that keep a stored bias from applying (empty: it applies)."""
    return sorted(k for k in fixed if not k.startswith(MATERIAL_PREFIXES))


def measure(test: str, response: str, cheap: str, production: str,
            runs: list[dict], source: str = "", measured: str = "") -> ProfileBias:
    """The bias from bench-study rows (``benchmarks/bench_study.py`` JSON lines).

    ``runs`` are rows with ``test``, ``profile``, ``set`` (the settings of the point) and
    ``responses``; points are grouped by their settings, and only points with runs at both
    profiles count. Raises ValueError with one sentence when fewer than two points have.
    """
    groups: dict[str, dict[str, list[float]]] = {}
    settings: dict[str, dict] = {}
    for row in runs:
        if row.get("test") != test or "responses" not in row or response not in row["responses"]:
            continue
        if row.get("profile") not in (cheap, production):
            continue
        key = json.dumps(row.get("set", {}), sort_keys=True)
        settings[key] = row.get("set", {})
        groups.setdefault(key, {}).setdefault(row["profile"], []).append(float(row["responses"][response]))
    points = []
    for key, by in groups.items():
        if cheap not in by or production not in by:
            continue
        c, p = by[cheap], by[production]
        points.append({"settings": settings[key],
                       "cheap_mean": _mean(c), "cheap_sd": _sd(c), "cheap_n": len(c),
                       "production_mean": _mean(p), "production_sd": _sd(p), "production_n": len(p)})
    if len(points) < 2:
        raise ValueError(f"the study has {len(points)} point(s) of {test} with runs at both {cheap} and "
                         f"{production}; a bias needs at least two.")
    diffs = [pt["production_mean"] - pt["cheap_mean"] for pt in points]
    sd = _sd(diffs)
    return ProfileBias(test, response, cheap, production, _mean(diffs), sd / math.sqrt(len(diffs)), sd,
                       tuple(points), source, measured)


def _mean(values) -> float:
    return statistics.fmean(values)


def _sd(values) -> float | None:
    """The sample sd, None for fewer than two values (JSON has no NaN)."""
    return statistics.stdev(values) if len(values) > 1 else None
