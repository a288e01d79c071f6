"""The production bench's seed-to-seed noise, as the calibration loop knows it.

:func:`production_noise` pools the production runs the loop has seen with the stored
profile studies' replicated points of the production profile (:func:`stored_noise`,
from :mod:`demcal.bench.profiles`); :func:`pooled_sd` is the pure error both pool.
"""

from __future__ import annotations

import json
import math
from typing import Sequence

import numpy as np

from demcal.campaign.config import Campaign
from demcal.campaign.store import RunRecord


def pooled_sd(groups) -> tuple[float, int]:
    """The within-group standard deviation pooled over ``groups`` (sequences of values;
    groups of one add nothing) and its degrees of freedom: the pure error of the ANOVA."""
    ss, df = 0.0, 0
    for values in groups:
        v = np.asarray(values, dtype=float)
        if len(v) > 1:
            ss += float(((v - v.mean()) ** 2).sum())
            df += len(v) - 1
    return (math.sqrt(ss / df) if df else float("nan")), df


def production_noise(campaign: Campaign, records: Sequence[RunRecord], production: str,
                     responses, prior: dict[str, list] | None = None,
                     kinds: tuple[str, ...] | None = ("verification",)) -> dict[str, tuple[float, int, int]]:
    """Per response: the seed-to-seed sd of the production runs the loop has seen,
    pooled over their points, its df, and how many of those df are the campaign's own
    (``kinds``: the runs that count, by kind; None: every run at ``production``, the
    design's replicated points among them);
    with ``prior`` (response -> the stored studies' ``(settings, n, sd)`` points of the
    production profile: :func:`stored_noise`) pooled in as further points, each point
    the campaign has run itself left out (its own runs there count instead: a stored
    point may be the very runs of an earlier calibration at the same settings and seeds).

    Every condition's points count, not only this condition's: the noise is the
    production bench's scatter at nearby material values, which a condition's fixed
    settings (another condition's calibrated values, ``from_campaign``) change no more
    than its own factors do; the discrepancy is shared between conditions the same way.
    A point is its whole settings (factors and fixed settings). Pooling assumes the
    scatter is alike at every point; the paper-profile incline's stored points range
    from 0.1 to 1.5 deg with three seeds each, the larger at high film friction, which a
    test of equal variances with 2 df a point does not tell apart from chance."""
    groups: dict[tuple, list[RunRecord]] = {}
    for r in records:
        if (r.status == "done" and (kinds is None or r.kind in kinds) and r.test == campaign.test
                and r.profile == production):
            groups.setdefault(json.dumps(r.settings, sort_keys=True), []).append(r)
    own_settings = [rows[0].settings for rows in groups.values()]
    out = {}
    for name in responses:
        sd, df = pooled_sd([r.responses[name] for r in rows if name in r.responses] for rows in groups.values())
        own = df
        ss = sd * sd * df if df else 0.0
        for settings, n, p_sd in (prior or {}).get(name, []):
            if not any(_same_point(settings, mine) for mine in own_settings):
                ss, df = ss + (n - 1) * p_sd * p_sd, df + n - 1
        out[name] = ((math.sqrt(ss / df) if df else float("nan")), df, own)
    return out


def _same_point(stored: dict, settings: dict) -> bool:
    """Whether a run's ``settings`` are the stored point's (which names the material
    values it varied; the rest were the profile's defaults)."""
    try:
        return all(abs(float(settings[k]) - float(v)) < 1e-9 for k, v in stored.items())
    except (KeyError, TypeError, ValueError):
        return False


def stored_noise(campaign: Campaign, production: str, responses) -> dict[str, list]:
    """Response -> the stored profile studies' replicated points of the production
    profile, ``(settings, n, sd)`` each (:func:`demcal.bench.profiles.noise_points`),
    where they apply to the campaign's fixed settings (the same rule as a stored bias:
    material values only) and ``[calibration] stored_noise`` is on. With them the first
    production point is sized by a noise already measured on the same bench instead of
    the ``[calibration] replicates`` asked for at an unknown noise, and its 95 % interval
    uses those degrees of freedom too: on the paper-profile incline (0.74 deg over
    22 df, against lab sds of 2.6-3.2 deg) one run decides a point. The campaign's own
    production runs join the pool as they come (:func:`production_noise`)."""
    from demcal.bench import profiles

    if not campaign.calibration.stored_noise or profiles.applies(campaign.settings):
        return {}
    out = {}
    for name in responses:
        points = profiles.noise_points(campaign.test, name, production)
        if points:
            out[name] = points
    return out
