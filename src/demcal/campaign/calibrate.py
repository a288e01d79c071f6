"""Calibrate: fit the response model, solve each lab target, verify by simulation.

``demcal calibrate campaign.toml`` (paper §2.3 and §3.2):

1. the design results from the store are fitted with :mod:`demcal.rsm` (fit summary
   of the orders, the campaign's model order, reduced by backward elimination at
   ``[model] reduce_alpha`` if set);
2. each condition's target is solved with :mod:`demcal.optimize`: the whole
   solution set (desirability >= 0.99) and the range of every factor over it --
   one angle cannot pin down four parameters. The solution simulated is the one of
   the set nearest the design centre (least extrapolation); a target outside what
   the model reaches inside the design box is said so plainly, and the box's
   nearest point is simulated instead;
3. the chosen parameters are simulated again (``[verification] replicates``) through
   the same runner and store, and the simulated mean is set against the lab's mean
   with its relative error and whether it lies inside the lab's standard deviation;
   beside that verdict, the model check sets their mean against the model's 95 %
   prediction interval of a mean of that many runs (:func:`prediction_parts`,
   :attr:`ResponseVerdict.mean_interval`).

The model's adequacy is checked before anything is trusted (:func:`adequacy_warnings`,
Design-Expert's rules): predicted R² negative or more than 0.2 below adjusted R²,
significant lack of fit, adequate precision below 4, or the ``tiny`` profile.

Everything is recomputed from the store each time (the fits and the seeded search are
deterministic), so ``demcal report`` shows exactly what ``calibrate`` found.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from demcal.campaign.config import Campaign, Condition
from demcal.campaign.runner import check_store_owner, design_results, run_specs
from demcal.campaign.solve import fit_models, round_parameter, solve_condition
from demcal.campaign.store import RunRecord, RunSpec, Store, write_json_atomic
from demcal.errors import DataError

#: Design-Expert's rule: predicted R² within this of adjusted R² ("reasonable agreement").
R2_AGREEMENT = 0.2
#: Lack of fit significant below this p.
LACK_OF_FIT_ALPHA = 0.05
#: Adequate precision (signal to noise) below this cannot navigate the design space.
MIN_ADEQUATE_PRECISION = 4.0
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


def calibrate(campaign: Campaign, *, workers: int | None = None, scheduler: str | None = None,
              progress: bool = True, simulate: bool = True, retry_failed: bool = False,
              executor=None) -> Calibration:
    """Fit, solve every condition and (``simulate=True``) run the verification replicates.

    With ``simulate=False`` nothing is run: verification results are taken from the
    store as far as they exist (what ``demcal report`` does). A campaign whose conditions
    take settings from another campaign (``from_campaign``) reads them first
    (:func:`demcal.campaign.chain.resolve_chain`); conditions with settings of their own
    are fitted, solved and verified on their own design's runs.
    """
    from demcal.campaign.chain import resolve_chain

    campaign = resolve_chain(campaign)
    store_path = campaign.store_path
    production_profile(campaign)  # a production profile that does not suit the campaign: one sentence first
    if not store_path.is_file():
        if store_path.exists():  # a folder in its place: the store's own sentence
            Store(store_path, readonly=True).close()
        old = campaign.path.parent / f"{campaign.path.stem}-runs" / "store.sqlite"
        if old.is_file() and old.parent != store_path.parent:
            raise DataError(f"{campaign.path.name} has no results in {store_path.parent.name}, the store of campaign "
                            f"'{campaign.name}'; those in {old.parent.name} (the folder once named after the file) "
                            f"are found by adding workdir = \"{old.parent.name}\" to its [campaign].")
        raise DataError(f"{campaign.path.name} has no results yet; run `demcal run {campaign.path}` first.")
    with Store(store_path, readonly=True) as store:
        check_store_owner(campaign, store)
        designs = [(boxed, conditions) + _design_table(boxed, store) for boxed, conditions in campaign.designs()]
    fits, failed, poor, notes = [], [], [], []
    for boxed, conditions, table, elsewhere in designs:
        # with several designs, each sentence says whose design it is about
        whose = f"the design of {', '.join(c.name for c in conditions)}: " if len(designs) > 1 else ""
        fit, fit_failed, fit_notes = _fit_design(boxed, conditions, table, elsewhere, simulate, whose)
        fits.append(fit)
        failed += fit_failed
        poor += [whose + w for w in adequacy_warnings(boxed, fit.models, profile=False)]
        notes += fit_notes
    warnings = failed + adequacy_warnings(campaign, {}) + poor  # failed design runs first
    from demcal.campaign.chain import chain_notes

    notes = warnings + chain_notes(campaign) + [note for note in notes if note not in warnings]
    results = _close_loops(campaign, fits, notes, simulate=simulate, workers=workers, scheduler=scheduler,
                           progress=progress, retry_failed=retry_failed, executor=executor)
    first = fits[0]
    calibration = Calibration(campaign, first.table, first.full, first.models, first.removed, results, notes,
                              warnings, designs=fits)
    if simulate:
        write_json_atomic(campaign.workdir / "calibration.json", calibration.to_dict())
    return calibration


def _design_table(campaign: Campaign, store: Store) -> tuple[pd.DataFrame, dict[str, int]]:
    """The design with its results, and, when too few of its runs are done under the
    campaign's profile, profile -> design runs done under each other profile."""
    table = design_results(campaign, store)
    done = int((table["status"] == "done").sum())
    elsewhere = {}
    if done <= len(campaign.factors) + 1:
        from demcal.bench.registry import get_experiment
        from demcal.errors import DemcalError

        for profile in get_experiment(campaign.test).profiles:
            if profile == campaign.profile:
                continue
            try:
                other = design_results(campaign.with_profile(profile), store)
            except DemcalError:  # the campaign's settings do not fit that profile
                continue
            if (count := int((other["status"] == "done").sum())):
                elsewhere[profile] = count
    return table, elsewhere


def _fit_design(campaign: Campaign, conditions, table: pd.DataFrame, elsewhere: dict[str, int], simulate: bool,
                whose: str) -> tuple[DesignFit, list[str], list[str]]:
    """Fit one design's models once enough of its runs are done: ``(fit, failed, notes)``,
    ``failed`` the warning about its failed runs, if any (each sentence prefixed by
    ``whose``); one :class:`DataError` sentence when the design is not ready."""
    done = int((table["status"] == "done").sum())
    failed = int((table["status"] == "failed").sum())
    unfinished = len(table) - done - failed  # pending, running in another runner, or never planned
    if done <= len(campaign.factors) + 1 or (simulate and unfinished):
        if elsewhere:
            best = max(elsewhere, key=elsewhere.get)
            there = ", ".join(f"{n} are done under '{p}'" for p, n in sorted(elsewhere.items(), key=lambda i: -i[1]))
            here = (f"no design run is done under profile '{campaign.profile}'" if done == 0 else
                    f"only {done} of {len(table)} design runs are done under profile '{campaign.profile}'")
            raise DataError(f"{whose}{here}; {there}: give --profile {best}, or run "
                            f"`demcal run {campaign.path} --profile {campaign.profile}` to finish these.")
        if unfinished:
            raise _unfinished(campaign, table, unfinished, failed, whose)
        raise DataError(f"{whose}only {done} of {len(table)} design runs are done; rerun the failed ones with "
                        f"`demcal run {campaign.path} --profile {campaign.profile} --retry-failed`.")
    try:
        full, models, removed, notes = fit_models(campaign, table)
    except DataError:
        if unfinished:  # too few runs for the model: the advice is to finish the design
            raise _unfinished(campaign, table, unfinished, failed, whose) from None
        raise
    warnings = []
    if failed and not unfinished:
        # Said once, first, in place of the fit's per-response note of the same runs.
        warnings.append(f"{failed} of {len(table)} design runs failed and are left out of the fit, so the "
                        f"model rests on {done}; rerun them with `demcal run {campaign.path} --profile "
                        f"{campaign.profile} --retry-failed`, then calibrate again.")
        notes = [n for n in notes if "are left out of the fit" not in n]
    fit = DesignFit(campaign, tuple(conditions), table, full, models, removed)
    return fit, [whose + w for w in warnings], [whose + n for n in notes]


def adequacy_warnings(campaign: Campaign, models: dict, profile: bool = True) -> list[str]:
    """Why the fitted models may not be fit to calibrate with, one sentence each.

    Design-Expert's checks (Stat-Ease's help on the ANOVA's fit statistics): predicted
    R² negative, or more than :data:`R2_AGREEMENT` below adjusted R²; lack of fit
    significant (p < :data:`LACK_OF_FIT_ALPHA`); adequate precision (signal to noise)
    below :data:`MIN_ADEQUATE_PRECISION`. And (``profile``) the ``tiny`` profile, which
    only checks that the machinery runs.
    """
    out = []
    profiles = {campaign.profile, production_profile(campaign)}
    if profile and "tiny" in profiles:
        out.append("profile 'tiny' is a smoke test; not a calibration: its particles are too few for the "
                   f"angles to mean anything; run `demcal run {campaign.path} --profile quick` "
                   "and calibrate at that profile for parameters to use.")
    for response, model in models.items():
        fit = model.fit
        if np.isfinite(fit.pred_r2) and fit.pred_r2 < 0:
            out.append(f"{response}: predicted R² is {fit.pred_r2:.2f}, below zero: the model predicts a new run "
                       "worse than the mean of the runs does, so the calibrated parameters rest on noise; use more "
                       "runs (replicates, a larger design) or a lower [model] order.")
        elif np.isfinite(fit.pred_r2) and np.isfinite(fit.adj_r2) and fit.adj_r2 - fit.pred_r2 > R2_AGREEMENT:
            out.append(f"{response}: predicted R² {fit.pred_r2:.2f} is more than {R2_AGREEMENT:g} below adjusted "
                       f"R² {fit.adj_r2:.2f} (Design-Expert's rule): the model may be over-fitted or a run may be "
                       "an outlier; look at the diagnostics, reduce the model ([model] reduce_alpha) or add runs.")
        if model.has_lack_of_fit:
            p = float(model.anova.loc["Lack of Fit", "p"])
            if np.isfinite(p) and p < LACK_OF_FIT_ALPHA:
                out.append(f"{response}: lack of fit is significant (p = {p:.4f} < {LACK_OF_FIT_ALPHA:g}): the "
                           "design's points deviate from the model by more than the replicates scatter, so "
                           "its predictions between them are less certain than R² suggests; try a higher "
                           "[model] order or a smaller design box.")
        if np.isfinite(fit.adeq_precision) and fit.adeq_precision < MIN_ADEQUATE_PRECISION:
            out.append(f"{response}: adequate precision is {fit.adeq_precision:.2f}, below "
                       f"{MIN_ADEQUATE_PRECISION:g}: the model's signal is too weak against the run-to-run noise "
                       "to navigate the design space; widen the factor levels or add replicates.")
    return out


def prediction_parts(model, corrected, point,
                     level: float = PREDICTION_LEVEL) -> tuple[float, float, float, float]:
    """What the ``level`` prediction intervals at the coded ``point`` are made of:
    ``(centre, t, MSE, se)`` with ``centre = corrected.predict(point)``, ``t`` the
    ``1 - (1 - level)/2`` quantile at the residual degrees of freedom, ``MSE`` the
    residual mean square and ``se`` the standard error of the mean prediction of
    ``model`` (the cheap profile's fit in its box); ``corrected`` is that model plus the
    discrepancy (:class:`demcal.campaign.loop.CorrectedSurface`), whose mean shifts the
    interval and whose own uncertainty is not added (the regression prediction interval
    of Montgomery, *Design and Analysis of Experiments*, chapter "Fitting Regression
    Models"). NaNs when the model has no residual degrees of freedom."""
    from scipy import stats

    df = getattr(model, "df_residual", 0)
    mse = getattr(model, "mse", float("nan"))
    if df <= 0 or not np.isfinite(mse):
        return (float("nan"),) * 4
    point = np.asarray(point, float)
    se = float(model.prediction_se(point[None, :])[0])
    centre = float(np.asarray(corrected.predict(point[None, :]))[0])
    return centre, float(stats.t.ppf(0.5 + level / 2, df)), float(mse), se


def production_profile(campaign: Campaign) -> str:
    """The profile the loop verifies at (``[calibration] production``, else the campaign's)."""
    production = campaign.calibration.production or campaign.profile
    if production != campaign.profile:
        campaign.with_profile(production)  # its settings must suit that profile too
    return production


def _close_loops(campaign: Campaign, designs: list[DesignFit], notes: list[str], *, simulate: bool, workers,
                 scheduler, progress: bool, retry_failed: bool, executor) -> list[ConditionResult]:
    """Run :func:`demcal.campaign.loop.run_condition` for every condition, on its design
    and with its fixed settings (every run the loop asks for carries them)."""
    from demcal.campaign.executors import make_executor
    from demcal.campaign.loop import run_condition
    from demcal.optimize import reachable_range

    production = production_profile(campaign)
    store_path = campaign.store_path
    own: list = []
    cache: dict[str, Any] = {}

    # The loop sees only the runs it has asked for so far (the designs', then each
    # step's, in order), never runs that a later step or condition added to the store:
    # that keeps a replay (resume, `demcal report`) identical to the first pass.
    seen: set[str] = {key for design in designs for key in design.table["key"]}

    def records() -> list[RunRecord]:
        if "all" not in cache:
            with Store(store_path, readonly=True) as store:
                cache["all"] = store.records()
        return [r for r in cache["all"] if r.key in seen]

    def run(specs: list[RunSpec], desc: str):
        if simulate:
            if executor is None and not own:
                config = campaign.executor
                own.append(make_executor(config.kind, config.workers if workers is None else workers,
                                         scheduler or config.scheduler, config.start_method, campaign.plugins))
            summary = run_specs(campaign, specs, workers=workers, scheduler=scheduler, progress=progress,
                                retry_failed=retry_failed, executor=executor or own[0], desc=desc)
            cache.clear()
            if summary.failed:
                line = (f"{summary.failed} runs of '{desc}' failed (rerun with --retry-failed): "
                        + "; ".join(f"{label}: {error}" for label, error in summary.failures[:3]))
                if line not in notes:
                    notes.append(line)
        with Store(store_path, readonly=True) as store:
            found = {r.key: r for r in store.records([s.key for s in specs])}
        out = [found.get(s.key) for s in specs]
        if any(r is None or r.status not in ("done", "failed") for r in out):
            return None
        seen.update(s.key for s in specs)
        cache.clear()
        return out

    results: list[ConditionResult] = []
    residuals: dict[str, list] = {}  # production - cheap, learnt condition after condition
    try:
        for ci, condition in enumerate(campaign.conditions):
            design = next(d for d in designs if condition in d.conditions)
            loop = run_condition(design.campaign, condition, ci, cheap=campaign.profile, production=production,
                                 design_table=design.table, run=run, records=records, residuals=residuals)
            results.append(_condition_result(design.campaign, condition, loop, reachable_range))
    finally:
        for ex in own:
            ex.close()
    return results


def _condition_result(campaign: Campaign, condition: Condition, loop, reachable_range) -> ConditionResult:
    """The ConditionResult of a finished (or stopped) loop."""
    boxed = loop.box.campaign(campaign)
    by_name = {f.name: f for f in boxed.factors}
    names = campaign.factor_names
    corrected = loop.corrected()
    best, optimization, cond_notes = loop.best, loop.optimization, []
    if best is None:  # stopped before a solve: the box's nearest point to the target
        best, optimization, cond_notes = solve_condition(boxed, corrected or loop.models, condition)
    chosen = {by_name[n].parameter: round_parameter(float(best[f"actual:{n}"])) for n in names}
    desirability = float(best["desirability"])
    ranges = {by_name[n].parameter: tuple(map(float, r)) for n, r in optimization.factor_ranges.items()}
    on_path = loop.on_path
    if on_path is not None:
        # verified on a path beyond the box: that point, with no solution set around it
        # (and none of the box's solve notes: its nearest point is not what was simulated)
        chosen = {by_name[n].parameter: float(on_path["point"][by_name[n].parameter]) for n in names}
        desirability, ranges, cond_notes = float("nan"), {}, []
    coded = {n: float(by_name[n].to_coded(chosen[by_name[n].parameter])) for n in names}
    point = np.array([coded[n] for n in names])
    reference_predicted = {}
    if condition.reference and all(f.parameter in condition.reference for f in boxed.factors):
        ref = np.array([[by_name[n].to_coded(condition.reference[by_name[n].parameter]) for n in names]])
        reference_predicted = {r: float(m.predict(ref)[0]) for r, m in corrected.items()}
    verdicts = []
    for target in condition.targets:
        model = corrected.get(target.response, loop.models[target.response])
        verdicts.append(ResponseVerdict(
            response=target.response, target=target.mean, lab_sd=target.sd,
            predicted=(float(model.predict(point[None, :])[0]) if on_path is None
                       else float(on_path.get("reading", target.mean))),
            simulated=[], reachable=tuple(map(float, reachable_range(model))),
            parts=(prediction_parts(loop.models[target.response], model, point) if on_path is None
                   else (float("nan"),) * 4),
            **({} if on_path is None else {"no_interval": f"{'the end of' if on_path.get('limit') else 'a point on'} "
                                                          f"the path of steepest {on_path['way']}, beyond the "
                                                          f"box's model"}),
        ))
    notes = list(cond_notes) + list(loop.notes)
    if loop.status != "verified":
        notes.insert(0, f"the loop stopped ({loop.status}): {loop.reason}.")
    result = ConditionResult(
        condition=condition, chosen=chosen, chosen_coded=coded, desirability=desirability,
        optimization=optimization, factor_ranges=ranges, verdicts=verdicts, verification=list(loop.production),
        specs=list(loop.specs), notes=notes, reference_predicted=reference_predicted, loop=loop)
    for verdict in verdicts:
        verdict.simulated = [float(r.responses[verdict.response]) for r in result.verification
                             if r.status == "done" and verdict.response in r.responses]
        _judge(result, verdict)
    return result


def _unfinished(campaign: Campaign, table: pd.DataFrame, unfinished: int, failed: int, whose: str = "") -> DataError:
    """Design runs still pending: a fit of part of a design (and verification runs spent
    on it) is no calibration -- the design's balance is gone until every point is in."""
    running = int((table["status"] == "running").sum())
    busy = f" ({running} running in another runner)" if running else ""
    retry = f" (add --retry-failed for the {failed} failed)" if failed else ""
    return DataError(f"{whose}{unfinished} of {len(table)} design runs are not done yet{busy}; finish them "
                     f"with `demcal run {campaign.path} --profile {campaign.profile}`{retry}, "
                     f"then calibrate again.")


def _judge(result: ConditionResult, verdict: ResponseVerdict) -> None:
    """Say in words how the verification went, and why it missed if it did."""
    if not verdict.simulated:
        result.notes.append(f"{verdict.response}: no verification run is done yet.")
        return
    if verdict.within_lab_sd is False:
        why = ("the target is outside what the design box can reach" if not verdict.target_reachable else
               f"the model predicted {verdict.predicted:.2f} but the simulations gave "
               f"{verdict.simulated_mean:.2f} (model error plus run-to-run noise"
               + (f", replicate sd {verdict.simulated_sd:.2f}" if np.isfinite(verdict.simulated_sd) else "")
               + ")")
        result.notes.append(
            f"{verdict.response}: simulated {verdict.simulated_mean:.2f} misses the lab's "
            f"{verdict.target:g} ± {verdict.lab_sd:g} by {abs(verdict.simulated_mean - verdict.target):.2f}; {why}.")


def describe(calibration: Calibration) -> str:
    """A few lines for the terminal; warnings about the design come first."""
    lines = [f"warning: {warning}" for warning in calibration.warnings]
    several = len(calibration.designs) > 1
    for design in calibration.designs:
        for response, model in design.models.items():
            fit = model.fit
            lines.append((f"{design.name}: " if several else "")
                         + f"{response}: {calibration.campaign.model_order} model"
                         + (f" reduced at alpha {calibration.campaign.reduce_alpha:g}"
                            if design.removed[response] else "")
                         + f", R² {fit.r2:.3f}, adj. R² {fit.adj_r2:.3f}, pred. R² {fit.pred_r2:.3f}")
            lines.append(f"  {model.equation('coded', digits=4)}")
    fixed = {}
    if calibration.campaign.per_condition:
        from demcal.campaign.chain import SOURCE_DEFAULT, condition_settings

        fixed = condition_settings(calibration.campaign)
    for result in calibration.conditions:
        params = ", ".join(f"{k} = {v:g}" for k, v in result.chosen.items())
        lines.append(f"{result.condition.name}: {params}")
        if fixed:
            lines.append("  fixed: " + ", ".join(f"{k} = {v} ({source})" for k, (v, source)
                                                 in fixed[result.condition.name].items() if source != SOURCE_DEFAULT))
        if result.loop is not None:
            moved = len(result.loop.boxes) - 1
            lines.append(f"  loop: {result.loop.status}"
                         + (f" after {moved} box move{'s' if moved != 1 else ''}" if moved else "")
                         + f"; {result.loop.reason}")
        for v in result.verdicts:
            inside = {True: "inside", False: "outside", None: "no lab sd"}[v.within_lab_sd]
            sim = (f"simulated {v.simulated_mean:.2f} (n={len(v.simulated)}), error {v.relative_error_percent:.2f} %, "
                   f"{inside} the lab spread" if v.simulated else "not simulated yet")
            sd = f" ± {v.lab_sd:g}" if v.lab_sd is not None else ""
            lines.append(f"  {v.response}: target {v.target:g}{sd}, predicted {v.predicted:.2f}, {sim}")
            if v.simulated and np.all(np.isfinite(v.mean_interval)):
                lo, hi = v.mean_interval
                lines.append(f"  {v.response}: model check: the model's 95 % interval for a mean of "
                             f"{len(v.simulated)} is {lo:.2f} to {hi:.2f}: {v.confirmation}")
        for note in result.notes:
            lines.append(f"  note: {note}")
    for note in calibration.notes:
        if note not in calibration.warnings:
            lines.append(f"note: {note}")
    return "\n".join(lines)
