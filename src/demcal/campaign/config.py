"""Campaign files: TOML parsed once into frozen dataclasses.

A campaign file says which virtual test to run, which contact parameters to vary
(factors with low/high levels), how to lay out the design, which responses to
fit, which lab targets to solve for (one condition per material state, e.g. per
moisture content) and how to run it. :func:`load_campaign` reads and checks the
whole file before anything runs; every mistake becomes one
:class:`~demcal.errors.ConfigError` sentence naming the file, the line and the key,
e.g. ``repose.toml line 12: factor 'particle.static_friction' has low 0.5 >=
high 0.3; swap them.``

Layout (every table and key; ``examples/residual-film-soil/repose.toml`` is a full
example)::

    [campaign]      name, description, workdir, lab (a TOML file of lab records), from_campaign
    [experiment]    test, profile, plugins, [experiment.settings] KEY = VALUE
    [[factors]]     name, parameter, low, high, label, unit, hard_low, hard_high
    [design]        type, center, variant, alpha, fraction, generators, levels, runs
    [[responses]]   name, label, unit
    [runs]          seed, replicates
    [model]         order, reduce_alpha
    [[conditions]]  name, label, sample, photo, from_campaign, [conditions.targets] RESPONSE = {mean, sd},
                    [conditions.settings] KEY = VALUE, [conditions.reference] PARAMETER = VALUE
    [verification]  replicates, seed
    [calibration]   production, replicates, min_replicates, max_replicates, iterations,
                    box_moves, box_replicates, path_points, path_replicates, verify_on_path,
                    stored_noise, replicate_batch (the closed loop of :mod:`demcal.campaign.loop`)
    [budget]        runs, cpu_hours
    [executor]      kind, workers, scheduler, start_method, heartbeat_timeout_s, backend
    [report]        title, reference_table, captions = {KEY = "source", ...} (the published
                    tables each report table reproduces, e.g. ``factors = "paper Table 3"``:
                    only a campaign that reproduces a publication names one; see
                    :data:`CAPTION_KEYS`)

Settings fixed for one condition's runs alone (a moisture content's own inter-particle
values, say) come from ``[conditions.settings]`` and from ``from_campaign`` (per condition,
or in ``[campaign]`` for every condition): another campaign file whose calibrated values
(its ``calibration.json``) the condition of the same name takes. The file only names that
campaign; :func:`demcal.campaign.chain.resolve_chain` reads its values when runs are planned.

Results live in ``[campaign] workdir``, by default ``<name>-runs`` next to the file
(the campaign's name made filename-safe), so a copy of the file finds the same results.

Paths in the file (``workdir``, ``lab``, a condition's ``photo``, the lab record's
photos, ``reference_table``) are taken relative to the campaign file's folder and must
lie inside it, unless the loader is told ``allow_outside`` (``--allow-outside`` on the
command line). Input files are read with a size limit (:data:`demcal._checks.MAX_TOML_BYTES`
for the campaign and lab files). ``plugins`` are modules that register extra virtual
experiments: they are only named while the file is read, and imported only when the
caller asks for it (``import_plugins=True``: ``demcal run``, ``calibrate`` and ``demo``,
which run simulations; never ``demcal report`` or ``export``), from the campaign's
folder or the installed packages.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib
import importlib.util
import math
import os
import re
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from demcal._checks import MAX_SEED, MAX_TOML_BYTES, read_limited
from demcal.doe.factors import Factor as CodedFactor
from demcal.doe.factors import default_names
from demcal.errors import ConfigError

#: Keys allowed in each table; the path uses ``[]`` for an array of tables.
_ALLOWED: dict[str, tuple[str, ...]] = {
    "": ("campaign", "experiment", "factors", "design", "responses", "runs", "model",
         "conditions", "verification", "calibration", "budget", "executor", "report"),
    "campaign": ("name", "description", "workdir", "lab", "from_campaign"),
    "experiment": ("test", "profile", "plugins", "settings"),
    "factors[]": ("name", "parameter", "low", "high", "label", "unit", "hard_low", "hard_high"),
    "design": ("type", "center", "variant", "alpha", "fraction", "generators", "levels", "runs"),
    "responses[]": ("name", "label", "unit"),
    "runs": ("seed", "replicates"),
    "model": ("order", "reduce_alpha"),
    "conditions[]": ("name", "label", "sample", "photo", "from_campaign", "targets", "settings", "reference"),
    "conditions[].targets.*": ("mean", "sd"),
    "verification": ("replicates", "seed"),
    "calibration": ("production", "replicates", "min_replicates", "max_replicates", "iterations", "box_moves",
                    "box_replicates", "path_points", "path_replicates", "verify_on_path", "stored_noise",
                    "replicate_batch"),
    "budget": ("runs", "cpu_hours"),
    "executor": ("kind", "workers", "scheduler", "start_method", "heartbeat_timeout_s",
                 "backend"),
    "report": ("title", "reference_table", "captions"),
}
#: ``[report] captions`` keys: the report table (or text) each one's source is added to.
#: ``reference`` is what the conditions' ``[conditions.reference]`` values are called
#: (default "reference"), ``runs`` what the campaign's run count is compared with.
CAPTION_KEYS = ("targets", "sieve", "factors", "design", "calibrated", "verification", "images",
                "reference", "runs")
_REQUIRED_TABLES = ("campaign", "experiment", "factors", "conditions")
_MODEL_ORDERS = ("linear", "2fi", "quadratic", "cubic")
_EXECUTOR_KINDS = ("local", "dask")
_BACKENDS = ("cpu", "cuda")
_START_METHODS = ("spawn", "forkserver")


@dataclass(frozen=True)
class Factor(CodedFactor):
    """A varied contact parameter: a :class:`demcal.doe.factors.Factor` (name, low and
    high level, units, description; coded <-> actual) bound to an experiment setting."""

    parameter: str = ""  #: the experiment setting it drives, e.g. ``particle.restitution``
    #: limits the calibration loop never moves the box beyond (None: the setting's own range)
    hard_low: float | None = None
    hard_high: float | None = None


@dataclass(frozen=True)
class Response:
    name: str  #: key in the experiment's ``responses``
    label: str = ""
    unit: str = ""


@dataclass(frozen=True)
class Target:
    """A lab measurement to reproduce: mean and standard deviation."""

    response: str
    mean: float
    sd: float | None = None


@dataclass(frozen=True)
class Upstream:
    """Another campaign whose calibrated values a condition takes as fixed settings
    (``from_campaign``). ``values`` stay None until
    :func:`demcal.campaign.chain.resolve_chain` has read them from its calibration.json."""

    path: Path  #: the other campaign's file
    workdir: Path  #: its results' folder, where ``demcal calibrate`` writes calibration.json
    name: str  #: its ``[campaign] name``
    values: Mapping[str, float] | None = None  #: parameter key -> the value calibrated there
    status: str | None = None  #: how that condition's loop ended there ("verified", ...)
    profile: str | None = None  #: the profile it was calibrated at


@dataclass(frozen=True)
class Condition:
    """One material state (e.g. a moisture content) with its lab targets."""

    name: str
    label: str
    targets: tuple[Target, ...]
    #: published calibrated values to compare against, parameter key -> value
    reference: Mapping[str, float] = field(default_factory=dict)
    photo: Path | None = None  #: a measured heap photo shown next to the simulated one
    sample: Any = None  #: the sample's :class:`demcal.measure.lab.LabRecord`, if named
    #: ``[conditions.settings]``: settings fixed for this condition's runs alone
    settings: Mapping[str, Any] = field(default_factory=dict)
    upstream: Upstream | None = None  #: the campaign it takes calibrated values from, if any

    def target(self, response: str) -> Target:
        return next(t for t in self.targets if t.response == response)

    @property
    def fixed(self) -> dict[str, Any]:
        """The settings fixed for this condition's runs alone: the values calibrated by
        its ``from_campaign``, overridden by its own ``[conditions.settings]``."""
        if self.upstream is not None and self.upstream.values is None:
            raise RuntimeError(f"condition '{self.name}' takes values from {self.upstream.path.name}, which are "
                               "not read yet; pass the campaign through demcal.campaign.chain.resolve_chain")
        return {**(self.upstream.values if self.upstream is not None else {}), **self.settings}


@dataclass(frozen=True)
class DesignConfig:
    """``[design]``: a design kind (any spelling of :data:`demcal.doe.catalog.DESIGN_NAMES`),
    its centre points (None: the kind's default) and its other options."""

    type: str = "box-behnken"
    center: int | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def matrix(self, k: int):
        """The coded ``(runs, k)`` matrix, in standard order
        (:func:`demcal.doe.catalog.design_matrix`)."""
        from demcal.doe.catalog import design_matrix

        return design_matrix(self.type, k, center=self.center, **self.options)


@dataclass(frozen=True)
class CalibrationConfig:
    """``[calibration]`` and ``[budget]``: how ``demcal calibrate`` closes the loop
    (:mod:`demcal.campaign.loop`)."""

    production: str | None = None  #: production profile (None: the campaign's profile)
    replicates: int | None = None  #: first production replicates (None: [verification] replicates)
    #: fewest first replicates at a point once the pooled production noise says fewer
    #: than ``replicates`` give a 95 % interval narrower than the lab sd
    min_replicates: int = 1
    max_replicates: int = 10  #: most production replicates at one point
    #: production replicates are asked for in multiples of this many runs (set it to the
    #: number of workers: a batch that leaves a worker idle takes as long as a full one)
    replicate_batch: int = 1
    iterations: int = 4  #: re-solves on the corrected surface per condition
    box_moves: int = 3  #: most box moves per condition
    #: seeds per design point of a moved box (None: ``[runs] replicates``). A box is moved
    #: when the target lies beyond the one before, often near the edge of what the test
    #: reaches, where the factors' effects are small against the seed noise
    box_replicates: int | None = None
    path_points: int = 3  #: runs along the steepest path beyond the box, per move
    path_replicates: int = 1  #: seeds per path point
    #: verify first at the point where the path crosses the target (between two of its
    #: points), or at its step nearest the target when that reads inside the lab window
    #: without crossing, and lay the moved box's design only if that point misses
    verify_on_path: bool = True
    #: pool the stored profile studies' replicated production runs into the production
    #: noise from the start (:func:`demcal.campaign.noise.stored_noise`)
    stored_noise: bool = True
    budget_runs: int | None = None  #: most runs the calibration uses (its design included)
    budget_cpu_hours: float | None = None  #: most run hours (sum of the runs' wall times)


@dataclass(frozen=True)
class ExecutorConfig:
    kind: str = "local"
    workers: int = 0  #: 0 = one per CPU core
    scheduler: str | None = None  #: dask scheduler address, e.g. tcp://host:8786
    start_method: str = "spawn"
    heartbeat_timeout_s: float = 120.0
    backend: str = "cpu"  #: the compute backend of every run (demcal.dem.backend.BACKENDS)


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
        text = _decode(read_limited(path, MAX_TOML_BYTES, "campaign file"), path.name)
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


def _decode(data: bytes, name: str) -> str:
    """The UTF-8 text of a TOML file, refused by name if it is not UTF-8."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{name} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
                          "save it as UTF-8.") from None


def _check_bom(text: str, name: str) -> None:
    if text.startswith("\ufeff"):
        raise ConfigError(f"{name} starts with a UTF-8 byte-order mark (BOM), which TOML does not allow; "
                          "save the file as UTF-8 without BOM.")


#: A plugin is named as Python imports it: dotted identifiers, no path.
_MODULE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*")


def plugin_problem(module: str) -> str | None:
    """Why ``module`` cannot be a plugin (not a module name, a module of Python's
    standard library), or None."""
    if not isinstance(module, str) or not _MODULE_NAME.fullmatch(module):
        return f"plugin {module!r} is not a module name; give one like 'my_bench' or 'mypackage.benches'"
    top = module.split(".", 1)[0]
    if top in sys.stdlib_module_names or top in sys.builtin_module_names:
        return (f"plugin '{module}' is a module of Python's standard library, not a plugin; name a module "
                "in the campaign folder or an installed package that registers a virtual test")
    return None


def import_plugins(plugins, folder: str | Path) -> None:
    """Import the plugin modules ``plugins`` (which register extra virtual experiments),
    found in ``folder`` (the campaign's folder, added at the end of ``sys.path``, so
    that installed packages come first and spawned workers find it too) or among the
    installed packages.

    Raises
    ------
    ConfigError
        A name that is no plugin (:func:`plugin_problem`), a module that is found nowhere,
        or one that fails while it is imported; the sentence names it.
    """
    folder = str(Path(folder).resolve())
    if folder not in sys.path:
        sys.path.append(folder)
    importlib.invalidate_caches()  # a module written since the folder was last looked at
    for module in plugins:
        problem = plugin_problem(module)
        if problem:
            raise ConfigError(problem + ".")
        top = module.split(".", 1)[0]
        try:
            found = importlib.util.find_spec(top) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            raise ConfigError(f"plugin '{module}' is neither a module in the campaign folder {folder} nor an "
                              "installed package; put it there or install it.")
        try:
            importlib.import_module(module)
        except Exception as exc:  # noqa: BLE001 - a plugin is the user's code; any failure is theirs
            from demcal._checks import printable

            first = printable(str(exc).strip().splitlines()[0] if str(exc).strip() else "", 200)
            raise ConfigError(f"plugin '{module}' failed while being imported "
                              f"({type(exc).__name__}{': ' + first if first else ''}); fix the module.") from None


# --------------------------------------------------------------------------- loader


class _Loader:
    def __init__(self, text: str, path: Path, import_plugins: bool = False, allow_outside: bool = False):
        self.path = path
        self.text = text
        self.import_plugins = import_plugins
        self.allow_outside = allow_outside
        _check_bom(text, path.name)
        try:
            self.data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            message = str(exc)
            match = re.search(r"\(at line (\d+), column \d+\)", message)
            where = f" line {match.group(1)}" if match else ""
            reason = re.sub(r"\s*\(at line \d+, column \d+\)", "", message)
            raise ConfigError(f"{path.name}{where}: not valid TOML ({reason}).") from None
        self.lines = _key_lines(text)
        self.samples: dict = {}  # lab records by sample name, from [campaign] lab

    # -- errors
    def error(self, where: tuple, message: str) -> ConfigError:
        line = self.line(where)
        prefix = f"{self.path.name} line {line}" if line else self.path.name
        message = message.rstrip()
        if not message.endswith((".", "?", "!")):
            message += "."
        return ConfigError(f"{prefix}: {message}")

    def line(self, where: tuple) -> int | None:
        where = tuple(where)
        while where:
            if where in self.lines:
                return self.lines[where]
            where = where[:-1]
        return None

    # -- paths
    def inside(self, path: Path, written: str, where: tuple, what: str) -> Path:
        """``path`` (already joined to the campaign's folder), refused unless it lies in
        that folder or ``allow_outside`` was given; links are followed."""
        if self.allow_outside:
            return path
        folder = self.path.parent.resolve()
        try:
            resolved = path.resolve()
        except (OSError, RuntimeError):  # a loop of links
            resolved = Path(os.path.abspath(path))
        if resolved == folder or folder in resolved.parents:
            return path
        raise self.error(where, f"{what} '{written}' lies outside the campaign file's folder {folder}; "
                                "move it into that folder, or pass --allow-outside to use it where it is")

    # -- generic checks
    def check_keys(self, table: Mapping[str, Any], where: tuple, schema: str) -> None:
        allowed = _ALLOWED[schema]
        for key in table:
            if key not in allowed:
                near = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
                hint = f"did you mean '{near[0]}'?" if near else f"valid keys are: {', '.join(allowed)}"
                shown = _table_name(where) or "the top level"
                raise self.error(where + (key,), f"unknown key '{key}' in {shown}; {hint}")

    def table(self, data: Mapping, key: str, where: tuple, required: bool = False) -> dict:
        value = data.get(key)
        if value is None:
            if required:
                raise self.error(where, f"missing table [{_dotted(where + (key,))}]; add it")
            return {}
        if not isinstance(value, dict):
            raise self.error(where + (key,), f"'{_dotted(where + (key,))}' must be a table")
        return value

    def string(self, data: Mapping, key: str, where: tuple, default: str | None = None) -> str:
        value = data.get(key, default)
        if value is None:
            raise self.error(where, f"missing key '{key}' in {_table_name(where)}; add it")
        if not isinstance(value, str) or not value.strip():
            raise self.error(where + (key,), f"'{key}' must be a non-empty string")
        return value.strip()

    def number(self, data: Mapping, key: str, where: tuple, default: float | None = None) -> float:
        value = data.get(key, default)
        if value is None:
            raise self.error(where, f"missing key '{key}' in {_table_name(where)}; add it")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(where + (key,), f"'{key}' must be a finite number, got {value!r}")
        return float(value)

    def integer(self, data: Mapping, key: str, where: tuple, default: int, minimum: int) -> int:
        value = data.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(where + (key,), f"'{key}' must be a whole number, got {value!r}")
        if value < minimum:
            raise self.error(where + (key,), f"'{key}' must be at least {minimum}, got {value}")
        return value

    def boolean(self, data: Mapping, key: str, where: tuple, default: bool) -> bool:
        value = data.get(key, default)
        if not isinstance(value, bool):
            raise self.error(where + (key,), f"'{key}' must be true or false, got {value!r}")
        return value

    def choice(self, data: Mapping, key: str, where: tuple, choices: tuple[str, ...], default: str) -> str:
        value = self.string(data, key, where, default)
        if value not in choices:
            near = difflib.get_close_matches(value, choices, n=1, cutoff=0.5)
            hint = f"did you mean '{near[0]}'?" if near else f"choose one of: {', '.join(choices)}"
            raise self.error(where + (key,), f"'{key}' = '{value}' is not known; {hint}")
        return value

    def array_of_tables(self, key: str) -> list[dict]:
        value = self.data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error((key,), f"'{key}' must be written as [[{key}]] tables")
        return value

    # -- the campaign
    def campaign(self) -> Campaign:
        data = self.data
        self.check_keys(data, (), "")
        for name in _REQUIRED_TABLES:
            if name not in data:
                form = f"[[{name}]]" if name in ("factors", "conditions") else f"[{name}]"
                raise self.error((), f"missing {form}; a campaign needs {form}")

        meta, name, workdir = self.location()
        description = meta.get("description", "")
        upstream = self.upstream(meta, ("campaign",))

        self.samples = self.lab_records(meta)
        lab_file = self.path.parent / meta["lab"] if "lab" in meta else None
        experiment, test, profile, plugins, settings = self.experiment()
        table = experiment.settings(profile)
        factors = self.factors(experiment, table, profile)
        overlap = sorted(set(settings) & {f.parameter for f in factors})
        if overlap:
            raise self.error(("experiment", "settings", overlap[0]),
                             f"'{overlap[0]}' is both a factor and a fixed setting; keep one")
        design = self.design(len(factors))
        responses = self.responses(experiment)
        conditions = self.conditions(responses, factors, experiment, table, profile, upstream)
        self.check_order(table, settings, factors, conditions)

        runs = self.table(data, "runs", ())
        self.check_keys(runs, ("runs",), "runs")
        replicates = self.integer(runs, "replicates", ("runs",), 1, 1)
        if replicates > 1:
            from demcal.doe.designs import check_run_count

            try:
                check_run_count(self.design_runs * replicates,
                                f"{self.design_runs:,} design runs x {replicates:,} replicates",
                                "use fewer replicates")
            except ConfigError as exc:
                raise self.error(("runs", "replicates"), str(exc)) from None
        model = self.table(data, "model", ())
        self.check_keys(model, ("model",), "model")
        order = self.choice(model, "order", ("model",), _MODEL_ORDERS, "quadratic")
        alpha = model.get("reduce_alpha", False)
        if alpha is False:
            reduce_alpha = None
        else:
            reduce_alpha = self.number(model, "reduce_alpha", ("model",))
            if not 0 < reduce_alpha < 1:
                raise self.error(("model", "reduce_alpha"),
                                 f"'reduce_alpha' must lie between 0 and 1 (e.g. 0.05) or be false, got {alpha}")
        verification = self.table(data, "verification", ())
        self.check_keys(verification, ("verification",), "verification")
        report = self.table(data, "report", ())
        self.check_keys(report, ("report",), "report")
        reference_table = None
        if "reference_table" in report:
            written = self.string(report, "reference_table", ("report",))
            reference_table = self.inside(self.path.parent / written, written, ("report", "reference_table"),
                                          "reference_table")
            if not reference_table.is_file():
                raise self.error(("report", "reference_table"),
                                 f"reference_table '{written}' does not exist next to the campaign file"
                                 if not reference_table.exists() else
                                 f"reference_table '{written}' is not a file; give the CSV of a published design")
        captions = self.captions(report)
        calibration = self.calibration(experiment, factors, verification)
        verification_replicates = self.integer(verification, "replicates", ("verification",), 3, 0)
        seed = self.integer(runs, "seed", ("runs",), 1, 0)
        verification_seed = self.integer(verification, "seed", ("verification",), 100_000, 0)
        self.check_seed(("runs", "seed"), "[runs] seed", seed, self.seed_span(replicates, calibration, conditions))
        self.check_seed(("verification", "seed"), "[verification] seed", verification_seed,
                        1000 * len(conditions) + max(calibration.max_replicates, verification_replicates))

        return Campaign(
            path=self.path,
            name=name,
            description=str(description),
            test=test,
            profile=profile,
            plugins=plugins,
            settings=settings,
            factors=factors,
            design=design,
            responses=responses,
            conditions=conditions,
            seed=seed,
            replicates=replicates,
            model_order=order,
            reduce_alpha=reduce_alpha,
            verification_replicates=verification_replicates,
            verification_seed=verification_seed,
            executor=self.executor(),
            calibration=calibration,
            workdir=workdir,
            title=str(report.get("title", name)),
            reference_table=reference_table,
            lab_file=lab_file,
            captions=captions,
        )

    def location(self) -> tuple[dict, str, Path]:
        """``[campaign]``, the campaign's name and its workdir (the results' folder)."""
        meta = self.table(self.data, "campaign", (), required=True)
        self.check_keys(meta, ("campaign",), "campaign")
        name = self.string(meta, "name", ("campaign",))
        written = self.string(meta, "workdir", ("campaign",), default_workdir(name, self.path))
        workdir = self.inside(self.path.parent / written, written, ("campaign", "workdir"), "workdir")
        self.inside_workdir(workdir, written)
        return meta, name, workdir

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

    def upstream(self, data: Mapping, where: tuple) -> Upstream | None:
        """The campaign that ``from_campaign`` in ``data`` names: its file, name and results'
        folder (read from its ``[campaign]`` table only; its values are read when runs are
        planned, by :func:`demcal.campaign.chain.resolve_chain`)."""
        if "from_campaign" not in data:
            return None
        key = where + ("from_campaign",)
        written = self.string(data, "from_campaign", where)
        path = self.inside(self.path.parent / written, written, key, "from_campaign")
        if not path.is_file():
            raise self.error(key, f"from_campaign '{written}' does not exist next to the campaign file"
                             if not path.exists() else
                             f"from_campaign '{written}' is not a file; give the other campaign's file (TOML)")
        if path.resolve() == self.path.resolve():
            raise self.error(key, f"from_campaign '{written}' is this campaign file itself; name the campaign "
                                  "whose calibrated values the conditions take")
        try:
            text = _decode(read_limited(path, MAX_TOML_BYTES, "campaign file"), path.name)
            _, name, workdir = _Loader(text, path, allow_outside=self.allow_outside).location()
        except OSError as exc:
            raise self.error(key, f"from_campaign '{written}' cannot be read ({exc.strerror or exc})") from None
        except ConfigError as exc:
            raise self.error(key, f"from_campaign '{written}': {exc}") from None
        return Upstream(path=path, workdir=workdir, name=name)

    def captions(self, report: Mapping) -> dict[str, str]:
        """``[report] captions``: a table of strings keyed by :data:`CAPTION_KEYS`."""
        where = ("report", "captions")
        value = self.table(report, "captions", ("report",))
        for key, text in value.items():
            if key not in CAPTION_KEYS:
                near = difflib.get_close_matches(key, CAPTION_KEYS, n=1, cutoff=0.6)
                hint = f"did you mean '{near[0]}'?" if near else f"valid keys are: {', '.join(CAPTION_KEYS)}"
                raise self.error(where + (key,), f"unknown caption '{key}' in [report] captions; {hint}")
            if not isinstance(text, str) or not text.strip():
                raise self.error(where + (key,), f"caption '{key}' must be a non-empty string, e.g. "
                                                 f'{key} = "paper Table 3"')
        return {key: text.strip() for key, text in value.items()}

    def seed_span(self, replicates: int, calibration: CalibrationConfig, conditions) -> int:
        """How far above ``[runs] seed`` the seeds of a campaign's runs reach: design runs
        (``seed + replicate * points + point``, :func:`demcal.campaign.runner.plan_design`)
        and the calibration loop's moved boxes and path runs (:mod:`demcal.campaign.loop`)."""
        from demcal.campaign.seeds import BOX_SEED, PATH_SEED

        design = self.design_runs * max(replicates, calibration.box_replicates or 0)
        boxes = calibration.box_moves * len(conditions)
        return (BOX_SEED * boxes + design + PATH_SEED + 997 * boxes
                + 10 * (calibration.path_points + 2) + calibration.path_replicates)

    def check_seed(self, where: tuple, name: str, seed: int, span: int) -> None:
        """Refuse a seed whose derived run seeds (up to ``seed + span``) leave 0 .. 2^63 - 1."""
        if seed + span > MAX_SEED:
            raise self.error(where, f"{name} = {seed} leaves no room for the run seeds derived from it (up to "
                                    f"seed + {span:,}), which must stay within 0 .. 2^63 - 1 ({MAX_SEED}); "
                                    f"give a seed of at most {MAX_SEED - span}")

    def lab_records(self, meta: Mapping) -> dict:
        """Lab records of the file named by ``[campaign] lab`` (one table per sample)."""
        if "lab" not in meta:
            return {}
        from demcal.measure.lab import LabRecord

        where = ("campaign", "lab")
        name = self.string(meta, "lab", ("campaign",))
        path = self.inside(self.path.parent / name, name, where, "lab file")
        if path.is_dir():
            raise self.error(where, f"lab file '{name}' is a folder; give the lab records' TOML file")
        try:
            text = _decode(read_limited(path, MAX_TOML_BYTES, "lab file"), path.name)
            _check_bom(text, path.name)
            data = tomllib.loads(text)
        except FileNotFoundError:
            raise self.error(where, f"lab file '{name}' does not exist next to the campaign file") from None
        except OSError as exc:
            raise self.error(where, f"lab file '{name}' cannot be read ({exc.strerror or exc})") from None
        except ConfigError as exc:
            raise self.error(where, str(exc)) from None
        except tomllib.TOMLDecodeError as exc:
            raise self.error(where, f"lab file '{name}' is not valid TOML ({exc})") from None
        lines = _key_lines(text)
        records = {}
        for key, table in data.items():
            records[key] = LabRecord.from_dict(table, f"[{key}]", file=path.name,
                                               lines={k[1:]: n for k, n in lines.items() if k[:1] == (key,)})
        return records

    def experiment(self):
        from demcal.bench.registry import get_experiment

        where = ("experiment",)
        data = self.table(self.data, "experiment", (), required=True)
        self.check_keys(data, where, "experiment")
        plugins = data.get("plugins", [])
        if not isinstance(plugins, list) or not all(isinstance(p, str) for p in plugins):
            raise self.error(where + ("plugins",), "'plugins' must be a list of module names")
        for module in plugins:
            problem = plugin_problem(module)
            if problem:
                raise self.error(where + ("plugins",), problem)
        if self.import_plugins:  # only for callers that run simulations; never while just reading
            try:
                import_plugins(plugins, self.path.parent)
            except ConfigError as exc:
                raise self.error(where + ("plugins",), str(exc)) from None
        test = self.string(data, "test", where)
        try:
            experiment = get_experiment(test)
        except ConfigError as exc:
            if plugins and not self.import_plugins:
                raise self.error(where + ("test",),
                                 f"unknown virtual test '{test}' among those registered; the plugins that may "
                                 f"register it ({', '.join(plugins)}) are imported only by the commands that run "
                                 "simulations (run, calibrate), never while a campaign file is just read") from None
            raise self.error(where + ("test",), str(exc)) from None
        profiles = tuple(experiment.profiles)
        profile = self.choice(data, "profile", where, profiles, "quick" if "quick" in profiles else profiles[0])
        settings = dict(self.table(data, "settings", where))
        table = experiment.settings(profile)
        for key, value in settings.items():
            self.check_setting(experiment, table, profile, key, value, where + ("settings", key))
        return experiment, test, profile, tuple(plugins), settings

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
        raw = self.array_of_tables("factors")
        if not raw:
            raise self.error(("factors",), "a campaign needs at least one [[factors]] table")
        factors, names, parameters = [], set(), set()
        for i, data in enumerate(raw):
            where = ("factors", i)
            self.check_keys(data, where, "factors[]")
            parameter = self.string(data, "parameter", where)
            name = self.string(data, "name", where, default_names(len(raw))[i])
            if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
                raise self.error(where + ("name",), f"factor name '{name}' must be a letter followed by letters, digits or _")
            if name in names:
                raise self.error(where + ("name",), f"factor name '{name}' is used twice; give each factor its own")
            if parameter in parameters:
                raise self.error(where + ("parameter",), f"parameter '{parameter}' is a factor twice; keep one")
            names.add(name)
            parameters.add(parameter)
            low = self.number(data, "low", where)
            high = self.number(data, "high", where)
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
            for level, value in (("low", low), ("high", high)):
                if _is_restitution(parameter) and not 0 < value <= 1:
                    raise self.error(where + (level,),
                                     f"factor '{parameter}' has {level} {value:g}, but a coefficient of restitution must lie in (0, 1]")
                self.check_setting(experiment, table, profile, parameter, value, where + (level,))
            hard = {}
            for key in ("hard_low", "hard_high"):
                if key in data:
                    hard[key] = self.number(data, key, where)
                    self.check_setting(experiment, table, profile, parameter, hard[key], where + (key,))
            if hard.get("hard_low", low) > low or hard.get("hard_high", high) < high:
                key = "hard_low" if hard.get("hard_low", low) > low else "hard_high"
                raise self.error(where + (key,),
                                 f"factor '{parameter}' has {key} {hard[key]:g}, which excludes part of its "
                                 f"design box ({low:g} to {high:g}); hard limits must contain low and high")
            unit = data.get("unit", table[parameter].unit)
            factors.append(Factor(name=name, low=low, high=high, units=str(unit),
                                  description=str(data.get("label", parameter)), parameter=parameter,
                                  hard_low=hard.get("hard_low"), hard_high=hard.get("hard_high")))
        return tuple(factors)

    def design(self, k: int) -> DesignConfig:
        where = ("design",)
        data = self.table(self.data, "design", ())
        self.check_keys(data, where, "design")
        kind = self.string(data, "type", where, "box-behnken")
        center = data.get("center")
        if center is not None:
            center = self.integer(data, "center", where, 0, 0)
        options = {key: value for key, value in data.items() if key not in ("type", "center")}
        try:
            # without the given centre points first, so that a huge `center` is refused
            # by its run count before any centre row is built
            runs = DesignConfig(kind, None if center is None else 0, options).matrix(k).shape[0]
        except ConfigError as exc:
            raise self.error(where + ("type",), str(exc)) from None
        if center:
            from demcal.doe.designs import check_run_count

            try:
                check_run_count(runs + center, f"a {kind} design of {runs:,} runs plus {center:,} centre points",
                                "use fewer centre points")
            except ConfigError as exc:
                raise self.error(where + ("center",), str(exc)) from None
        self.design_runs = runs + (center or 0)  # `runs` holds the design's default centre points if center is None
        return DesignConfig(type=kind, center=center, options=options)

    def responses(self, experiment) -> tuple[Response, ...]:
        raw = self.array_of_tables("responses")
        known = tuple(experiment.responses)
        if not raw:
            return (Response(name=known[0]),)
        responses = []
        for i, data in enumerate(raw):
            where = ("responses", i)
            self.check_keys(data, where, "responses[]")
            name = self.string(data, "name", where)
            if name not in known:
                near = difflib.get_close_matches(name, known, n=1, cutoff=0.5)
                hint = f"did you mean '{near[0]}'?" if near else f"it measures: {', '.join(known)}"
                raise self.error(where + ("name",), f"{experiment.name} has no response '{name}'; {hint}")
            responses.append(Response(name=name, label=str(data.get("label", name)), unit=str(data.get("unit", ""))))
        return tuple(responses)

    def conditions(self, responses, factors, experiment, table, profile,
                   upstream: Upstream | None) -> tuple[Condition, ...]:
        raw = self.array_of_tables("conditions")
        if not raw:
            raise self.error(("conditions",), "a campaign needs at least one [[conditions]] table with its targets")
        conditions, names = [], set()
        for i, data in enumerate(raw):
            where = ("conditions", i)
            self.check_keys(data, where, "conditions[]")
            name = self.string(data, "name", where)
            if name in names:
                raise self.error(where + ("name",), f"condition '{name}' appears twice; give each its own name")
            names.add(name)
            sample = None
            if "sample" in data:
                key = self.string(data, "sample", where)
                if key not in self.samples:
                    known = ", ".join(self.samples) or "none (set [campaign] lab)"
                    raise self.error(where + ("sample",), f"sample '{key}' is not in the lab file; samples: {known}")
                sample = self.samples[key]
            targets_data = dict(self.table(data, "targets", where))
            if sample is not None:
                from demcal.measure.lab import resolve_targets

                targets_of = resolve_targets(sample, self.path.parent, confine=not self.allow_outside)
                for response, angle in targets_of.items():
                    if response in {r.name for r in responses} and response not in targets_data:
                        sd = angle.sd_deg if math.isfinite(angle.sd_deg) else None
                        targets_data[response] = {"mean": angle.mean_deg} | ({"sd": sd} if sd is not None else {})
            targets = []
            for key, value in targets_data.items():
                if key not in {r.name for r in responses}:
                    near = difflib.get_close_matches(key, [r.name for r in responses], n=1, cutoff=0.5)
                    hint = f"did you mean '{near[0]}'?" if near else f"the campaign's responses are: {', '.join(r.name for r in responses)}"
                    raise self.error(where + ("targets", key), f"condition '{name}' has a target for unknown response '{key}'; {hint}")
                if isinstance(value, dict):
                    self.check_keys(value, where + ("targets", key), "conditions[].targets.*")
                    mean = self.number(value, "mean", where + ("targets", key))
                    sd = value.get("sd")
                    if sd is not None:
                        sd = self.number(value, "sd", where + ("targets", key))
                        if sd < 0:
                            raise self.error(where + ("targets", key, "sd"), f"target sd of '{key}' must not be negative")
                else:
                    mean = self.number(targets_data, key, where + ("targets",))
                    sd = None
                response = next(r for r in responses if r.name == key)
                if _is_angle(response) and not 0 <= mean < 90:
                    at = (where + ("targets", key, "mean") if isinstance(value, dict) else where + ("targets", key)
                          ) if key in data.get("targets", {}) else where + ("sample",)
                    raise self.error(at, f"condition '{name}' has a target of {mean:g}° for '{key}', but an angle "
                                         "target must lie in [0°, 90°); give the lab's angle in degrees")
                targets.append(Target(response=key, mean=mean, sd=sd))
            for response in responses:
                if response.name not in targets_data:
                    raise self.error(
                        where,
                        f"condition '{name}' has no target for response '{response.name}'; add "
                        f"[conditions.targets] {response.name} = {{ mean = ..., sd = ... }} "
                        f"or a sample whose lab record gives it",
                    )
            reference = dict(self.table(data, "reference", where))
            valid = {f.parameter for f in factors} | {f.name for f in factors}
            for key, value in reference.items():
                if key not in valid:
                    near = difflib.get_close_matches(key, sorted(valid), n=1, cutoff=0.6)
                    hint = f"did you mean '{near[0]}'?" if near else "use a factor's parameter"
                    raise self.error(where + ("reference", key), f"reference value '{key}' is not a factor; {hint}")
                self.number(reference, key, where + ("reference",))
            by_name = {f.name: f.parameter for f in factors}
            reference = {by_name.get(k, k): float(v) for k, v in reference.items()}
            settings = dict(self.table(data, "settings", where))
            for key, value in settings.items():
                if key in {f.parameter for f in factors}:
                    raise self.error(where + ("settings", key),
                                     f"'{key}' is a factor of this campaign, so condition '{name}' cannot fix it; "
                                     "remove it from [conditions.settings] (the design varies it)")
                self.check_setting(experiment, table, profile, key, value, where + ("settings", key))
            photo = None
            if "photo" in data:
                written = self.string(data, "photo", where)
                photo = self.inside(self.path.parent / written, written, where + ("photo",), "photo")
                if not photo.is_file():
                    raise self.error(where + ("photo",), f"photo '{written}' does not exist next to the campaign file"
                                     if not photo.exists() else f"photo '{written}' is not a file; give an image file")
            conditions.append(Condition(name=name, label=str(data.get("label", name)),
                                        targets=tuple(targets), reference=reference, photo=photo,
                                        sample=sample, settings=settings,
                                        upstream=self.upstream(data, where) or upstream))
        return tuple(conditions)

    def calibration(self, experiment, factors, verification: Mapping) -> CalibrationConfig:
        where = ("calibration",)
        data = self.table(self.data, "calibration", ())
        self.check_keys(data, where, "calibration")
        production = None
        if "production" in data:
            profiles = tuple(experiment.profiles)
            production = self.choice(data, "production", where, profiles, profiles[0])
            from demcal.bench.registry import resolve_settings

            try:
                resolve_settings(experiment, {}, production)
            except ConfigError as exc:  # pragma: no cover - a registered profile resolves
                raise self.error(where + ("production",), str(exc)) from None
        replicates = data.get("replicates")
        if replicates is not None:
            replicates = self.integer(data, "replicates", where, 3, 1)
        budget = self.table(self.data, "budget", ())
        self.check_keys(budget, ("budget",), "budget")
        runs = hours = None
        if "runs" in budget:
            runs = self.integer(budget, "runs", ("budget",), 1, 1)
        if "cpu_hours" in budget:
            hours = self.number(budget, "cpu_hours", ("budget",))
            if hours <= 0:
                raise self.error(("budget", "cpu_hours"),
                                 f"'cpu_hours' must be positive, got {hours:g}; give e.g. cpu_hours = 2")
        config = CalibrationConfig(
            production=production, replicates=replicates,
            min_replicates=self.integer(data, "min_replicates", where, 1, 1),
            max_replicates=self.integer(data, "max_replicates", where, 10, 2),
            replicate_batch=self.integer(data, "replicate_batch", where, 1, 1),
            iterations=self.integer(data, "iterations", where, 4, 1),
            box_moves=self.integer(data, "box_moves", where, 3, 0),
            box_replicates=(self.integer(data, "box_replicates", where, 1, 1) if "box_replicates" in data
                            else None),
            path_points=self.integer(data, "path_points", where, 3, 1),
            path_replicates=self.integer(data, "path_replicates", where, 1, 1),
            verify_on_path=self.boolean(data, "verify_on_path", where, True),
            stored_noise=self.boolean(data, "stored_noise", where, True),
            budget_runs=runs, budget_cpu_hours=hours)
        first = config.replicates or self.integer(verification, "replicates", ("verification",), 3, 0)
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
        where = ("executor",)
        data = self.table(self.data, "executor", ())
        self.check_keys(data, where, "executor")
        kind = self.choice(data, "kind", where, _EXECUTOR_KINDS, "local")
        scheduler = data.get("scheduler")
        if scheduler is not None:
            from demcal.campaign.executors import scheduler_address_problem

            scheduler = self.string(data, "scheduler", where)
            problem = scheduler_address_problem(scheduler)
            if problem:
                raise self.error(where + ("scheduler",),
                                 f"scheduler '{scheduler}' is not a Dask scheduler address: {problem}")
        timeout = self.number(data, "heartbeat_timeout_s", where, 120.0)
        if timeout <= 0:
            raise self.error(where + ("heartbeat_timeout_s",), "'heartbeat_timeout_s' must be positive")
        return ExecutorConfig(
            kind=kind,
            workers=self.integer(data, "workers", where, 0, 0),
            scheduler=scheduler,
            start_method=self.choice(data, "start_method", where, _START_METHODS, "spawn"),
            heartbeat_timeout_s=timeout,
            backend=self.choice(data, "backend", where, _BACKENDS, "cpu"),
        )


def default_workdir(name: str, path: str | Path) -> str:
    """``<name>-runs``: the campaign's name made filename-safe (letters, digits, ``.``,
    ``_`` and ``-`` kept, any other run of characters one ``-``), else the file's stem."""
    safe = re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-.")
    return f"{safe or Path(path).stem}-runs"


#: Units that make a response an angle (its lab targets lie in [0°, 90°)), besides a
#: name ending in ``_deg`` (``repose_angle_deg``, ``sliding_angle_deg``).
_DEGREES = ("°", "deg", "degree", "degrees")


def _is_angle(response: Response) -> bool:
    return response.name.endswith("_deg") or response.unit.strip().lower() in _DEGREES


def _is_restitution(key: str) -> bool:
    return key.rsplit(".", 1)[-1] == "restitution"


def _dotted(where: tuple) -> str:
    return ".".join(str(p) for p in where if not isinstance(p, int))


def _table_name(where: tuple) -> str:
    if not where:
        return ""
    if len(where) >= 2 and isinstance(where[1], int):
        head = f"[[{where[0]}]] #{where[1] + 1}"
        rest = _dotted(where[2:])
        return f"{head} {rest}".strip() if rest else head
    return f"[{_dotted(where)}]"


# --------------------------------------------------------------- key -> line map

_HEADER = re.compile(r"^\s*(\[\[?)\s*(.+?)\s*(\]\]?)\s*(?:#.*)?$")
_KEY_PART = r'(?:[A-Za-z0-9_-]+|"(?:[^"\\]|\\.)*"|\'[^\']*\')'
_KEY = re.compile(rf"^\s*({_KEY_PART}(?:\s*\.\s*{_KEY_PART})*)\s*=")
_INLINE_KEY = re.compile(rf"[{{,]\s*({_KEY_PART})\s*=")


def _split_key(key: str) -> tuple[str, ...]:
    parts = re.findall(_KEY_PART, key)
    return tuple(p[1:-1] if p[:1] in "\"'" else p for p in parts)


def _key_lines(text: str) -> dict[tuple, int]:
    """Map each table and key path (array indices included) to its 1-based line.

    ``tomllib`` keeps no positions, so this scans the text once: table headers,
    ``key = value`` lines and the keys of one-line inline tables. Lines inside
    multi-line arrays and strings are skipped. Good enough to point a user at the
    line of a mistake; the parse itself is ``tomllib``'s.
    """
    lines: dict[tuple, int] = {}
    counts: dict[tuple, int] = {}
    current: tuple = ()
    depth = 0  # open brackets of a multi-line array
    in_string = False
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw
        if in_string:
            if '"""' in line or "'''" in line:
                in_string = False
            continue
        if depth > 0:
            depth += _bracket_balance(line)
            continue
        header = _HEADER.match(line)
        if header and not _KEY.match(line):
            parts = _split_key(header.group(2))
            path = _with_indices(parts, counts)
            if header.group(1) == "[[":
                counts[parts] = counts.get(parts, -1) + 1
                path = _with_indices(parts, counts)
            current = path
            lines.setdefault(path, number)
            continue
        key = _KEY.match(line)
        if not key:
            continue
        path = current + _split_key(key.group(1))
        lines.setdefault(path, number)
        value = line[key.end():]
        for inner in _INLINE_KEY.finditer(value):
            lines.setdefault(path + _split_key(inner.group(1)), number)
        if value.count('"""') == 1 or value.count("'''") == 1:
            in_string = True
        depth = max(0, _bracket_balance(value))
    return lines


def _with_indices(parts: tuple[str, ...], counts: dict[tuple, int]) -> tuple:
    """Insert the current index after each prefix that names an array of tables."""
    path: list = []
    for i in range(len(parts)):
        path.append(parts[i])
        prefix = parts[: i + 1]
        if prefix in counts:
            path.append(counts[prefix])
    return tuple(path)


def _bracket_balance(text: str) -> int:
    text = re.sub(r'"(?:[^"\\]|\\.)*"|\'[^\']*\'', "", text)
    text = text.split("#", 1)[0]
    return text.count("[") - text.count("]")
