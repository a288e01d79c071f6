"""How many production replicates the calibration loop runs at a point, and their runs
(:mod:`demcal.campaign.loop`, step 3)."""

from __future__ import annotations

import math

import numpy as np

from demcal.campaign.store import RunSpec


def replicates_needed(sd: float, df: int, n: int, lab_sd: float, cap: int) -> int:
    """The fewest replicates ``m > n`` whose 95 % half-width, Student t with the pooled
    ``df`` grown by the new runs, falls below ``lab_sd`` at the current ``sd`` (``cap``
    if none up to it does): the whole batch at once, so the runs go in parallel instead
    of one per round. ``n`` runs already at the point: ``m - n`` more add as many degrees
    of freedom; at a new point (``n = 0``) its ``m`` runs add ``m - 1``."""
    from scipy import stats

    for m in range(n + 1, cap + 1):
        if stats.t.ppf(0.975, df + m - max(n, 1)) * sd / math.sqrt(m) < lab_sd:
            return m
    return cap


def batched(need: int, done: int, step: int, cap: int) -> int:
    """``need`` replicates at a point that has ``done``, the new runs rounded up to a
    multiple of ``step`` (``[calibration] replicate_batch``), at most ``cap``. With
    ``step`` the number of workers, a batch never leaves a worker idle: three runs on two
    workers take as long as four, and the fourth may save a later round of one run. The
    loop does not round a probe (one run where nothing is known of production - cheap),
    nor a batch whose extra seeds would pass the ``[budget] runs``."""
    return min(cap, done + -(-max(need - done, 0) // step) * step)


def first_batch(noise: dict[str, tuple], targets, first: int, least: int) -> int:
    """Replicates of the first batch at a new production point.

    ``first`` (``[calibration] replicates``) while the production noise is unknown: no
    point has two runs yet. Once ``noise`` (per response: the seed-to-seed sd pooled over
    the production points so far, and its df) is known, the fewest replicates, at least
    ``least`` (``min_replicates``) and at most ``first``, whose 95 % half-width falls
    below every target's lab sd: where production runs scatter little against the lab
    (the paper-profile incline: 0.5-1.2 deg against 2.6-3.2), one run decides a point
    instead of three. A point that lands inside the lab band with too wide an interval
    still gets more replicates (:func:`replicates_needed`)."""
    if first <= least:
        return first
    need = 0
    for t in targets:
        if t.sd is None:
            continue
        sd, df = noise.get(t.response, (float("nan"), 0))[:2]
        if df < 1 or not np.isfinite(sd):
            return first
        # the half-width only shrinks as m grows, so the fewest m >= 1, raised to least
        need = max(need, replicates_needed(sd, df, 0, t.sd, first))
    return first if need == 0 else max(need, least)  # no lab sd anywhere: nothing to size it by


def production_specs(campaign, condition, ci, chosen, production, replicates) -> list[RunSpec]:
    from demcal.campaign.runner import point_settings

    settings = point_settings(campaign, chosen)
    return [RunSpec("verification", f"verify {condition.name} #{r + 1}", campaign.test, production, chosen,
                    settings, campaign.verification_seed + 1000 * ci + r) for r in range(replicates)]
