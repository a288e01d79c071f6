"""Campaign files: TOML parsed once into frozen dataclasses.

A campaign file says which virtual test to run, which contact parameters to vary
(factors with low/high levels), how to lay out the design, which responses to
fit, which lab targets to solve for (one condition per material state, e.g. per
moisture content) and how to run it. :func:`load_campaign` reads and checks the
whole file before anything runs; every mistake becomes one
:class:`~demcal.errors.ConfigError` sentence naming the file, the line and the key,
e.g. ``repose.toml line 12: factor 'particle.static_friction' has low 0.5 >=
high 0.3; swap them.``

Every table and key (its type, default, range or choices and meaning) is declared in
:mod:`demcal.campaign.schema`, together with the dataclasses a campaign is made of, and
checked against its declaration by :class:`demcal.campaign.reader.Reader`. The loader here
reads the file table by table and checks what the declarations cannot: what depends on the
virtual test (a factor's parameter and levels, the settings, profiles and responses), on
the lab file, on another campaign, or on several tables at once (the design's run count,
the calibration's replicates, the seeds' room).

Settings fixed for one condition's runs alone (a moisture content's own inter-particle
values, say) come from ``[conditions.settings]`` and from ``from_campaign`` (per condition,
or in ``[campaign]`` for every condition): another campaign file whose calibrated values
(its ``calibration.json``) the condition of the same name takes. The file only names that
campaign; :func:`demcal.campaign.chain.resolve_chain` reads its values when runs are planned.

Results live in ``[campaign] workdir``, by default ``<name>-runs`` next to the file (the
campaign's name made filename-safe), so a copy of the file finds the same results. Paths
in the file (``workdir``, ``lab``, a condition's ``photo``, the lab record's photos,
``reference_table``) are taken relative to the campaign file's folder and must lie
inside it, unless the loader is told ``allow_outside`` (``--allow-outside`` on the
command line). Input files are read with a size limit
(:data:`demcal._checks.MAX_TOML_BYTES` for the campaign and lab files). ``plugins`` are
only named while the file is read, and imported only when the caller asks for it
(``import_plugins=True``; see :mod:`demcal.campaign.plugins`).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from demcal._checks import MAX_SEED
from demcal.campaign.plugins import import_plugins, plugin_problem  # noqa: F401  (plugin_problem: importable here)
from demcal.campaign.reader import Reader, allowed_keys, key_lines, read_toml_text
from demcal.campaign.schema import (CAPTION_KEYS, BudgetTable, CalibrationConfig, CampaignFile,  # noqa: F401
                                    CampaignTable, Condition, ConditionTable, DesignConfig, DesignTable,
                                    ExecutorConfig, ExperimentTable, Factor, FactorTable, Holdout, HoldoutTable,
                                    ModelTable, ReportTable, Response, RunsTable, Target, Upstream,
                                    VerificationTable, _is_angle)
from demcal.doe.factors import default_names
from demcal.errors import ConfigError

#: Keys allowed in each table (``[]``: an array of tables), from the declarations.
_ALLOWED: dict[str, tuple[str, ...]] = allowed_keys(CampaignFile)


@dataclass(frozen=True)
class Campaign:
    """Everything one campaign file says, checked."""

    path: Path
    name: str
    description: str
    test: str
    profile: str
    plugins: tuple[str, ...]
    settings: Mapping[str, Any]  #: fixed setting overrides applied to every run
    factors: tuple[Factor, ...]
    design: DesignConfig
    responses: tuple[Response, ...]
    conditions: tuple[Condition, ...]
    seed: int = 1
    replicates: int = 1
    model_order: str = "quadratic"
    reduce_alpha: float | None = None
    verification_replicates: int = 3
    verification_seed: int = 100_000
    executor: ExecutorConfig = ExecutorConfig()
    calibration: CalibrationConfig = CalibrationConfig()
    workdir: Path = Path(".")
    title: str = ""
    reference_table: Path | None = None  #: a published design table to re-analyse
    lab_file: Path | None = None  #: ``[campaign] lab``: the lab records' file, if named
    #: ``[report] captions``: key of :data:`CAPTION_KEYS` -> the published source it reproduces
    captions: Mapping[str, str] = field(default_factory=dict)
    #: ``[[holdout]]``: tests predicted with the calibrated values, not fitted (None: none,
    #: so that a campaign without them keeps its hash)
    holdouts: tuple[Holdout, ...] | None = None

    @property
    def factor_names(self) -> list[str]:
        return [f.name for f in self.factors]

    @property
    def response_names(self) -> list[str]:
        return [r.name for r in self.responses]

    @property
    def store_path(self) -> Path:
        return self.workdir / "store.sqlite"

    @property
    def per_condition(self) -> bool:
        """Whether some condition fixes settings of its own (``[conditions.settings]`` or
        ``from_campaign``), so that its runs differ from the other conditions'."""
        return any(c.settings or c.upstream is not None for c in self.conditions)

    def for_condition(self, condition: Condition) -> "Campaign":
        """The campaign as ``condition``'s runs see it: its own fixed settings added to
        (and taking precedence over) ``[experiment.settings]``."""
        fixed = condition.fixed
        if not fixed:
            return self
        return dataclasses.replace(self, settings={**self.settings, **fixed})

    def designs(self) -> list[tuple["Campaign", tuple[Condition, ...]]]:
        """One design per distinct set of conditions' fixed settings: the campaign its runs
        see (:meth:`for_condition`) and the conditions it serves. A campaign without
        per-condition settings has one, itself."""
        groups: dict[str, list[Condition]] = {}
        for condition in self.conditions:
            groups.setdefault(repr(sorted(condition.fixed.items())), []).append(condition)
        return [(self.for_condition(members[0]), tuple(members)) for members in groups.values()]

    def with_profile(self, profile: str) -> "Campaign":
        """The same campaign run at another profile of its experiment."""
        if profile == self.profile:
            return self
        from demcal.bench.registry import get_experiment, resolve_settings

        experiment = get_experiment(self.test)
        for settings in [{}] + [c.settings for c in self.conditions]:  # the factors' order: at load
            resolve_settings(experiment, {**self.settings, **settings}, profile, ordered=False)
        return dataclasses.replace(self, profile=profile)

    def with_production(self, production: str) -> "Campaign":
        """The same campaign verified at another profile (``[calibration] production``);
        its settings must suit that profile."""
        self.with_profile(production)
        return dataclasses.replace(self, calibration=dataclasses.replace(self.calibration, production=production))

    def with_workdir(self, workdir: Path) -> "Campaign":
        return dataclasses.replace(self, workdir=Path(workdir))


def load_campaign(path: str | Path, *, import_plugins: bool = False, allow_outside: bool = False) -> Campaign:
    """Read and check a campaign file; raise :class:`ConfigError` on the first mistake.

    Parameters
    ----------
    path : the campaign file (TOML, at most :data:`demcal._checks.MAX_TOML_BYTES`).
    import_plugins : import the modules of ``[experiment] plugins`` (see
        :func:`import_plugins`) before the virtual test is looked up; only for callers
        that run simulations. Without it nothing of the campaign's is imported, and a
        test that only a plugin provides is refused by name.
    allow_outside : accept paths (``workdir``, ``lab``, photos, ``reference_table``)
        outside the campaign file's folder.
    """
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"'{path}' is a folder; give the campaign file (TOML) itself.")
    try:
        text = read_toml_text(path, "campaign file")
    except FileNotFoundError:
        raise ConfigError(f"campaign file '{path}' does not exist.") from None
    except OSError as exc:
        raise ConfigError(f"cannot read campaign file '{path}': {exc.strerror or exc}.") from None
    return parse_campaign(text, path, import_plugins=import_plugins, allow_outside=allow_outside)


def parse_campaign(text: str, path: str | Path = "campaign.toml", *, import_plugins: bool = False,
                   allow_outside: bool = False) -> Campaign:
    """Check ``text`` (the contents of the campaign file ``path``) into a :class:`Campaign`;
    the keywords are :func:`load_campaign`'s."""
    return _Loader(text, Path(path), import_plugins, allow_outside).campaign()


# --------------------------------------------------------------------------- loader


class _Loader(Reader):
    """Reads the campaign file's tables (:mod:`demcal.campaign.schema`) and checks them
    against the virtual test, the lab file, other campaigns and one another."""

    def __init__(self, text: str, path: Path, import_plugins: bool = False, allow_outside: bool = False):
        super().__init__(text, path, allow_outside)
        self.import_plugins = import_plugins
        self.samples: dict = {}  # lab records by sample name, from [campaign] lab
        self.experiment_test = None  # the registered test of [experiment], once read

    def campaign(self) -> Campaign:
        self.check_file(CampaignFile)
        meta, workdir = self.location()
        upstream = self.upstream(meta.from_campaign, self.data["campaign"], ("campaign",))
        self.samples = self.lab_records(meta.lab)
        experiment, spec, profile = self.experiment()
        self.experiment_test = experiment
        table = experiment.settings(profile)
        factors = self.factors(experiment, table, profile)
        overlap = sorted(set(spec.settings) & {f.parameter for f in factors})
        if overlap:
            raise self.error(("experiment", "settings", overlap[0]),
                             f"'{overlap[0]}' is both a factor and a fixed setting; keep one")
        design = self.design(len(factors))
        responses = self.responses(experiment)
        conditions = self.conditions(responses, factors, experiment, table, profile, upstream)
        settings = self.fixed_settings(table, spec)
        self.check_order(table, settings, factors, conditions)
        self.check_runnable(experiment, profile, settings, conditions)
        runs = self.section(RunsTable, "runs")
        if runs.replicates > 1:
            self.check_runs(("runs", "replicates"), self.design_runs * runs.replicates,
                            f"{self.design_runs:,} design runs x {runs.replicates:,} replicates",
                            "use fewer replicates")
        model, report = self.section(ModelTable, "model"), self.section(ReportTable, "report")
        verification = self.section(VerificationTable, "verification")
        calibration = self.calibration(experiment, verification.replicates)
        self.check_seeds(runs, verification, calibration, conditions)
        return Campaign(
            path=self.path, name=meta.name, description=meta.description, test=spec.test, profile=profile,
            plugins=spec.plugins, settings=settings, factors=factors, design=design,
            responses=responses, conditions=conditions, seed=runs.seed, replicates=runs.replicates,
            model_order=model.order, reduce_alpha=model.reduce_alpha,
            verification_replicates=verification.replicates, verification_seed=verification.seed,
            executor=self.executor(), calibration=calibration, workdir=workdir,
            title=meta.name if report.title is None else report.title, reference_table=report.reference_table,
            lab_file=meta.lab, captions=dict(report.captions),
            holdouts=self.holdouts(conditions, experiment, profile) or None)

    def location(self) -> tuple[CampaignTable, Path]:
        """``[campaign]`` and the campaign's workdir (the results' folder)."""
        meta = self.section(CampaignTable, "campaign", required=True)
        written = self.data["campaign"].get("workdir", "").strip() or default_workdir(meta.name, self.path)
        workdir = meta.workdir or self.inside(self.path.parent / written, written, ("campaign", "workdir"), "workdir")
        self.inside_workdir(workdir, written)
        return meta, workdir

    def inside_workdir(self, workdir: Path, written: str) -> None:
        """What the workdir holds (store, runs and each run folder, report, calibration)
        must lie inside the campaign's folder too, links followed: a link in the workdir
        must not lead its results out of it (unless ``allow_outside``)."""
        if self.allow_outside or not workdir.is_dir():
            return
        names = ("store.sqlite", "runs", "report", "calibration.json")
        entries = [workdir / n for n in names if (workdir / n).is_symlink() or (workdir / n).exists()]
        runs = workdir / "runs"
        if runs.is_dir():
            entries += [p for p in runs.iterdir() if p.is_symlink()]
        for entry in entries:
            shown = f"{written.rstrip('/')}/{entry.relative_to(workdir).as_posix()}"
            self.inside(entry, shown, ("campaign", "workdir"), "workdir entry")

    def upstream(self, path: Path | None, data: Mapping, where: tuple) -> Upstream | None:
        """The campaign that ``from_campaign`` (``path``, written in ``data``) names: its file,
        name and results' folder (read from its ``[campaign]`` table only; its values are
        read when runs are planned, by :func:`demcal.campaign.chain.resolve_chain`)."""
        if path is None:
            return None
        key, written = where + ("from_campaign",), data["from_campaign"].strip()
        if path.resolve() == self.path.resolve():
            raise self.error(key, f"from_campaign '{written}' is this campaign file itself; name the campaign "
                                  "whose calibrated values the conditions take")
        try:
            text = read_toml_text(path, "campaign file")
            other, workdir = _Loader(text, path, allow_outside=self.allow_outside).location()
        except OSError as exc:
            raise self.error(key, f"from_campaign '{written}' cannot be read ({exc.strerror or exc})") from None
        except ConfigError as exc:
            raise self.error(key, f"from_campaign '{written}': {exc}") from None
        return Upstream(path=path, workdir=workdir, name=other.name)

    def check_seeds(self, runs: RunsTable, verification: VerificationTable, calibration: CalibrationConfig,
                    conditions) -> None:
        """Refuse a seed whose derived run seeds leave 0 .. 2^63 - 1: above ``[runs] seed`` the
        design runs (``seed + replicate * points + point``, :func:`demcal.campaign.runner.plan_design`)
        and the calibration loop's moved boxes and path runs (:mod:`demcal.campaign.loop`),
        above ``[verification] seed`` each condition's verification runs."""
        from demcal.campaign.seeds import BOX_SEED, PATH_SEED

        design = self.design_runs * max(runs.replicates, calibration.box_replicates or 0)
        boxes = calibration.box_moves * len(conditions)
        spans = ((runs.seed, BOX_SEED * boxes + design + PATH_SEED + 997 * boxes
                  + 10 * (calibration.path_points + 2) + calibration.path_replicates),
                 (verification.seed, 1000 * len(conditions) + max(calibration.max_replicates, verification.replicates)))
        for table, (seed, span) in zip(("runs", "verification"), spans):
            if seed + span > MAX_SEED:
                raise self.error((table, "seed"), f"[{table}] seed = {seed} leaves no room for the run seeds derived "
                                                  f"from it (up to seed + {span:,}), which must stay within 0 .. "
                                                  f"2^63 - 1 ({MAX_SEED}); give a seed of at most {MAX_SEED - span}")

    def check_runs(self, where: tuple, runs: int, what: str, fix: str) -> None:
        """Refuse more runs than a design may have (:func:`demcal.doe.designs.check_run_count`)."""
        from demcal.doe.designs import check_run_count

        try:
            check_run_count(runs, what, fix)
        except ConfigError as exc:
            raise self.error(where, str(exc)) from None

    def lab_records(self, path: Path | None) -> dict:
        """Lab records of the file named by ``[campaign] lab`` (one table per sample)."""
        if path is None:
            return {}
        from demcal.measure.lab import LabRecord

        where, name = ("campaign", "lab"), self.data["campaign"]["lab"].strip()
        if path.is_dir():
            raise self.error(where, f"lab file '{name}' is a folder; give the lab records' TOML file")
        try:
            text = read_toml_text(path, "lab file")
            data = tomllib.loads(text)
        except FileNotFoundError:
            raise self.error(where, f"lab file '{name}' does not exist next to the campaign file") from None
        except OSError as exc:
            raise self.error(where, f"lab file '{name}' cannot be read ({exc.strerror or exc})") from None
        except ConfigError as exc:
            raise self.error(where, str(exc)) from None
        except tomllib.TOMLDecodeError as exc:
            raise self.error(where, f"lab file '{name}' is not valid TOML ({exc})") from None
        lines = key_lines(text)
        return {key: LabRecord.from_dict(table, f"[{key}]", file=path.name,
                                         lines={k[1:]: n for k, n in lines.items() if k[:1] == (key,)})
                for key, table in data.items()}

    def experiment(self) -> tuple[Any, ExperimentTable, str]:
        """The registered experiment, ``[experiment]`` and the profile of the design runs."""
        from demcal.bench.registry import get_experiment

        where, spec = ("experiment",), self.section(ExperimentTable, "experiment", required=True)
        data = self.data["experiment"]
        if self.import_plugins:  # only for callers that run simulations; never while just reading
            try:
                import_plugins(spec.plugins, self.path.parent)
            except ConfigError as exc:
                raise self.error(where + ("plugins",), str(exc)) from None
        try:
            experiment = get_experiment(spec.test)
        except ConfigError as exc:
            if spec.plugins and not self.import_plugins:
                raise self.error(where + ("test",),
                                 f"unknown virtual test '{spec.test}' among those registered; the plugins that may "
                                 f"register it ({', '.join(spec.plugins)}) are imported only by the commands that "
                                 "run simulations (run, calibrate), never while a campaign file is just read") from None
            raise self.error(where + ("test",), str(exc)) from None
        profiles = tuple(experiment.profiles)
        profile = (self.value(str, data, "profile", where, {"choices": profiles}) if "profile" in data
                   else "quick" if "quick" in profiles else profiles[0])
        table = experiment.settings(profile)
        for key, value in spec.settings.items():
            self.check_setting(experiment, table, profile, key, value, where + ("settings", key))
        return experiment, spec, profile

    def fixed_settings(self, table, spec: ExperimentTable) -> dict:
        """``[experiment.settings]`` with its listed values as canonical text, and the
        sieve table of the sample ``[experiment] sieve`` names."""
        settings = _canonical(table, spec.settings)
        if spec.sieve is None:
            return settings
        where = ("experiment", "sieve")
        given = sorted({"particles.sizes", "particles.sieve_mm", "particles.sieve_percent"} & set(settings))
        if given:
            raise self.error(where, f"[experiment] sieve and the setting '{given[0]}' both give the sizes; "
                                    "keep one")
        if "particles.sieve_mm" not in table:
            raise self.error(where, f"{self.data['experiment'].get('test')} draws no particle sizes, so it "
                                    "takes no sieve table; remove [experiment] sieve")
        record = self.samples.get(spec.sieve)
        if record is None:
            known = ", ".join(self.samples) or "none (set [campaign] lab)"
            raise self.error(where, f"sample '{spec.sieve}' is not in the lab file; samples: {known}")
        if record.sieve is None:
            raise self.error(where, f"sample '{spec.sieve}' of the lab file has no [{spec.sieve}.sieve] table; "
                                    "add its edges_mm and mass_percent, or remove [experiment] sieve")
        return {**settings, "particles.sizes": "sieve",
                **_canonical(table, {"particles.sieve_mm": record.sieve.edges_mm.tolist(),
                                     "particles.sieve_percent": record.sieve.mass_percent.tolist()})}

    def holdouts(self, conditions, experiment, profile) -> tuple[Holdout, ...]:
        """``[[holdout]]``: each test predicted with the calibrated values, its response,
        settings and a lab value for every condition (its own ``targets``, else the
        condition's sample's record)."""
        from demcal.bench.registry import get_experiment
        from demcal.measure.lab import resolve_targets

        out = []
        for i, data in enumerate(self.tables("holdout")):
            where = ("holdout", i)
            spec = self.read(HoldoutTable, data, where)
            try:
                test = get_experiment(spec.test)
            except ConfigError as exc:
                plugins = self.data.get("experiment", {}).get("plugins", [])
                if plugins and not self.import_plugins:
                    raise self.error(where + ("test",),
                                     f"unknown virtual test '{spec.test}' among those registered; the plugins that "
                                     f"may register it ({', '.join(plugins)}) are imported only by the commands "
                                     "that run simulations (run, calibrate)") from None
                raise self.error(where + ("test",), str(exc)) from None
            response = spec.response or test.responses[0]
            if response not in test.responses:
                raise self.error(where + ("response",), f"hold-out test '{spec.test}' measures no '{response}'; "
                                                        f"its responses: {', '.join(test.responses)}")
            if spec.profile is not None and spec.profile not in test.profiles:
                raise self.error(where + ("profile",), f"hold-out test '{spec.test}' has no profile "
                                                       f"'{spec.profile}'; choose {', '.join(test.profiles)}")
            run_profile = spec.profile or (profile if profile in test.profiles else test.profiles[0])
            table = test.settings(run_profile)
            for key, value in spec.settings.items():
                self.check_setting(test, table, run_profile, key, value, where + ("settings", key))
            targets = {}
            for j, condition in enumerate(conditions):
                given = spec.targets.get(condition.name)
                at = where + ("targets", condition.name)
                if isinstance(given, Mapping):
                    targets[condition.name] = self.read(Target, given, at, {"response": response})
                elif given is not None:
                    targets[condition.name] = Target(response=response,
                                                     mean=self.value(float, spec.targets, condition.name,
                                                                     where + ("targets",)))
                elif condition.sample is not None:
                    angle = resolve_targets(condition.sample, self.path.parent,
                                            confine=not self.allow_outside).get(response)
                    if angle is not None:
                        sd = angle.sd_deg if math.isfinite(angle.sd_deg) else None
                        targets[condition.name] = Target(response=response, mean=angle.mean_deg, sd=sd)
                if condition.name not in targets:
                    raise self.error(where, f"hold-out test '{spec.test}' has no lab value for condition "
                                            f"'{condition.name}': give [holdout.targets] \"{condition.name}\" = "
                                            f"{{ mean = ..., sd = ... }}, or a sample whose record gives {response}")
            unknown = sorted(set(spec.targets) - {c.name for c in conditions})
            if unknown:
                raise self.error(where + ("targets", unknown[0]), f"hold-out target for '{unknown[0]}', which is no "
                                                                  "condition of the campaign")
            out.append(Holdout(test=spec.test, response=response, profile=spec.profile,
                               replicates=spec.replicates, settings=dict(spec.settings), targets=targets))
        return tuple(out)

    def check_runnable(self, experiment, profile, settings, conditions) -> None:
        """The test's own check (sizes, geometry) of the fixed settings, per condition,
        the factors at their defaults: refused when the file loads, not run by run."""
        from demcal.bench.registry import resolve_settings

        check = getattr(experiment, "check", None)
        if check is None:
            return
        for i, condition in enumerate(conditions):
            try:
                check(resolve_settings(experiment, {**settings, **condition.settings}, profile))
            except ConfigError as exc:
                where = ("conditions", i, "settings") if condition.settings else ("experiment", "settings")
                raise self.error(where, str(exc).rstrip(".")) from None

    def check_setting(self, experiment, table, profile, key, value, where) -> None:
        from demcal.bench.registry import resolve_settings

        if key not in table:
            near = difflib.get_close_matches(key, list(table), n=1, cutoff=0.6)
            hint = f"did you mean '{near[0]}'?" if near else f"`demcal bench {experiment.name} --help` lists them"
            raise self.error(where, f"'{key}' is not a setting of {experiment.name}; {hint}")
        if _is_restitution(key) and isinstance(value, (int, float)) and not 0 < value <= 1:
            raise self.error(where, f"'{key}' = {value} is a coefficient of restitution and must lie in (0, 1]")
        try:  # one value: the order of pairs is checked once all are known (check_order)
            resolve_settings(experiment, {key: value}, profile, ordered=False)
        except ConfigError as exc:
            raise self.error(where, str(exc)) from None

    def check_order(self, table, settings, factors, conditions) -> None:
        """Refuse settings that break an order of :data:`demcal.bench.registry.ORDERED_SETTINGS`
        (``measure.band_low < measure.band_high``, ...) in any run the design can make: the
        lower key at its highest (a factor's high level, or its hard_high), the upper key at
        its lowest, each condition's own settings over ``[experiment.settings]`` over the
        test's defaults. The sentence names the line of the value that breaks it."""
        from demcal.bench.registry import order_problem, ordered_pairs

        pairs = ordered_pairs(table)
        by_parameter = {f.parameter: (i, f) for i, f in enumerate(factors)}
        groups = [((), {})] + [(("conditions", i), dict(c.settings)) for i, c in enumerate(conditions)]

        def extreme(key, highest, own, own_where):
            """(value, where written) of ``key`` at the end of its range that ``highest`` asks for."""
            if key in by_parameter:
                i, f = by_parameter[key]
                level = ("hard_high" if f.hard_high is not None else "high") if highest else \
                    ("hard_low" if f.hard_low is not None else "low")
                return getattr(f, level), ("factors", i, level)
            if key in own:
                return float(own[key]), own_where + ("settings", key)
            if key in settings:
                return float(settings[key]), ("experiment", "settings", key)
            return float(table[key].default), None

        for own_where, own in groups:
            for low, high, may_equal in pairs:
                a, where_a = extreme(low.key, True, own, own_where)
                b, where_b = extreme(high.key, False, own, own_where)
                problem = order_problem(low, high, may_equal, a, b)
                if problem:
                    raise self.error(where_a or where_b or ("experiment",), problem)

    def factors(self, experiment, table, profile) -> tuple[Factor, ...]:
        raw = self.tables("factors")
        if not raw:
            raise self.error(("factors",), "a campaign needs at least one [[factors]] table")
        factors, names, parameters = [], set(), set()
        for i, data in enumerate(raw):
            where = ("factors", i)
            spec = self.read(FactorTable, data, where, {"name": default_names(len(raw))[i]})
            name, parameter, low, high = spec.name, spec.parameter, spec.low, spec.high
            if name in names:
                raise self.error(where + ("name",), f"factor name '{name}' is used twice; give each factor its own")
            if parameter in parameters:
                raise self.error(where + ("parameter",), f"parameter '{parameter}' is a factor twice; keep one")
            names.add(name)
            parameters.add(parameter)
            if low == high:
                raise self.error(where + ("low",),
                                 f"factor '{parameter}' has low = high = {low:g}, so it does not vary; give "
                                 f"low < high, or fix its value in [experiment.settings] instead")
            if low > high:
                raise self.error(where + ("low",), f"factor '{parameter}' has low {low:g} >= high {high:g}; swap them")
            if parameter not in table:
                near = difflib.get_close_matches(parameter, list(table), n=1, cutoff=0.6)
                hint = f"did you mean '{near[0]}'?" if near else f"`demcal bench {experiment.name} --help` lists them"
                raise self.error(where + ("parameter",),
                                 f"factor parameter '{parameter}' is not a setting of {experiment.name}; {hint}")
            hard = {k: v for k, v in (("hard_low", spec.hard_low), ("hard_high", spec.hard_high)) if v is not None}
            for level, value in (("low", low), ("high", high), *hard.items()):
                if _is_restitution(parameter) and level in ("low", "high") and not 0 < value <= 1:
                    raise self.error(where + (level,), f"factor '{parameter}' has {level} {value:g}, but a "
                                                       "coefficient of restitution must lie in (0, 1]")
                self.check_setting(experiment, table, profile, parameter, value, where + (level,))
            if hard.get("hard_low", low) > low or hard.get("hard_high", high) < high:
                key = "hard_low" if hard.get("hard_low", low) > low else "hard_high"
                raise self.error(where + (key,),
                                 f"factor '{parameter}' has {key} {hard[key]:g}, which excludes part of its "
                                 f"design box ({low:g} to {high:g}); hard limits must contain low and high")
            unit = table[parameter].unit if spec.unit is None else spec.unit
            factors.append(Factor(name=name, low=low, high=high, units=str(unit), description=spec.label,
                                  parameter=parameter, hard_low=spec.hard_low, hard_high=spec.hard_high))
        return tuple(factors)

    def design(self, k: int) -> DesignConfig:
        where, spec, data = ("design",), self.section(DesignTable, "design"), self.data.get("design", {})
        options = {key: value for key, value in data.items() if key not in ("type", "center")}
        try:
            # without the given centre points first, so that a huge `center` is refused
            # by its run count before any centre row is built
            runs = DesignConfig(spec.type, None if spec.center is None else 0, options).matrix(k).shape[0]
        except ConfigError as exc:
            raise self.error(where + ("type",), str(exc)) from None
        if spec.center:
            self.check_runs(where + ("center",), runs + spec.center,
                            f"a {spec.type} design of {runs:,} runs plus {spec.center:,} centre points",
                            "use fewer centre points")
        self.design_runs = runs + (spec.center or 0)  # `runs` holds the kind's default centre points if center is None
        return DesignConfig(type=spec.type, center=spec.center, options=options)

    def responses(self, experiment) -> tuple[Response, ...]:
        raw = self.tables("responses")
        known = tuple(experiment.responses)
        if not raw:
            return (Response(name=known[0]),)
        responses = []
        for i, data in enumerate(raw):
            responses.append(spec := self.read(Response, data, ("responses", i)))
            if spec.name not in known:
                near = difflib.get_close_matches(spec.name, known, n=1, cutoff=0.5)
                hint = f"did you mean '{near[0]}'?" if near else f"it measures: {', '.join(known)}"
                raise self.error(("responses", i, "name"), f"{experiment.name} has no response '{spec.name}'; {hint}")
        return tuple(responses)

    def conditions(self, responses, factors, experiment, table, profile,
                   upstream: Upstream | None) -> tuple[Condition, ...]:
        raw = self.tables("conditions")
        if not raw:
            raise self.error(("conditions",), "a campaign needs at least one [[conditions]] table with its targets")
        conditions, names = [], set()
        for i, data in enumerate(raw):
            where = ("conditions", i)
            spec = self.read(ConditionTable, data, where)
            if spec.name in names:
                raise self.error(where + ("name",), f"condition '{spec.name}' appears twice; give each its own name")
            names.add(spec.name)
            sample = None
            if spec.sample is not None:
                if spec.sample not in self.samples:
                    known = ", ".join(self.samples) or "none (set [campaign] lab)"
                    raise self.error(where + ("sample",),
                                     f"sample '{spec.sample}' is not in the lab file; samples: {known}")
                sample = self.samples[spec.sample]
            targets = self.targets(spec, data, sample, responses, where)
            reference = self.reference(spec.reference, factors, where)
            for key, value in spec.settings.items():
                if key in {f.parameter for f in factors}:
                    raise self.error(where + ("settings", key),
                                     f"'{key}' is a factor of this campaign, so condition '{spec.name}' cannot fix "
                                     "it; remove it from [conditions.settings] (the design varies it)")
                self.check_setting(experiment, table, profile, key, value, where + ("settings", key))
            conditions.append(Condition(name=spec.name, label=spec.label, targets=targets, reference=reference,
                                        photo=spec.photo, sample=sample, settings=_canonical(table, spec.settings),
                                        upstream=self.upstream(spec.from_campaign, data, where) or upstream))
        return tuple(conditions)

    def targets(self, spec: ConditionTable, data: Mapping, sample, responses, where: tuple) -> tuple[Target, ...]:
        """A condition's targets: its ``[conditions.targets]``, and what its sample's lab
        record gives for the responses they leave out."""
        known = [r.name for r in responses]
        given = dict(spec.targets)
        if sample is not None:
            from demcal.measure.lab import resolve_targets

            angles = resolve_targets(sample, self.path.parent, confine=not self.allow_outside,
                                     drums=self.drum_speeds(spec))
            for response, angle in angles.items():
                if response in known and response not in given:
                    sd = angle.sd_deg if math.isfinite(angle.sd_deg) else None
                    given[response] = {"mean": angle.mean_deg} | ({"sd": sd} if sd is not None else {})
        targets = []
        for key, value in given.items():
            at = where + ("targets", key)
            if key not in known:
                near = difflib.get_close_matches(key, known, n=1, cutoff=0.5)
                hint = f"did you mean '{near[0]}'?" if near else f"the campaign's responses are: {', '.join(known)}"
                raise self.error(at, f"condition '{spec.name}' has a target for unknown response '{key}'; {hint}")
            if isinstance(value, dict):
                target = self.read(Target, value, at, {"response": key})
            else:
                target = Target(response=key, mean=self.value(float, given, key, where + ("targets",)))
            mean = target.mean
            if _is_angle(responses[known.index(key)]) and not 0 <= mean < 90:
                at = (at + ("mean",) if isinstance(value, dict) else at) if key in data.get("targets", {}) \
                    else where + ("sample",)
                raise self.error(at, f"condition '{spec.name}' has a target of {mean:g}° for '{key}', but an angle "
                                     "target must lie in [0°, 90°); give the lab's angle in degrees")
            targets.append(target)
        for name in known:
            if name not in given:
                raise self.error(where, f"condition '{spec.name}' has no target for response '{name}'; add "
                                        f"[conditions.targets] {name} = {{ mean = ..., sd = ... }} "
                                        f"or a sample whose lab record gives it")
        return tuple(targets)

    def drum_speeds(self, spec: ConditionTable) -> dict[str, float | None]:
        """Each drum response of the campaign's test with the speed a condition's runs turn
        that drum at [1/min] (its own setting over the campaign's; None when neither sets
        it): ``drum.rpm`` of a drum, ``PART:drum.rpm`` of each drum of a joint test."""
        settings = {**self.data.get("experiment", {}).get("settings", {}), **spec.settings}
        experiment = self.experiment_test
        parts = list(zip(getattr(experiment, "part_names", ()), getattr(experiment, "parts", ())))
        if not parts:
            rpm = settings.get("drum.rpm")
            return {"dynamic_angle_deg": None if rpm is None else float(rpm)}
        from demcal.bench.joint import renamed

        out = {}
        for name, part in parts:
            if "dynamic_angle_deg" in part.responses:
                rpm = settings.get(f"{name}:drum.rpm")
                out[renamed("dynamic_angle_deg", name)] = None if rpm is None else float(rpm)
        return out

    def reference(self, values: Mapping, factors, where: tuple) -> dict[str, float]:
        """``[conditions.reference]``: published values of the factors, by parameter."""
        valid = {f.parameter for f in factors} | {f.name for f in factors}
        for key in values:
            if key not in valid:
                near = difflib.get_close_matches(key, sorted(valid), n=1, cutoff=0.6)
                hint = f"did you mean '{near[0]}'?" if near else "use a factor's parameter"
                raise self.error(where + ("reference", key), f"reference value '{key}' is not a factor; {hint}")
            self.value(float, values, key, where + ("reference",))
        by_name = {f.name: f.parameter for f in factors}
        return {by_name.get(k, k): float(v) for k, v in values.items()}

    def calibration(self, experiment, verification_replicates: int) -> CalibrationConfig:
        where = ("calibration",)
        config = self.section(CalibrationConfig, "calibration")
        if config.production is not None:
            self.value(str, self.data["calibration"], "production", where, {"choices": tuple(experiment.profiles)})
            from demcal.bench.registry import resolve_settings

            try:
                resolve_settings(experiment, {}, config.production)
            except ConfigError as exc:  # pragma: no cover - a registered profile resolves
                raise self.error(where + ("production",), str(exc)) from None
        budget = self.section(BudgetTable, "budget")
        config = dataclasses.replace(config, budget_runs=budget.runs, budget_cpu_hours=budget.cpu_hours)
        first = config.replicates or verification_replicates
        if first > config.max_replicates:
            raise self.error(where + ("max_replicates",),
                             f"'max_replicates' ({config.max_replicates}) is below the first production "
                             f"replicates ({first}); raise it")
        if config.replicate_batch > config.max_replicates:
            raise self.error(where + ("replicate_batch",),
                             f"'replicate_batch' ({config.replicate_batch}) is above 'max_replicates' "
                             f"({config.max_replicates}); set it to your number of workers, at most "
                             f"max_replicates")
        if first and config.min_replicates > first:
            raise self.error(where + ("min_replicates",),
                             f"'min_replicates' ({config.min_replicates}) is above the first production "
                             f"replicates ({first}); lower it or raise [calibration] replicates")
        return config

    def executor(self) -> ExecutorConfig:
        config = self.section(ExecutorConfig, "executor")
        if config.scheduler is not None:
            from demcal.campaign.executors import scheduler_address_problem

            problem = scheduler_address_problem(config.scheduler)
            if problem:
                raise self.error(("executor", "scheduler"),
                                 f"scheduler '{config.scheduler}' is not a Dask scheduler address: {problem}")
        if config.ensemble and (config.backend != "cuda" or config.kind != "local" or config.scheduler):
            raise self.error(("executor", "ensemble"),
                             f"'ensemble' ({config.ensemble}) steps runs together on one GPU: it needs "
                             "backend = \"cuda\" and a local executor; set backend = \"cuda\" or remove "
                             "'ensemble'")
        return config


def _canonical(table, settings: Mapping) -> dict:
    """``settings`` with each listed setting's value as its canonical text (a list of
    numbers, ``inf`` among them, kept as text in stores, hashes and JSON files)."""
    from demcal.bench.registry import number_list

    return {key: number_list(table[key], value) if getattr(table.get(key), "listed", False) else value
            for key, value in settings.items()}


def default_workdir(name: str, path: str | Path) -> str:
    """``<name>-runs``: the campaign's name made filename-safe (letters, digits, ``.``,
    ``_`` and ``-`` kept, any other run of characters one ``-``), else the file's stem."""
    safe = re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-.")
    return f"{safe or Path(path).stem}-runs"


def _is_restitution(key: str) -> bool:
    return key.rsplit(".", 1)[-1] == "restitution"

