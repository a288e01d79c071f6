"""Gravity as a function of time, held piecewise constant over windows of steps.

The compiled step loop reads gravity as one constant vector per call. A schedule lets
gravity change with time without a Python call per step: :meth:`Simulation.run`
splits the steps into *windows* of :meth:`GravitySchedule.window` steps (counted from
the step at which the schedule was set), and before each window sets ``sim.gravity``
to the schedule's value at the window's middle. The steps of a window still run in one
compiled call (between neighbour rebuilds and reporters, as without a schedule).

Error bound. A window of ``W`` steps applies the same gravity to the force
evaluations at ``t_1 .. t_W`` (``t_k = t_0 + k dt``); held at ``g(t_mid)``,
``t_mid = t_0 + (W + 1) dt / 2``, it differs from the exact ``g(t_k)`` by at most
``|dg/dt| (W - 1) dt / 2``. Each schedule below picks the largest ``W`` that keeps this
under its ``tolerance`` [m/s2], so ``|g_applied - g(t)| <= tolerance`` at every force
evaluation (while the time step stays as it was when the window began; particles
added during a run may shrink an automatic step). On a linear ramp the mean gravity
over a window is exact.

The windows and their values depend only on the step count and the time step, so a
run with a schedule is bitwise the same however it is split into ``run()`` calls or
read by reporters. A schedule is not stored in a checkpoint (``sim.gravity`` is): set
it again after :meth:`Simulation.load_checkpoint`.

>>> import math
>>> tilt = GravityRotation((0, 0, -9.81), axis=(0, 1, 0), rate=math.radians(5))
>>> [round(float(x), 4) for x in tilt.at(1.0)]           # 5 deg after one second
[-0.855, 0.0, -9.7727]
"""

from __future__ import annotations

import math

import numpy as np

from demcal._checks import checked_float
from demcal.errors import ConfigError
from demcal.geometry.motion import _unit, _vec3, rotation_matrix

__all__ = ["GravitySchedule", "GravityRamp", "GravityRotation"]


def _active(t: float, start: float, stop: float) -> float:
    """Time [s] the schedule has run by ``t`` (it changes on [start, stop) only)."""
    return min(max(t - start, 0.0), stop - start)


class GravitySchedule:
    """Base class: gravity ``at(t)`` [m/s2] changing at most ``rate_bound`` [m/s3].

    Subclasses give :meth:`at` and :attr:`rate_bound` (an upper bound of |dg/dt|);
    ``tolerance`` [m/s2] (> 0) bounds the error of holding gravity constant over a
    window (module docstring).
    """

    rate_bound: float = 0.0

    def __init__(self, start=0.0, stop=math.inf, tolerance=1e-3):
        self.start = checked_float(start, "gravity schedule start", "a finite time [s]")
        self.stop = checked_float(stop, "gravity schedule stop", "a time [s] after start",
                                  lambda v: v > self.start)
        self.tolerance = checked_float(tolerance, "gravity schedule tolerance",
                                       "a finite number > 0 [m/s2]",
                                       lambda v: math.isfinite(v) and v > 0)

    def at(self, t: float) -> np.ndarray:
        """Gravity [m/s2] at time ``t`` [s], a new (3,) array."""
        raise NotImplementedError

    def window(self, dt: float) -> int:
        """Steps per window for the time step ``dt`` [s]: the most steps ``W`` with
        ``rate_bound (W - 1) dt / 2 <= tolerance``, at least 1 (``2**62`` when gravity
        does not change)."""
        if self.rate_bound == 0.0:
            return 2 ** 62
        return 1 + min(2 ** 62, math.floor(2.0 * self.tolerance / (self.rate_bound * dt)))


class GravityRamp(GravitySchedule):
    """Gravity changing linearly: ``g(t) = g0 + rate * (t - start)`` on [start, stop),
    ``g0`` before, held after.

    Parameters
    ----------
    g0 : 3 floats
        Gravity [m/s2] up to ``start``.
    rate : 3 floats
        Its change per second [m/s3].
    start, stop : float
        When the ramp runs [s] (default: from 0 on, without end).
    tolerance : float
        Largest deviation [m/s2] of the gravity applied from ``g(t)`` (default 1e-3).
    """

    def __init__(self, g0, rate, start=0.0, stop=math.inf, tolerance=1e-3):
        super().__init__(start, stop, tolerance)
        self.g0 = _vec3(g0, "gravity ramp g0")
        self.rate = _vec3(rate, "gravity ramp rate")
        self.rate_bound = float(np.linalg.norm(self.rate))

    def at(self, t):
        return self.g0 + self.rate * _active(t, self.start, self.stop)


class GravityRotation(GravitySchedule):
    """Gravity turning at a constant rate about a fixed axis: ``g(t) = R(axis,
    rate (t - start)) g0`` on [start, stop), ``g0`` before, held after. This is the
    tilting plate of an inclined-plane test seen from the plate (exact in the plate's
    frame up to the inertial forces of a frame turning at ``rate``).

    Parameters
    ----------
    g0 : 3 floats
        Gravity [m/s2] up to ``start``.
    axis : 3 floats
        Axis the gravity vector turns about (right-hand rule; normalised).
    rate : float
        Turning rate [rad/s].
    start, stop : float
        When it turns [s] (default: from 0 on, without end).
    tolerance : float
        Largest deviation [m/s2] of the gravity applied from ``g(t)`` (default 1e-3,
        1e-4 g: an angle of 1e-4 rad for Earth's gravity).
    """

    def __init__(self, g0, axis, rate, start=0.0, stop=math.inf, tolerance=1e-3):
        super().__init__(start, stop, tolerance)
        self.g0 = _vec3(g0, "gravity rotation g0")
        self.axis = _unit(axis, "gravity rotation axis")
        self.rate = checked_float(rate, "gravity rotation rate", "a finite number [rad/s]")
        # |dg/dt| = |rate| |axis x g0| <= |rate| |g0|
        self.rate_bound = abs(self.rate) * float(np.linalg.norm(np.cross(self.axis, self.g0)))

    def angle(self, t: float) -> float:
        """Angle [rad] turned by time ``t``."""
        return self.rate * _active(t, self.start, self.stop)

    def at(self, t):
        return rotation_matrix(self.axis, self.angle(t)) @ self.g0


def as_schedule(value):
    """``value`` if it is a :class:`GravitySchedule` (or None), else a ConfigError."""
    if value is None or isinstance(value, GravitySchedule):
        return value
    raise ConfigError(f"gravity_schedule must be a GravityRamp, GravityRotation (from "
                      f"demcal.dem.gravity) or None, got {type(value).__name__}.")


class ScheduleClock:
    """A schedule as a simulation applies it: the windows are counted from the step at
    which the schedule was set (``anchor``: that step, its time, the time step and the
    window's width), and start again when the time step changes."""

    def __init__(self, schedule):
        self.schedule = as_schedule(schedule)
        self.anchor = None

    def apply(self, gravity, time, step, dt, nsteps) -> int:
        """Set ``gravity`` (in place) for the coming steps; returns how many of the
        ``nsteps`` lie in the current window (all of them without a schedule).
        ``dt`` is None while there are no particles (gravity set to its value now)."""
        sch = self.schedule
        if sch is None or dt is None:
            if sch is not None:
                gravity[:] = sch.at(time)
            return nsteps
        a = self.anchor
        if a is None or a[2] != dt:   # first use, or particles changed the step
            a = self.anchor = (step, time, dt, sch.window(dt))
        n0, t0, _, width = a
        first = n0 + (step - n0) // width * width
        gravity[:] = sch.at(t0 + (first - n0 + 0.5 * (width + 1)) * dt)
        return min(nsteps, first + width - step)
