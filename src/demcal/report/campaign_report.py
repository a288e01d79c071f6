"""The campaign report: one HTML page, its figures as PNG files, CSV/JSON of every table.

The page answers first. Its first screen holds, per campaign and condition
(:func:`_summary`): the calibrated values with the ranges of their solution set, the
verification verdict (the lab's mean ± sd against the simulated mean ± its 95 %
interval, with n), the simulations spent, the warnings on the model's adequacy
(:func:`demcal.campaign.calibrate.adequacy_warnings`), and where the material card is
(calibration.json, the ``demcal export`` command). A table of contents follows, then
for each campaign (the layout of the reference paper, IJABE 2020; captions name a
publication only where the campaign file's ``[report] captions`` say which of its tables
a report table reproduces, and columns that would be empty are left out):

* lab samples and targets (Table 1);
* calibrated parameters per condition (Tables 6, 10) with the ranges of the
  solution set, next to the published (``[conditions.reference]``) values, with the
  desirability ramps and the overlay plot of the lab window;
* verification: simulated against measured, relative error, inside the lab spread
  or not, inside the model's 95 % prediction interval or not -- and plainly why not;
  the calibration loop's boxes and steps;
* the calibrated material's complete parameter set per condition, each value's source
  (calibrated, fixed by the campaign, default), as the material card gives it;
* heap images simulated next to measured (Fig. 7), when the runs and photos exist: the
  verification run's final spheres in 3-D, its silhouette with the fitted flank lines,
  and the lab photo with the outline and flank lines demcal measures in it;
* factors and levels (Tables 3, 7); where a campaign fixes settings per condition
  (``[conditions.settings]``, ``from_campaign``): each condition's fixed settings with
  their values and where each came from;
* the design with its simulated results (Tables 4, 8) and the run statistics (one design
  per distinct set of conditions' fixed settings, each with its own model);
* fit summary, ANOVA (Tables 5, 9), fit statistics, coefficients, the model
  equation in coded and actual units (Eqs. 4, 6);
* predicted vs actual (Fig. 6), perturbation, response surfaces (Figs. 5, 9);
* Design-Expert's diagnostics of each model: normal plot, externally studentized
  residuals against predicted and run order, Cook's distance, Box-Cox, interaction
  plots (:mod:`demcal.report.diagnostics`);

then a section that re-analyses the paper's own tables. Headings and columns name
responses and factors by their labels and units (``[[responses]] label, unit``,
``[[factors]] label``). The page is rendered by the jinja2 templates of
:mod:`demcal.report.html`; each figure is rendered once, to ``figures/<name>.png``.
"""

from __future__ import annotations

import json
import os
import shlex
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from demcal.campaign.calibrate import Calibration, calibrate
from demcal.campaign.config import Campaign
from demcal.errors import DataError
from demcal.report.html import HtmlReport, format_number

#: How many response-surface figures per campaign (the strongest two-factor interactions).
SURFACES = 3


def write_report(campaigns: Campaign | Sequence[Campaign], out: str | Path | None = None,
                 calibrations: Sequence[Calibration] | None = None, title: str | None = None,
                 figure_files: bool = True) -> Path:
    """Write the HTML report of one or more campaigns; returns the HTML file's path.

    Parameters
    ----------
    campaigns : a campaign, or several (the demo reports both of the paper's).
    out : report folder; default ``<workdir>/report`` of the first campaign.
    calibrations : results of :func:`demcal.campaign.calibrate.calibrate`; recomputed
        from the store (nothing simulated) when omitted.
    figure_files : write each figure once as ``figures/<name>.png`` and refer to it from
        the page (the folder is the report); False: embed each in the page instead (one
        file to mail).
    """
    if isinstance(campaigns, Campaign):
        campaigns = [campaigns]
    campaigns = list(campaigns)
    references = {c.name: _reference_table(c) for c in campaigns if c.reference_table is not None}
    if calibrations is None:
        calibrations = [calibrate(c, simulate=False, progress=False) for c in campaigns]
    out = Path(out) if out is not None else campaigns[0].workdir / "report"
    report = HtmlReport(title or (campaigns[0].title if len(campaigns) == 1 else
                                  "DEM contact parameter calibration"), out,
                        figure_formats=(), link_figures=figure_files)
    several = len(campaigns) > 1
    report.block("summary", campaigns=[_summary(report, cal, several) for cal in calibrations])
    report.contents()
    for calibration in calibrations:
        _campaign_sections(report, calibration, prefix=calibration.campaign.name if several else "")
    _paper_sections(report, campaigns, references)
    return report.write()


# --------------------------------------------------------------------------- the answer first


def _identify_section(report: HtmlReport, c, n) -> None:
    """What ``demcal identify`` found before the design, where its identify.json is in the
    campaign's folder: each factor's effect on each response in seed-noise units, and
    which parameters the responses cannot pin (docs/identify.md)."""
    import json

    from demcal.campaign.identify import RESULT_FILE

    path = c.workdir / RESULT_FILE
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return
    if "effects" not in data:
        return
    report.section("Identifiability before the design", 3)
    labels = {f["name"]: f["label"] for f in data.get("factors", [])}
    rows = [{"factor": e["factor"], "response": e["response"], "effect": e["effect"], "se": e["se"], "t": e["t"],
             "beyond the seed noise": "yes" if e["beyond_noise"] else "no"} for e in data["effects"]]
    design = data.get("design", {})
    unpinned = [u["factor"] for u in data.get("unpinned", [])]
    tied = [" and ".join(g["factors"]) for g in data.get("not_separately_identifiable", [])]
    report.paragraph(
        f"`demcal identify` screened the factors at the {data.get('profile')} profile ({design.get('kind')}, "
        f"{design.get('points')} points x {design.get('replicates')} seeds): "
        + ("every factor is pinned by the responses." if data.get("identifiable") else
           "; ".join(([f"not pinned by any response: {', '.join(labels.get(u, u) for u in unpinned)}"] if unpinned
                      else []) + ([f"not separately identifiable: {', '.join(tied)}"] if tied else [])) + ".")
        + " The effects below are half the high-minus-low difference with their standard error from the "
          "seed noise (docs/identify.md).")
    report.table(pd.DataFrame(rows).set_index("factor"), n("identify_effects"),
                 caption="Screening effects of the factors on the responses (demcal identify)",
                 values={"factor": labels})


def _holdout_table(report: HtmlReport, c, cal: Calibration, n) -> None:
    """The tests the calibration did not fit, run at each condition's calibrated values
    against their lab values (``[[holdout]]``)."""
    rows = []
    for result in cal.conditions:
        for h in result.holdouts:
            lo, hi = h.interval
            rows.append({"condition": result.condition.name, "test": h.test, "response": h.response,
                         "profile": h.profile, "lab mean ± sd": f"{h.target:g} ± {h.lab_sd:g}" if h.lab_sd else
                         f"{h.target:g}", "runs": f"{len(h.simulated)} of {h.runs}",
                         "simulated mean": f"{h.mean:.2f}" if h.simulated else "-",
                         "95 % interval": f"{lo:.2f} to {hi:.2f}" if np.isfinite(lo) else "-", "verdict": h.verdict})
    if not rows:
        return
    report.section("Hold-out tests", 3)
    report.paragraph("Tests the calibration did not fit, run at each condition's calibrated values: a check "
                     "that the parameters carry over to another bench. The rule is the verification's: the "
                     "simulated mean inside the lab mean ± sd agrees.")
    report.table(pd.DataFrame(rows).set_index("condition"), n("holdout"),
                 caption="Hold-out tests at the calibrated values against their lab values")


def _ranges_by_test(report: HtmlReport, c, cal: Calibration, n) -> None:
    """A joint test's compatible ranges (the box's region where every target's model
    predicts inside its lab mean ± sd, within the fit's 95 % interval of the mean) of each
    test alone beside those of all together: how much each further test pins down."""
    rows = []
    for result in cal.conditions:
        if not result.compatible_by_test:
            continue
        for f in c.factors:
            row = {"condition": result.condition.name, "factor": f.name}
            widths = []
            for test, ranges in result.compatible_by_test.items():
                lo, hi = ranges.get(f.parameter, (np.nan, np.nan))
                row[f"{test} alone"] = f"{lo:.3g} to {hi:.3g}" if np.isfinite(lo) else "none in the box"
                widths.append(hi - lo)
            lo, hi = result.compatible.get(f.parameter, (np.nan, np.nan))
            row["all together"] = f"{lo:.3g} to {hi:.3g}" if np.isfinite(lo) else "none in the box"
            narrowest = np.nanmin(widths) if np.isfinite(widths).any() else np.nan
            row["together / narrowest alone"] = (f"{(hi - lo) / narrowest:.2f}" if narrowest > 0 and np.isfinite(lo)
                                                 else "-")
            rows.append(row)
    if not rows:
        return
    report.paragraph("Each test of the joint campaign alone and all together: the ranges of the design box "
                     "where every one of their targets is predicted inside the lab mean ± sd, within the fitted "
                     "surface's 95 % confidence interval of the mean (Design-Expert's overlay region with the "
                     "seed noise the surface averages, sampled). A range that shrinks from one test to all is "
                     "pinned down by the others; one that does not, no test here pins.")
    report.table(pd.DataFrame(rows).set_index("condition"), n("compatible_ranges_by_test"),
                 caption="Ranges compatible with the lab targets, each test alone and all together",
                 values={"factor": {f.name: f.label for f in c.factors}})


def _summary(report: HtmlReport, cal: Calibration, several: bool) -> dict:
    """What the first screen says of one campaign (template ``summary.html.j2``): per
    condition the calibrated values with their solution-set ranges, the verdict and the
    runs; the campaign's facts, warnings and material card."""
    from demcal.campaign.wording import Words
    from demcal.rounding import ranged

    c = cal.campaign
    responses = sorted({v.response for r in cal.conditions for v in r.verdicts}, key=str)
    one = responses[0] if len(responses) == 1 else None
    conditions = []
    for result in cal.conditions:
        values = []
        on_path = result.loop is not None and result.loop.on_path is not None
        for f in c.factors:
            value = result.chosen.get(f.parameter)
            lo, hi = result.factor_ranges.get(f.parameter, (np.nan, np.nan))
            shown, low, high = ranged(value, lo, hi, f.units) if value is not None else ("", "", "")
            values.append({"value": shown,
                           "range": f"set {low} to {high}" if low and high else
                           "a point on the path, no solution set" if on_path else ""})
        conditions.append({"name": result.condition.name,
                           "label": result.condition.label if result.condition.label != result.condition.name else "",
                           "values": values, "verdicts": [_verdict(c, result, v, one is None)
                                                          for v in result.verdicts],
                           "status": _loop_words(c, result), "runs": _condition_runs(result)})
    table = pd.concat([design.table for design in cal.designs])
    done = int((table["status"] == "done").sum())
    spent = _runs_spent(cal)
    facts = (f"Virtual test {c.test}, profile {c.profile}; campaign file {c.path.name}; {done} of {len(table)} "
             "design runs done" + ("; simulations spent: " + ", ".join(f"{count} {what}" for what, count in spent)
                                   + f", {sum(count for _, count in spent)} in all" if spent else "") + ".")
    card = c.workdir / "calibration.json"
    links = []
    if card.is_file():
        links.append({"href": Path(os.path.relpath(card, report.out_dir)).as_posix(), "text": "calibration.json"})
    links.append({"href": "#" + _anchor(_name(c.name if several else "", "material")),
                  "text": "every parameter (below)"})
    return {"id": report.anchor(f"summary {c.name}"),
            "heading": f"{c.title}: calibrated values" if several else "Calibrated values",
            "factor_headings": [f.label for f in c.factors],
            "verdict_heading": ("Verification: " + _response_heading(c, one)) if one else "Verification",
            "conditions": conditions, "facts": facts, "links": links,
            "warnings": [Words(c).keys(w) for w in list(cal.warnings) + list(cal.lab_noise)],
            "export_text": "the card for a DEM code (json, liggghts or edem):",
            "export": _command(c, "export").replace(" --profile " + shlex.quote(str(c.profile)), "")
            + f" --format json -o {shlex.quote(c.name + '-card.json')}"}


def _anchor(name: str) -> str:
    """The id of a section the summary links to (``name``: its file-name stem)."""
    from demcal.report.html import _slug

    return "s-" + _slug(name).lower()


def _verdict(c: Campaign, result, v, labelled: bool) -> dict:
    """One response's verdict: lab mean ± sd, simulated mean ± its 95 % interval, n, each
    rounded to the precision its noise supports, with its unit."""
    from demcal.campaign.wording import Words, half_width

    w = Words(c, result.condition)
    lab = w.window(v.target, v.lab_sd, v.response)
    n = len(v.simulated)
    half = half_width(result, v)
    simulated = (f"{w.window(v.simulated_mean, half, v.response)} (95 %)" if np.isfinite(half)
                 else w.value(v.simulated_mean, v.response)) if n else ""
    if result.loop is not None:
        words, ok = result.loop.status, result.loop.status == "verified"
    elif not n:
        words, ok = f"not simulated yet (0/{len(result.specs)})", False
    elif v.within_lab_sd is None:
        words, ok = "no lab sd to judge by", False
    else:
        ok = bool(v.within_lab_sd)
        words = "inside the lab's mean ± sd" if ok else "outside the lab's mean ± sd"
    return {"label": _response_heading(c, v.response) if labelled else "", "lab": lab, "simulated": simulated,
            "n": n, "words": words, "ok": ok}


def _loop_words(c: Campaign, result) -> str:
    """Why a loop that did not verify stopped, in one sentence (the verdict says the rest)."""
    from demcal.campaign.wording import stop

    loop = result.loop
    return stop(c, result) if loop is not None and loop.status != "verified" else ""


def _condition_runs(result) -> str:
    """The runs one condition spent beyond the campaign's design."""
    if result.loop is not None:
        kinds = result.loop.runs_by_stage()
        parts = [f"{kinds[k]} {k}" for k in ("path", "design") if kinds.get(k)]
        return ", ".join(parts + [f"{len(result.verification)} production"])
    done = sum(r.status == "done" for r in result.verification)
    return f"{done}/{len(result.specs)} verification"


def _response_heading(c: Campaign, name: str) -> str:
    """``Angle of repose β [°]``: the campaign's label and unit of a response (read from
    its name when the campaign gives none)."""
    from demcal.report.figures import response_label

    response = next((r for r in c.responses if r.name == name), None)
    label = response.label if response is not None and response.label else None
    unit = response.unit if response is not None and response.unit else None
    return response_label(name, label, unit)


def _common_unit(c: Campaign, names) -> str | None:
    """The unit all of the responses ``names`` share, else None."""
    units = {_response_unit(c, name) for name in names}
    return units.pop() if len(units) == 1 else None


def _response_unit(c: Campaign, name: str) -> str | None:
    heading = _response_heading(c, name)
    return heading[heading.rindex("[") + 1:-1] if heading.endswith("]") else None


def _with_unit(text: str, unit: str | None) -> str:
    return f"{text} [{unit}]" if unit else text


# --------------------------------------------------------------------------- sections


def _name(prefix: str, name: str) -> str:
    return f"{prefix}_{name}" if prefix else name


def _cite(campaign: Campaign, key: str) -> str:
    """`` (paper Table 3)``: the source the campaign file names for a table, else nothing."""
    return f" ({campaign.captions[key]})" if key in campaign.captions else ""


def _reference_word(campaign: Campaign) -> str:
    """What the conditions' ``[conditions.reference]`` values are called ("reference",
    or the campaign's ``[report] captions.reference``, e.g. "paper")."""
    return campaign.captions.get("reference", "reference")


def _drop_empty(frame: pd.DataFrame) -> pd.DataFrame:
    """The table without columns in which every cell is empty (None, NaN or "")."""
    empty = [col for col in frame.columns
             if all(v is None or (isinstance(v, str) and not v.strip()) or
                    (isinstance(v, (float, np.floating)) and not np.isfinite(v)) for v in frame[col])]
    return frame.drop(columns=empty)


def _campaign_sections(report: HtmlReport, cal: Calibration, prefix: str) -> None:
    from demcal.campaign.wording import Words

    c = cal.campaign
    n = lambda name: _name(prefix, name)  # noqa: E731
    if prefix:
        report.section(c.title, level=2)
    if c.description:
        report.paragraph(c.description)
    table = pd.concat([design.table for design in cal.designs])
    done = table[table["status"] == "done"]
    report.paragraph(
        f"Virtual test {c.test}, profile {c.profile}; {len(done)} of {len(table)} design runs done"
        + (f", {int((table['status'] == 'failed').sum())} failed" if (table["status"] == "failed").any() else "")
        + f"; campaign file {c.path.name}; store {c.store_path}.")
    if c.plugins:
        report.paragraph(f"Plugins named by the campaign file: {', '.join(c.plugins)} (imported by `demcal run` and "
                         "`demcal calibrate` to register the virtual test; `demcal report` imports none).")
    if len(done) < len(table):
        report.note(f"{len(table) - len(done)} of {len(table)} design runs are not done, so the model is fitted "
                    f"to {len(done)}: run `{_command(c, 'run')}`"
                    + (" (add --retry-failed for the failed ones)" if (table["status"] == "failed").any() else "")
                    + f", then `{_command(c, 'calibrate')}`.")

    # the answer: targets, calibrated values, their verification, the material
    _lab_section(report, cal, n)
    _calibration_sections(report, cal, n)
    _verification_sections(report, cal, n)
    _loop_sections(report, cal, n)
    _parameters_section(report, cal, n)
    _images_section(report, cal, n)

    # how it was found: the design, its models, their diagnostics
    report.section("Factors and levels", 3)
    levels = pd.DataFrame(
        [{"factor": f.name, "parameter": f.parameter, "label": f.description, "units": f.units,
          "-1": f.low, "0": f.centre, "+1": f.high} for f in c.factors]).set_index("factor")
    report.table(_drop_empty(levels), n("factors"), caption="Factors and levels" + _cite(c, "factors"))
    _settings_section(report, cal, n)
    _identify_section(report, c, n)

    several = len(cal.designs) > 1
    for design in cal.designs:
        m = (lambda name, design=design: n(f"{name}_{design.name}")) if several else n
        report.section("Design and results" + (f" of {design.name}" if several else ""), 3)
        if several:
            report.paragraph(f"The runs of {design.name} with the settings fixed for "
                             f"{'it' if len(design.conditions) == 1 else 'them'} (table above); the model "
                             "fitted to them is what the calibration of "
                             f"{'that condition' if len(design.conditions) == 1 else 'those conditions'} solves.")
        _design_section(report, c, design.table, m)
        _benchmark_section(report, design.campaign, m)
        for response in design.models:
            _model_sections(report, c, design, response, m)
    for note in cal.notes:
        if note not in cal.warnings:
            report.note(Words(c).plain(note))


def _lab_section(report: HtmlReport, cal: Calibration, n) -> None:
    c = cal.campaign
    report.section("Lab data and targets", 3)
    rows = []
    sieve_rows = []
    for cond in c.conditions:
        record = cond.sample
        for t in cond.targets:
            rows.append({"condition": cond.name, "sample": record.name if record else "",
                         "moisture %": getattr(record, "moisture_percent", None),
                         "bulk density kg/m³": getattr(record, "bulk_density", None),
                         "response": t.response, "target": t.mean, "lab sd": t.sd})
        if record is not None and record.sieve is not None:
            s = record.sieve
            for lo, hi, m in zip(s.lower_mm, s.upper_mm, s.mass_percent):
                sieve_rows.append({"sample": record.name, "class mm": f"[{lo:g}, {hi:g})", "mass %": m})
    unit = _common_unit(c, {row["response"] for row in rows})
    report.table(_drop_empty(pd.DataFrame(rows).set_index("condition")), n("targets"),
                 caption="Lab samples and measured targets" + _cite(c, "targets"),
                 headings={"target": _with_unit("target", unit), "lab sd": _with_unit("lab sd", unit)},
                 values={"response": {r: _response_heading(c, r) for r in c.response_names}})
    if sieve_rows:
        sieve = pd.DataFrame(sieve_rows).pivot(index="class mm", columns="sample", values="mass %")
        sieve = sieve.reindex([r["class mm"] for r in sieve_rows if r["sample"] == sieve_rows[0]["sample"]])
        report.table(sieve, n("sieve"), caption="Particle-size distribution, mass %" + _cite(c, "sieve"))


def _settings_section(report: HtmlReport, cal: Calibration, n) -> None:
    """Each condition's fixed settings: value and source (campaign file, the campaign whose
    calibration it takes, or the test's default), when the campaign fixes any per condition."""
    from demcal.campaign.chain import condition_settings

    c = cal.campaign
    if not c.per_condition:
        return
    rows = [{"condition": name, "setting": key, "value": value, "source": source}
            for name, settings in condition_settings(c).items() for key, (value, source) in settings.items()]
    report.section("Fixed settings per condition", 3)
    report.paragraph("The settings each condition's runs keep fixed besides the factors, and where each value "
                     "comes from: the campaign file ([experiment.settings] for every condition, "
                     "[conditions.settings] for one), another campaign's calibration (from_campaign, for the "
                     "condition of the same name), or the virtual test's default. A condition's own settings "
                     "take precedence over the other campaign's values, which take precedence over "
                     "[experiment.settings].")
    report.table(pd.DataFrame(rows).set_index("condition"), n("condition_settings"),
                 caption="Fixed settings per condition and their sources")


def _design_section(report: HtmlReport, c: Campaign, table: pd.DataFrame, n) -> None:
    cols = ["run"] + c.factor_names + [f.parameter for f in c.factors] + c.response_names + ["seed", "status", "wall_s"]
    if c.replicates > 1:
        cols.insert(1, "replicate")
    shown = table[cols].set_index("run").rename(
        columns={f.parameter: f"{f.name} actual" for f in c.factors})
    headings = {f"{f.name} actual": f.label for f in c.factors}
    headings.update({f.name: f"{f.name} coded" for f in c.factors})
    headings.update({r: _response_heading(c, r) for r in c.response_names})
    headings["wall_s"] = "wall time [s]"
    report.table(shown, n("design_results"),
                 caption="Design (coded and actual levels) with simulated responses" + _cite(c, "design"),
                 headings=headings)
    walls = table["wall_s"].dropna()
    if len(walls):
        report.paragraph(f"Wall time per design run: mean {walls.mean():.1f} s, max {walls.max():.1f} s, "
                         f"total {walls.sum() / 60:.1f} CPU-min.", "small")


def _model_sections(report: HtmlReport, c: Campaign, design, response: str, n) -> None:
    """ANOVA (Tables 5, 9), fit statistics, equations, fit summary, reduced model and
    figures (Figs. 5, 6, 9) of one design's model, built by the statistics helper's report blocks."""
    from demcal.report.paper import add_model_sections
    from demcal.rsm import Reduction

    full = design.full[response]
    model = design.models[response]
    several = design.conditions != tuple(c.conditions)
    report.section(f"Response model of {_response_heading(c, response)}" + (f" ({design.name})" if several else ""),
                   3)
    used = ("the reduced model" if design.removed.get(response) else f"the full {c.model_order} model") + (
        f" (backward elimination at alpha = {c.reduce_alpha:g})" if c.reduce_alpha is not None else "")
    report.paragraph(f"{c.model_order.capitalize()} model in coded factors "
                     + ", ".join(f"{f.name} = {f.parameter}" for f in c.factors)
                     + f"; the calibration solves {used}, and the diagnostics and figures "
                       "are of that model.")
    reduction = (Reduction(model, tuple(design.removed.get(response, ()))) if c.reduce_alpha is not None
                 else None)
    add_model_sections(report, full, n(response), surfaces=_surface_pairs(model, len(c.factors)),
                       reduce_alpha=c.reduce_alpha, level=4, used_by="calibration", reduction=reduction,
                       run_order=np.flatnonzero(design.table[response].notna().to_numpy()) + 1)


def _surface_pairs(model, k: int) -> list[tuple[int, int]]:
    """The factor pairs with the largest interaction F values (all pairs when few), of
    the factors ``model`` keeps: a factor the reduced model dropped has a flat surface."""
    from demcal.report.paper import active_factors

    active = active_factors(model)
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k) if i in active and j in active]
    if not pairs:  # one factor left: show it against each other one
        pairs = [(i, j) for i in range(k) for j in range(i + 1, k) if i in active or j in active]
    if len(pairs) <= SURFACES:
        return pairs[:SURFACES]
    names = model.names

    def strength(pair):
        term = f"{names[pair[0]]}*{names[pair[1]]}"
        if term in model.anova.index and np.isfinite(model.anova.loc[term, "F"]):
            return float(model.anova.loc[term, "F"])
        return -1.0

    return sorted(pairs, key=strength, reverse=True)[:SURFACES]


def _calibration_sections(report: HtmlReport, cal: Calibration, n) -> None:
    from demcal.campaign.wording import Words, stop
    from demcal.report.diagnostics import add_desirability_sections
    from demcal.report.paper import add_optimization_sections

    c = cal.campaign
    report.section("Calibrated parameters", 3)
    report.paragraph(
        "For each condition the model is solved for the lab target by a desirability search; every "
        "setting with desirability >= 0.99 belongs to the solution set, and the range of each factor "
        "over it is given: one angle does not pin down all parameters. The setting simulated for "
        "verification is the one of the set nearest the design centre.")
    ref = _reference_word(c)
    rows = []
    for result in cal.conditions:
        outside = _outside_box(c, result.condition.reference)
        for f in c.factors:
            lo, hi = result.factor_ranges.get(f.parameter, (np.nan, np.nan))
            rows.append({"condition": result.condition.name, "factor": f.name, "parameter": f.parameter,
                         "calibrated": result.chosen[f.parameter], "set low": lo, "set high": hi,
                         ref: result.condition.reference.get(f.parameter, np.nan),
                         f"{ref} value": (f"outside the design box: extrapolated ({f.low:g} to {f.high:g})"
                                           if f.parameter in outside else "")})
    params = _drop_empty(pd.DataFrame(rows).set_index("condition"))
    report.table(params, n("calibrated_parameters"),
                 caption="Calibrated parameters per condition with the solution-set ranges"
                         + (f", and the {ref} values" if ref in params.columns else "") + _cite(c, "calibrated"),
                 values={"factor": {f.name: f.label for f in c.factors}})
    _ranges_by_test(report, c, cal, n)
    _holdout_table(report, c, cal, n)
    pred = []
    for result in cal.conditions:
        outside = _outside_box(c, result.condition.reference)
        flag = ""
        if outside and result.reference_predicted:
            flag = "outside the design box: extrapolated (" + ", ".join(
                f"{f.name} = {result.condition.reference[f.parameter]:g} outside {f.low:g} to {f.high:g}"
                for f in c.factors if f.parameter in outside) + ")"
        for v in result.verdicts:
            goal = _goal_solved(result, v.response)
            solved = "the target"
            on_path = result.loop.on_path if result.loop is not None else None
            if on_path is not None and on_path.get("limit"):
                solved = (f"the nearest the test reaches: the end of the path from box {on_path['box']}, at the "
                          f"parameters' limits")
            elif on_path is not None and on_path.get("nearest"):
                solved = (f"the lab window, at the path's nearest step to the target from box {on_path['box']} "
                          f"(read {on_path['reading']:.2f})")
            elif on_path is not None:
                solved = f"the target, on the path from box {on_path['box']} (read off the path)"
            elif goal is not None and not v.target_reachable:
                solved = f"unreachable; solved for {goal.target:.2f}, the nearest the box reaches"
            pred.append({"condition": result.condition.name, "response": v.response, "target": v.target,
                         "goal solved": solved,
                         "predicted at calibrated": v.predicted,
                         f"predicted at {ref} values": result.reference_predicted.get(v.response, np.nan),
                         f"{ref} values": flag,
                         "model reaches low": v.reachable[0], "model reaches high": v.reachable[1],
                         "desirability": (_target_desirability(result, v, goal) if on_path is None
                                          else np.nan)})
    unit = _common_unit(c, c.response_names)
    headings = {key: _with_unit(key, unit) for key in ("target", "predicted at calibrated",
                                                        f"predicted at {ref} values", "model reaches low",
                                                        "model reaches high")}
    report.table(_drop_empty(pd.DataFrame(pred).set_index("condition")), n("model_predictions"),
                 headings=headings, values={"response": {r: _response_heading(c, r) for r in c.response_names}},
                 caption="Model predictions at the calibrated parameters"
                         + (f" and at the {ref} values" if any(r.reference_predicted for r in cal.conditions)
                            else "") + ", and the "
                         "range the model reaches inside the design box; desirability is that of the "
                         "lab target itself at the calibrated setting (Derringer-Suich, the solved "
                         "goal's limits widened to the target), so an unreachable target scores below "
                         "the 0.99 of the solution set")
    for result in cal.conditions:
        words = Words(c, result.condition)
        for note in result.notes:
            if "outside what the model reaches" in note:
                report.note(f"{result.condition.name}: {words.plain(note)}")
        outside = _outside_box(c, result.condition.reference)
        if outside:
            values = ", ".join(f"{f.parameter} = {result.condition.reference[f.parameter]:g} (design box "
                               f"{f.low:g} to {f.high:g})" for f in c.factors if f.parameter in outside)
            report.note(f"{result.condition.name}: the {ref} value{'' if len(outside) == 1 else 's'} {values} "
                        f"{'is' if len(outside) == 1 else 'are'} "
                        "outside the design box; the model's prediction there is extrapolated and not to "
                        "be trusted.")
        on_path = result.loop.on_path if result.loop is not None else None
        if on_path is not None:
            steps = on_path["steps"]
            reading = words.value(on_path.get("reading", np.nan), result.condition.targets[0].response)
            where = (f"a point on the path of steepest {on_path['way']} from box {on_path['box']}, "
                     f"where the path, read at the production profile and interpolated linearly between its steps "
                     f"{steps[0]} and {steps[1]}, crosses the lab target")
            if on_path.get("limit"):
                where = (f"the end of the path of steepest {on_path['way']} from box {on_path['box']}: its step "
                         f"{steps[0]}, where the parameters' limits stop it short of the lab mean (read there at "
                         f"the production profile: {reading}, within the noise of the lab window, "
                         f"so it was measured at the production profile rather than the target being called out "
                         f"of reach)")
            elif on_path.get("nearest"):
                where = (f"the step of the path of steepest {on_path['way']} from box {on_path['box']} nearest the "
                         f"lab target: its step {steps[0]}, which the path did not carry past the lab mean but read "
                         f"inside the lab window at the production profile ({reading}), so it was "
                         f"measured there before a new box was laid")
            if result.loop.status == "verified":
                report.paragraph(
                    f"{result.condition.name}: verified at {where}. The production runs there met the "
                    f"{'lab window' if on_path.get('limit') or on_path.get('nearest') else 'target'}, so "
                    "no design was laid around the point: it is one verified parameter set, with no solution set "
                    "and no factor ranges. Lay a design around it (set [calibration] verify_on_path = false) to "
                    "map the other settings that give the same angle.")
            else:
                report.paragraph(f"{result.condition.name}: the loop stopped at {where}. {stop(c, result)}")
            continue
        title = f"Solving for {result.condition.name} (solution 1, the star, is simulated)"
        substitutes = [f"the lab's {words.value(v.target, v.response)} ({words.label(v.response)}) is out of reach, "
                       f"so the goal is {words.value(goal.target, v.response)}"
                       for v in result.verdicts
                       if not v.target_reachable and (goal := _goal_solved(result, v.response)) is not None]
        if substitutes:
            title += ": " + "; ".join(substitutes)
        add_optimization_sections(report, result.optimization, n(f"solve_{result.condition.name}"),
                                  title, level=4, labels={r: _response_heading(c, r) for r in c.response_names})
        add_desirability_sections(report, cal, result, n(f"solve_{result.condition.name}"))


def _parameters_section(report: HtmlReport, cal: Calibration, n) -> None:
    """The calibrated material's complete parameter set per condition, as the material
    card gives it (:func:`demcal.export.card.build_card`, what ``demcal export`` writes):
    every value with its unit and its source -- calibrated (a factor), fixed by the
    campaign, another campaign's calibration, or a default -- plus the derived Young's
    moduli, the steel of the walls, the particle template and its size distribution."""
    from demcal.errors import DemcalError
    from demcal.export.card import build_card
    from demcal.export.text import number

    c = cal.campaign
    report.section("Calibrated material: every parameter", 3, anchor=_anchor(n("material")))
    try:
        card = build_card(c, cal.to_dict())
    except DemcalError as exc:
        report.note(f"The full parameter set cannot be listed: {exc}")
        return
    factors = {f.parameter: f.name for f in c.factors}
    sources = {"calibrated": "calibrated", "fixed": "fixed by the campaign",
               "default": f"default of {c.test} ({c.profile})",
               "demcal default": "demcal default (not a setting of the test)"}
    several = len(card["conditions"]) > 1
    rows: dict[str, dict] = {}

    def put(key, unit, condition, value, source):
        row = rows.setdefault(key, {"parameter": key, "unit": unit})
        row[condition if several else "value"] = number(value) if isinstance(value, float) else value
        row[f"{condition} source" if several else "source"] = source

    shape = card["particle"]
    radii = " + ".join(f"{1e3 * sphere['radius']:g}" for sphere in shape["spheres"])
    apart = f", centres {1e3 * shape['centre_distance']:g} mm apart" if "centre_distance" in shape else ""
    sizes = shape["size_distribution"]
    for condition in card["conditions"]:
        name, parameters = condition["name"], condition["parameters"]
        for key, entry in parameters.items():
            source = sources.get(entry["source"], entry["source"])
            if entry["source"] == "calibrated" and key in factors:
                source = f"calibrated (factor {factors[key]})"
            put(key, entry["unit"], name, entry["value"], source)
            prefix = key.split(".")[0]
            if key.endswith(".shear_modulus") and prefix in condition["materials"]:
                put(f"{prefix}.youngs_modulus", "Pa", name, condition["materials"][prefix]["youngs_modulus"],
                    "derived: E = 2 G (1 + nu)")
        if any(k.startswith("wall.") and e["source"] != "demcal default" for k, e in parameters.items()):
            steel = condition["materials"]["steel"]
            for prop, unit in (("density", "kg/m3"), ("shear_modulus", "Pa"), ("youngs_modulus", "Pa"),
                               ("poisson_ratio", "-"), ("yield_strength", "Pa")):
                put(f"steel.{prop}", unit, name, steel[prop], "demcal's steel (the walls)")
        shape_source = sources.get(parameters.get("particles.shape", {}).get("source"), "default")
        put("particle template", "mm", name, f"{shape['shape']}: radii {radii} mm{apart}", shape_source)
        put("size distribution", "-", name,
            f"{sizes['kind']} size factor {sizes['scale_min']:g} to {sizes['scale_max']:g} (by {sizes['basis']})"
            + (f": lab sizes {sizes['lab_window_mm'][0]:g}-{sizes['lab_window_mm'][1]:g} mm x{sizes['coarse_grain']:g}, "
               f"{sizes['left_out_percent']:.3g} % of the lab mass outside them left out" if sizes["kind"] == "sieve" else ""),
            shape_source)
    report.paragraph("The complete parameter set of the calibrated material, the one `demcal export` writes to "
                     "the material card: 'calibrated' values are solved from the model (the campaign's factors), "
                     "'fixed by the campaign' ones are set in the campaign file, and the others are the virtual "
                     "test's defaults at the campaign's profile; Young's moduli are derived from the shear "
                     "modulus and Poisson ratio.")
    columns = ["unit"] + [column for cond in card["conditions"]
                          for column in ((cond["name"], f"{cond['name']} source") if several else ("value", "source"))]
    table = pd.DataFrame(list(rows.values())).set_index("parameter")[columns]
    report.table(_drop_empty(table), n("material_parameters"),
                 caption=f"{c.title}: calibrated material per condition, every parameter with its unit and source")
    for warning in card["warnings"]:
        report.note(warning)


def _outside_box(campaign, reference) -> set[str]:
    """Parameters whose published value lies outside the factor's design range."""
    out = set()
    for f in campaign.factors:
        if f.parameter in reference:
            value, lo, hi = float(reference[f.parameter]), min(f.low, f.high), max(f.low, f.high)
            tol = 1e-9 * max(1.0, hi - lo)
            if not lo - tol <= value <= hi + tol:
                out.add(f.parameter)
    return out


def _goal_solved(result, response: str):
    """The goal the search actually solved for ``response`` (a substitute when the lab
    target is outside what the box reaches)."""
    for goal in getattr(result.optimization, "goals", ()):
        if goal.response == response:
            return goal
    return None


def _target_desirability(result, verdict, goal) -> float:
    """Desirability of the lab target at the calibrated (unrounded) solution."""
    if goal is None or goal.kind != "target" or goal.low is None:
        return float(result.desirability)
    key = f"predicted:{verdict.response}"
    solutions = result.optimization.solutions
    predicted = float(solutions.iloc[0][key]) if key in solutions else verdict.predicted
    if goal.target == verdict.target:
        return float(goal.desirability(predicted))
    from dataclasses import replace

    real = replace(goal, target=verdict.target, low=min(goal.low, verdict.target),
                   high=max(goal.high, verdict.target))
    return float(real.desirability(predicted))


def _command(campaign, verb: str, *extra: str) -> str:
    return " ".join(["demcal", verb, shlex.quote(str(campaign.path)), "--profile",
                     shlex.quote(str(campaign.profile)), *extra])


def _stale(cal: Calibration) -> list[str]:
    """Conditions whose parameters in calibration.json differ from what the store gives now."""
    path = cal.campaign.workdir / "calibration.json"
    try:
        saved = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if saved.get("profile") != cal.campaign.profile:
        return []
    before = {c.get("name"): c.get("chosen") for c in saved.get("conditions", []) if isinstance(c, dict)}
    return [r.condition.name for r in cal.conditions
            if r.condition.name in before and before[r.condition.name] != r.chosen]


def _benchmark_section(report: HtmlReport, c: Campaign, n) -> None:
    """demcal's benches against the published responses at the same parameter values (the
    runs with the fixed settings of ``c``, one design's campaign)."""
    from demcal.campaign.store import Store
    from demcal.report import benchmark

    if c.reference_table is None or not c.store_path.is_file():
        return
    with Store(c.store_path, readonly=True) as store:
        records = store.records()
    for response in c.response_names:
        comparisons = benchmark.compare(c, response, records)
        if not comparisons:
            continue
        label = next((r.label for r in c.responses if r.name == response and r.label), response)
        report.section(f"demcal's benches against the published responses ({_response_heading(c, response)})", 3)
        report.paragraph(
            f"Each design point of {c.reference_table.name} simulated by demcal ({c.test}) at the same parameter "
            "values: the mean of demcal's runs there against the published value. Offset = demcal - published; "
            "slope of demcal on published (1: the same factor effects); error bars: the seed-to-seed sd "
            "(the point's own where it has replicates, else pooled). The published responses come from "
            "another code and set-up (docs/validation.md explains the offsets).")
        report.table(pd.DataFrame([x.summary() for x in comparisons]).set_index("profile"),
                     n(f"{response}_vs_published"), caption="demcal against the published responses, per profile")
        points = pd.concat([x.points.assign(profile=x.profile) for x in comparisons]).set_index("profile")
        report.table(points, n(f"{response}_vs_published_points"),
                     caption="Point by point (n: demcal runs at the point; sd: their seed-to-seed sd)")
        report.figure(benchmark.figure(comparisons, response, label), n(f"{response}_vs_published"),
                      caption="demcal against the published responses at the same parameters (dashed: 1:1)")


def _loop_sections(report: HtmlReport, cal: Calibration, n) -> None:
    """The closed loop per condition: why it stopped, how the box moved, every step."""
    loops = [(r, r.loop) for r in cal.conditions if r.loop is not None]
    if not loops:
        return
    from demcal.campaign.calibrate import production_profile
    from demcal.campaign.wording import Words, stop
    from demcal.campaign.wording import step as wording_step

    c = cal.campaign
    report.section("The calibration loop", 3)
    report.paragraph(f"Designs and path points run at profile {c.profile}; the chosen parameters are verified at "
                     f"profile {production_profile(c)}, and the difference between the two (production minus the "
                     f"cheap model) corrects the target the model is solved for (demcal.campaign.loop).")
    status, boxes, steps = [], [], []
    for result, loop in loops:
        name = result.condition.name
        words = Words(c, result.condition)
        kinds = loop.runs_by_stage()
        status.append({"condition": name, "status": loop.status, "boxes": len(loop.boxes),
                       "path runs": kinds.get("path", 0), "new design runs": kinds.get("design", 0),
                       "production runs": len(result.verification), "discrepancy":
                       "; ".join(d.describe() for d in loop.discrepancy.values()), "why it stopped": stop(c, result)})
        for box in loop.boxes:
            row = {"condition": name, "box": box.index}
            for f, lo, hi in zip(c.factors, box.low, box.high):
                row[f.parameter] = f"{lo:.4g} to {hi:.4g}"
            row["why"] = words.plain(box.reason)
            boxes.append(row)
        for step in loop.history:
            steps.append({"condition": name, "iteration": step.iteration + 1, "box": step.box, "stage": step.stage,
                          "runs": step.runs, "predicted": step.predicted, "simulated": step.simulated,
                          "95 % half-width": step.half_width,
                          "what happened": wording_step(c, result.condition, step)})
    spent = _runs_spent(cal)
    if spent:
        report.paragraph("Simulations this campaign spent: " + ", ".join(f"{count} {what}" for what, count in spent)
                         + f"; {sum(count for _, count in spent)} in all" + _cite(c, "runs") + ".")
    report.table(pd.DataFrame(status).set_index("condition"), n("loop_status"),
                 caption="How each condition's loop ended, and the runs it spent beyond the campaign's design")
    report.table(pd.DataFrame(boxes).set_index("condition"), n("loop_boxes"),
                 headings={f.parameter: f.label for f in c.factors},
                 caption="Design boxes (box 0 is the campaign's; a box moves along the path of steepest "
                         "ascent or descent when a target lies outside what the model reaches)")
    if steps:
        unit = _common_unit(c, c.response_names)
        report.table(pd.DataFrame(steps).set_index("condition"), n("loop_history"),
                     headings={key: _with_unit(key, unit) for key in ("predicted", "simulated", "95 % half-width")},
                     caption="Every step of the loop (predicted: the corrected model at the chosen parameters)")


def _runs_spent(cal: Calibration) -> list[tuple[str, int]]:
    """Finished runs in the store by kind and profile, e.g. ("29 design runs at quick")."""
    from demcal.campaign.store import Store

    if not cal.campaign.store_path.is_file():
        return []
    names = {"design": "design runs", "path": "path runs", "verification": "verification runs"}
    counts: dict[tuple[str, str], int] = {}
    with Store(cal.campaign.store_path, readonly=True) as store:
        for r in store.records():
            if r.status == "done" and r.test == cal.campaign.test:
                counts[(r.kind, r.profile)] = counts.get((r.kind, r.profile), 0) + 1
    return [(f"{names.get(kind, kind + ' runs')} at {profile}", count)
            for (kind, profile), count in sorted(counts.items())]


def _verification_sections(report: HtmlReport, cal: Calibration, n) -> None:
    from demcal.campaign.calibrate import PREDICTION_LEVEL
    from demcal.campaign.wording import Words, half_width, notes

    c = cal.campaign
    report.section("Verification by simulation", 3)
    level = f"{100 * PREDICTION_LEVEL:g} % PI"
    rows = []
    for result in cal.conditions:
        for v in result.verdicts:
            inside = {True: "yes", False: "NO", None: ""}[v.within_lab_sd]
            rows.append({
                "condition": result.condition.name, "response": v.response,
                "lab mean": v.target, "lab sd": v.lab_sd, "model": v.predicted,
                "replicates": f"{len(v.simulated)}/{len(result.specs)}",
                "simulated": ", ".join(f"{x:.2f}" for x in v.simulated),
                "simulated mean": v.simulated_mean if v.simulated else np.nan,
                "simulated sd": v.simulated_sd if v.simulated else np.nan,
                "error %": v.relative_error_percent if v.simulated else np.nan,
                "inside lab sd": inside,
                f"{level} of the mean, low": v.mean_interval[0], f"{level} of the mean, high": v.mean_interval[1],
                "model check": v.confirmation,
            })
    loops = any(r.loop is not None and r.loop.discrepancy for r in cal.conditions)
    unit = _common_unit(c, c.response_names)
    headings = {key: _with_unit(key, unit) for key in ("lab mean", "lab sd", "model", "simulated", "simulated mean",
                                                        "simulated sd", f"{level} of the mean, low",
                                                        f"{level} of the mean, high")}
    report.table(_drop_empty(pd.DataFrame(rows).set_index("condition")), n("verification"),
                 headings=headings, values={"response": {r: _response_heading(c, r) for r in c.response_names}},
                 caption="Simulated against measured at the calibrated parameters "
                         "(replicates: done / planned; relative error = |simulated mean - lab mean| / lab mean); "
                         "inside lab sd: the verification rule, the simulated mean within the lab's mean ± sd "
                         "(the loop asks also that its 95 % interval be narrower than the lab sd); "
                         f"{level} of the mean: the model's {100 * PREDICTION_LEVEL:g} % prediction interval of the "
                         "mean of that many runs at the calibrated parameters, "
                         + ("the cheap model's (final design box) shifted by the discrepancy's mean, whose own "
                            "uncertainty it leaves out" if loops else "from the fitted model")
                         + "; model check: confirmed when the simulated mean lies inside it (whether the response "
                           "model predicted the simulation, not whether the calibration is verified)"
                         + _cite(c, "verification"))
    _next_step(report, cal)
    for result in cal.conditions:
        words = Words(c, result.condition)
        for v in result.verdicts:
            if v.simulated and v.within_lab_sd:
                half = half_width(result, v)
                mean = (f"{words.window(v.simulated_mean, half, v.response)} (95 %)" if np.isfinite(half)
                        else words.value(v.simulated_mean, v.response))
                report.paragraph(f"{result.condition.name}: the simulated {words.label(v.response)}, {mean}, lies "
                                 f"within the lab's {words.window(v.target, v.lab_sd, v.response)}.")
        for note in notes(c, result):
            if "outside what the model reaches" not in note:
                report.note(f"{result.condition.name}: {note}")


def _next_step(report: HtmlReport, cal: Calibration) -> None:
    """Say what to run when the verification is stale or unfinished."""
    c = cal.campaign
    planned = sum(len(r.specs) for r in cal.conditions)
    records = [rec for r in cal.conditions for rec in r.verification]
    done = sum(rec.status == "done" for rec in records)
    failed = sum(rec.status == "failed" for rec in records)
    stale = _stale(cal)
    if stale:
        report.note(f"calibration.json is out of date: the design results now give other parameters for "
                    f"{', '.join(stale)} than it holds. Run `{_command(c, 'calibrate')}` to solve and verify "
                    "them again.")
    if done >= planned:
        return
    missing = planned - done
    text = (f"Verification is not finished: {done} of {planned} replicate runs are done. Run "
            f"`{_command(c, 'calibrate')}` to simulate the {missing} missing; runs already done are reused.")
    if failed:
        text += (f" {failed} failed; rerun them with `{_command(c, 'calibrate', '--retry-failed')}`.")
    report.note(text)


def _picture(report: HtmlReport, path: Path, name: str, alt: str) -> str:
    """The ``<img>`` of a picture file (read with the photo size limit), placed as the
    report places figures (:meth:`HtmlReport.picture_html`)."""
    from demcal._checks import MAX_PHOTO_BYTES, read_limited

    data = read_limited(path, MAX_PHOTO_BYTES, "photo", DataError)
    return report.picture_html(data, name, alt, path.suffix or ".png")


def _measured_photo(condition, base: Path):
    """``(path, photos)``: the condition's lab photo -- its ``photo``, else the first of its
    sample's photos -- and the lab record's photo settings (region, base line, scale; None
    for a ``photo`` of the condition), or None when it has none."""
    if condition.photo is not None:
        return condition.photo, None
    record = condition.sample
    photos = getattr(record, "repose_photos", None) if record is not None else None
    if photos is not None:
        try:
            paths = photos.paths(base)
        except Exception:  # a missing photo is reported by the lab check, not here
            return None
        return (Path(paths[0]), photos) if paths else None
    return None


#: Columns of the images table: key -> (heading for heaps, heading for other tests, what the
#: caption says the column shows for heaps, for other tests).
_IMAGE_COLUMNS = {
    "3d": ("simulated heap in 3-D", "simulated, in 3-D",
           "the run's final spheres in 3-D, each to scale and coloured by its height",
           "the run's final spheres in 3-D"),
    "picture": ("simulated heap as measured: silhouette and fitted flanks", "simulated: the run's measurement picture",
                "the side view of the heap demcal measured (its silhouette), with the flank lines fitted to it",
                "the picture the run's measurement wrote"),
    "photo": ("lab photo as measured: outline and fitted flanks", "lab photo as measured",
              "the condition's lab photo with the outline, base line and flank lines `demcal measure` finds in "
              "it, and their angles",
              "the condition's lab photo as `demcal measure` measures it"),
}


def _images_section(report: HtmlReport, cal: Calibration, n) -> None:
    """Per condition, side by side: the final spheres of its verification run in 3-D
    (:func:`demcal.report.heaps.heap_3d_figure`), the run's measurement picture (for a
    heap, the silhouette with the fitted flank lines) and the lab photo with the outline
    and flank lines that ``demcal measure`` finds in it
    (:func:`demcal.report.heaps.lab_photo_figure`)."""
    from demcal.errors import DemcalError
    from demcal.io.spheres import read_spheres
    from demcal.report.heaps import heap_3d_figure, lab_photo_figure

    c = cal.campaign
    rows = []
    heaps = False
    for result in cal.conditions:
        name = result.condition.name
        record = next((r for r in result.verification if r.status == "done" and r.artifacts_dir), None)
        folder = c.workdir / "runs" / record.artifacts_dir if record is not None else None
        artifacts = {key: folder / rel for key, rel in (record.result.get("artifacts", {}) if record else {}).items()}
        cells = {}
        spheres = artifacts.get("heap_spheres")
        if spheres is not None and spheres.is_file():
            try:
                figure = heap_3d_figure(read_spheres(spheres),
                                        title=f"{name}: verification run at the calibrated parameters")
                cells["3d"] = [{"img": report.figure_html(figure, n(f"heap_3d_{name}"),
                                                          f"simulated heap of {name} in 3-D")}]
            except DemcalError as exc:
                cells["3d"] = [{"text": str(exc)}]
        picture = next(((key, path) for key, path in artifacts.items()
                        if path.suffix.lower() in (".png", ".jpg", ".jpeg") and path.is_file()), None)
        if picture is not None:
            heaps = heaps or picture[0].startswith("heap")
            cells["picture"] = [{"img": _picture(report, picture[1], n(f"simulated_{name}"), f"simulated {name}")}]
        measured = _measured_photo(result.condition, c.path.parent)
        if measured is not None and measured[0].is_file():
            try:
                cells["photo"] = [{"img": report.figure_html(lab_photo_figure(*measured), n(f"lab_photo_{name}"),
                                                             f"lab photo of {name} as measured")}]
            except DemcalError as exc:  # shown as it is, with the reason it does not measure
                cells["photo"] = [{"img": _picture(report, measured[0], n(f"lab_photo_{name}"),
                                                   f"lab photo of {name}")},
                                  {"text": f"not measured: {exc}"}]
        if cells:
            chosen = ", ".join(f"{key} = {value:g}" for key, value in result.chosen.items())
            rows.append((name, chosen, cells))
    if not rows:
        return
    shown = [key for key in _IMAGE_COLUMNS if any(key in cells for _, _, cells in rows)]
    caption = (f"{c.title}: the verification run of each condition at its calibrated parameters (virtual test "
               f"{c.test}, profile {c.profile})" + (" beside its lab photo" if "photo" in shown else "")
               + _cite(c, "images") + ". " + ("Left to right: " if len(shown) > 1 else "")
               + "; ".join(_IMAGE_COLUMNS[key][2 if heaps else 3] for key in shown) + ".")
    report.section("Heap images: simulated and measured" if heaps else "Verification runs: what was measured", 3)
    report.block("image_table", caption=caption, width=f"{90 // len(shown)}%",
                 headings=[_IMAGE_COLUMNS[key][0 if heaps else 1] for key in shown],
                 rows=[{"name": name, "sub": chosen,
                        "cells": [cells.get(key, [{"text": "no image"}]) for key in shown]}
                       for name, chosen, cells in rows])


# --------------------------------------------------------------------------- paper


def _reference_table(campaign: Campaign):
    """The campaign's ``[report] reference_table``, read (with the CSV size limit) and
    checked: the columns of the paper's study of the same name (``repose``,
    ``sliding``), else the campaign's factors and responses. Returns ``(frame, runs)``;
    a table that does not fit is one :class:`DataError` sentence, before anything is written."""
    from demcal.doe.io import read_csv_text
    from demcal.errors import DemcalError
    from demcal.report.paper import STUDIES
    from demcal.rsm.data import read_table_checked, runs_from_frame

    path = campaign.reference_table
    study = {s.key: s for s in STUDIES}.get(campaign.name)
    factors = study.factors if study is not None else campaign.factors
    responses = [study.response] if study is not None else campaign.response_names
    try:
        frame = read_table_checked(path, read_csv_text(path))
        runs = runs_from_frame(frame, responses, [f.name for f in factors], {f.name: f for f in factors},
                               str(path), coded=None)
    except DemcalError as exc:
        raise DataError(f"[report] reference_table of {campaign.path.name}: {exc}") from None
    return frame, runs


def _paper_sections(report: HtmlReport, campaigns: Sequence[Campaign], references: dict) -> None:
    """Re-analyse the reference tables: the paper's own design tables with its printed
    numbers and verification errors, any other campaign's table with its own model."""
    from demcal.report.paper import STUDIES, add_model_sections, analyse_study

    studies = {study.key: study for study in STUDIES}
    for campaign in campaigns:
        if campaign.name in references and campaign.name not in studies:
            _reference_sections(report, campaign, *references[campaign.name])
    chosen = [c for c in campaigns if c.name in references and c.name in studies]
    if not chosen:
        return
    report.section("The reference paper re-analysed", 2)
    report.paragraph(
        "The paper's own simulated responses (its Tables 4 and 8) analysed with the same statistics, "
        "its calibrated parameters (Tables 6 and 10) evaluated on that model, and its verification "
        "errors recomputed from the numbers it prints.")
    for campaign in chosen:
        study = studies[campaign.name]
        analysis = analyse_study(study, n_starts=10, frame=references[campaign.name][0])
        report.section(study.title, 3)
        add_model_sections(report, analysis.model, f"paper_{study.key}", f"{study.anova_table} re-analysed: ",
                           study.printed_anova, study.printed_equation, study.printed_fit, surfaces=(),
                           reduce_alpha=None, level=4)
        report.table(analysis.points, f"paper_{study.key}_points",
                     caption=f"The paper's calibrated parameters ({study.points_table}) on its own model")
        _paper_verification(report, campaign)


def _reference_sections(report: HtmlReport, campaign: Campaign, frame, runs) -> None:
    """A campaign's published design table (not one of the paper's) fitted with the
    campaign's model order, each response its own sections."""
    from demcal.report.paper import add_model_sections
    from demcal.rsm import fit_response_surface

    report.section(f"Reference table re-analysed: {campaign.reference_table.name}", 2)
    report.paragraph(f"The published runs of {campaign.reference_table.name} ({len(frame)} runs) fitted with the "
                     f"campaign's {campaign.model_order} model, to compare with the campaign's own fit above.")
    for response in campaign.response_names:
        model = fit_response_surface(runs.coded, runs.responses[response], runs.factors, campaign.model_order,
                                     response)
        add_model_sections(report, model, f"reference_{response}", "Reference table: ", surfaces=(),
                           reduce_alpha=campaign.reduce_alpha, level=3)


def _paper_verification(report: HtmlReport, campaign: Campaign) -> None:
    from demcal.doe.io import read_table

    path = campaign.path.parent / "paper_verification.csv"
    if not path.is_file():
        return
    data = read_table(path)
    columns = ("campaign", "condition", "simulated", "measured", "measured_sd", "reported_error_percent")
    missing = [c for c in columns if c not in data.columns]
    if missing:
        raise DataError(f"{path} has no column {missing[0]!r}; it needs the columns {', '.join(columns)}.")
    data = data[data["campaign"] == campaign.name]
    if data.empty:
        return
    data = data.assign(
        recomputed_error_percent=100.0 * (data["simulated"] - data["measured"]).abs() / data["measured"],
        inside_lab_sd=(data["simulated"] - data["measured"]).abs() <= data["measured_sd"],
    )
    shown = data.drop(columns=["campaign"]).set_index("condition")
    report.table(shown, f"paper_verification_{campaign.name}",
                 caption="The paper's verification (Sections 2.3 and 3.2): its printed errors and the errors "
                         "its own numbers give")
    for _, row in data.iterrows():
        if abs(row["recomputed_error_percent"] - row["reported_error_percent"]) > 0.05:
            report.note(
                f"{campaign.name}, {row['condition']}: the paper reports an error of "
                f"{format_number(row['reported_error_percent'])} %, but {row['simulated']:g} against "
                f"{row['measured']:g} is {row['recomputed_error_percent']:.2f} %.")
