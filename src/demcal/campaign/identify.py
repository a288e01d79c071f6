"""``demcal identify``: before the costly design, can the campaign's responses pin its factors?

A cheap two-level screen over the campaign's factors (a Plackett-Burman design by
default, or the smallest two-level fraction of resolution III; :func:`screening_design`)
at a cheap profile (``tiny`` by default), each point run with ``replicates`` seeds so that
the seed noise is measured. The runs are the campaign's own (kind ``screen``, seeds
``[runs] seed + SCREEN_SEED + replicate * points + point``): they go through
:func:`demcal.campaign.runner.run_specs` into the campaign's store, so they are cached,
resumable, shared by several runners and shown with progress, as ``demcal run``'s are.

From them (:mod:`demcal.rsm.sensitivity`): per factor and response the main effect with
its standard error from the replicates, its t-ratio and whether it moves the response
beyond its seed noise; the scaled sensitivity matrix (responses x factors, the change over
the factor's range in seed sds), its singular values and condition number; the factors no
chosen response can pin; the combinations of factors the responses cannot tell apart.
For what is left unpinned it names the responses the same bench measured in these runs
that would pin it (measured), and the other registered benches declared to read those
parameters (:mod:`demcal.bench.reads`: declared, not measured). The result is written to
``identify.json`` in the campaign's work folder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal._checks import MAX_SEED, significant
from demcal.campaign.config import Campaign
from demcal.campaign.runner import RunSummary, checked_point, run_specs
from demcal.campaign.seeds import SCREEN_SEED
from demcal.campaign.store import RunSpec, Store, write_json_atomic
from demcal.errors import ConfigError, DataError

#: Design kinds a screen may use (any spelling of :data:`demcal.doe.catalog.DESIGN_NAMES`).
SCREEN_DESIGNS = ("plackett-burman", "fractional-factorial")
#: Seeds per screening point, unless told otherwise.
DEFAULT_REPLICATES = 2
#: The profile a screen runs at, where the test has it (else the campaign's).
DEFAULT_PROFILE = "tiny"
#: The file the result is written to, in the campaign's work folder.
RESULT_FILE = "identify.json"


def screening_design(k: int, design: str = "plackett-burman", runs: int | None = None) -> np.ndarray:
    """The coded ``(points, k)`` screening design.

    ``plackett-burman``: ``runs`` of 8, 12, 16, 20 or 24 (default the smallest that fits);
    ``fractional-factorial``: a 2^(k-p) fraction of ``runs`` points (a power of 2; default
    the smallest of the standard fractions, Montgomery Table 8.14, with at least ``k + 1``
    points; the full 2^k factorial where none is stored).
    """
    from demcal.doe.catalog import design_kind, design_matrix
    from demcal.doe.designs import FRACTION_GENERATORS

    name = design_kind(design, also=())
    if name not in SCREEN_DESIGNS:
        raise ConfigError(f"a screen needs a two-level design from which main effects are read; '{design}' is "
                          f"not one: give --design plackett-burman or fractional-factorial.")
    if runs is not None and runs < k + 1:
        raise ConfigError(f"a screen of {runs} runs cannot estimate {k} main effects and the mean; give --runs "
                          f"{k + 1} or more (or leave it out for the smallest design that fits).")
    if name == "plackett-burman":
        return design_matrix(name, k, runs=runs, center=0)
    if runs is not None:
        p = k - int(round(math.log2(runs))) if runs > 0 and runs & (runs - 1) == 0 else -1
        if p < 0:
            raise ConfigError(f"a two-level fraction of {k} factors has 2^(k-p) runs, a power of 2 of at most "
                              f"{2 ** k}; {runs} is not one.")
    else:
        fitting = [p for (kk, p) in FRACTION_GENERATORS if kk == k and 2 ** (k - p) >= k + 1]
        p = max(fitting, default=0)
    if p == 0:
        return design_matrix("full-factorial", k, center=0)
    return design_matrix(name, k, fraction=p, center=0)


@dataclass(frozen=True)
class ScreenPlan:
    """The screen's points and the runs that simulate them (point-major)."""

    coded: np.ndarray  #: (points, k)
    specs: tuple[RunSpec, ...]
    replicates: int


def plan_screen(campaign: Campaign, coded: np.ndarray, replicates: int) -> ScreenPlan:
    """One run per point and seed, at ``campaign``'s profile and fixed settings."""
    from demcal.bench.registry import get_experiment

    experiment = get_experiment(campaign.test)
    n = coded.shape[0]
    last = campaign.seed + SCREEN_SEED + replicates * n
    if last > MAX_SEED:
        raise ConfigError(f"[runs] seed = {campaign.seed} leaves no room for the screen's seeds (up to seed + "
                          f"{SCREEN_SEED + replicates * n:,}); give a seed of at most {MAX_SEED - last + campaign.seed}.")
    specs = []
    for i, row in enumerate(coded):
        parameters, settings = checked_point(campaign, experiment, row, f"screening point {i + 1}")
        for r in range(replicates):
            specs.append(RunSpec("screen", f"screen {i + 1} r{r + 1}", campaign.test, campaign.profile, parameters,
                                 settings, campaign.seed + SCREEN_SEED + r * n + i))
    return ScreenPlan(np.asarray(coded, dtype=float), tuple(specs), replicates)


@dataclass
class Identification:
    """What ``demcal identify`` found; ``analysis`` is None until every screening run is done."""

    campaign: Campaign  #: at the screen's profile and (one design's) fixed settings
    design: str
    plan: ScreenPlan
    summary: RunSummary
    conditions: tuple[str, ...] = ()  #: the conditions whose fixed settings the screen ran with
    responses: tuple[str, ...] = ()  #: the chosen responses, then the bench's others measured
    analysis: Any = None  #: demcal.rsm.sensitivity.Identifiability of the chosen responses
    screen: Any = None  #: demcal.rsm.sensitivity.Screen of every response in ``responses``
    notes: list[str] = field(default_factory=list)
    path: Any = None  #: identify.json, once written

    @property
    def chosen(self) -> tuple[str, ...]:
        return tuple(self.campaign.response_names)

    @property
    def others(self) -> tuple[str, ...]:
        return self.responses[len(self.chosen):]


def identify(campaign: Campaign, *, profile: str | None = None, design: str = "plackett-burman",
             runs: int | None = None, replicates: int = DEFAULT_REPLICATES, condition: str | None = None,
             workers: int | None = None, scheduler: str | None = None, retry_failed: bool = False,
             progress: bool = True, executor=None) -> Identification:
    """Screen ``campaign``'s factors and say which its responses can pin.

    Parameters
    ----------
    profile : the screen's bench profile (default ``tiny`` where the test has it, else the
        campaign's).
    design, runs : the screening design (:func:`screening_design`).
    replicates : seeds per point, at least 2 (the seed noise is their spread).
    condition : the condition whose fixed settings the screen runs with, where the
        campaign's conditions fix settings of their own (default the first).
    workers, scheduler, retry_failed, progress, executor : as ``demcal run``'s.
    """
    from demcal.bench.registry import get_experiment

    if isinstance(replicates, bool) or not isinstance(replicates, int) or replicates < 2:
        raise ConfigError(f"--replicates must be 2 or more (the seed noise is the spread of a point's seeds), "
                          f"got {replicates!r}.")
    experiment = get_experiment(campaign.test)
    profile = profile or (DEFAULT_PROFILE if DEFAULT_PROFILE in experiment.profiles else campaign.profile)
    screened, conditions = _screened(campaign.with_profile(profile), condition)
    coded = screening_design(len(screened.factors), design, runs)
    plan = plan_screen(screened, coded, replicates)
    summary = run_specs(screened, plan.specs, workers=workers, scheduler=scheduler, retry_failed=retry_failed,
                        progress=progress, executor=executor, desc=f"{campaign.name} screen")
    result = Identification(screened, design, plan, summary, conditions)
    if summary.done < summary.total:
        return result
    _analyse(result, experiment)
    result.path = screened.workdir / RESULT_FILE
    write_json_atomic(result.path, to_dict(result))
    return result


def _screened(campaign: Campaign, condition: str | None) -> tuple[Campaign, tuple[str, ...]]:
    """The campaign as the screen's runs see it: one design's fixed settings (the named
    condition's, else the first's) and the conditions that design serves."""
    from demcal.campaign.chain import resolve_chain

    names = [c.name for c in campaign.conditions]
    if condition is not None and condition not in names:
        raise ConfigError(f"condition '{condition}' is not in {campaign.path.name}; its conditions are: "
                          f"{', '.join(names)}.")
    if not campaign.per_condition:
        return campaign, ()
    for boxed, members in resolve_chain(campaign).designs():
        if condition is None or condition in [c.name for c in members]:
            return boxed, tuple(c.name for c in members)
    raise AssertionError("unreachable: every condition is in one design")  # pragma: no cover


def _analyse(result: Identification, experiment) -> None:
    """Fill ``result.screen`` and ``result.analysis`` from the stored runs."""
    from demcal.rsm.sensitivity import identifiability, main_effects

    campaign, plan = result.campaign, result.plan
    with Store(campaign.store_path, readonly=True) as store:
        records = {r.key: r for r in store.records([s.key for s in plan.specs])}
    chosen = list(campaign.response_names)
    candidates = chosen + [name for name in experiment.responses if name not in chosen]
    n, r = plan.coded.shape[0], plan.replicates
    values = np.full((n, r, len(candidates)), np.nan)
    for index, spec in enumerate(plan.specs):
        got = records[spec.key].responses
        for j, name in enumerate(candidates):
            value = got.get(name)
            values[index // r, index % r, j] = float(value) if isinstance(value, (int, float)) else np.nan
    for j, name in enumerate(chosen):
        if not np.all(np.isfinite(values[..., j])):
            raise DataError(f"some screening runs have no finite '{name}'; rerun them (demcal identify "
                            f"{campaign.path.name} --retry-failed) or check the bench.")
        if np.all(np.ptp(values[..., j], axis=1) == 0):
            raise DataError(f"response '{name}' is the same for every seed at every screening point, so it has "
                            f"no seed noise to weigh the effects against; identify needs a bench whose runs vary "
                            f"with the seed.")
    kept = list(range(len(chosen)))
    for j in range(len(chosen), len(candidates)):
        column = values[..., j]
        if np.all(np.isfinite(column)) and not np.all(np.ptp(column, axis=1) == 0):
            kept.append(j)
        else:
            result.notes.append(f"{candidates[j]}, also measured by {campaign.test}, is left out: it is not a "
                                "finite number in every run or has no seed noise.")
    result.responses = tuple(candidates[j] for j in kept)
    result.screen = main_effects(plan.coded, values[..., kept])
    result.analysis = identifiability(_rows(result.screen, range(len(chosen))))


def _rows(screen, rows):
    """``screen`` restricted to the responses ``rows``."""
    from demcal.rsm.sensitivity import Screen

    rows = list(rows)
    return Screen(effects=screen.effects[rows], se=screen.se[rows], noise=screen.noise[rows], dof=screen.dof,
                  se_unit=screen.se_unit)


# --------------------------------------------------------------------------- what would pin the rest


def other_pins(result: Identification) -> dict[str, Any]:
    """What the bench's other responses, measured in these runs, would pin:
    ``{"factors": {factor index: [response, ...]}, "combinations": {combination index: [response, ...]}}``."""
    from demcal.rsm.sensitivity import pins_more

    a, screen = result.analysis, result.screen
    m = len(result.chosen)
    out: dict[str, Any] = {"factors": {}, "combinations": {}}
    t = screen.t
    sensitivity = screen.sensitivity
    informative_rows = [i for i in range(m) if a.informative[i].any()]
    for i, name in enumerate(result.others, start=m):
        for j in a.unpinned:
            if abs(t[i, j]) > a.t_crit:
                out["factors"].setdefault(j, []).append(name)
        for c, combo in enumerate(a.combinations):
            cols = list(combo.factors)
            if pins_more(sensitivity[np.ix_(informative_rows, cols)], sensitivity[i, cols], a.threshold):
                out["combinations"].setdefault(c, []).append(name)
    return out


def other_benches(result: Identification) -> dict[int, list[tuple[str, str]]]:
    """Per factor not pinned: the other registered benches declared to read its parameter
    (:func:`demcal.bench.reads.benches_reading`)."""
    from demcal.bench.reads import benches_reading

    a = result.analysis
    loose = list(a.unpinned) + [j for c in a.combinations for j in c.factors]
    return {j: benches_reading(result.campaign.factors[j].parameter, exclude=(result.campaign.test,))
            for j in loose}


# --------------------------------------------------------------------------- output


def _num(value: float, digits: int = 4) -> float | None:
    """``value`` to ``digits`` significant digits; None for a value that is not finite."""
    return significant(value, digits) if value is not None and math.isfinite(value) else None


def factor_label(factor) -> str:
    return factor.description or factor.parameter


def response_labels(result: Identification) -> dict[str, tuple[str, str]]:
    """response -> (label, unit): the campaign's where it names them, else the key and no unit."""
    out = {name: (name, "") for name in result.responses}
    for r in result.campaign.responses:
        out[r.name] = (r.label or r.name, r.unit)
    return out


def to_dict(result: Identification) -> dict[str, Any]:
    """The whole result as plain data (identify.json, ``--json``)."""
    from demcal import __version__

    c, plan = result.campaign, result.plan
    data: dict[str, Any] = {
        "campaign": c.name, "file": str(c.path), "test": c.test, "profile": c.profile,
        "conditions": list(result.conditions), "demcal_version": __version__,
        "design": {"kind": result.design, "points": int(plan.coded.shape[0]), "replicates": plan.replicates,
                   "runs": len(plan.specs), "coded": plan.coded.astype(int).tolist(),
                   "seeds": [s.seed for s in plan.specs]},
        "runs": {"done": result.summary.done, "failed": result.summary.failed, "total": result.summary.total},
        "factors": [{"name": f.name, "parameter": f.parameter, "label": factor_label(f), "unit": f.units,
                     "low": f.low, "high": f.high} for f in c.factors],
        "notes": list(result.notes),
    }
    if result.analysis is None:
        return data
    a, screen = result.analysis, result.screen
    labels = response_labels(result)
    data["responses"] = [{"name": name, "label": labels[name][0], "unit": labels[name][1],
                          "chosen": i < len(result.chosen), "noise_sd": _num(screen.noise[i])}
                         for i, name in enumerate(result.responses)]
    data["noise_dof"] = screen.dof
    data["t_critical"] = _num(a.t_crit)
    data["effects"] = [
        {"factor": f.name, "parameter": f.parameter, "response": name, "effect": _num(screen.effects[i, j]),
         "se": _num(screen.se[i, j]), "t": _num(screen.t[i, j], 3),
         "beyond_noise": bool(abs(screen.t[i, j]) > a.t_crit), "scaled": _num(screen.sensitivity[i, j])}
        for i, name in enumerate(result.responses) for j, f in enumerate(c.factors)]
    names = [f.name for f in c.factors]
    data["sensitivity"] = {"rows": list(result.chosen), "columns": names,
                           "matrix": [[_num(x) for x in row] for row in a.screen.sensitivity],
                           "singular_values": [_num(s) for s in a.singular_values],
                           "condition_number": _num(a.condition_number), "threshold": _num(a.threshold),
                           "pinned_directions": a.rank}
    pins, benches = other_pins(result), other_benches(result)
    data["pinned"] = [names[j] for j in a.pinned]
    data["unpinned"] = [{"factor": names[j], "measured_by_other_responses": pins["factors"].get(j, []),
                         "benches_declared": [b for b, _ in benches[j]]} for j in a.unpinned]
    data["not_separately_identifiable"] = [
        {"factors": [names[j] for j in combo.factors], "free_directions": combo.free,
         "pinned_combinations": [[_num(w, 3) for w in v] for v in combo.pinned],
         "measured_by_other_responses": pins["combinations"].get(k, []),
         "benches_declared": sorted({b for j in combo.factors for b, _ in benches[j]})}
        for k, combo in enumerate(a.combinations)]
    data["identifiable"] = not a.unpinned and not a.combinations
    return data


def describe(result: Identification) -> str:
    """The human table: per response the effects with their units, then the verdict."""
    c, plan, a = result.campaign, result.plan, result.analysis
    n = plan.coded.shape[0]
    lines = [f"{c.name}: a {result.design} screen of {n} points x {plan.replicates} seeds ({len(plan.specs)} runs) of "
             f"{c.test} at {c.profile}" + (f", with the settings of {', '.join(result.conditions)}"
                                          if result.conditions else "")]
    if a is None:
        lines.append(result.summary.sentence(c.name))
        return "\n".join(lines)
    screen, labels = result.screen, response_labels(result)
    width = max(len(_factor_head(f)) for f in c.factors)
    for i, name in enumerate(result.responses):
        label, unit = labels[name]
        u = f" {unit}" if unit else ""
        chosen = "" if i < len(result.chosen) else " (measured, not a campaign response)"
        lines += ["", f"{label}{f' [{unit}]' if unit else ''}{chosen}: seed noise sd {_fmt(screen.noise[i])}{u} "
                      f"({screen.dof} degrees of freedom); beyond noise: |t| > {a.t_crit:.2f}",
                  f"  {'factor':<{width}}  {'low to high':>15}  {'effect ± se':>17}  {'t':>6}  "
                  f"{'over range':>10}  beyond noise"]
        for j, f in enumerate(c.factors):
            t = screen.t[i, j]
            effect = f"{_fmt(screen.effects[i, j])} ± {_fmt(screen.se[i, j])}"
            lines.append(f"  {_factor_head(f):<{width}}  {f'{f.low:g} to {f.high:g}':>15}  {effect:>17}  "
                         f"{t:>6.1f}  {_fmt(screen.sensitivity[i, j]):>10}  {'yes' if abs(t) > a.t_crit else 'no'}")
    names = [factor_label(f) for f in c.factors]
    k = len(c.factors)
    condition = ("infinite" if not math.isfinite(a.condition_number) else f"{a.condition_number:.3g}")
    lines += ["", "effect: half the high-minus-low difference of the means; over range: the response's change "
                  "over the factor's range in seed sds (the scaled sensitivity)",
              f"scaled sensitivity of the campaign's responses: singular values "
              f"{', '.join(_fmt(s) for s in a.singular_values)}; condition number {condition}"
              + (f" ({len(result.chosen)} response{'s' if len(result.chosen) > 1 else ''} for {k} factors)"
                 if len(result.chosen) < k else "")
              + f"; the screen detects a move of {_fmt(a.threshold)} sds or more",
              f"the responses pin {a.rank} of the {k} directions"]
    lines += [""] + _verdict(result, names)
    pins, benches = other_pins(result), other_benches(result)
    lines += _remedies(result, names, pins, benches)
    lines += [f"note: {note}" for note in result.notes]
    if result.path is not None:
        lines += ["", f"Written: {result.path}"]
    return "\n".join(lines)


def _verdict(result: Identification, names: list[str]) -> list[str]:
    from demcal.rsm.sensitivity import describe_combination

    a = result.analysis
    lines = [f"pinned: {', '.join(names[j] for j in a.pinned) or 'none'}"]
    if a.unpinned:
        lines.append(f"not pinned (within the seed noise of every response): {', '.join(names[j] for j in a.unpinned)}")
        lines.append(f"  (this screen sees a factor that moves a response by {_fmt(a.threshold)} seed sds or more over "
                     "its range; more seeds or points lower that as 1/sqrt(runs), a larger profile lowers the noise)")
    for combo in a.combinations:
        members = [names[j] for j in combo.factors]
        seen = "; ".join(describe_combination(v, members) for v in combo.pinned)
        lines.append(f"not separately identifiable: {', '.join(members)}: "
                     + (f"the responses pin only {seen} (each factor over its range), " if seen else "")
                     + f"{combo.free} direction{'s' if combo.free > 1 else ''} left free")
    if not a.unpinned and not a.combinations:
        lines.append("every factor is pinned: the responses move each beyond its seed noise and tell them apart")
    return lines


def _remedies(result: Identification, names: list[str], pins: dict, benches: dict) -> list[str]:
    a = result.analysis
    lines = []
    for j in a.unpinned:
        if pins["factors"].get(j):
            lines.append(f"measured in these runs: {', '.join(pins['factors'][j])} moves {names[j]} beyond its noise "
                         "(a response of this bench the campaign does not fit)")
    for k, combo in enumerate(a.combinations):
        if pins["combinations"].get(k):
            lines.append(f"measured in these runs: adding {', '.join(pins['combinations'][k])} would tell "
                         f"{', '.join(names[j] for j in combo.factors)} apart")
    loose = sorted(benches)
    if loose:
        lines += ["", "other benches whose response reads these parameters (declared in demcal.bench.reads, "
                      "not measured here):"]
        for j in loose:
            found = ", ".join(b for b, _ in benches[j]) or "none registered"
            lines.append(f"  {names[j]} ({result.campaign.factors[j].parameter}): {found}")
    return lines


def _factor_head(factor) -> str:
    unit = factor.units if factor.units not in ("", None) else "-"
    return f"{factor_label(factor)} [{unit}]"


def _fmt(value: float) -> str:
    """Three significant digits, no exponent for ordinary magnitudes."""
    if not math.isfinite(value):
        return "inf" if value > 0 else "-inf" if value < 0 else "nan"
    if value == 0:
        return "0"
    digits = max(3 - int(math.floor(math.log10(abs(value)))) - 1, 0)
    return f"{value:.{digits}f}" if abs(value) < 1e6 else f"{value:.3g}"
