#!/usr/bin/env python3
"""The key tables of the guide (docs/guide.md, docs/guide-campaign.md, docs/guide-run.md),
generated from the code's own settings tables.

Each table sits in one of the guide's pages between ``<!-- BEGIN keys:NAME -->`` and
``<!-- END keys:NAME -->``:

* ``campaign:TABLE``: the keys of one campaign table, in the order of
  ``demcal.campaign.config._ALLOWED[TABLE]``, each with the description below; a key the
  loader accepts but this file does not describe (or the reverse) is an error, so the
  guide cannot drift from the loader.
* ``captions``: ``demcal.campaign.config.CAPTION_KEYS``.
* ``lab:TABLE``: the keys of a lab record (``TABLE`` = ``record``, ``sieve``, ``repose``,
  ``sliding``), read from the sentence ``demcal.measure.lab.LabRecord.from_dict`` gives
  for an unknown key ("known keys are ...").
* ``bench:NAME``: the settings of the virtual test NAME at its ``quick`` profile, from
  ``demcal.bench.registry`` (what ``demcal bench NAME --help`` prints).
* ``file:PATH``: the file PATH of the repository, verbatim (the example's lab and
  campaign files).
* ``tests``: the registered virtual tests with their responses and profiles.

Usage::

    python scripts/guide_tables.py           # rewrite the tables in the guide's pages
    python scripts/guide_tables.py --check   # exit 1 if a table is out of date

``tests/test_guide.py`` runs the check.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "guide.md"
#: the guide's pages, in reading order (their ``sh test`` blocks run in this order)
GUIDES = (GUIDE, GUIDE.with_name("guide-campaign.md"), GUIDE.with_name("guide-run.md"))

#: (table, key) -> description. Tables as in ``_ALLOWED``; defaults are the loader's.
CAMPAIGN_KEYS: dict[tuple[str, str], str] = {
    ("campaign", "name"): "**required**. The campaign's name; it names the result store "
                          "(`<name>-runs/` next to the file, made filename-safe), so a copy of the "
                          "file under another name finds the same results.",
    ("campaign", "description"): "free text, shown in the report.",
    ("campaign", "workdir"): "folder of the results (store, run folders, report); default "
                             "`<name>-runs`. Relative to the campaign file's folder and inside it.",
    ("campaign", "lab"): "TOML file of lab records (one table per sample, see docs/guide.md, "
                         "*The lab file*); relative to the campaign file's folder and inside it.",
    ("campaign", "from_campaign"): "another campaign file (e.g. `\"repose.toml\"`) whose calibrated "
                                   "values each condition's runs keep fixed: the values `demcal "
                                   "calibrate` found there for the condition of the same name. For "
                                   "every condition that names none of its own; see *Chained "
                                   "campaigns*.",
    ("experiment", "test"): "**required**. The virtual test: `demcal bench --list` names them "
                            "(the table of virtual tests in docs/guide.md, step 3).",
    ("experiment", "profile"): "the test's profile for the design runs: `tiny` (a smoke test), "
                               "`quick` (default), `paper`, or a test's own (the incline's `medium`: "
                               "the paper bed's response for a tenth of its cost). `--profile` on "
                               "the command line overrides it.",
    ("experiment", "plugins"): "list of module names that register extra virtual tests, found in "
                               "the campaign's folder or installed packages; imported only by the "
                               "commands that simulate (`run`, `calibrate`, `demo`). Default `[]`.",
    ("experiment", "settings"): "table `KEY = VALUE` of the test's settings fixed for every run "
                                "(`demcal bench TEST --help`; a key may not also be a factor). "
                                "Write dotted keys in quotes: `\"particle.density\" = 2600`.",
    ("experiment", "sieve"): "a sample (table key) of the `[campaign] lab` file whose sieve table "
                             "the particles follow: sets `particles.sizes = \"sieve\"`, "
                             "`particles.sieve_mm` and `particles.sieve_percent` for every run; "
                             "choose `particles.coarse_grain` and the window `particles.size_min_mm` "
                             "/ `size_max_mm` in `[experiment.settings]` (\"Your own particles\").",
    ("factors[]", "name"): "short name used in the model's equation (`A`, `B`, ...); default the "
                           "next letter. A letter followed by letters, digits or `_`.",
    ("factors[]", "parameter"): "**required**. The setting the factor drives, e.g. "
                                "`particle.static_friction` (a key of the test's settings).",
    ("factors[]", "low"): "**required**. Level at coded -1, in the setting's unit; inside the "
                          "setting's allowed range (restitution in (0, 1]).",
    ("factors[]", "high"): "**required**. Level at coded +1; greater than `low`.",
    ("factors[]", "label"): "the factor's long name in tables and axes; default the parameter.",
    ("factors[]", "unit"): "unit shown with it; default the setting's unit.",
    ("factors[]", "hard_low"): "optional limit below which `demcal calibrate` never moves the box "
                               "(default: the setting's own range); must not exceed `low`.",
    ("factors[]", "hard_high"): "optional upper limit of the same kind; must not be below `high`.",
    ("design", "type"): "`box-behnken` (default; alias `bbd`), `central-composite` (`ccd`), "
                        "`full-factorial` (`factorial`), `fractional-factorial` (`fractional`), "
                        "`plackett-burman`; `demcal design` takes the same names.",
    ("design", "center"): "centre points added to the design; default 5 for Box-Behnken, 6 for a "
                          "central composite, none for the others.",
    ("design", "variant"): "central composite only: `circumscribed` (default), `inscribed` or "
                           "`face-centred`.",
    ("design", "alpha"): "central composite only: `rotatable` (default), `orthogonal` or a number.",
    ("design", "fraction"): "central composite or fractional factorial: the number p of "
                            "generators of the 2^(k-p) factorial part (default 0 and 1).",
    ("design", "generators"): "fractional factorial only: its generators, e.g. `\"D=ABC,E=ABD\"` or "
                              "`[\"D=ABC\", \"E=ABD\"]` (default: the standard ones for `fraction`).",
    ("design", "levels"): "full factorial only: levels per factor (default 2).",
    ("design", "runs"): "Plackett-Burman only: number of runs (default: the design's own for k factors).",
    ("responses[]", "name"): "**required**. A response the test measures (its `responses:` line "
                             "in `demcal bench TEST --help`). Without `[[responses]]` the test's "
                             "first response is fitted.",
    ("responses[]", "label"): "long name with its symbol, e.g. `Angle of repose β`; default the name.",
    ("responses[]", "unit"): "unit shown with it, e.g. `°`.",
    ("runs", "seed"): "seed of the first design run (default 1); run i of replicate r gets "
                      "`seed + r * points + i`.",
    ("runs", "replicates"): "seeds per design point (default 1); more replicates give a pure-error "
                            "estimate beyond the centre points.",
    ("model", "order"): "`linear`, `2fi`, `quadratic` (default) or `cubic`.",
    ("model", "reduce_alpha"): "drop terms whose p-value exceeds it (backward elimination), "
                               "e.g. `0.05`; `false` or absent: the full model.",
    ("holdout[]", "test"): "**required**. A virtual test the calibration does not fit, run at each "
                           "condition's calibrated values (`demcal bench --list`; a joint test's names too).",
    ("holdout[]", "response"): "its response compared with the lab's; default the test's first.",
    ("holdout[]", "profile"): "the profile it runs at; default the calibration's production profile "
                              "(the test's first profile where it has none of that name).",
    ("holdout[]", "replicates"): "runs at each condition's values; default `[verification] replicates`.",
    ("holdout[]", "settings"): "table `KEY = VALUE` of the test's own settings; the calibrated material "
                               "(the chosen values and the campaign's fixed material settings) comes "
                               "from the calibration.",
    ("holdout[]", "targets"): "table `CONDITION = { mean = ..., sd = ... }` (or `= mean`): the lab value "
                              "per condition; default the condition's sample's record. A condition "
                              "with neither is refused when the file loads.",
    ("conditions[]", "name"): "**required**, unique. One material state (a moisture content, a "
                              "batch): the calibration solves one parameter set per condition.",
    ("conditions[]", "label"): "long name in the report; default the name.",
    ("conditions[]", "sample"): "a sample (table key) of the `[campaign] lab` file; its measured "
                                "angles become the targets of the responses the campaign fits "
                                "(`repose_angle_deg`, `sliding_angle_deg`), and its record "
                                "(moisture, bulk density, sieve table) goes into the report and "
                                "the material card.",
    ("conditions[]", "photo"): "a lab heap photo shown next to the simulated heap in the report; "
                               "inside the campaign folder.",
    ("conditions[]", "from_campaign"): "this condition's `from_campaign` (overrides `[campaign] "
                                       "from_campaign`): the campaign file whose values calibrated "
                                       "for the condition of the same name its runs keep fixed.",
    ("conditions[]", "targets"): "table `RESPONSE = { mean = ..., sd = ... }` (or `RESPONSE = "
                                 "mean`): the lab value to reproduce; overrides the sample's. "
                                 "Every response needs a target, given here or by the sample.",
    ("conditions[]", "settings"): "table `KEY = VALUE` of settings fixed for this condition's runs "
                                  "only (a key may not be a factor); wins over `from_campaign`, which "
                                  "wins over `[experiment.settings]`. Conditions with different "
                                  "fixed settings get a design each.",
    ("conditions[]", "reference"): "table `PARAMETER = VALUE` (parameter or factor name): "
                                   "published calibrated values the report evaluates next to "
                                   "demcal's; leave it out for a material of your own.",
    ("conditions[].targets.*", "mean"): "**required**. The lab mean, in the response's unit.",
    ("conditions[].targets.*", "sd"): "the lab standard deviation (>= 0); the calibration stops "
                                      "when the simulated mean lies within mean ± sd.",
    ("verification", "replicates"): "seeds per verification (production) run; default 3.",
    ("verification", "seed"): "first seed of the verification runs; default 100000.",
    ("calibration", "production"): "profile of the verification (production) runs; default the "
                                   "campaign's profile. `--production` overrides it.",
    ("calibration", "replicates"): "first production replicates at a point; default "
                                   "`[verification] replicates`.",
    ("calibration", "min_replicates"): "fewest first replicates at a new point once the production "
                                       "noise is known (default 1): the first batch is the fewest seeds "
                                       "whose 95 % half-width with the pooled sd is below the lab sd, "
                                       "between this and `replicates`. The noise is known from the start "
                                       "where a stored profile study replicated the production profile (the "
                                       "paper-profile incline: 0.74° over 22 df), and is pooled with the "
                                       "campaign's own production runs (docs/calibration.md).",
    ("calibration", "max_replicates"): "most production replicates at one point (default 10, "
                                       "at least 2 and at least the first replicates).",
    ("calibration", "iterations"): "re-solves on the corrected surface per condition (default 4).",
    ("calibration", "box_moves"): "most box moves per condition (default 3; 0: never move).",
    ("calibration", "box_replicates"): "seeds per design point of a moved box (default `[runs] "
                                       "replicates`). A moved box often lies where the target is near "
                                       "the edge of what the test reaches and the effects are small "
                                       "against the seed noise: two seeds there resolved the friction's "
                                       "effect in the paper-profile incline's 14.1 % box where one did not "
                                       "(docs/performance.md).",
    ("calibration", "path_points"): "cheap runs along the path of steepest ascent beyond the box "
                                    "edge, per move (default 3).",
    ("calibration", "path_replicates"): "seeds per path point (default 1).",
    ("calibration", "verify_on_path"): "where two path points bracket the target, verify first at the "
                                       "crossing read off the path (where the path crosses nothing but "
                                       "reads inside the lab window, at its step nearest the target), and "
                                       "lay the moved box's design only if it misses (default true; false: "
                                       "always lay the design, which maps a solution set around the point).",
    ("calibration", "stored_noise"): "pool the stored profile studies' replicated production runs "
                                     "into the production noise from the start (default true: the "
                                     "paper-profile incline's 0.74° over 22 df, so one paper run can "
                                     "decide a point; a point the campaign runs itself counts once). "
                                     "false: the campaign's own runs only, as before 27 Nov 2026.",
    ("calibration", "replicate_batch"): "production replicates are asked for in batches of a multiple "
                                        "of this many new runs (default 1: as many as the noise asks "
                                        "for). Set it to the number of workers: three runs on two "
                                        "workers take as long as four, and the fourth may spare a later "
                                        "round of one. A probe stays one run, and a batch whose extra "
                                        "seeds would pass `[budget] runs` runs what the noise asks for. A "
                                        "campaign setting, not the worker count itself, so a calibration "
                                        "replays the same whatever `--workers` is (at most "
                                        "`max_replicates`).",
    ("budget", "runs"): "most runs the calibration uses, its design included (default: no limit).",
    ("budget", "cpu_hours"): "most run hours, the sum of the runs' wall times (default: no limit).",
    ("executor", "kind"): "`local` (default: a pool of worker processes) or `dask`.",
    ("executor", "workers"): "worker processes; 0 (default) is one per CPU core. `--workers` "
                             "overrides it.",
    ("executor", "scheduler"): "a Dask scheduler address, e.g. `tcp://host:8786`; its workers need "
                               "the campaign folder at the same path. `--scheduler` overrides it.",
    ("executor", "start_method"): "how local workers start: `spawn` (default) or `forkserver`.",
    ("executor", "heartbeat_timeout_s"): "seconds after which a run claimed by a runner that "
                                         "stopped heartbeating (killed, machine lost) is taken over "
                                         "by another runner (default 120).",
    ("executor", "backend"): "where the runs simulate: `cpu` (default) or `cuda` (an NVIDIA GPU "
                             "with numba-cuda, `pip install 'demcal[cuda]'`; docs/dem-backends.md).",
    ("executor", "ensemble"): "with `backend = \"cuda\"`: up to this many runs stepped together on "
                              "the GPU as one ensemble, in one worker process (each run joins as it "
                              "is claimed and is recorded as it ends; docs/dem-backends.md, "
                              "\"Ensembles\"); 0 (default) runs one run per worker process.",
    ("report", "title"): "the report's title; default the campaign's name.",
    ("report", "reference_table"): "a CSV of a published design with its responses, re-analysed "
                                   "in the report's last section; inside the campaign folder.",
    ("report", "captions"): "table `KEY = \"source\"`: the published table each report table "
                            "reproduces (keys below). Only a campaign that reproduces a "
                            "publication names one; without it the report names none.",
}

#: ``[report.captions]`` key -> what it labels.
CAPTION_TEXT = {
    "targets": "the lab data and targets table",
    "sieve": "the sieve table",
    "factors": "the factors and levels table",
    "design": "the design and results table",
    "calibrated": "the calibrated parameters table",
    "verification": "the verification table",
    "images": "the simulated and lab heap images",
    "reference": "what the `[conditions.reference]` values are called (default \"reference\")",
    "runs": "what the campaign's run count is compared with",
}

#: lab table -> (probe: a record with one unknown key there, {key: description}).
LAB_KEYS = {
    "record": {
        "name": "**required**. The sample's name.",
        "notes": "free text.",
        "moisture_percent": "water content [%], 0-100.",
        "moisture_sd_percent": "its standard deviation [%].",
        "bulk_density": "bulk density [kg/m³], > 0.",
        "sieve": "table: the particle-size distribution (below).",
        "repose": "table: the angle of repose, given or measured from photos (below).",
        "sliding": "table: the sliding angle, given or from incline readings (below).",
        "drum": "table: a rotating drum's dynamic angle at one or more speeds (below).",
    },
    "sieve": {
        "edges_mm": "class bounds [mm], increasing, one more than the classes; the first may be "
                    "0 (\"< d\"), the last `inf` (\">= d\").",
        "mass_percent": "mass of each class [%]; sums to 100 within 0.5 %.",
    },
    "repose": {
        "mean_deg": "the angle [deg] when given (then no `photos`).",
        "sd_deg": "its standard deviation [deg].",
        "n": "number of tests behind it.",
        "photos": "a glob pattern or a list of them, relative to the campaign file's folder: "
                  "the heap photos measured for the angle (then no `mean_deg`). A photo that "
                  "cannot be measured stops the campaign with its name; it is never silently "
                  "left out.",
        "exclude": "patterns of photos left out on purpose.",
        "mm_per_px": "scale of the photos [mm/px], for heights and widths.",
        "roi": "region of interest `[x0, y0, x1, y1]` [px].",
        "base_y": "row of the base line [px]; default found from the heap's outline.",
    },
    "sliding": {
        "mean_deg": "the angle [deg] when given (then no `H_mm`).",
        "sd_deg": "its standard deviation [deg].",
        "n": "number of tests behind it.",
        "H_mm": "inclined-plane readings: the height at which the sample slid [mm]; "
                "θ = arcsin((H - H0) / L) per reading.",
        "L_mm": "the arm's length [mm]; default 300.",
        "H0_mm": "the same point's height above the base with the plate level [mm]; default 0, "
                 "the paper's Eq. 5 (exact only when the spindle's axis is level with that base).",
        "repeats": "readings per group (the mean of each group is one test).",
    },
    "drum": {
        "rpm": "**required**. The drum speeds [1/min], each once.",
        "mean_deg": "**required**. The dynamic angle measured at each speed [deg], one per speed.",
        "sd_deg": "its standard deviation at each speed [deg].",
        "n": "tests at each speed: one number for all, or one per speed.",
    },
}


def _lab_known(table: str) -> list[str]:
    """The keys the lab loader accepts in ``table``, from its unknown-key sentence."""
    from demcal.errors import ConfigError
    from demcal.measure.lab import LabRecord

    probe = {"name": "x", "zz_unknown": 1}
    if table != "record":
        probe = {"name": "x", table: {"zz_unknown": 1}}
    try:
        LabRecord.from_dict(probe)
    except ConfigError as exc:
        match = re.search(r"known keys are (.+?)\.$", str(exc))
        if match:
            return [k.strip() for k in match.group(1).split(",")]
        raise RuntimeError(f"unexpected sentence from the lab loader: {exc}") from None
    raise RuntimeError(f"the lab loader accepted an unknown key in '{table}'")


def _row(cells) -> str:
    return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"


def _md_table(header, rows) -> str:
    lines = [_row(header), _row(["---"] * len(header))]
    lines += [_row(r) for r in rows]
    return "\n".join(lines)


def tables() -> dict[str, str]:
    """Every generated block, by marker name. Raises ``RuntimeError`` on drift."""
    from demcal.cli.bench import settings_rows
    from demcal.bench.registry import get_experiment, names

    # demcal's own tests only: plug-ins registered in this process (tests' doubles) are not
    builtin = [n for n in names() if type(get_experiment(n)).__module__.startswith("demcal.")]
    from demcal.campaign.config import _ALLOWED, CAPTION_KEYS

    problems = []
    out: dict[str, str] = {}
    for table, keys in _ALLOWED.items():
        if table == "":
            continue
        for key in keys:
            if (table, key) not in CAMPAIGN_KEYS:
                problems.append(f"campaign key [{table}] {key} has no description in {__file__}")
        out[f"campaign:{table}"] = _md_table(["key", "meaning"],
                                             [[f"`{k}`", CAMPAIGN_KEYS.get((table, k), "")] for k in keys])
    for table, key in CAMPAIGN_KEYS:
        if key not in _ALLOWED.get(table, ()):
            problems.append(f"[{table}] {key} is described but the campaign loader does not accept it")
    missing = sorted(set(_ALLOWED[""]) - {t.rstrip("[]") for t in _ALLOWED} )
    if missing:
        problems.append(f"campaign tables without keys: {missing}")
    if set(CAPTION_KEYS) != set(CAPTION_TEXT):
        problems.append(f"caption keys {sorted(CAPTION_KEYS)} differ from the described {sorted(CAPTION_TEXT)}")
    out["captions"] = _md_table(["key", "labels"], [[f"`{k}`", CAPTION_TEXT.get(k, "")] for k in CAPTION_KEYS])
    for table, described in LAB_KEYS.items():
        known = _lab_known(table)
        if set(known) != set(described):
            problems.append(f"lab table '{table}': loader keys {sorted(known)} differ from the described "
                            f"{sorted(described)}")
        out[f"lab:{table}"] = _md_table(["key", "meaning"], [[f"`{k}`", described.get(k, "")] for k in described])
    rows = []
    for name in builtin:
        exp = get_experiment(name)
        rows.append([f"`{name}`", exp.description, ", ".join(f"`{r}`" for r in exp.responses),
                     ", ".join(exp.profiles)])
    out["tests"] = _md_table(["test", "what it does", "responses", "profiles"], rows)
    for name in builtin:
        exp = get_experiment(name)
        profile = "quick" if "quick" in exp.profiles else exp.profiles[0]
        body = [[f"`{key}`", default, unit, allowed.replace("|", " \\| "), text]
                for key, default, unit, allowed, text in settings_rows(exp, profile)]
        out[f"bench:{name}"] = _md_table(["setting", "default (quick)", "unit", "allowed", "meaning"], body)
    if problems:
        raise RuntimeError("; ".join(problems))
    return out


# the body may be empty (a block not generated yet): it ends with its own newline
_BLOCK = re.compile(r"(<!-- BEGIN keys:(?P<name>[^ ]+) -->\n)(?P<body>.*?)(<!-- END keys:(?P=name) -->)", re.S)


def render(text: str) -> str:
    """``text`` (a page of the guide) with every generated block replaced by the current table;
    a block ``file:PATH`` is that file of the repository, verbatim, as a TOML block."""
    blocks = tables()
    root = GUIDE.parent.parent
    for match in _BLOCK.finditer(text):
        name = match.group("name")
        if name.startswith("file:"):
            body = (root / name[5:]).read_text(encoding="utf-8").rstrip("\n")
            blocks[name] = f"```toml\n{body}\n```"

    def replace(match):
        name = match.group("name")
        if name not in blocks:
            raise RuntimeError(f"the guide names an unknown generated table '{name}'")
        return match.group(1) + blocks[name] + "\n" + match.group(4)

    return _BLOCK.sub(replace, text)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a page of the guide is out of date")
    args = parser.parse_args()
    stale = []
    for page in GUIDES:
        text = page.read_text(encoding="utf-8")
        new = render(text)
        if new != text:
            stale.append(page)
            if not args.check:
                page.write_text(new, encoding="utf-8")
    if args.check and stale:
        names = ", ".join(f"docs/{page.name}" for page in stale)
        print(f"{names}: a key table is out of date; run python scripts/guide_tables.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
