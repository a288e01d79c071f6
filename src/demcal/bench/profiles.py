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

The bias is a constant, or linear in the material values that it measurably depends
on: :func:`measure` adds a setting to the model only when an F-test says its slope is
real (p < 0.05) and two degrees of freedom remain (forward selection, the classic way to
grow a regression from few points). With type A rolling the funnel's paper-profile heap
falls where the quick heap rises with the rolling friction, so its bias is a slope in
``particle.rolling_friction``; the incline's grows with the base's resistance (the deep
paper bed fails inside before its base slides), a slope in ``film.static_friction`` and
``film.rolling_friction`` (docs/validation.md).
:meth:`ProfileBias.at` gives the bias and its standard deviation at a point: the model's
standard error there and the scatter of the points about the model, combined.

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
    #: settings the bias is linear in (none: a constant); ``bias`` and ``se`` hold at
    #: ``reference`` (their mean over the points), ``slopes`` are degrees per unit of each
    terms: tuple = field(default=())
    reference: dict = field(default_factory=dict)
    slopes: tuple = field(default=())
    covariance: tuple = field(default=())  #: of (bias, *slopes), rows; empty for a constant
    sd_resid: float | None = None  #: scatter of the points about the model (None: sd_points)

    def at(self, settings: Mapping[str, float]) -> tuple[float, float]:
        """The bias at ``settings`` and its sd: the model's standard error there and the
        points' scatter about the model, combined (a constant: ``hypot(se, sd_points)``).
        A term missing from ``settings`` is taken at the reference."""
        if not self.terms:
            return self.bias, math.hypot(self.se, self.sd_points)
        x = self._offsets(settings)
        mean = self.bias + sum(s * xi for s, xi in zip(self.slopes, x[1:]))
        return mean, math.hypot(self.se_at(settings), self.sd_resid)

    def se_at(self, settings: Mapping[str, float]) -> float:
        """The standard error of the bias model itself at ``settings`` (without the
        points' scatter about it; a constant: ``se``)."""
        if not self.terms:
            return self.se
        x = self._offsets(settings)
        var = sum(x[i] * self.covariance[i][j] * x[j] for i in range(len(x)) for j in range(len(x)))
        return math.sqrt(max(var, 0.0))

    def _offsets(self, settings) -> list[float]:
        """(1, term - reference, ...) at ``settings``; a missing term at its reference."""
        return [1.0] + [float(settings.get(t, self.reference[t])) - self.reference[t] for t in self.terms]

    def slope_text(self) -> str:
        """The slopes in words, per 0.1 of each term (material values are coefficients of
        order 0.1-1, so a slope reads best per 0.1); empty for a constant."""
        return ", ".join(f"{s / 10:+.1f}° per 0.1 of {t}" for t, s in zip(self.terms, self.slopes))

    def outside(self, settings: Mapping[str, float], tol: float = 1e-9) -> list[str]:
        """The settings of ``settings`` that lie outside the range the bias was measured
        over (the points' lowest to highest value of each setting they name), one phrase
        each, e.g. ``"film.static_friction 0.746 (measured 0.4 to 0.6)"``. A bias is a
        measurement at its points: beyond them it is an extrapolation, which the loop
        says (:func:`demcal.campaign.loop.run_condition`)."""
        out = []
        for key in sorted({k for pt in self.points for k in pt.get("settings", {})}):
            values = [float(pt["settings"][key]) for pt in self.points if key in pt.get("settings", {})]
            if key not in settings or not values:
                continue
            lo, hi, v = min(values), max(values), float(settings[key])
            if v < lo - tol or v > hi + tol:
                out.append(f"{key} {v:g} (measured {lo:g} to {hi:g})")
        return out

    def describe(self) -> str:
        if not self.terms:
            return (f"stored {self.cheap} → {self.production} bias {self.bias:+.2f} ± {self.se:.2f}° "
                    f"(sd over {len(self.points)} design points {self.sd_points:.2f}°; measured {self.measured})")
        linear = self.slope_text()
        at = ", ".join(f"{t} = {self.reference[t]:g}" for t in self.terms)
        return (f"stored {self.cheap} → {self.production} bias {self.bias:+.2f} ± {self.se:.2f}° at {at}, "
                f"{linear} (scatter about it over {len(self.points)} design points {self.sd_resid:.2f}°; "
                f"measured {self.measured})")


def _load() -> list[ProfileBias]:
    path = importlib.resources.files("demcal") / "data" / "profile_bias.json"
    if not path.is_file():
        return []
    rows = json.loads(path.read_text())
    return [ProfileBias(**{**r, "points": tuple(r.get("points", ())), "terms": tuple(r.get("terms", ())),
                           "slopes": tuple(r.get("slopes", ())),
                           "covariance": tuple(tuple(c) for c in r.get("covariance", ()))}) for r in rows]


def stored(test: str, response: str, cheap: str, production: str) -> ProfileBias | None:
    """The stored bias for this test, response and pair of profiles, or None."""
    for b in _load():
        if (b.test, b.response, b.cheap, b.production) == (test, response, cheap, production):
            return b
    return None


def noise_points(test: str, response: str, profile: str) -> list[tuple[dict, int, float]]:
    """``(settings, n, sd)`` of each distinct point that the stored studies with
    ``profile`` as their *production* profile ran with two seeds or more: the seed-to-seed
    scatter of that bench, measured where the studies measured the bias.

    A study of a cheap and a production profile replicates its production runs to
    measure the bias; the same runs measure the production bench's scatter between seeds.
    The calibration loop pools them with its own production runs
    (:func:`demcal.campaign.loop.production_noise`), leaving out a point it has run
    itself (some of the incline's stored points are the verification runs of earlier
    paper-profile calibrations, and would otherwise count twice). Two studies that share
    production points (``quick`` and ``medium`` against ``paper``) count each point once."""
    seen: dict[str, tuple[dict, int, float]] = {}
    for b in _load():
        if (b.test, b.response, b.production) != (test, response, profile):
            continue
        for pt in b.points:
            n, sd = int(pt.get("production_n") or 0), pt.get("production_sd")
            settings = dict(pt.get("settings", {}))
            key = json.dumps(settings, sort_keys=True)
            if n > 1 and sd is not None and n > seen.get(key, ({}, 0, 0.0))[1]:
                seen[key] = (settings, n, float(sd))
    return list(seen.values())


def stored_noise(test: str, response: str, profile: str) -> tuple[float, int, int]:
    """``(sd, df, runs)``: the seed-to-seed sd of ``profile``'s ``response`` pooled over
    :func:`noise_points` (the paper-profile incline: 0.74 deg over eleven points of three
    seeds, 22 df), its degrees of freedom and the runs behind it; ``(nan, 0, 0)`` where no
    study replicated that profile."""
    points = noise_points(test, response, profile)
    df = sum(n - 1 for _, n, _ in points)
    ss = sum((n - 1) * sd * sd for _, n, sd in points)
    return (math.sqrt(ss / df) if df else float("nan")), df, sum(n for _, n, _ in points)


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
    seen = set()
    for row in runs:
        if row.get("test") != test or "responses" not in row or response not in row["responses"]:
            continue
        if row.get("profile") not in (cheap, production):
            continue
        key = json.dumps(row.get("set", {}), sort_keys=True)
        run = (key, row["profile"], row.get("seed"))
        if row.get("seed") is not None and run in seen:
            continue  # the same run in two study files (a rerun on another machine) counts once
        seen.add(run)
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
    terms, fit = _select_terms([pt["settings"] for pt in points], diffs)
    if not terms:
        return ProfileBias(test, response, cheap, production, _mean(diffs), sd / math.sqrt(len(diffs)), sd,
                           tuple(points), source, measured)
    coef, cov, s_resid, reference = fit
    return ProfileBias(test, response, cheap, production, float(coef[0]), math.sqrt(cov[0][0]), sd,
                       tuple(points), source, measured, terms=tuple(terms), reference=reference,
                       slopes=tuple(float(c) for c in coef[1:]),
                       covariance=tuple(tuple(float(v) for v in row) for row in cov), sd_resid=s_resid)


def _fit(settings: list[dict], diffs: list[float], terms: list[str]):
    """Least squares of the differences on the terms, centred on their mean: (coefficients,
    their covariance, residual sd, reference), or None without two degrees of freedom."""
    import numpy as np

    n, k = len(diffs), len(terms) + 1
    if n - k < 2:
        return None
    reference = {t: statistics.fmean(float(s[t]) for s in settings) for t in terms}
    X = np.column_stack([np.ones(n)] + [[float(s[t]) - reference[t] for s in settings] for t in terms])
    if np.linalg.matrix_rank(X) < k:
        return None  # a term that moves with one already in: nothing new to fit
    y = np.asarray(diffs, float)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    ss = float(((y - X @ coef) ** 2).sum())
    s2 = ss / (n - k)
    return coef, (s2 * np.linalg.inv(X.T @ X)).tolist(), math.sqrt(s2), reference, ss


def _select_terms(settings: list[dict], diffs: list[float]) -> tuple[list[str], tuple | None]:
    """Forward selection: add the setting that explains most of the differences while its
    partial F-test gives p < 0.05 and two degrees of freedom remain. Only settings that
    every point has and that vary between points are candidates. (Each step tests the
    best of several candidates, so the chance of taking a term by luck is above 5 %:
    a stored slope should be one the physics explains, as the funnel's is.)"""
    from scipy import stats

    names = set.intersection(*(set(s) for s in settings)) if settings else set()
    candidates = sorted(t for t in names if len({round(float(s[t]), 9) for s in settings}) > 1)
    mean = statistics.fmean(diffs)
    ss_now = sum((d - mean) ** 2 for d in diffs)
    chosen: list[str] = []
    best_fit = None
    while True:
        trials = [(f, t) for t in candidates if t not in chosen
                  for f in [_fit(settings, diffs, chosen + [t])] if f is not None]
        if not trials:
            break
        fit, term = min(trials, key=lambda ft: ft[0][4])
        dof = len(diffs) - len(chosen) - 2
        ss_new = fit[4]
        if ss_new > 0.0 and stats.f.sf((ss_now - ss_new) / (ss_new / dof), 1, dof) >= 0.05:
            break
        chosen.append(term)
        best_fit, ss_now = fit[:4], ss_new
    return chosen, best_fit


def _mean(values) -> float:
    return statistics.fmean(values)


def _sd(values) -> float | None:
    """The sample sd, None for fewer than two values (JSON has no NaN)."""
    return statistics.stdev(values) if len(values) > 1 else None
