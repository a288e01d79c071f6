"""Reporters: observers of a run, OpenMM style.

``Simulation.run`` asks every reporter ``next_report(sim)`` (steps until it next wants
data), advances exactly that far, then calls ``report(sim)`` on the reporters that are
due. Optional ``start(sim, total_steps)`` and ``finish(sim)`` bracket a run. Reporters
read ``sim.snapshot()`` (one :class:`Snapshot` per step, shared by every reporter due
then: the state and what is derived from it, computed once) or ``sim.state``, and may
change the simulation (add particles, tilt gravity, move a wall). A reporter ends the
run by raising :class:`StopRun` (the run returns normally, its summary saying why) or
an error. Progress, energy, blow-up detection, the rest criterion, VTK output and
checkpoints are reporters, not code inside the physics; the bench tests run their
phases this way (:func:`demcal.bench.experiment.run_phase`). :class:`StatusLine` is the
one-line display that progress reporters write to: rewritten in place on a terminal,
plain lines in a log.
"""

from __future__ import annotations

import functools
import math
import os
import time as _time

import numpy as np

from demcal.errors import ConfigError, SimulationError


class StopRun(Exception):
    """Raised by a reporter's ``report`` to end the run after the step it reports on:
    :meth:`~demcal.dem.Simulation.run` finishes the reporters and returns its summary
    with ``stopped`` set to ``reason`` (an error ends a run with the error instead)."""

    def __init__(self, reason: str = "stopped by a reporter"):
        super().__init__(reason)
        self.reason = reason


class Snapshot:
    """The simulation at one step, shared by the reporters due then (``sim.snapshot()``).

    ``time``, ``step`` and ``state`` (:class:`~demcal.dem.storage.State`, user order)
    at once; ``kinetic_energy``, ``rms_speed`` and ``finite`` computed on
    first use and kept, so that reporters due at the same step (a rest criterion, a
    progress line, a blow-up check) compute them once. A reporter that changes the
    particles (adds, removes) makes the next ``sim.snapshot()`` a new one; one that
    writes into the arrays in place (a velocity) is seen by ``state`` at once and by the
    derived values from the next step's snapshot on. Outside a run every
    ``sim.snapshot()`` is a new one.
    """

    def __init__(self, sim):
        self._sim = sim
        self.time, self.step = sim.time, sim.step_count
        self.state = sim.state

    @functools.cached_property
    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy [J] of the free particles."""
        return self._sim.kinetic_energy()

    @functools.cached_property
    def rms_speed(self) -> float:
        """sqrt(2 KE / M) of the free particles [m/s] (KE includes rotation): the rest
        criterion of the bench tests."""
        st = self.state
        m = float(st.masses[~st.fixed].sum())
        return math.sqrt(2.0 * self.kinetic_energy / m) if m > 0 else 0.0

    @functools.cached_property
    def finite(self) -> bool:
        """Whether every position and velocity is a finite number."""
        st = self.state
        return bool(np.isfinite(st.positions).all() and np.isfinite(st.velocities).all())


class Reporter:
    """Base class: report every ``interval`` steps (counted from the start of each run)."""

    def __init__(self, interval: int):
        if not (isinstance(interval, (int, np.integer)) and interval >= 1):
            raise ConfigError(f"reporter interval must be a positive number of steps, "
                              f"got {interval!r}.")
        self.interval = int(interval)
        self._origin = 0

    def start(self, sim, total_steps):
        self._origin = sim.step_count

    def next_report(self, sim) -> int:
        return self.interval - (sim.step_count - self._origin) % self.interval

    def report(self, sim):  # pragma: no cover - abstract
        raise NotImplementedError

    def finish(self, sim):
        pass


class Callback(Reporter):
    """Call ``function(sim)`` every ``interval`` steps (e.g. an inserter at a rate)."""

    def __init__(self, interval, function):
        super().__init__(interval)
        self.function = function

    def report(self, sim):
        self.function(sim)


class EnergyReporter(Reporter):
    """Record (time [s], kinetic energy [J], number of particles) every ``interval`` steps.

    ``self.times``, ``self.energies`` and ``self.counts`` are lists; ``as_array()`` stacks
    them.
    """

    def __init__(self, interval):
        super().__init__(interval)
        self.times, self.energies, self.counts = [], [], []

    def report(self, sim):
        self.times.append(sim.time)
        self.energies.append(sim.kinetic_energy())
        self.counts.append(sim.n_particles)

    def as_array(self):
        return np.column_stack([self.times, self.energies, self.counts])


class BlowUpDetector(Reporter):
    """Stop with a :class:`SimulationError` on NaN/inf or unphysical speeds.

    A run "blows up" when a position or velocity is not finite, or when a particle moves
    faster than ``max_speed`` [m/s] (default 100 m/s; far above any bench test), which
    is the signature of a time step too large for the contact stiffness. ``what`` names
    the simulation and ``fix`` the remedy in the message (a bench test names its own
    setting).
    """

    def __init__(self, interval=100, max_speed=100.0, what="simulation", fix="reduce dt (or dt_fraction)"):
        super().__init__(interval)
        self.max_speed = float(max_speed)
        self.what, self.fix = what, fix

    def report(self, sim):
        snap = sim.snapshot()
        if snap.state.n == 0:
            return
        v = snap.state.velocities
        vmax = float(np.sqrt((v ** 2).sum(axis=1)).max()) if snap.finite else math.inf
        if not snap.finite or vmax > self.max_speed:
            raise SimulationError(
                f"the {self.what} blew up at t = {sim.time:.6g} s (step {sim.step_count}, "
                f"max speed {vmax:.3g} m/s): time step {sim.dt:.3g} s too large for these "
                f"stiffnesses; {self.fix}.")


class RestDetector(Reporter):
    """End the run (:class:`StopRun`, reason ``"at rest"``) once the particles are at
    rest: the snapshot's rms speed below ``limit`` [m/s] at ``checks`` reports in a row,
    every ``interval`` steps. ``ready(sim)``, if given, is asked first: None means "not
    yet" (the count is left as it is), False counts as a miss, True lets the speed
    decide (e.g. "no particle still in the hopper"). A test with more to check than that
    calls :meth:`at_rest` from its own reporter instead (the funnel). :attr:`hits`
    carries over between runs; a new phase takes a new detector."""

    def __init__(self, interval, limit, checks=2, ready=None):
        super().__init__(interval)
        self.limit, self.checks, self.ready = float(limit), int(checks), ready
        self.hits = 0

    def at_rest(self, sim, extra_ok=True) -> bool:
        """Count one check (``extra_ok`` and the speed below the limit) and say whether
        ``checks`` in a row are reached."""
        self.hits = self.hits + 1 if (extra_ok and sim.snapshot().rms_speed < self.limit) else 0
        return self.hits >= self.checks

    def report(self, sim):
        ok = True if self.ready is None else self.ready(sim)
        if ok is not None and self.at_rest(sim, ok):
            raise StopRun("at rest")


class TimeLimit(Reporter):
    """End the run (:class:`StopRun`, reason ``"time limit"``) at the first report at or
    after ``max_time`` [s] of simulated time, every ``interval`` steps."""

    def __init__(self, interval, max_time):
        super().__init__(interval)
        self.max_time = float(max_time)

    def report(self, sim):
        if sim.time >= self.max_time:
            raise StopRun("time limit")


class _LogLines:
    """A file for tqdm when the output is not a terminal (a batch job's log): each
    update goes on a line of its own instead of being overwritten with ``\\r``."""

    def __init__(self, file):
        self._file = file
        self._open = False  # the current line has text and no newline yet

    def write(self, text):
        for i, chunk in enumerate(text.split("\r")):
            if i and self._open:
                self._file.write("\n")
                self._open = False
            chunk = chunk.rstrip(" ")  # tqdm's padding over a longer previous status
            if chunk:
                self._file.write(chunk)
                self._open = not chunk.endswith("\n")

    def flush(self):
        getattr(self._file, "flush", lambda: None)()

    def __getattr__(self, name):  # encoding, isatty, ... of the real file
        return getattr(self._file, name)


def _is_terminal(file) -> bool:
    try:
        return bool(file.isatty())
    except (AttributeError, ValueError, OSError):
        return False


class StatusLine:
    """One line of status that follows a run, with permanent messages above it.

    On a terminal the status is rewritten in place (a carriage return, the text cut to
    the terminal's width, then "erase to the end of the line") at most every
    ``refresh`` seconds. Anywhere else (a log file, a pipe, a batch job) each status is
    a plain line of its own, at most one every ``log_interval`` seconds and the first
    after ``log_interval`` seconds, so a log gets no carriage returns and a short run
    no status at all. :meth:`message` prints a line that stays (above the status on a
    terminal).

    Parameters
    ----------
    file : text file, optional
        Where to write (default ``sys.stderr`` at construction).
    log_interval : float
        Seconds between two status lines when ``file`` is not a terminal.
    refresh : float
        Seconds between two redraws on a terminal.
    clock : callable
        Wall clock [s] (tests pass their own).
    """

    def __init__(self, file=None, log_interval=10.0, refresh=0.2, clock=_time.perf_counter):
        import sys

        self.file = sys.stderr if file is None else file
        self.terminal = _is_terminal(self.file)
        self.log_interval = float(log_interval)
        self.refresh = float(refresh)
        self.clock = clock
        self._last = -math.inf if self.terminal else clock()
        self._text = ""
        self._shown = False  # a status is on the terminal's last line

    def due(self) -> bool:
        """Whether :meth:`update` would write now (build costly text only then)."""
        wait = self.refresh if self.terminal else self.log_interval
        return self.clock() - self._last >= wait

    def update(self, text: str) -> None:
        """Show ``text`` as the status, if it is time to (:meth:`due`)."""
        self._text = text
        if not self.due():
            return
        self._last = self.clock()
        if self.terminal:
            self._write("\r" + self._fit(text) + "\x1b[K")
            self._shown = True
        else:
            self._write(text + "\n")

    def message(self, text: str) -> None:
        """Print ``text`` on a line of its own (the status, if shown, is drawn again below it)."""
        if self.terminal and self._shown:
            self._write("\r\x1b[K" + text + "\n" + self._fit(self._text) + "\x1b[K")
        else:
            self._write(text + "\n")

    def close(self) -> None:
        """Erase the status from the terminal (a log keeps its lines)."""
        if self.terminal and self._shown:
            self._write("\r\x1b[K")
            self._shown = False

    def _fit(self, text: str) -> str:
        import shutil

        width = shutil.get_terminal_size((100, 24)).columns - 1
        return text if len(text) <= width else text[:max(0, width - 3)] + "..."

    def _write(self, text: str) -> None:
        try:
            self.file.write(text)
            self.file.flush()
        except (OSError, ValueError):  # the reader went away: progress is not worth dying for
            pass


class ProgressReporter(Reporter):
    """tqdm progress bar with simulated time, ETA and particle-steps per second.

    It writes to ``file`` (default ``sys.stderr``) whether or not that is a terminal:
    in a batch job or a log it prints one plain line per update, at most every
    ``log_interval`` seconds (and the final state when the run ends). ``disable=True``
    turns it off; ``disable=None`` is tqdm's rule (off when not a terminal).
    """

    def __init__(self, interval=200, description="DEM", file=None, disable=False,
                 log_interval=10.0):
        super().__init__(interval)
        if not (isinstance(log_interval, (int, float)) and not isinstance(log_interval, bool)
                and math.isfinite(log_interval) and log_interval >= 0):
            raise ConfigError(f"ProgressReporter log_interval must be a number of seconds >= 0, "
                              f"got {log_interval!r}.")
        self.description = description
        self.file = file
        self.disable = disable
        self.log_interval = float(log_interval)
        self._bar = None

    def start(self, sim, total_steps):
        super().start(sim, total_steps)
        import sys

        from tqdm.auto import tqdm
        file = sys.stderr if self.file is None else self.file
        options = {}
        if not _is_terminal(file):
            file = _LogLines(file)
            options = dict(mininterval=self.log_interval, ascii=True)
        self._bar = tqdm(total=total_steps, desc=self.description, unit="step",
                         file=file, disable=self.disable, dynamic_ncols=True, **options)
        self._t0 = _time.perf_counter()
        self._last = sim.step_count
        self._psteps = 0.0

    def _advance(self, sim):
        """Count the steps since the last call and set the postfix to ``sim``'s state
        (without drawing: the following update draws, throttled by tqdm)."""
        now = _time.perf_counter()
        n = sim.step_count - self._last
        self._psteps += n * sim.n_particles
        self._last = sim.step_count
        rate = self._psteps / max(now - self._t0, 1e-9)
        self._bar.set_postfix_str(f"t={sim.time:.4g} s, {rate:.3g} particle-steps/s",
                                  refresh=False)
        return n

    def report(self, sim):
        self._bar.update(self._advance(sim))

    def finish(self, sim):
        if self._bar is not None:
            # the last report may be steps behind the end: show the final time
            self._bar.update(self._advance(sim))
            self._bar.close()
            self._bar = None


class CheckpointReporter(Reporter):
    """Write ``sim.save_checkpoint(path)`` every ``interval`` steps (atomic replace)."""

    def __init__(self, path, interval):
        super().__init__(interval)
        self.path = os.fspath(path)

    def report(self, sim):
        sim.save_checkpoint(self.path)


class VTKReporter(Reporter):
    """Write spheres (and walls) as VTK PolyData frames plus a ``.pvd`` (ParaView).

    Uses :meth:`demcal.io.vtk.VtkSeries.write_state`. Each particle frame has the sphere
    centres with the point data of :data:`demcal.io.vtk.STATE_FIELDS`: ``radius``,
    ``id``, ``body_id``, ``velocity``, ``angular_velocity``, ``orientation``
    (quaternion), ``force`` and ``material``.
    """

    def __init__(self, directory, interval, name="particles", walls=True):
        super().__init__(interval)
        self.directory = os.fspath(directory)
        self.name = name
        self.walls = walls
        self._series = None

    def report(self, sim):
        from demcal.io.vtk import VtkSeries
        if self._series is None:
            os.makedirs(self.directory, exist_ok=True)
            self._series = VtkSeries(self.directory, name=self.name)
        self._series.write_state(sim.time, sim.state, walls=sim.walls if self.walls else None)

    @property
    def pvd_path(self):
        return None if self._series is None else self._series.pvd_path
