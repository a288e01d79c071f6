"""The calibration loop's design boxes: a box in actual units, the physical limits its
points stay inside, and the cheap runs its response surface is fitted to
(:mod:`demcal.campaign.loop`)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import pandas as pd

from demcal._checks import significant
from demcal.campaign.config import Campaign
from demcal.campaign.seeds import BOX_SEED
from demcal.campaign.solve import fit_models, round_parameter
from demcal.campaign.store import RunRecord

#: A point counts as inside a box up to this far beyond its coded edge.
INSIDE_TOL = 1e-6


@dataclass(frozen=True)
class Box:
    """A design box in actual units; box 0 is the campaign's own."""

    index: int
    low: tuple[float, ...]
    high: tuple[float, ...]
    reason: str = "the campaign's design box"

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.low) + np.asarray(self.high))

    @property
    def half(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.high) - np.asarray(self.low))

    def campaign(self, campaign: Campaign, replicates: int | None = None) -> Campaign:
        """The campaign with this box's factor levels (and its own design seeds), with
        ``replicates`` seeds per design point if given (a moved box: ``[calibration]
        box_replicates``)."""
        if self.index == 0:
            return campaign
        factors = tuple(dataclasses.replace(f, low=significant(lo), high=significant(hi))
                        for f, lo, hi in zip(campaign.factors, self.low, self.high))
        return dataclasses.replace(campaign, factors=factors, seed=campaign.seed + BOX_SEED * self.index,
                                   replicates=replicates or campaign.replicates)

    def to_coded(self, actual) -> np.ndarray:
        return (np.asarray(actual, float) - self.centre) / self.half

    def to_actual(self, coded) -> np.ndarray:
        return self.centre + np.asarray(coded, float) * self.half

    def to_dict(self, campaign: Campaign) -> dict[str, Any]:
        return {"index": self.index, "reason": self.reason,
                "low": {f.parameter: significant(v) for f, v in zip(campaign.factors, self.low)},
                "high": {f.parameter: significant(v) for f, v in zip(campaign.factors, self.high)}}


def box_parameters(campaign: Campaign, box: Box, coded, limits: np.ndarray) -> dict[str, float]:
    """The campaign's factor settings at a point in ``box``'s coded units, held inside the
    physical limits and rounded as the store keys them."""

    actual = clean(box.to_actual(coded), limits)
    return {f.parameter: round_parameter(v) for f, v in zip(campaign.factors, actual)}


def clean(values, limits: np.ndarray) -> np.ndarray:
    """Actual values clipped to their limits and rid of binary noise (-2.8e-17 -> 0)."""
    return np.clip(np.round(np.asarray(values, float), 10), limits[:, 0], limits[:, 1]) + 0.0


#: The highest coefficient of restitution a path or a moved box may reach unless the
#: factor's ``hard_high`` (or its own design level) says otherwise: demcal's choice, a
#: bound and not a fitted value. Restitution 1 is a perfectly elastic contact, on which
#: a bed never comes to rest; a calibrated material's restitution lies below it (the
#: paper's Table 2 range for the soil is 0.5-0.7), and a loop with no upper hard limit
#: once pushed an own-material calibration to e = 1.
RESTITUTION_MAX = 0.95


def physical_limits(campaign: Campaign, profile: str) -> np.ndarray:
    """``(k, 2)`` limits of each factor in actual units: the bench setting's range,
    restitution in (0, :data:`RESTITUTION_MAX`] (up to 1 where ``hard_high`` or the
    factor's high level asks for more), and the factor's ``hard_low`` / ``hard_high``."""
    from demcal.bench.registry import get_experiment

    table = get_experiment(campaign.test).settings(profile)
    out = []
    for f in campaign.factors:
        setting = table[f.parameter]
        lo = -math.inf if setting.low is None else float(setting.low)
        hi = math.inf if setting.high is None else float(setting.high)
        if "restitution" in f.parameter.rsplit(".", 1)[-1]:
            own = max(f.high, f.hard_high if f.hard_high is not None else RESTITUTION_MAX)
            lo, hi = max(lo, 1e-3), min(hi, 1.0, max(RESTITUTION_MAX, own))
        if f.hard_low is not None:
            lo = max(lo, f.hard_low)
        if f.hard_high is not None:
            hi = min(hi, f.hard_high)
        out.append((lo, hi))
    return np.array(out, dtype=float)


def fit_box(campaign: Campaign, box: Box, records: Sequence[RunRecord], cheap: str, design_table=None):
    """Full and reduced models of the cheap runs inside ``box`` (box 0: its design only)."""

    boxed = box.campaign(campaign)
    if box.index == 0 and design_table is not None:
        table = design_table
    else:
        rows = []
        for r in campaign_runs(campaign, records, cheap, kinds=("design", "path")):
            x = point_of(campaign, r)
            coded = box.to_coded(x)
            if np.all(np.abs(coded) <= 1 + INSIDE_TOL):
                row = {f.name: float(c) for f, c in zip(campaign.factors, coded)}
                row.update({name: r.responses.get(name, np.nan) for name in campaign.response_names})
                rows.append(row)
        table = pd.DataFrame(rows, columns=campaign.factor_names + campaign.response_names)
    return fit_models(boxed, table) + (table,)


def campaign_runs(campaign: Campaign, records: Sequence[RunRecord], profile: str | None = None,
                  kinds: tuple[str, ...] | None = None):
    """Done runs of this campaign's test with its fixed settings (and every factor set),
    at ``profile`` and of ``kinds`` when given."""
    params = {f.parameter for f in campaign.factors}
    fixed = dict(campaign.settings)
    for r in records:
        if (r.status != "done" or r.test != campaign.test or (profile is not None and r.profile != profile)
                or (kinds is not None and r.kind not in kinds) or not params <= set(r.parameters)):
            continue
        if {k: v for k, v in r.settings.items() if k not in params} != fixed:
            continue
        yield r


def point_of(campaign: Campaign, record: RunRecord) -> np.ndarray:
    return np.array([float(record.parameters[f.parameter]) for f in campaign.factors])


def out_of_box(mean: float, sd: float | None, lo: float, hi: float) -> bool:
    """Whether a target calls for a box move: the box's reach ``[lo, hi]`` misses the
    middle half of the lab window ``mean +- sd`` (the mean itself without an sd). A box
    that reaches it is solved where it is: the verification accepts any mean inside the
    window, and a move costs a path and a new design."""
    near = 0.5 * sd if sd else 0.0
    return hi < mean - near or lo > mean + near


def in_window(target, lo: float, hi: float) -> bool:
    """Whether the box's reach ``[lo, hi]`` meets the lab window ``mean +- sd`` at all
    (a target without an sd: never, the window is its mean alone and out_of_box decides)."""
    return bool(target.sd) and hi >= target.mean - target.sd and lo <= target.mean + target.sd
