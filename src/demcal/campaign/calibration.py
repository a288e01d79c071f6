"""What ``demcal calibrate`` found: the calibration's result types and their text.

A :class:`Calibration` holds every design's fit (:class:`DesignFit`) and every
condition's result (:class:`ConditionResult`): the chosen parameters, the solution
set's factor ranges and, per response, a :class:`ResponseVerdict` of simulated against
measured, with the model's prediction intervals (:meth:`ResponseVerdict.interval_of`).
:meth:`Calibration.to_dict` is calibration.json; :func:`describe` is the terminal's
summary. :func:`demcal.campaign.calibrate.calibrate` makes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from demcal.campaign.config import Campaign, Condition
from demcal.campaign.store import RunRecord, RunSpec

#: Confidence of the verification runs' prediction intervals.
PREDICTION_LEVEL = 0.95


@dataclass
class ResponseVerdict:
    """Simulated against measured for one response of one condition."""

    response: str
    target: float
    lab_sd: float | None
    predicted: float  #: the model's prediction at the chosen parameters
    simulated: list[float]  #: each verification replicate
    reachable: tuple[float, float]  #: the model's range inside the design box
    #: why there is no interval, when there is none
    no_interval: str = "no residual degrees of freedom"
    #: what the intervals are made of (:func:`prediction_parts`): the model's prediction,
    #: the t quantile, the residual mean square and the prediction's standard error
    #: (NaNs: no interval)
    parts: tuple[float, float, float, float] = (float("nan"),) * 4

    def interval_of(self, n: int) -> tuple[float, float]:
        """The model's 95 % prediction interval of the mean of ``n`` new runs at the
        chosen parameters, ``centre ± t · sqrt(MSE / n + se²)`` (NaNs: none)."""
        centre, t, mse, se = self.parts
        if n < 1 or not np.all(np.isfinite(self.parts)):
            return float("nan"), float("nan")
        half = t * float(np.sqrt(mse / n + se * se))
        return centre - half, centre + half

    @property
    def interval(self) -> tuple[float, float]:
        """The 95 % prediction interval of one new run."""
        return self.interval_of(1)

    @property
    def simulated_mean(self) -> float:
        return float(np.mean(self.simulated)) if self.simulated else float("nan")

    @property
    def simulated_sd(self) -> float:
        return float(np.std(self.simulated, ddof=1)) if len(self.simulated) > 1 else float("nan")

    @property
    def relative_error_percent(self) -> float:
        return 100.0 * abs(self.simulated_mean - self.target) / abs(self.target)

    @property
    def within_lab_sd(self) -> bool | None:
        if self.lab_sd is None or not self.simulated:
            return None
        return abs(self.simulated_mean - self.target) <= self.lab_sd

    @property
    def mean_interval(self) -> tuple[float, float]:
        """The model's 95 % prediction interval of the mean of the verification runs
        (:meth:`interval_of` their number), so that the check it makes does not fail more
        often as replicates are added."""
        return self.interval_of(len(self.simulated))

    @property
    def confirmation(self) -> str:
        """The model check: "confirmed" when the mean of the verification runs lies inside
        the model's prediction interval for a mean of that many runs (:attr:`mean_interval`).
        It says whether the response model predicted the simulation; whether the
        calibration is verified is the lab's rule (:attr:`within_lab_sd` and the loop's)."""
        if not self.simulated:
            return "not simulated yet"
        lo, hi = self.mean_interval
        if not (np.isfinite(lo) and np.isfinite(hi)):
            return f"no interval ({self.no_interval})"
        if lo <= self.simulated_mean <= hi:
            return "confirmed"
        return f"not confirmed (the mean {self.simulated_mean:.2f} lies outside {lo:.2f} to {hi:.2f})"

    @property
    def target_reachable(self) -> bool:
        lo, hi = self.reachable
        tol = 1e-9 * max(1.0, abs(hi - lo))
        return lo - tol <= self.target <= hi + tol


@dataclass
class HoldoutResult:
    """A test the calibration did not fit (``[[holdout]]``), run at one condition's
    calibrated values, against its lab value. The rule is the verification's: the
    simulated mean inside the lab mean ± sd agrees."""

    test: str
    response: str
    profile: str
    target: float
    lab_sd: float | None
    simulated: list[float]  #: each replicate
    runs: int  #: replicates asked for

    @property
    def mean(self) -> float:
        return float(np.mean(self.simulated)) if self.simulated else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        """The 95 % confidence interval of the simulated mean (Student's t), NaNs with
        fewer than two runs."""
        n = len(self.simulated)
        if n < 2:
            return float("nan"), float("nan")
        from scipy import stats

        half = float(stats.t.ppf(0.975, n - 1)) * float(np.std(self.simulated, ddof=1)) / np.sqrt(n)
        return self.mean - half, self.mean + half

    @property
    def verdict(self) -> str:
        if len(self.simulated) < self.runs:
            return f"{len(self.simulated)} of {self.runs} runs done"
        if self.lab_sd is None:
            return f"simulated {self.mean:.2f} against the lab's {self.target:g} (no lab sd to judge by)"
        miss = self.mean - self.target
        if abs(miss) <= self.lab_sd:
            return "agrees: the simulated mean lies inside the lab mean ± sd"
        return (f"misses: the simulated mean lies {abs(miss):.2f} {'above' if miss > 0 else 'below'} the lab "
                f"mean, outside its sd {self.lab_sd:g}")

    def to_dict(self) -> dict:
        lo, hi = self.interval
        return {"test": self.test, "response": self.response, "profile": self.profile, "target": self.target,
                "lab_sd": self.lab_sd, "simulated": self.simulated, "simulated_mean": _num(self.mean),
                "interval_95": [_num(lo), _num(hi)], "runs": self.runs, "verdict": self.verdict}


@dataclass
class ConditionResult:
    """The calibration of one condition (e.g. one moisture content)."""

    condition: Condition
    chosen: dict[str, float]  #: parameter key -> calibrated value (what was simulated)
    chosen_coded: dict[str, float]  #: factor name -> coded level
    desirability: float
    optimization: Any  #: demcal.optimize.Optimization; its first solution is the chosen one
    factor_ranges: dict[str, tuple[float, float]]  #: parameter key -> range over the solution set
    verdicts: list[ResponseVerdict]
    verification: list[RunRecord]
    specs: list[RunSpec]
    notes: list[str] = field(default_factory=list)
    reference_predicted: dict[str, float] = field(default_factory=dict)  #: response -> model at the published values
    loop: Any = None  #: the :class:`demcal.campaign.loop.LoopResult` that found it
    #: parameter key -> (low, high) over the box's region where every target's model
    #: predicts inside the lab mean ± sd within its 95 % interval of the mean
    #: (:func:`demcal.campaign.calibrate.compatible_ranges`)
    compatible: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: a joint test's compatible ranges of each of its tests alone, by test
    compatible_by_test: dict[str, dict[str, tuple[float, float]]] = field(default_factory=dict)
    #: the campaign's hold-out tests run at these values (``[[holdout]]``)
    holdouts: list[HoldoutResult] = field(default_factory=list)

    @property
    def solutions(self) -> pd.DataFrame:
        """The distinct solutions of the search, the chosen one first."""
        return self.optimization.solutions

    @property
    def verified(self) -> bool:
        return bool(self.verification) and all(r.status == "done" for r in self.verification)


@dataclass
class DesignFit:
    """One design of a campaign with its results and models: the campaign's own, or one per
    distinct set of conditions' fixed settings (:meth:`Campaign.designs`)."""

    campaign: Campaign  #: the campaign as this design's runs see it (its conditions' settings added)
    conditions: tuple[Condition, ...]  #: the conditions it serves
    table: pd.DataFrame  #: the design with its results (design_results)
    full: dict[str, Any]  #: response -> the full model of the campaign's order
    models: dict[str, Any]  #: response -> the model used (reduced if asked)
    removed: dict[str, tuple]  #: response -> terms removed by the reduction, with p

    @property
    def name(self) -> str:
        """The conditions it serves, e.g. "6.26 %" or "6.26 %, 14.1 %"."""
        return ", ".join(c.name for c in self.conditions)


@dataclass
class Calibration:
    """Everything ``demcal calibrate`` found for a campaign."""

    campaign: Campaign
    table: pd.DataFrame  #: the (first) design with its results (design_results)
    full: dict[str, Any]  #: response -> the full model of the campaign's order (first design)
    models: dict[str, Any]  #: response -> the model used (reduced if asked; first design)
    removed: dict[str, tuple]  #: response -> terms removed by the reduction, with p (first design)
    conditions: list[ConditionResult]
    notes: list[str] = field(default_factory=list)
    #: what must be read before the results (failed design runs left out of the fit);
    #: the same facts are in ``notes``, which the report shows
    warnings: list[str] = field(default_factory=list)
    #: every design: one, or one per distinct set of conditions' fixed settings
    designs: list[DesignFit] = field(default_factory=list)
    #: lab sds below the simulation's seed noise, one sentence each
    #: (:func:`demcal.campaign.calibrate.lab_noise_warnings`): the terminal and the report
    #: say them with the warnings; calibration.json does not hold them
    lab_noise: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.designs:
            self.designs = [DesignFit(self.campaign, tuple(self.campaign.conditions), self.table, self.full,
                                      self.models, self.removed)]

    def to_dict(self) -> dict[str, Any]:
        """calibration.json: with several designs, each condition holds its design's models;
        with per-condition settings, each condition holds its fixed settings and their sources."""
        from demcal.campaign.digest import campaign_hash

        out: dict[str, Any] = {"campaign": self.campaign.name, "profile": self.campaign.profile,
                               "production": self.campaign.calibration.production,
                               "campaign_hash": campaign_hash(self.campaign),
                               "test": self.campaign.test, "warnings": list(self.warnings),
                               "notes": list(self.notes), "models": {},
                               "conditions": []}
        several = len(self.designs) > 1
        if not several:
            out["models"] = _models_dict(self.campaign, self.designs[0])
        settings = {}
        if self.campaign.per_condition:
            from demcal.campaign.chain import condition_settings

            settings = condition_settings(self.campaign)
        for result in self.conditions:
            design = next(d for d in self.designs if result.condition.name in {c.name for c in d.conditions})
            out["conditions"].append({
                "name": result.condition.name,
                **({"settings": {key: {"value": value, "source": source}
                                 for key, (value, source) in settings[result.condition.name].items()}}
                   if settings else {}),
                **({"models": _models_dict(self.campaign, design)} if several else {}),
                "chosen": result.chosen, "chosen_coded": result.chosen_coded,
                "desirability": _num(result.desirability),
                "factor_ranges": {k: list(v) for k, v in result.factor_ranges.items()},
                "compatible_ranges": {k: list(v) for k, v in result.compatible.items()},
                **({"holdout": [h.to_dict() for h in result.holdouts]} if result.holdouts else {}),
                **({"compatible_ranges_by_test": {test: {k: list(v) for k, v in ranges.items()}
                                                  for test, ranges in result.compatible_by_test.items()}}
                   if result.compatible_by_test else {}),
                "reference": dict(result.condition.reference),
                "reference_predicted": result.reference_predicted,
                "notes": result.notes,
                **(_loop_dict(self.campaign, result.loop) if result.loop is not None else {}),
                "verification": [
                    {"response": v.response, "target": v.target, "lab_sd": v.lab_sd, "predicted": v.predicted,
                     "simulated": v.simulated, "simulated_mean": _num(v.simulated_mean),
                     "simulated_sd": _num(v.simulated_sd), "relative_error_percent": _num(v.relative_error_percent),
                     "within_lab_sd": v.within_lab_sd, "reachable": list(v.reachable),
                     "target_reachable": v.target_reachable,
                     "prediction_interval": {"level": PREDICTION_LEVEL, "low": _num(v.interval[0]),
                                             "high": _num(v.interval[1])},
                     "mean_interval": {"level": PREDICTION_LEVEL, "n": len(v.simulated),
                                       "low": _num(v.mean_interval[0]), "high": _num(v.mean_interval[1])},
                     "confirmation": v.confirmation}
                    for v in result.verdicts
                ],
            })
        return out


def _models_dict(campaign: Campaign, design: DesignFit) -> dict[str, Any]:
    """The models of one design, for calibration.json."""
    return {name: {**model.to_dict(), "order": campaign.model_order,
                   "removed": [{"term": t, "p": p} for t, p in design.removed.get(name, ())],
                   "equation_coded": model.equation("coded"), "equation_actual": model.equation("actual")}
            for name, model in design.models.items()}


def _loop_dict(campaign: Campaign, loop) -> dict[str, Any]:
    """The loop's status, boxes, history and discrepancy models, for calibration.json."""
    return {"status": loop.status, "runs_by_stage": loop.runs_by_stage(), "status_reason": loop.reason,
            "production_profile": production_profile(campaign), "cheap_profile": campaign.profile,
            "box": loop.box.to_dict(campaign), "boxes": [b.to_dict(campaign) for b in loop.boxes],
            "history": [step.to_dict() for step in loop.history],
            "discrepancy": {r: d.describe() for r, d in loop.discrepancy.items()},
            "cheap_target": loop.cheap_target,
            **({"on_path": {**loop.on_path, "steps": list(loop.on_path["steps"])}} if loop.on_path else {})}


def _num(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def production_profile(campaign: Campaign) -> str:
    """The profile the loop verifies at (``[calibration] production``, else the campaign's)."""
    production = campaign.calibration.production or campaign.profile
    if production != campaign.profile:
        campaign.with_profile(production)  # its settings must suit that profile too
    return production


def describe(calibration: Calibration) -> str:
    """A few lines for the terminal; warnings about the design come first.

    Every value is rounded to the precision its noise supports and carries its unit
    (:mod:`demcal.rounding`): a response value to its lab sd's, a mean with its 95 %
    interval, a parameter to its solution set's width; responses go by their labels and
    the loop's notes read as short sentences (:mod:`demcal.campaign.wording`).
    calibration.json keeps every digit and the loop's own words."""
    from demcal.campaign import wording
    from demcal.rounding import measured, ranged, rounded

    c = calibration.campaign
    words = wording.Words(c)
    lines = [f"warning: {words.keys(warning)}" for warning in calibration.warnings + calibration.lab_noise]
    several = len(calibration.designs) > 1
    for design in calibration.designs:
        for response, model in design.models.items():
            fit = model.fit
            unit = words.unit(response)
            lines.append((f"{design.name}: " if several else "")
                         + words.title(response) + (f" [{unit}]" if unit else "")
                         + f": {c.model_order} model"
                         + (f" reduced at alpha {c.reduce_alpha:g}" if design.removed[response] else "")
                         + f", R² {fit.r2:.3f}, adj. R² {fit.adj_r2:.3f}, pred. R² {fit.pred_r2:.3f}")
            lines.append(f"  {model.equation('coded', digits=4)}")
    fixed = {}
    if c.per_condition:
        from demcal.campaign.chain import SOURCE_DEFAULT, condition_settings

        fixed = condition_settings(c)
    units = {f.parameter: f.units for f in c.factors}
    for result in calibration.conditions:
        w = wording.Words(c, result.condition)
        lines.append(f"{result.condition.name}: {wording.clause(wording.stop(c, result))}".rstrip(": "))
        for key, value in result.chosen.items():
            lo, hi = result.factor_ranges.get(key, (float("nan"), float("nan")))
            shown, low, high = ranged(value, lo, hi, units.get(key))
            lines.append(f"  {key} = {shown}" + (f" (solution set {low} to {high})" if low and high else ""))
        if fixed:
            lines.append("  fixed: " + ", ".join(f"{k} = {v} ({source})" for k, (v, source)
                                                 in fixed[result.condition.name].items() if source != SOURCE_DEFAULT))
        for v in result.verdicts:
            lines.extend(_verdict_lines(w, result, v, rounded))
        for h in result.holdouts:
            lab = measured(h.target, h.lab_sd if h.lab_sd else float("nan"))
            lo, hi = h.interval
            sim = (f"{measured(h.mean, (hi - lo) / 2)} (95 %, n = {len(h.simulated)})" if np.isfinite(lo) else
                   (f"{rounded(h.mean, h.lab_sd or float('nan'))} (n = {len(h.simulated)})" if h.simulated
                    else "not simulated yet"))
            lines.append(f"  hold-out {h.test}, {w.title(h.response)}: lab {lab}, simulated {sim}: {h.verdict}")
        lines.extend(f"  note: {note}" for note in wording.notes(c, result))
    for note in calibration.notes:
        if note not in calibration.warnings:
            lines.append(f"note: {words.plain(note)}")
    return "\n".join(lines)


def _verdict_lines(w, result: ConditionResult, v: ResponseVerdict, rounded) -> list[str]:
    """One response's verdict for the terminal: lab, model, simulated mean ± its 95 %
    interval, and the model check."""
    from demcal.campaign.wording import half_width

    r = v.response
    parts = [f"lab {w.window(v.target, v.lab_sd, r)}", f"model {w.value(v.predicted, r)}"]
    n = len(v.simulated)
    half = half_width(result, v) if n else float("nan")
    if n:
        spread = half if np.isfinite(half) else (v.lab_sd or float("nan"))
        inside = {True: "inside the lab's mean ± sd", False: "outside the lab's mean ± sd",
                  None: "no lab sd to judge by"}[v.within_lab_sd]
        mean = (f"{w.window(v.simulated_mean, half, r)} (95 %, n = {n})" if np.isfinite(half)
                else f"{w.value(v.simulated_mean, r)} (n = {n})")
        parts.append(f"simulated {mean}, error "
                     f"{rounded(v.relative_error_percent, 100 * spread / abs(v.target), '%')}: {inside}")
    else:
        parts.append("not simulated yet")
    lines = [f"  {w.title(r)}: " + ", ".join(parts)]
    lo, hi = v.mean_interval
    if n and np.isfinite(lo) and np.isfinite(hi):
        half_model = (hi - lo) / 2
        unit = w.unit(r)
        check = "confirmed" if v.confirmation == "confirmed" else (
            f"not confirmed, the mean {rounded(v.simulated_mean, half_model, unit)} lies outside it")
        lines.append(f"  model check: the model's 95 % interval for a mean of {n} is "
                     f"{rounded(lo, half_model)} to {rounded(hi, half_model, unit)}: {check}")
    return lines
