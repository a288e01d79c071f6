"""Reporters: observers of a run, OpenMM style.

``Simulation.run`` asks every reporter ``next_report(sim)`` (steps until it next wants
data), advances exactly that far, then calls ``report(sim)`` on the reporters that are
due. Optional ``start(sim, total_steps)`` and ``finish(sim)`` bracket a run. Reporters
read ``sim.state`` and may change the simulation (add particles, tilt gravity) or raise
to stop it. Progress, energy, blow-up detection, VTK output and checkpoints are
reporters, not code inside the physics. :class:`StatusLine` is the one-line display
that progress reporters write to: rewritten in place on a terminal, plain lines in a log.
"""

from __future__ import annotations

import math
import os
import time as _time

import numpy as np

from demcal.errors import ConfigError, SimulationError


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
    is the signature of a time step too large for the contact stiffness.
    """

    def __init__(self, interval=100, max_speed=100.0):
        super().__init__(interval)
        self.max_speed = float(max_speed)

    def report(self, sim):
        st = sim.state
        if st.n == 0:
            return
        finite = np.isfinite(st.positions).all() and np.isfinite(st.velocities).all()
        vmax = float(np.sqrt((st.velocities ** 2).sum(axis=1)).max()) if finite else math.inf
        if not finite or vmax > self.max_speed:
            raise SimulationError(
                f"the simulation blew up at t = {sim.time:.6g} s (step {sim.step_count}, "
                f"max speed {vmax:.3g} m/s): time step {sim.dt:.3g} s too large for these "
                "stiffnesses; reduce dt (or dt_fraction).")


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
