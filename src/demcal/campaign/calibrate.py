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
deterministic), so ``demcal report`` shows exactly what ``calibrate`` found. The
result types (:class:`Calibration` and its parts) and :func:`describe` are in
:mod:`demcal.campaign.calibration`, and importable from here.
"""

from __future__ import annotations

import dataclasses

from typing import Any

import numpy as np
import pandas as pd

from demcal.campaign.calibration import PREDICTION_LEVEL, Calibration, ConditionResult, DesignFit, ResponseVerdict
from demcal.campaign.calibration import describe, production_profile  # noqa: F401
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
#: The most production runs :func:`lab_noise_warnings` counts up to.
MANY_RUNS = 1000


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
    if campaign.holdouts:
        _holdouts(campaign, results, simulate=simulate, workers=workers, scheduler=scheduler, progress=progress,
                  retry_failed=retry_failed, executor=executor)
    first = fits[0]
    with Store(store_path, readonly=True) as store:
        lab_noise = lab_noise_warnings(campaign, store.records())
    calibration = Calibration(campaign, first.table, first.full, first.models, first.removed, results, notes,
                              warnings, designs=fits, lab_noise=lab_noise)
    if simulate:
        write_json_atomic(campaign.workdir / "calibration.json", calibration.to_dict())
    return calibration


def holdout_specs(campaign: Campaign, result: ConditionResult, ci: int) -> list[tuple]:
    """The hold-out runs of one condition: ``(holdout, specs)`` for each ``[[holdout]]``,
    each run at the condition's calibrated material (the chosen values, the campaign's
    and the condition's fixed material settings: the keys a joint test shares) with the
    hold-out's own settings, at its profile (default the production profile where the
    test has it)."""
    from demcal.bench.joint import is_shared
    from demcal.bench.registry import get_experiment
    from demcal.campaign.seeds import HOLDOUT_SEED

    production = production_profile(campaign)
    material = {k: v for k, v in {**campaign.settings, **result.condition.fixed, **result.chosen}.items()
                if is_shared(k)}
    out = []
    for hi, holdout in enumerate(campaign.holdouts or ()):
        test = get_experiment(holdout.test)
        profile = holdout.profile or (production if production in test.profiles else test.profiles[0])
        keys = test.settings(profile)
        settings = {**{k: v for k, v in material.items() if k in keys}, **holdout.settings}
        n = holdout.replicates or max(1, campaign.verification_replicates)
        seed = campaign.verification_seed + HOLDOUT_SEED + 1000 * ci + 100 * hi
        out.append((holdout, profile, [
            RunSpec("holdout", f"holdout {holdout.test} {result.condition.name} #{r + 1}", holdout.test, profile,
                    dict(result.chosen), settings, seed + r) for r in range(n)]))
    return out


def _holdouts(campaign: Campaign, results: list[ConditionResult], *, simulate: bool, **run) -> None:
    """Run (``simulate``) or read from the store the hold-out tests at each condition's
    calibrated values and attach their results."""
    from demcal.campaign.calibration import HoldoutResult

    planned = [(result, holdout_specs(campaign, result, ci)) for ci, result in enumerate(results)]
    if simulate:
        specs = [spec for _, plans in planned for _, _, specs in plans for spec in specs]
        run_specs(campaign, specs, desc=f"{campaign.name} hold-out", **run)
    with Store(campaign.store_path, readonly=True) as store:
        for result, plans in planned:
            for holdout, profile, specs in plans:
                found = {r.key: r for r in store.records([s.key for s in specs])}
                done = [found[s.key] for s in specs if s.key in found and found[s.key].status == "done"]
                target = holdout.targets[result.condition.name]
                result.holdouts.append(HoldoutResult(
                    test=holdout.test, response=holdout.response, profile=profile, target=target.mean,
                    lab_sd=target.sd, runs=len(specs),
                    simulated=[float(r.responses[holdout.response]) for r in done if holdout.response in r.responses]))


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


def lab_noise_warnings(campaign: Campaign, records: list[RunRecord]) -> list[str]:
    """One sentence for each lab target whose sd is below the simulation's seed noise.

    The noise is the seed-to-seed sd of the campaign's test at its production profile, as
    far as the store and the stored profile studies know it: every done run there pooled
    over its points (the design's centre points, path and production replicates:
    :func:`demcal.campaign.noise.production_noise` with every kind of run) with the
    studies' replicated points (:func:`demcal.campaign.noise.stored_noise`). The loop
    verifies a target once the 95 % interval of the production mean is narrower than the
    lab sd, so a lab sd below the noise asks for about (1.96 x noise / lab sd)² runs at
    one point (:func:`demcal.campaign.replicates.replicates_needed`); more than
    ``[calibration] max_replicates`` allows, and the target cannot be verified at that
    profile. Not written to calibration.json: a fact about the lab's numbers, said where
    a user reads the result (docs/guide.md, "The lab file")."""
    from demcal.campaign.noise import production_noise, stored_noise
    from demcal.campaign.replicates import replicates_needed
    from demcal.campaign.wording import Words

    production = production_profile(campaign)
    responses = campaign.response_names
    noise = production_noise(campaign, records, production, responses,
                             stored_noise(campaign, production, responses), kinds=None)
    cap = campaign.calibration.max_replicates
    out = []
    for condition in campaign.conditions:
        w = Words(campaign, condition)
        for t in condition.targets:
            sd, df, _ = noise.get(t.response, (float("nan"), 0, 0))
            if t.sd is None or df < 1 or not np.isfinite(sd) or t.sd >= sd:
                continue
            lab, seed = _apart(t.sd, sd, w.unit(t.response))
            what = (f"{condition.name}: the lab sd of the {w.label(t.response)}, {lab}, is below the simulation's "
                    f"seed noise at profile {production}, {seed} ({df} degrees of freedom of replicated runs)")
            if t.sd == 0:
                out.append(f"{what}: no number of runs verifies it, since the 95 % interval of a mean is never "
                           "narrower than 0; give the spread between at least three tests.")
                continue
            need = replicates_needed(sd, df, 0, t.sd, MANY_RUNS)
            about = f"about {need}" if need < MANY_RUNS else f"more than {MANY_RUNS}"
            if need > cap:
                out.append(f"{what}: the 95 % interval of a simulated mean is narrower than that only after {about} "
                           f"production runs at one point, more than [calibration] max_replicates ({cap}) allows, "
                           "so this target cannot be verified at this profile; take the lab sd from the spread "
                           "between at least three tests, or raise max_replicates and [budget] runs.")
            else:
                out.append(f"{what}: verifying it takes {about} production runs at one point, since the 95 % "
                           "interval of their mean must be narrower than the lab sd; check that the sd is the "
                           "spread between at least three tests, not between repeats of one.")
    return out


def _apart(a: float, b: float, unit: str | None) -> tuple[str, str]:
    """Two sds to two significant digits each, or three where two would print them alike."""
    from demcal.rounding import rounded

    shown = (rounded(a, a, unit), rounded(b, b, unit))
    return shown if shown[0] != shown[1] else (rounded(a, a, unit, digits=3), rounded(b, b, unit, digits=3))


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
                                         scheduler or config.scheduler, config.start_method, campaign.plugins,
                                         ensemble=config.ensemble))
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


#: Confidence level of the fitted mean that the compatible ranges allow for (the seed
#: noise the surface averages): a setting is compatible where that interval reaches into
#: every lab window.
COMPATIBLE_LEVEL = 0.95


def compatible_ranges(boxed: Campaign, models: dict, targets) -> dict[str, tuple[float, float]]:
    """The parameter ranges of the box compatible with every one of ``targets`` within its
    lab sd and the seed noise: the region where each model's 95 % confidence interval of
    the mean (:data:`COMPATIBLE_LEVEL`) reaches into mean ± sd
    (:func:`demcal.optimize.overlay.overlay`, Design-Expert's overlay with its interval),
    by parameter key; empty when a target has no sd or no point of the box meets every
    window."""
    from demcal.optimize.overlay import overlay

    if not targets or any(t.sd is None or not np.isfinite(t.sd) or t.sd <= 0 for t in targets):
        return {}
    region = overlay(models, {t.response: (t.mean - t.sd, t.mean + t.sd) for t in targets}, len(boxed.factors),
                     level=COMPATIBLE_LEVEL)
    return {f.parameter: (float(f.to_actual(region.ranges[j][0])), float(f.to_actual(region.ranges[j][1])))
            for j, f in enumerate(boxed.factors) if j in region.ranges}


def _compatible_by_test(boxed: Campaign, models: dict, condition: Condition) -> dict[str, dict[str, tuple]]:
    """A joint test's compatible ranges of each of its tests alone (its own targets, the
    same models and box), by test; empty unless two or more of its tests have targets.
    Beside the ranges of all targets together they show how much each test pins down."""
    from demcal.bench.registry import get_experiment

    experiment = get_experiment(boxed.test)
    if not hasattr(experiment, "part_of"):
        return {}
    by_test: dict[str, list] = {}
    for target in condition.targets:
        by_test.setdefault(experiment.part_of(target.response), []).append(target)
    if len(by_test) < 2:
        return {}
    return {test: compatible_ranges(boxed, models, targets) for test, targets in by_test.items()}


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
        specs=list(loop.specs), notes=notes, reference_predicted=reference_predicted, loop=loop,
        compatible=({} if on_path is not None else
                    compatible_ranges(boxed, corrected or loop.models, condition.targets)),
        compatible_by_test=({} if on_path is not None else
                            _compatible_by_test(boxed, corrected or loop.models, condition)))
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
