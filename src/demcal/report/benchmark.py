"""demcal's benches against published responses at the same parameter values.

A campaign whose ``[report] reference_table`` is a published design table (coded factor
columns named like the campaign's factors and a response column, e.g. the paper's
Tables 4 and 8) is compared point by point: for every profile that has runs at those
parameter values in the store, the mean of demcal's runs at each design point against
the published value, with the mean offset (demcal - published), the RMS difference, the
correlation and the slope of demcal on published (ordinary least squares). A slope of 1
with an offset is a level shift; a slope far from 1 means the factor effects differ.
Error bars are the seed-to-seed sd: the point's own where it has replicates, else the sd
pooled over every point that has.

Where a bias from a cheap profile to the paper profile was measured
(:mod:`demcal.bench.profiles`) and applies to the campaign's fixed settings, the cheap
profile's comparison is repeated with that bias added ("quick + stored bias"): what the
cheap runs say the paper profile would give, with the bias's standard error added to the
error bars. It is a separate row, never a replacement of the runs' own numbers.
"""

from __future__ import annotations

import textwrap

from dataclasses import dataclass

import numpy as np
import pandas as pd

from demcal.campaign.config import Campaign


@dataclass
class Comparison:
    """One profile's point-by-point comparison."""

    profile: str
    points: pd.DataFrame  #: run, coded factors, published, demcal mean, sd, n
    offset: float
    rms: float
    correlation: float
    slope: float
    pooled_sd: float

    def summary(self) -> dict:
        return {"profile": self.profile, "points": len(self.points), "mean offset": self.offset,
                "RMS": self.rms, "correlation": self.correlation, "slope": self.slope,
                "seed sd (pooled)": self.pooled_sd}


def read_reference(campaign: Campaign, response: str) -> pd.DataFrame | None:
    """The reference table with the campaign's factor columns and ``response``, or None."""
    if campaign.reference_table is None:
        return None
    from demcal.doe.io import read_table
    from demcal.errors import DemcalError

    try:
        ref = read_table(campaign.reference_table)  # with the CSV size limit
    except (OSError, DemcalError):
        return None
    if response not in ref or not set(campaign.factor_names) <= set(ref.columns):
        return None
    return ref


def compare(campaign: Campaign, response: str, records) -> list[Comparison]:
    """One :class:`Comparison` per profile with runs at the reference table's points."""
    ref = read_reference(campaign, response)
    if ref is None:
        return []
    from demcal.campaign.loop import campaign_runs, pooled_sd

    names = campaign.factor_names
    by_profile: dict[str, dict[tuple, list[float]]] = {}
    for r in campaign_runs(campaign, records):
        if response not in r.responses:
            continue
        coded = tuple(round(float(f.to_coded(r.parameters[f.parameter])), 6) for f in campaign.factors)
        by_profile.setdefault(r.profile, {}).setdefault(coded, []).append(float(r.responses[response]))
    out = []
    for profile, groups in sorted(by_profile.items()):
        rows = []
        for _, row in ref.iterrows():
            key = tuple(round(float(row[n]), 6) for n in names)
            values = groups.get(key)
            if not values:
                continue
            rows.append({"run": int(row["run"]) if "run" in row else len(rows) + 1,
                         **{n: float(row[n]) for n in names}, "published": float(row[response]),
                         "demcal": float(np.mean(values)), "n": len(values),
                         "sd": float(np.std(values, ddof=1)) if len(values) > 1 else np.nan})
        if len(rows) < 3:
            continue
        points = pd.DataFrame(rows)
        pooled, _ = pooled_sd(groups.values())
        out.append(_comparison(profile, points, pooled))
    return out + [b for b in (_with_stored_bias(campaign, response, c) for c in out) if b is not None]


def _comparison(profile: str, points: pd.DataFrame, pooled: float) -> Comparison:
    diff = points["demcal"] - points["published"]
    x, y = points["published"].to_numpy(), points["demcal"].to_numpy()
    slope = float(np.polyfit(x, y, 1)[0]) if np.ptp(x) > 0 else np.nan
    corr = float(np.corrcoef(x, y)[0, 1]) if np.ptp(x) > 0 and np.ptp(y) > 0 else np.nan
    return Comparison(profile, points, float(diff.mean()), float(np.sqrt((diff ** 2).mean())), corr, slope, pooled)


def _with_stored_bias(campaign: Campaign, response: str, c: Comparison) -> Comparison | None:
    """``c`` shifted by the stored bias from its profile to the paper profile, if one applies."""
    from demcal.bench import profiles

    if c.profile == "paper":
        return None
    bias = profiles.stored(campaign.test, response, c.profile, "paper")
    if bias is None or profiles.applies(campaign.settings):
        return None
    points = c.points.copy()
    # a bias linear in a material value (the funnel's, in the rolling friction) is read at
    # each point's settings; its se there is the model's, not the points' scatter about it
    settings = [{**campaign.settings, **{f.parameter: float(f.to_actual(row[f.name])) for f in campaign.factors}}
                for _, row in points.iterrows()]
    shift = np.array([bias.at(x)[0] for x in settings])
    se = np.array([bias.se_at(x) for x in settings])
    points["demcal"] = points["demcal"] + shift
    seed_sd = points["sd"].fillna(c.pooled_sd).fillna(0.0)  # no replicates anywhere: the bias's se alone
    points["sd"] = np.sqrt(seed_sd ** 2 + se ** 2)
    label = ", ".join([f"{bias.bias:+.2f}°" + (" at the centre" if bias.terms else "")]
                      + ([bias.slope_text()] if bias.terms else []))
    return _comparison(f"{c.profile} + stored bias to paper ({label})", points,
                       float(np.hypot(c.pooled_sd, float(se.mean()))))


def figure(comparisons: list[Comparison], response: str, label: str):
    """demcal against published, one marker per profile, 1:1 line, seed sd as error bars."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.2, 4.6), dpi=110)
    ax = fig.add_subplot()
    lo, hi = np.inf, -np.inf
    for i, c in enumerate(comparisons):
        p = c.points
        err = p["sd"].fillna(c.pooled_sd).to_numpy()
        # a profile with a stored linear bias has a long name: wrapped, so the legend
        # stays inside the figure
        name = textwrap.fill(f"{c.profile}: offset {c.offset:+.2f}°, RMS {c.rms:.2f}°, slope {c.slope:.2f}",
                             52, subsequent_indent="  ")
        ax.errorbar(p["published"], p["demcal"], yerr=np.where(np.isfinite(err), err, 0.0), fmt="os^D"[i % 4],
                    ms=4, lw=0.8, capsize=2, color=f"C{i}", label=name)
        lo = min(lo, p["published"].min(), p["demcal"].min())
        hi = max(hi, p["published"].max(), p["demcal"].max())
    pad = 0.05 * (hi - lo)
    ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], color="0.4", lw=1, ls="--", label="1:1")
    ax.set_xlabel(f"published {label} [°]")
    ax.set_ylabel(f"demcal {label} [°]")
    ax.legend(frameon=False, fontsize=8)
    fig.tight_layout()
    return fig
