"""The campaign file's schema: every table and key, declared as frozen dataclasses.

Each table of a campaign file is one dataclass here and each of its keys one field: the
field's type is the key's TOML type, its default the value an absent key takes (none: the
key is required), and its metadata (:func:`demcal.campaign.reader.key`) the key's range
or choices, the sentence a refused value gets and what the key means.
:class:`~demcal.campaign.reader.Reader` checks a table against its declaration;
:mod:`demcal.campaign.config` reads the file table by table and checks what depends on
the virtual test, the lab file, other campaigns or several tables at once. Where what a
campaign keeps is the table itself (:class:`Response`, :class:`Target`,
:class:`CalibrationConfig`, :class:`ExecutorConfig`) the declaration is that dataclass;
the others a campaign is made of (:class:`Factor`, :class:`Condition`, ...) are here too.

Layout (``examples/residual-film-soil/repose.toml`` is a full example)::

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
    [executor]      kind, workers, scheduler, start_method, heartbeat_timeout_s, backend, ensemble
    [report]        title, reference_table, captions = {KEY = "source", ...} (the published
                    tables each report table reproduces, e.g. ``factors = "paper Table 3"``:
                    only a campaign that reproduces a publication names one; see
                    :data:`CAPTION_KEYS`)

The declarations are standard-library dataclasses with field metadata, not a schema
library's models: demcal's dependencies (numpy, scipy, numba, pandas, scikit-image,
matplotlib, dask.distributed, scikit-learn, pyDOE3, tqdm, jinja2) hold none (no pydantic,
no attrs), and a frozen dataclass is what a campaign is made of anyway.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from demcal.campaign.plugins import plugin_problem
from demcal.campaign.reader import Names, Table, Text, key
from demcal.doe.factors import Factor as CodedFactor


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
    """``[[responses]]``: a measured response to fit."""

    name: str = key(doc="key in the experiment's ``responses``")
    label: Text = key("", fallback="name", doc="name shown in the report; default its name")
    unit: Text = key("", doc="unit shown in the report")


#: Units that make a response an angle (its lab targets lie in [0°, 90°)), besides a
#: name ending in ``_deg`` (``repose_angle_deg``, ``sliding_angle_deg``).
_DEGREES = ("°", "deg", "degree", "degrees")


def _is_angle(response: Response) -> bool:
    """Whether ``response`` is an angle, whose lab targets lie in [0°, 90°)."""
    return response.name.endswith("_deg") or response.unit.strip().lower() in _DEGREES


@dataclass(frozen=True)
class Target:
    """A lab measurement to reproduce: mean and standard deviation (``[conditions.targets]
    RESPONSE = {mean, sd}``, or ``RESPONSE = mean``)."""

    response: str = key(source="conditions.targets", doc="the response, the entry's key")
    mean: float = key(doc="the lab mean")
    sd: float | None = key(None, minimum=0, says="target sd of '{table}' must not be negative",
                           doc="the lab standard deviation")


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


# --------------------------------------------------------------------------- the tables


@dataclass(frozen=True, kw_only=True)
class CampaignTable:
    """``[campaign]``: what the campaign is called and where its inputs and results lie."""

    name: str = key(doc="the campaign's name; it names the result store")
    description: Text = key("", doc="free text, shown in the report")
    workdir: Path | None = key(None, doc="folder of the results; default `<name>-runs` next to the file")
    lab: Path | None = key(None, what="lab file", doc="TOML file of lab records, one table per sample")
    from_campaign: Path | None = key(None, file="give the other campaign's file (TOML)",
                                     doc="campaign whose calibrated values every condition takes")


@dataclass(frozen=True, kw_only=True)
class ExperimentTable:
    """``[experiment]``: the virtual test, its profile, plugins and fixed settings."""

    test: str = key(doc="the virtual test (`demcal bench --list`)")
    profile: str | None = key(None, doc="the test's profile for the design runs; default `quick`")
    plugins: Names = key((), says="'{key}' must be a list of module names", check=plugin_problem,
                         doc="modules that register extra virtual tests")
    settings: Table = key({}, doc="setting overrides applied to every run")
    sieve: str | None = key(None, doc="a lab sample whose sieve table the particles follow: sets "
                            "particles.sizes = sieve, particles.sieve_mm and particles.sieve_percent "
                            "for every run")


@dataclass(frozen=True, kw_only=True)
class FactorTable:
    """``[[factors]]``: one varied setting with its low and high level."""

    name: str | None = key(None, pattern=r"[A-Za-z][A-Za-z0-9_]*",
                           says="factor name '{value}' must be a letter followed by letters, digits or _",
                           doc="the factor's letter in the model; default A, B, C, ...")
    parameter: str = key(doc="the experiment setting it drives, e.g. `particle.restitution`")
    low: float = key(doc="level -1")
    high: float = key(doc="level +1")
    label: Text = key("", fallback="parameter", doc="name shown in the report; default the parameter")
    unit: Text | None = key(None, doc="unit shown in the report; default the setting's")
    hard_low: float | None = key(None, doc="limit the calibration loop never moves the box below")
    hard_high: float | None = key(None, doc="limit the calibration loop never moves the box above")


@dataclass(frozen=True, kw_only=True)
class DesignTable:
    """``[design]``: the design kind and its options (checked by :mod:`demcal.doe.catalog`)."""

    type: str = key("box-behnken", doc="any spelling of demcal.doe.catalog.DESIGN_NAMES")
    center: int | None = key(None, minimum=0, doc="centre points; default the kind's")
    variant: object = key(None, doc="central-composite: circumscribed, inscribed or faced")
    alpha: object = key(None, doc="central-composite: axial distance")
    fraction: object = key(None, doc="central-composite: its factorial part's fraction")
    generators: object = key(None, doc="fractional factorial: the generators, e.g. D=ABC")
    levels: object = key(None, doc="full factorial: levels per factor")
    runs: object = key(None, doc="Latin hypercube and the like: number of runs")


@dataclass(frozen=True, kw_only=True)
class RunsTable:
    """``[runs]``: the design runs' seeds and replicates."""

    seed: int = key(1, minimum=0, doc="seed of the first design run")
    replicates: int = key(1, minimum=1, doc="seeds per design point")


@dataclass(frozen=True, kw_only=True)
class ModelTable:
    """``[model]``: the response-surface model."""

    order: str = key("quadratic", choices=("linear", "2fi", "quadratic", "cubic"), doc="model order")
    reduce_alpha: float | None = key(None, above=0, below=1, off=True,
                                     says="'{key}' must lie between 0 and 1 (e.g. 0.05) or be false, got {raw}",
                                     doc="drop terms above this p-value; false keeps the full model")


@dataclass(frozen=True, kw_only=True)
class ConditionTable:
    """``[[conditions]]``: one material state with its lab targets."""

    name: str = key(doc="the condition's name")
    label: Text = key("", fallback="name", doc="name shown in the report; default its name")
    sample: str | None = key(None, doc="a sample of the lab file, whose records give the targets")
    photo: Path | None = key(None, file="give an image file", doc="a measured heap photo")
    from_campaign: Path | None = key(None, file="give the other campaign's file (TOML)",
                                     doc="campaign whose calibrated values this condition takes")
    targets: Table = key({}, entries=Target, doc="response = {mean, sd}, or response = mean")
    settings: Table = key({}, doc="settings fixed for this condition's runs alone")
    reference: Table = key({}, doc="published calibrated values, parameter = value")


@dataclass(frozen=True, kw_only=True)
class HoldoutTable:
    """``[[holdout]]``: a test the calibration does not fit, run at each condition's
    calibrated values and compared with its lab value."""

    test: str = key(doc="the virtual test to predict (`demcal bench --list`)")
    response: str | None = key(None, doc="its response to compare; default the test's first")
    profile: str | None = key(None, doc="the profile it runs at; default the calibration's production profile")
    replicates: int | None = key(None, minimum=1, doc="runs at each condition's values; default [verification] "
                                                      "replicates")
    settings: Table = key({}, doc="the test's own settings; the material's come from the calibration")
    targets: Table = key({}, doc="condition = {mean, sd}: the lab value; default the condition's sample's")


@dataclass(frozen=True)
class Holdout:
    """A test predicted with the calibrated values (``[[holdout]]``), resolved."""

    test: str
    response: str
    profile: str | None
    replicates: int | None
    settings: Mapping[str, Any]
    targets: Mapping[str, Target]  #: condition name -> its lab value


@dataclass(frozen=True, kw_only=True)
class VerificationTable:
    """``[verification]``: the runs at each solved point."""

    replicates: int = key(3, minimum=0, doc="verification runs per condition")
    seed: int = key(100_000, minimum=0, doc="seed of the first verification run")


@dataclass(frozen=True, kw_only=True)
class CalibrationConfig:
    """``[calibration]`` and ``[budget]``: how ``demcal calibrate`` closes the loop
    (:mod:`demcal.campaign.loop`)."""

    production: str | None = key(None, doc="production profile (None: the campaign's profile)")
    replicates: int | None = key(None, minimum=1, doc="first production replicates (None: [verification] "
                                                      "replicates)")
    min_replicates: int = key(1, minimum=1, doc="fewest first replicates at a point once the pooled production "
                                                "noise says fewer than `replicates` give a 95 % interval "
                                                "narrower than the lab sd")
    max_replicates: int = key(10, minimum=2, doc="most production replicates at one point")
    iterations: int = key(4, minimum=1, doc="re-solves on the corrected surface per condition")
    box_moves: int = key(3, minimum=0, doc="most box moves per condition")
    box_replicates: int | None = key(None, minimum=1, doc="seeds per design point of a moved box (None: [runs] "
                                     "replicates); a moved box often lies near the edge of what the test "
                                     "reaches, where the factors' effects are small against the seed noise")
    path_points: int = key(3, minimum=1, doc="runs along the steepest path beyond the box, per move")
    path_replicates: int = key(1, minimum=1, doc="seeds per path point")
    verify_on_path: bool = key(True, doc="verify first where the path crosses the target (or at its step "
                                         "nearest it, inside the lab window), and lay the moved box's design "
                                         "only if that point misses")
    stored_noise: bool = key(True, doc="pool the stored profile studies' replicated production runs into the "
                                       "production noise from the start (demcal.campaign.noise.stored_noise)")
    replicate_batch: int = key(1, minimum=1, doc="production replicates are asked for in multiples of this "
                                                 "many runs (set it to the number of workers)")
    budget_runs: int | None = key(None, source="budget", doc="most runs the calibration uses (its design "
                                                             "included)")
    budget_cpu_hours: float | None = key(None, source="budget", doc="most run hours (sum of the runs' wall "
                                                                    "times)")


@dataclass(frozen=True, kw_only=True)
class BudgetTable:
    """``[budget]``: the most the calibration may spend."""

    runs: int | None = key(None, minimum=1, doc="most runs (CalibrationConfig.budget_runs)")
    cpu_hours: float | None = key(None, above=0, says="'{key}' must be positive, got {value:g}; give e.g. "
                                                      "cpu_hours = 2", doc="most run hours")


@dataclass(frozen=True, kw_only=True)
class ExecutorConfig:
    """``[executor]``: where and how the runs are executed."""

    kind: str = key("local", choices=("local", "dask"), doc="a local process pool or a Dask cluster")
    workers: int = key(0, minimum=0, doc="0 = one per CPU core")
    scheduler: str | None = key(None, doc="dask scheduler address, e.g. tcp://host:8786")
    start_method: str = key("spawn", choices=("spawn", "forkserver"), doc="how local workers start")
    heartbeat_timeout_s: float = key(120.0, above=0, says="'{key}' must be positive",
                                     doc="a run whose worker is silent this long is taken back [s]")
    backend: str = key("cpu", choices=("cpu", "cuda"), doc="the compute backend of every run "
                                                           "(demcal.dem.backend.BACKENDS)")
    ensemble: int = key(0, minimum=0, doc="with backend cuda: up to this many runs stepped together on "
                                          "the GPU as one ensemble (demcal.dem.cuda.ensemble); 0 = one run "
                                          "per worker process")


#: ``[report] captions`` keys: the report table (or text) each one's source is added to.
#: ``reference`` is what the conditions' ``[conditions.reference]`` values are called
#: (default "reference"), ``runs`` what the campaign's run count is compared with.
CAPTION_KEYS = ("targets", "sieve", "factors", "design", "calibrated", "verification", "images",
                "reference", "runs")


@dataclass(frozen=True, kw_only=True)
class ReportTable:
    """``[report]``: the report's title and the publication it reproduces, if any."""

    title: Text | None = key(None, doc="the report's title; default the campaign's name")
    reference_table: Path | None = key(None, file="give the CSV of a published design",
                                       doc="a published design table to re-analyse")
    captions: Table = key({}, keys=CAPTION_KEYS, unknown="unknown caption '{key}' in [report] captions; {hint}",
                          says="caption '{key}' must be a non-empty string, e.g. {key} = \"paper Table 3\"",
                          doc="KEY = the published source the report's table KEY reproduces")


@dataclass(frozen=True, kw_only=True)
class CampaignFile:
    """A campaign file's tables."""

    campaign: CampaignTable = key(doc="what the campaign is called and where it keeps its results")
    experiment: ExperimentTable = key(doc="the virtual test")
    factors: tuple[FactorTable, ...] = key(doc="the varied settings")
    design: DesignTable = key(None, doc="the design")
    responses: tuple[Response, ...] = key((), doc="the responses to fit; default the test's first")
    runs: RunsTable = key(None, doc="seeds and replicates")
    model: ModelTable = key(None, doc="the model")
    conditions: tuple[ConditionTable, ...] = key(doc="the material states and their lab targets")
    holdout: tuple[HoldoutTable, ...] = key((), doc="tests predicted, not fitted")
    verification: VerificationTable = key(None, doc="the verification runs")
    calibration: CalibrationConfig = key(None, doc="the closed calibration loop")
    budget: BudgetTable = key(None, doc="the calibration's budget")
    executor: ExecutorConfig = key(None, doc="where the runs execute")
    report: ReportTable = key(None, doc="the report")
