"""The solution set of a card condition: the range of each calibrated value.

What calibration.json's ``factor_ranges`` hold (:mod:`demcal.optimize.search`, solved by
:func:`demcal.campaign.solve.solve_condition` on the loop's last box): per calibrated
parameter, its lowest and highest value over the settings inside the condition's last
design box where the fitted response surface -- the cheap model plus its discrepancy to
the production profile (:class:`demcal.campaign.discrepancy.CorrectedSurface`) -- gives
every lab target an overall Derringer-Suich desirability D >= :data:`THRESHOLD` (a target
the box cannot reach is replaced by its nearest reachable value). A target's
desirability is 1 at the lab mean and falls linearly to 0 at the lowest and highest
responses of the runs the box's model is fitted to (shifted by the discrepancy), so for
one target the set is where the predicted *mean* lies within 1 % of that distance of the
lab mean (several targets: the geometric mean of their d at least 0.99). The lab sd, the
model's prediction interval and the seed noise do not enter: the set is not widened for
any of them, and the parameters compatible with the lab within its sd and the noise form
a wider set than this. Each range is the set's extent along one parameter; not every
combination of values inside the ranges meets the targets. calibration.json does not
record how many solutions the search found, so the card gives no count.

Where calibrate wrote ``compatible_ranges`` (:func:`demcal.campaign.calibrate.compatible_ranges`:
the box's region where every target is predicted inside the lab mean +- sd within the
fitted surface's 95 % confidence interval of the mean, Design-Expert's overlay with the seed
noise), the card gives those instead, the set the lab's spread and the noise allow, with
:data:`COMPATIBLE_MEANING`; the narrow desirability set above is what older calibrations
and a region the box does not hold leave.

The card rounds each end outward to :data:`DIGITS` significant digits (the low end down,
the high end up), so the rounded range still holds the set; the unrounded ranges stay
under the condition's ``calibration``.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

#: The desirability that defines the set: the default of :func:`demcal.optimize.optimize`,
#: which :func:`demcal.campaign.solve.solve_condition` uses (Design-Expert's "most desirable").
THRESHOLD = 0.99

#: Significant digits of a range's ends on the card (the calibrated values' own digits,
#: :data:`demcal.campaign.solve.PARAMETER_DIGITS`).
DIGITS = 3

MEANING = (
    "Each range is the extent, along that parameter, of the settings inside the condition's last "
    "design box where the fitted response surface (corrected to the production profile) meets every "
    f"lab target's mean with overall desirability >= {THRESHOLD:g}, which for one target is a predicted "
    "mean within 1 % of the distance from the lab mean to the box runs' lowest or highest response "
    "(multi-start search, then SLSQP extremes and slices of the box; ends rounded outward to "
    f"{DIGITS} significant digits); not every combination inside the ranges meets the targets, and "
    "the set is not widened for the lab sd, the model's prediction interval or the seed noise, so "
    "the parameters compatible with the lab within its sd and the noise form a wider set."
)


COMPATIBLE_MEANING = (
    "Each range is the extent, along that parameter, of the region of the condition's last design box "
    "where the fitted response surface (corrected to the production profile) predicts every lab target "
    "inside the lab mean +- sd, within the surface's 95 % confidence interval of the mean (the seed noise "
    "it averages; Design-Expert's overlay region, sampled with 2^14 scrambled Sobol points; ends rounded "
    f"outward to {DIGITS} significant digits); not every combination inside the ranges meets the targets, "
    "and the uncertainty of a correction to the production profile is not added."
)


def solution_set(calibrated: Mapping[str, Any],
                 parameters: Mapping[str, Mapping[str, Any]]) -> tuple[dict[str, Any] | None, str | None]:
    """The card's ``solution_set`` of one condition (its entry ``calibrated`` of
    calibration.json; ``parameters`` the card's, for the units), and why there is none.

    Returns ``({KEY: {"low", "high", "unit"}, ..., "meaning": MEANING}, None)``, or
    ``(None, reason)`` when calibration.json holds no range for the condition: verified at
    a point on the path of steepest ascent (no design around it), no setting of the box
    meeting the targets, or no ``factor_ranges`` at all (an older calibration.json).
    """
    ranges = calibrated.get("factor_ranges")
    meaning = MEANING
    if calibrated.get("compatible_ranges"):  # the lab window's region, where calibrate wrote it
        ranges, meaning = calibrated["compatible_ranges"], COMPATIBLE_MEANING
    chosen = calibrated.get("chosen") or {}
    out: dict[str, Any] = {}
    for key in chosen:
        ends = ranges.get(key) if isinstance(ranges, Mapping) else None
        if not _ends(ends):
            continue
        unit = parameters.get(key, {}).get("unit", "-")
        out[key] = {"low": outward(min(ends), down=True), "high": outward(max(ends), down=False), "unit": unit}
    if out:
        out["meaning"] = meaning
        return out, None
    return None, _why_none(calibrated, ranges)


def _ends(ends) -> bool:
    return (isinstance(ends, (list, tuple)) and len(ends) == 2
            and all(isinstance(x, (int, float)) and math.isfinite(x) for x in ends))


def _why_none(calibrated: Mapping[str, Any], ranges) -> str:
    """The end of the warning "condition 'X' has no solution set: ...", by what
    calibration.json says."""
    on_path = calibrated.get("on_path")
    if isinstance(on_path, Mapping):
        where = "the end of" if on_path.get("limit") else "a point on"
        way = on_path.get("way")
        status = calibrated.get("status", "verified")
        done = "it was verified" if status == "verified" else f"its loop stopped ({status})"
        return (f"{done} at {where} the path of steepest {way or 'ascent'}, with no design around it, "
                "so the card gives one point and no ranges")
    if ranges is None:
        return ("calibration.json records no factor_ranges for it (written by an older demcal or by hand); "
                "calibrate again for the ranges")
    return ("no setting of its last design box meets every target on the model (desirability >= "
            f"{THRESHOLD:g}), so the card gives the box's best point and no ranges")


def outward(value: float, down: bool, digits: int = DIGITS) -> float:
    """``value`` to ``digits`` significant digits, rounded down (``down``) or up:
    ``outward(0.31573, True)`` is 0.315, ``outward(0.49585, False)`` 0.496; a value
    already that short is kept (0.52 stays 0.52, not 0.521)."""
    x = float(value)
    if x == 0 or not math.isfinite(x):
        return x
    exponent = math.floor(math.log10(abs(x))) - digits + 1
    scaled = round(x / 10.0 ** exponent, 6)  # drop binary noise: 0.52 / 1e-3 = 520.0000000000001
    whole = math.floor(scaled) if down else math.ceil(scaled)
    return float(f"{whole}e{exponent}")
