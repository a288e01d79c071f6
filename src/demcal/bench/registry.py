"""Registry of virtual bench tests.

A virtual experiment is a pure function of (settings, seed): it builds a simulation
from its settings, runs it and measures it. The campaign runner maps
:meth:`Experiment.run` over design points, so everything it needs travels in its
arguments and its result is plain data.

Settings are one flat namespace of dotted keys with SI units, e.g.
``particle.restitution`` [-], ``particle.static_friction`` [-],
``particle.rolling_friction`` [-], ``particle.damping_factor`` [-],
``film.static_friction`` [-], ``geometry.scale`` [-], ``particles.count`` [-].
The same keys are the ``--set KEY=VALUE`` options of ``demcal bench`` and the
parameter paths of a campaign's factors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Protocol

from demcal.errors import ConfigError


@dataclass(frozen=True)
class Setting:
    """One overridable setting of a virtual experiment."""

    key: str
    default: float | int | str
    unit: str = "-"
    help: str = ""
    low: float | None = None  #: smallest allowed value (inclusive), if any
    high: float | None = None  #: largest allowed value (inclusive), if any
    choices: tuple[str, ...] = ()  #: allowed values of a text setting, if restricted
    #: a list of numbers (a sieve table, a clump's spheres): given as a list or as text,
    #: kept as canonical text ``"0.0, 0.5, inf"`` (:func:`number_list`); ``""`` is none
    listed: bool = False
    #: at its default the run is what it was before the setting existed (an option left
    #: off): the campaign hash (:mod:`demcal.campaign.digest`) leaves it out then, so that a
    #: new option does not make existing calibrations out of date
    inert: bool = False


@dataclass(frozen=True)
class RunResult:
    """What one virtual experiment returns: responses and run statistics."""

    test: str
    responses: dict[str, float]
    spread: dict[str, float] = field(default_factory=dict)
    particles: int = 0
    steps: int = 0
    simulated_s: float = 0.0
    wall_s: float = 0.0
    artifacts: dict[str, str] = field(default_factory=dict)  #: name -> file path

    @property
    def particle_steps_per_s(self) -> float:
        return self.particles * self.steps / self.wall_s if self.wall_s > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "test": self.test,
            "responses": dict(self.responses),
            "spread": dict(self.spread),
            "particles": self.particles,
            "steps": self.steps,
            "simulated_s": self.simulated_s,
            "wall_s": self.wall_s,
            "particle_steps_per_s": self.particle_steps_per_s,
            "artifacts": dict(self.artifacts),
        }


class Experiment(Protocol):
    """A virtual bench test."""

    name: str
    description: str
    responses: tuple[str, ...]
    profiles: tuple[str, ...]

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        """Every overridable setting with its default under ``profile``."""

    def run(
        self,
        settings: Mapping[str, Any] | None = None,
        seed: int = 0,
        profile: str = "quick",
        out_dir: str | Path | None = None,
        vtk: bool = False,
        progress: bool = False,
    ) -> RunResult:
        """Simulate and measure; artifacts (PNG, VTK) go to ``out_dir`` if given."""


_REGISTRY: dict[str, Experiment] = {}


def register(experiment: Experiment) -> Experiment:
    _REGISTRY[experiment.name] = experiment
    return experiment


def names() -> list[str]:
    _load_builtin()
    return sorted(_REGISTRY)


#: Functions that build a test from a name no module registered, each returning None for
#: a name that is not theirs (:mod:`demcal.bench.joint` builds ``+``-joined names).
_BUILDERS: list = []
#: Tests a builder made, kept apart from the registered ones so that :func:`names` lists
#: the same tests whatever joint names this process has asked for.
_BUILT: dict[str, Experiment] = {}


def register_builder(build) -> None:
    """Add ``build(name) -> Experiment | None`` to the builders :func:`get_experiment`
    asks for a name no module registered."""
    _BUILDERS.append(build)


def get_experiment(name: str) -> Experiment:
    """The registered test ``name``, or the one a builder makes of it (the joint test of
    registered tests joined by ``+``: :mod:`demcal.bench.joint`)."""
    _load_builtin()
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name not in _BUILT:
        for build in _BUILDERS:
            made = build(name)
            if made is not None:
                _BUILT[name] = made
                break
    try:
        return _BUILT[name]
    except KeyError:
        known = ", ".join(sorted(_REGISTRY)) or "none"
        raise ConfigError(f"unknown virtual test '{name}'; choose one of: {known}.") from None


#: Settings whose values must keep an order wherever a test has both: (lower key, upper
#: key, whether the two may be equal). :func:`resolve_settings` checks them once every
#: value is known, so that a run is refused before it starts, not when it measures.
ORDERED_SETTINGS: tuple[tuple[str, str, bool], ...] = (
    ("measure.band_low", "measure.band_high", False),  # the flank band, fractions of the heap height
    ("particles.scale_min", "particles.scale_max", True),  # the size factors' uniform distribution
    ("geometry.outlet_diameter", "geometry.funnel_diameter", False),  # the funnel's outlet and rim
)


def ordered_pairs(table: Mapping[str, Setting]) -> list[tuple[Setting, Setting, bool]]:
    """The pairs of :data:`ORDERED_SETTINGS` that the settings ``table`` holds."""
    return [(table[a], table[b], equal) for a, b, equal in ORDERED_SETTINGS if a in table and b in table]


def order_problem(low: Setting, high: Setting, may_equal: bool, a: float, b: float) -> str | None:
    """The sentence refusing ``low.key`` = ``a`` with ``high.key`` = ``b`` (a pair of
    :func:`ordered_pairs`), or None when they keep their order."""
    if a < b or (may_equal and a == b):
        return None
    relation, sign = ("at most", "<=") if may_equal else ("below", "<")
    return (f"setting '{low.key}' = {a:g} must be {relation} '{high.key}' = {b:g}; give {low.key}"
            f"{_allowed(low)} and {high.key}{_allowed(high)}, with {low.key} {sign} {high.key}.")


def resolve_settings(experiment: Experiment, overrides: Mapping[str, Any] | None,
                     profile: str = "quick", ordered: bool = True) -> dict[str, Any]:
    """Defaults of ``profile`` updated by ``overrides``, each key and range checked, and
    (with ``ordered``, for a whole run's settings) the pairs of :data:`ORDERED_SETTINGS`."""
    if profile not in experiment.profiles:
        raise ConfigError(
            f"unknown profile '{profile}' for {experiment.name}; choose one of: "
            f"{', '.join(experiment.profiles)}."
        )
    table = experiment.settings(profile)
    resolved = {key: s.default for key, s in table.items()}
    for key, value in (overrides or {}).items():
        if key not in table:
            raise ConfigError(
                f"unknown setting '{key}' for {experiment.name}; "
                f"`demcal bench {experiment.name} --help` lists them."
            )
        spec = table[key]
        if spec.listed:
            value = number_list(spec, value)
        elif isinstance(spec.default, (int, float)) and not isinstance(spec.default, bool):
            value = _number(spec, value)
        elif spec.choices and str(value) not in spec.choices:
            raise ConfigError(
                f"setting '{key}' = '{value}' is not one of: {', '.join(spec.choices)}."
            )
        resolved[key] = value
    for low, high, may_equal in ordered_pairs(table) if ordered else ():
        problem = order_problem(low, high, may_equal, float(resolved[low.key]), float(resolved[high.key]))
        if problem:
            raise ConfigError(problem)
    return resolved


def number_list(spec: Setting, value: Any) -> str:
    """A listed setting's ``value`` (a list of numbers, nested lists of them, or text of
    numbers split by commas or spaces) as canonical text: each number's ``repr``, joined by
    ``", "``; ``""`` for none. One sentence for anything that is not a finite number
    (``inf`` is allowed: a sieve's open top class)."""
    if isinstance(value, str):
        items = value.replace(",", " ").split()
    elif isinstance(value, (list, tuple)):
        items = list(_flatten(value))
    else:
        raise ConfigError(f"setting '{spec.key}' must be a list of numbers [{spec.unit}], got {value!r}.")
    numbers = []
    for item in items:
        try:
            if isinstance(item, bool):
                raise TypeError
            x = float(item)
        except (TypeError, ValueError, OverflowError):
            raise ConfigError(f"setting '{spec.key}' must be a list of numbers [{spec.unit}], got "
                              f"{item!r} in it.") from None
        if math.isnan(x) or x == -math.inf:
            raise ConfigError(f"setting '{spec.key}' holds {item!r}; give numbers (inf only for an "
                              "open top class).")
        numbers.append(x)
    return ", ".join(repr(x) for x in numbers)


def _flatten(value):
    for item in value:
        if isinstance(item, (list, tuple)):
            yield from _flatten(item)
        else:
            yield item


def listed_numbers(text: str) -> list[float]:
    """The numbers of a listed setting's canonical text (:func:`number_list`)."""
    return [float(x) for x in str(text).replace(",", " ").split()]


def _allowed(spec: Setting) -> str:
    """The allowed range of a numeric setting in words, e.g. ``from 1 to 64``."""
    unit = "" if spec.unit in ("", "-") else f" {spec.unit}"
    low, high = _plain(spec.low), _plain(spec.high)
    if spec.low is not None and spec.high is not None:
        return f" from {low} to {high}{unit}"
    if spec.low is not None:
        return f" of at least {low}{unit}"
    if spec.high is not None:
        return f" of at most {high}{unit}"
    return ""


def _plain(x: float | None) -> str:
    """A bound as written by a person: ``1000000``, ``0.01``, ``1e+11``."""
    if x is None:
        return ""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e7 else f"{x:g}"


def _number(spec: Setting, value: Any) -> float | int:
    """``value`` as the number type of ``spec``: finite, whole where the setting is an
    integer, inside the setting's range -- else one sentence naming key and range."""
    key = spec.key
    whole = isinstance(spec.default, int)
    kind = "whole number" if whole else "number"
    try:
        if isinstance(value, bool):
            raise TypeError
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(f"setting '{key}' must be a {kind}{_allowed(spec)}, got '{value}'.") from None
    if not math.isfinite(number):
        raise ConfigError(f"setting '{key}' must be a finite {kind}{_allowed(spec)}, got {value}.")
    if whole:
        if not number.is_integer():
            raise ConfigError(f"setting '{key}' must be a whole number{_allowed(spec)}, got {value}.")
        number = value if isinstance(value, int) else int(number)
    if spec.low is not None and number < spec.low or spec.high is not None and number > spec.high:
        raise ConfigError(f"setting '{key}' = {value} is outside its allowed range; "
                          f"give a {kind}{_allowed(spec)}.")
    return number


#: the entry-point group that lists bench-test modules (pyproject.toml)
ENTRY_POINT_GROUP = "demcal.benches"
_loaded = False


def _load_builtin() -> None:
    """Import every module of the ``demcal.benches`` entry-point group, demcal's own
    tests included (pyproject.toml), so that they register themselves; a campaign's
    ``plugins`` file registers the same way. One sentence if a module fails to load."""
    global _loaded
    if _loaded:
        return
    import importlib
    from importlib.metadata import entry_points

    found = entry_points(group=ENTRY_POINT_GROUP)
    if not any(ep.value.startswith("demcal.bench.") for ep in found):
        raise ConfigError("demcal's bench tests are not registered: its package metadata is "
                          "missing or stale; reinstall demcal (pip install -e . or make test).")
    for ep in found:
        try:
            importlib.import_module(ep.value)
        except Exception as exc:  # noqa: BLE001 -- a plug-in's failure in one sentence
            raise ConfigError(f"the bench-test module {ep.value!r} (entry point {ep.name!r} of "
                              f"{ep.dist.name if ep.dist else 'an installed package'}) failed to "
                              f"load: {exc}.") from None
    _loaded = True
