"""Prescribed rigid motions of walls.

A motion is a function of time giving a rigid transform and its velocity field:

* :meth:`Motion.transform` ``(t) -> (R, T)``: a point at ``x_ref`` in the wall's
  reference geometry is at ``R @ x_ref + T`` at time ``t`` [s];
* :meth:`Motion.twist` ``(t) -> (omega, v0)``: the velocity of any point of the wall at
  world position ``x`` is ``v0 + omega x x`` (``v0`` [m/s] is the velocity of the
  material point passing through the world origin, ``omega`` [rad/s] the angular
  velocity);
* :meth:`Motion.velocity_at` ``(t, x)``: that velocity at one point.

All motions are frozen dataclasses (pure descriptions); a :class:`Static` wall never
moves, which lets :class:`~demcal.geometry.wallset.WallSet` skip updates.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from demcal._checks import checked_float
from demcal.errors import ConfigError

_I3 = np.eye(3)


def _vec3(value, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f"{name} must be three finite numbers, got {value!r}.")
    return arr


#: Tolerance of the rotation check on a :class:`FunctionMotion`'s ``R``: ``R R^T = I``
#: and ``det R = 1`` to within this.
ROTATION_TOL = 1e-9


def _check_time_function(function, owner: str) -> None:
    """Refuse a motion function that is not callable or cannot be called as ``f(t)``."""
    if not callable(function):
        raise ConfigError(
            f"{owner} function must be a function of time t [s], got {type(function).__name__}."
        )
    try:
        sig = inspect.signature(function)
    except (TypeError, ValueError):  # builtins without a signature: trust them
        return
    try:
        sig.bind(0.0)
    except TypeError:
        raise ConfigError(
            f"{owner} function{sig} cannot be called with the time alone: define it as "
            f"f(t) returning a displacement (3,) [m] or a tuple (R, T)."
        ) from None


def _unit(value, name: str) -> np.ndarray:
    arr = _vec3(value, name)
    norm = float(np.linalg.norm(arr))
    if norm == 0.0:
        raise ConfigError(f"{name} must be a non-zero direction vector, got {value!r}.")
    return arr / norm


def rotation_matrix(axis, angle: float) -> np.ndarray:
    """Rotation by ``angle`` [rad] about the unit ``axis`` (Rodrigues' formula)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return _I3 + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def _active_time(t: float, start: float, stop: float) -> float:
    """Time spent moving by time ``t`` for a motion active on [start, stop)."""
    return min(max(t - start, 0.0), stop - start)


class Motion:
    """Base class of prescribed wall motions."""

    #: False only for :class:`Static`.
    moving: bool = True

    def transform(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Rotation matrix ``R`` and translation ``T`` at time ``t`` [s]."""
        raise NotImplementedError

    def twist(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Angular velocity ``omega`` [rad/s] and velocity ``v0`` [m/s] of the point at
        the world origin, at time ``t`` [s]."""
        raise NotImplementedError

    def velocity_at(self, t: float, x) -> np.ndarray:
        """Velocity [m/s] at time ``t`` of the wall point currently at ``x`` [m]."""
        omega, v0 = self.twist(t)
        return v0 + np.cross(omega, np.asarray(x, dtype=float))

    def pose(self, t: float, x_ref) -> np.ndarray:
        """World position at time ``t`` of the reference point ``x_ref``."""
        rot, trans = self.transform(t)
        return rot @ np.asarray(x_ref, dtype=float) + trans


@dataclass(frozen=True)
class Static(Motion):
    """A wall that never moves."""

    moving = False

    def transform(self, t):
        return _I3.copy(), np.zeros(3)

    def twist(self, t):
        return np.zeros(3), np.zeros(3)


@dataclass(frozen=True)
class Translation(Motion):
    """Translation at a constant ``velocity`` [m/s] while ``start <= t < stop`` [s].

    Before ``start`` the wall is at its reference position; after ``stop`` it stays
    where it got to, at rest.
    """

    velocity: tuple = (0.0, 0.0, 0.0)
    start: float = 0.0
    stop: float = math.inf

    def __post_init__(self):
        object.__setattr__(self, "velocity", tuple(_vec3(self.velocity, "velocity")))
        if not self.stop > self.start:
            raise ConfigError(
                f"Translation stop time ({self.stop}) must be after its start ({self.start})."
            )

    def transform(self, t):
        return _I3.copy(), np.asarray(self.velocity) * _active_time(t, self.start, self.stop)

    def twist(self, t):
        v = np.asarray(self.velocity) if self.start <= t < self.stop else np.zeros(3)
        return np.zeros(3), v


@dataclass(frozen=True)
class Rotation(Motion):
    """Rotation about the axis through ``point`` along ``axis`` at ``angular_speed``
    [rad/s] (right-hand rule) while ``start <= t < stop`` [s].

    The tilting plate of the inclined-plane test is a :class:`Rotation` about its hinge.
    """

    point: tuple = (0.0, 0.0, 0.0)
    axis: tuple = (0.0, 0.0, 1.0)
    angular_speed: float = 0.0
    start: float = 0.0
    stop: float = math.inf

    def __post_init__(self):
        object.__setattr__(self, "point", tuple(_vec3(self.point, "rotation point")))
        object.__setattr__(self, "axis", tuple(_unit(self.axis, "rotation axis")))
        object.__setattr__(self, "angular_speed", checked_float(
            self.angular_speed, "Rotation angular_speed", "a finite number [rad/s]"))
        if not self.stop > self.start:
            raise ConfigError(
                f"Rotation stop time ({self.stop}) must be after its start ({self.start})."
            )

    def angle(self, t: float) -> float:
        """Angle turned by time ``t`` [rad]."""
        return self.angular_speed * _active_time(t, self.start, self.stop)

    def transform(self, t):
        rot = rotation_matrix(self.axis, self.angle(t))
        c = np.asarray(self.point)
        return rot, c - rot @ c

    def twist(self, t):
        if not (self.start <= t < self.stop):
            return np.zeros(3), np.zeros(3)
        omega = self.angular_speed * np.asarray(self.axis)
        return omega, -np.cross(omega, np.asarray(self.point))


@dataclass(frozen=True)
class FunctionMotion(Motion):
    """A user-given motion: ``function(t)`` returns either a displacement 3-vector [m]
    (pure translation) or a tuple ``(R, T)`` (rotation matrix, translation).

    Velocities are central finite differences with step ``dt`` [s] (finite, > 0):
    ``v = (x(t+dt) - x(t-dt)) / 2dt`` and ``[omega]x = R'(t) R(t)^T``.

    ``R`` must be a 3 x 3 proper rotation (``R R^T = I`` and ``det R = 1`` within
    :data:`ROTATION_TOL`) and ``T`` three finite numbers; anything else is refused with a
    :class:`~demcal.errors.ConfigError` when the wall is moved.
    """

    function: Callable = field(default=lambda t: np.zeros(3))
    dt: float = 1e-6

    def __post_init__(self):
        _check_time_function(self.function, "FunctionMotion")
        object.__setattr__(self, "dt", checked_float(
            self.dt, "FunctionMotion dt", "a finite time step > 0 [s] (e.g. 1e-6)",
            lambda x: math.isfinite(x) and x > 0.0))

    def transform(self, t):
        out = self.function(t)
        if isinstance(out, (tuple, list)) and len(out) == 2:
            return self._rotation(out[0], t), self._translation(out[1], t)
        try:
            disp = np.asarray(out, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            disp = None
        if disp is None or disp.shape != (3,) or not np.all(np.isfinite(disp)):
            raise ConfigError(
                f"FunctionMotion function(t) returned {out!r} at t = {t:g} s: return a "
                f"displacement of three finite numbers [m] or a tuple (R, T)."
            )
        return _I3.copy(), disp

    @staticmethod
    def _rotation(value, t) -> np.ndarray:
        try:
            rot = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            rot = None
        if rot is None or rot.shape != (3, 3) or not np.all(np.isfinite(rot)):
            shape = ("not numeric" if rot is None else f"shape {rot.shape}"
                     if rot.shape != (3, 3) else "non-finite values")
            raise ConfigError(
                f"FunctionMotion rotation R at t = {t:g} s must be a 3 x 3 array of finite "
                f"numbers, got {shape}: return (R, T) with R a rotation matrix."
            )
        err = float(np.abs(rot @ rot.T - _I3).max())
        det = float(np.linalg.det(rot))
        if err > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
            raise ConfigError(
                f"FunctionMotion R at t = {t:g} s is not a rotation (|R R^T - I| = {err:.3g}, "
                f"det R = {det:.6g}; need orthonormal with det +1 within {ROTATION_TOL:g}): "
                f"build it with demcal.geometry.motion.rotation_matrix."
            )
        return rot

    @staticmethod
    def _translation(value, t) -> np.ndarray:
        try:
            trans = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            trans = None
        if trans is None or trans.size != 3 or trans.ndim > 2 or not np.all(np.isfinite(trans)):
            shape = ("not numeric" if trans is None else f"shape {trans.shape}"
                     if trans.size != 3 or trans.ndim > 2 else "non-finite values")
            raise ConfigError(
                f"FunctionMotion translation T at t = {t:g} s must be three finite numbers "
                f"[m], got {shape}: return (R, T) with T a 3-vector."
            )
        return trans.reshape(3)

    def twist(self, t):
        h = self.dt
        r_p, t_p = self.transform(t + h)
        r_m, t_m = self.transform(t - h)
        r_0, t_0 = self.transform(t)
        dr = (r_p - r_m) / (2.0 * h)
        w = dr @ r_0.T
        omega = 0.5 * np.array([w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1]])
        # x(t) = R x_ref + T  =>  v(x) = R' x_ref + T' = W (x - T) + T'
        v0 = (t_p - t_m) / (2.0 * h) - np.cross(omega, t_0)
        return omega, v0


def as_motion(motion) -> Motion:
    """``None`` -> :class:`Static`; a callable -> :class:`FunctionMotion`."""
    if motion is None:
        return Static()
    if isinstance(motion, Motion):
        return motion
    if callable(motion):
        return FunctionMotion(motion)
    raise ConfigError(
        f"a wall motion must be Static, Translation, Rotation or a function of time, "
        f"got {type(motion).__name__}."
    )
