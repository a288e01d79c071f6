"""The shape of a bench test: build a simulation, run its phases, measure.

A test is a :class:`BenchExperiment`: a settings table per profile (``_settings``),
:meth:`~BenchExperiment.build` (resolved settings and a seed -> a :class:`Setup`: the
simulation, the :class:`Phase` s it runs and the :class:`~demcal.bench.common.Watch` over
them) and :meth:`~BenchExperiment.measure` (the setup after its last phase -> the
responses). :meth:`~BenchExperiment.run` is the same for every test: resolve the
settings, build, run each phase on the engine's run control (:func:`run_phase`: one
``sim.run`` whose reporters are the phase's own, the watch's and, while ``demcal bench``
shows progress, the status line), check the end state for a blow-up, measure.

A phase ends one of three ways: its ``end`` (a condition asked every ``chunk`` seconds,
or an engine reporter that ends the run with :class:`~demcal.dem.reporters.StopRun`),
its ``max_time`` (simulated), or a fixed ``duration``. A phase that must end by its
``end`` names its ``failure``: the one sentence a user reads when it does not.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from demcal.bench import common as C
from demcal.bench.registry import RunResult, Setting, resolve_settings
from demcal.dem.reporters import Reporter, StopRun, TimeLimit
from demcal.errors import ConfigError, SimulationError


@dataclass
class Phase:
    """One stretch of a bench test on the engine's run control.

    end : a callable (true: the phase is over) asked every ``chunk`` seconds, after
        ``each`` and the watch; or an engine reporter that ends the run with
        :class:`StopRun` (a rest criterion, a tilt), at its own pace when ``chunk`` is
        None. None with ``duration``.
    max_time : the simulated time [s] the phase gives up at (None: no limit; asked
        every ``chunk``, or at the end reporter's pace).
    chunk : seconds between looks; None: the ``end`` reporter's own interval.
    each : called every ``chunk`` before the end is asked (insertion, a progress line).
    start : called just before the phase runs (move a wall, say what happens next).
    reporters : more engine reporters, ahead of the watch's (a rigid container).
    duration : run exactly this long [s] instead (``sim.run(duration=...)``, with the
        progress display only: no end, reporters or watch).
    ok : the :class:`StopRun` reasons that mean the phase did its job.
    failure : the error (a sentence, or a callable giving it) when the phase ends any
        other way; None: carry on.
    """

    end: Any = None
    max_time: float | None = None
    chunk: float | None = 0.02
    each: Callable[[], None] | None = None
    start: Callable[[], None] | None = None
    reporters: Sequence[Any] = ()
    duration: float | None = None
    ok: tuple[str, ...] = ("done", "at rest")
    failure: str | Callable[[], str] | None = None


@dataclass
class Setup:
    """What :meth:`BenchExperiment.build` makes: the simulation, its phases in order, the
    watch over them, and whatever the measurement needs (``info``)."""

    sim: Any
    phases: list[Phase]
    watch: C.Watch | None = None
    info: dict[str, Any] = field(default_factory=dict)


class _Look(Reporter):
    """A chunked phase's own reporter: every ``interval`` steps the progress display and
    ``each()``, then ``stop()`` (true: ``StopRun("done")``)."""

    def __init__(self, interval, each=None, stop=None, progress: bool = False):
        super().__init__(interval)
        self.each, self.stop, self.progress = each, stop, progress

    def report(self, sim):
        if self.progress:
            C.show(sim)
        if self.each is not None:
            self.each()
        if self.stop is not None and self.stop():
            raise StopRun("done")


def run_phase(setup: Setup, phase: Phase) -> str | None:
    """Run one phase of ``setup``; returns why it ended (the :class:`StopRun` reason,
    None when it ran out of time). Raises :class:`SimulationError` with the phase's
    ``failure`` when it did not end by one of its ``ok`` reasons."""
    sim, watch = setup.sim, setup.watch
    if phase.start is not None:
        phase.start()
    progress = C.current_progress()
    shown = [progress.reporter] if progress is not None and progress.enabled else []
    watching = list(watch.reporters) if watch is not None else []
    if phase.duration is not None:
        stopped = sim.run(duration=phase.duration, reporters=shown).stopped
        return stopped
    if phase.max_time is not None and sim.time >= phase.max_time:
        stopped = None
    else:
        if phase.chunk is None:  # the end reporter keeps its own pace
            steps, ahead, end = phase.end.interval, [], phase.end
        else:
            steps = max(1, int(round(phase.chunk / sim.dt)))
            # progress and each() first, all due every `steps`
            ahead = [_Look(steps, each=phase.each, progress=True)]
            if hasattr(phase.end, "next_report"):  # an engine reporter: it looks at the phase's pace
                phase.end.interval = steps
                end = phase.end
            else:
                end = _Look(steps, stop=phase.end)
        if watch is not None:
            watch.blowup.interval = steps
        # in this order: progress and each(), the phase's reporters, the watch, the end, the limit
        ordered = [*ahead, *phase.reporters, *watching, end]
        limit = contextlib.nullcontext()
        if phase.max_time is not None:
            ordered.append(TimeLimit(steps, phase.max_time))
            if progress is not None:
                limit = progress.time_limit(phase.max_time)
        with limit:
            stopped = sim.run(steps=1 << 62, reporters=[*ordered, *shown]).stopped
    if stopped not in phase.ok and phase.failure is not None:
        raise SimulationError(phase.failure() if callable(phase.failure) else phase.failure)
    return stopped


class BenchExperiment:
    """Base of the built-in virtual tests: a settings table per profile, a build, phases
    and a measurement (module docstring).

    Subclasses set ``name``, ``description``, ``responses`` and implement
    :meth:`_settings` (the table for a profile), :meth:`build` and :meth:`measure`
    (a dict with ``responses`` and optionally ``spread``, ``particles``,
    ``artifacts``; ``steps`` and ``simulated_s`` are the simulation's own).
    """

    name = ""
    description = ""
    responses: tuple[str, ...] = ()
    profiles: tuple[str, ...] = C.PROFILES

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        if profile not in self.profiles:
            raise ConfigError(f"unknown profile '{profile}' for {self.name}; choose one of: "
                              f"{', '.join(self.profiles)}.")
        return C.table(self._settings(profile))

    def _settings(self, profile: str) -> list[Setting]:  # pragma: no cover - abstract
        raise NotImplementedError

    def resolve(self, settings: Mapping[str, Any] | None, profile: str) -> dict[str, Any]:
        return resolve_settings(self, settings, profile)

    def check(self, s: Mapping[str, Any]) -> None:
        """Refuse resolved settings ``s`` that cannot run, in one sentence, before any
        simulation is built (a campaign calls it when it loads); the base checks the
        particle sizes, a test its geometry too."""
        if "particles.sizes" in s:
            C.sizes_for(s)

    def build(self, s: Mapping[str, Any], seed: int, out_dir, vtk: bool, progress) -> Setup:
        """The simulation and its phases for resolved settings ``s`` and ``seed``."""
        raise NotImplementedError  # pragma: no cover - abstract

    def measure(self, setup: Setup, s: Mapping[str, Any], out_dir, progress) -> dict:
        """The responses of ``setup`` after its last phase."""
        raise NotImplementedError  # pragma: no cover - abstract

    def run(self, settings: Mapping[str, Any] | None = None, seed: int = 0, profile: str = "quick",
            out_dir: str | Path | None = None, vtk: bool = False, progress: bool = False) -> RunResult:
        """Simulate and measure; artifacts (PNG, VTK) go to ``out_dir`` if given."""
        from demcal._checks import check_seed

        s = self.resolve(settings, profile)
        seed = check_seed(seed, "seed")
        if out_dir is not None:
            Path(out_dir).mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        with C.showing(C.Progress(bool(progress), rest_speed=s.get("time.rest_speed"))) as shown:
            setup = self.build(s, int(seed), out_dir, bool(vtk), shown)
            try:
                for phase in setup.phases:
                    run_phase(setup, phase)
                if setup.watch is not None:
                    setup.watch.check()
            finally:  # the last frame also when a phase failed: to look at what went wrong
                if setup.watch is not None:
                    setup.watch.last_frame()
            out = self.measure(setup, s, out_dir, shown)
        sim = setup.sim
        return RunResult(test=self.name, responses=out["responses"], spread=out.get("spread", {}),
                         particles=int(out.get("particles", sim.n_particles)), steps=int(sim.step_count),
                         simulated_s=float(sim.time), wall_s=time.perf_counter() - start,
                         artifacts=out.get("artifacts", {}))
