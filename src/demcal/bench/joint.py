"""Several bench tests as one: a joint experiment whose run runs each part.

One angle cannot pin several contact parameters; tests that respond differently can
(Rößler & Katterfeld 2019; Coetzee 2017). A campaign names them together as
``test = "repose-funnel+drum"``: :func:`joint_experiment` builds a
:class:`JointExperiment` from the registered tests, and the rest of demcal (design,
store, one fitted model per response, the solve over every target, verification) sees one
experiment whose run returns the responses of all its parts.

Settings. A material key (:data:`SHARED_PREFIXES`, :data:`SHARED_KEYS`: the particle and
wall materials, the contact and rolling models, the particles' shape and sizes) is shared:
one value for every part, so a factor on it moves every test at once; a part's default
is the first part's that has the key. Every other key is the part's own, written
``PART:key`` (``drum:drum.rpm``, ``repose-funnel:particles.count``). A test named twice
(a drum at two speeds) has parts ``drum`` and ``drum#2``; the second's responses are
``dynamic_angle_deg_2``.

A run runs the parts one after the other with the same seed, each in its own
sub-folder of ``out_dir``; its responses are the parts' (renamed where a test repeats),
its particles, steps, simulated and wall times the sums.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from demcal.bench.registry import RunResult, Setting, get_experiment, register_builder, resolve_settings
from demcal.errors import ConfigError

#: Settings that describe the material, not the bench: shared by every part.
SHARED_PREFIXES = ("particle.", "wall.", "film.", "contact.", "rolling.")
SHARED_KEYS = frozenset({"particles.shape", "particles.centre_distance", "particles.clump_mm",
                         "particles.scale_min", "particles.scale_max", "particles.sizes",
                         "particles.sieve_mm", "particles.sieve_percent", "particles.coarse_grain",
                         "particles.size_min_mm", "particles.size_max_mm"})
#: Joins the parts' names in a joint test's name.
JOIN = "+"


def is_shared(key: str) -> bool:
    """Whether ``key`` is a material setting every part shares."""
    return key.startswith(SHARED_PREFIXES) or key in SHARED_KEYS


def part_names(tests: list[str]) -> list[str]:
    """The parts' names: each test's name, ``NAME#k`` for its k-th repeat."""
    seen: dict[str, int] = {}
    names = []
    for test in tests:
        seen[test] = seen.get(test, 0) + 1
        names.append(test if seen[test] == 1 else f"{test}#{seen[test]}")
    return names


def renamed(response: str, part: str) -> str:
    """A part's response as the joint test names it: ``_k`` added for a repeat ``#k``."""
    return response if "#" not in part else f"{response}_{part.rsplit('#', 1)[1]}"


class JointExperiment:
    """Several registered tests run as one (module docstring)."""

    def __init__(self, parts: list):
        if len(parts) < 2:
            raise ConfigError("a joint test needs at least two tests, e.g. test = \"repose-funnel+drum\".")
        self.parts = list(parts)
        self.part_names = part_names([p.name for p in parts])
        self.name = JOIN.join(p.name for p in parts)
        self.description = "joint test: " + "; ".join(f"{n}: {p.description}" for n, p in
                                                       zip(self.part_names, parts))
        self.responses = tuple(renamed(r, n) for n, p in zip(self.part_names, parts) for r in p.responses)
        if len(set(self.responses)) != len(self.responses):
            raise ConfigError(f"the tests of '{self.name}' measure a response twice; name each test once "
                              "or repeat one test (its second responses end in _2).")
        profiles = [p for p in parts[0].profiles if all(p in q.profiles for q in parts[1:])]
        if not profiles:
            raise ConfigError(f"the tests of '{self.name}' share no profile; each has its own "
                              f"({'; '.join(f'{p.name}: ' + ', '.join(p.profiles) for p in parts)}).")
        self.profiles = tuple(profiles)

    def part_of(self, response: str) -> str:
        """The part that measures ``response``."""
        for name, part in zip(self.part_names, self.parts):
            if any(renamed(r, name) == response for r in part.responses):
                return name
        raise KeyError(response)

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        """Shared material keys (the first part's default) and every part's own keys as
        ``PART:key``."""
        out: dict[str, Setting] = {}
        for name, part in zip(self.part_names, self.parts):
            for key, spec in part.settings(profile).items():
                if is_shared(key):
                    out.setdefault(key, spec)
                else:
                    out[f"{name}:{key}"] = Setting(f"{name}:{key}", spec.default, spec.unit,
                                                   f"{name}: {spec.help}", spec.low, spec.high, spec.choices,
                                                   getattr(spec, "listed", False), getattr(spec, "inert", False))
        return out

    def split(self, s: Mapping[str, Any]) -> list[dict[str, Any]]:
        """Each part's own settings from the joint ones ``s``."""
        out = []
        for name, part in zip(self.part_names, self.parts):
            mine = {}
            for key, value in s.items():
                if is_shared(key):
                    if key in part_keys(part):
                        mine[key] = value
                elif key.startswith(f"{name}:"):
                    mine[key[len(name) + 1:]] = value
            out.append(mine)
        return out

    def check(self, s: Mapping[str, Any]) -> None:
        """Each part's own check of its settings."""
        for part, mine in zip(self.parts, self.split(s)):
            check = getattr(part, "check", None)
            if check is not None:  # ``mine`` holds every key: the profile only names defaults
                check(resolve_settings(part, mine, self.profiles[0]))

    def run(self, settings: Mapping[str, Any] | None = None, seed: int = 0, profile: str = "quick",
            out_dir: str | Path | None = None, vtk: bool = False, progress: bool = False) -> RunResult:
        s = resolve_settings(self, settings, profile)
        responses, spread, artifacts = {}, {}, {}
        particles = steps = 0
        simulated = wall = 0.0
        for name, part, mine in zip(self.part_names, self.parts, self.split(s)):
            sub = None if out_dir is None else Path(out_dir, name.replace("#", "-"))
            result = part.run(mine, seed=seed, profile=profile, out_dir=sub, vtk=vtk, progress=progress)
            for key, value in result.responses.items():
                responses[renamed(key, name) if key in part.responses else f"{name}:{key}"] = value
            for key, value in result.spread.items():
                spread[renamed(key, name) if key in part.responses else f"{name}:{key}"] = value
            artifacts.update({f"{name}:{key}": path for key, path in result.artifacts.items()})
            particles += result.particles
            steps += result.steps
            simulated += result.simulated_s
            wall += result.wall_s
        return RunResult(test=self.name, responses=responses, spread=spread, particles=particles, steps=steps,
                         simulated_s=simulated, wall_s=wall, artifacts=artifacts)


def part_keys(part) -> frozenset[str]:
    """The setting keys of ``part`` (at its first profile: the keys do not change with it)."""
    return frozenset(part.settings(part.profiles[0]))


def joint_experiment(name: str, get) -> JointExperiment:
    """The joint test ``name`` (tests joined by ``+``), its parts found with ``get``."""
    tests = [t.strip() for t in name.split(JOIN)]
    if any(not t for t in tests):
        raise ConfigError(f"joint test '{name}' has an empty part; join test names with '+', e.g. "
                          "repose-funnel+drum.")
    return JointExperiment([get(t) for t in tests])


def _build(name: str) -> JointExperiment | None:
    """A joint test for a ``+``-joined ``name`` (:func:`demcal.bench.registry.get_experiment`
    asks); None for any other name."""
    return joint_experiment(name, get_experiment) if JOIN in str(name) else None


register_builder(_build)
