"""Checks of user input to the engine: each returns the value in the engine's form or
raises :class:`~demcal.errors.ConfigError` with one sentence naming the value and the
fix."""

from __future__ import annotations

import math
import numbers

import numpy as np

from demcal.errors import ConfigError


def is_real(x) -> bool:
    """A real number (Python or numpy scalar), not a bool."""
    return isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))


def is_integer(x) -> bool:
    """A whole number (Python or numpy integer), not a bool."""
    return isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_))


def positive(value, name: str, unit: str, optional: bool = True):
    """``value`` as a float > 0 and finite (None passes when ``optional``)."""
    if value is None and optional:
        return None
    if not (is_real(value) and math.isfinite(value) and value > 0):
        raise ConfigError(f"{name} must be a finite number > 0 {unit}, got {value!r}.")
    return float(value)


def gravity_array(value):
    """``value`` as a float (3,) array; ConfigError unless three finite numbers."""
    try:
        g = np.array(value, dtype=float)
    except (TypeError, ValueError):
        g = None
    if g is None or g.size != 3 or not np.all(np.isfinite(g)):
        raise ConfigError(f"gravity must be three finite numbers [m/s2], got {value!r}; "
                          "give e.g. gravity=(0, 0, -9.81).")
    return g.reshape(3)


def finite_gravity(g) -> None:
    """ConfigError unless gravity (perhaps changed in place) is three finite numbers."""
    if not np.all(np.isfinite(g)):
        raise ConfigError(f"gravity must be three finite numbers [m/s2], got "
                          f"{g.tolist()}; set e.g. sim.gravity[:] = (0, 0, -9.81).")


def floats(value, name, unit):
    """``value`` as a float array; ConfigError naming ``name`` if it is not numbers."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be numbers [{unit}], got {value!r}.") from None


def rows(value, n, width, name, unit):
    """One row for all ``n`` particles, ``(width,)`` or ``(1, width)``, or one row per
    particle ``(n, width)``, as a new ``(n, width)`` float array of finite numbers."""
    a = floats(value, name, unit)
    if not (a.shape == (width,) or (a.ndim == 2 and a.shape[1] == width
                                    and a.shape[0] in (1, n))):
        raise ConfigError(f"{name} [{unit}] must be one ({width},) row for all particles "
                          f"or an ({n}, {width}) array (one row per particle), got shape "
                          f"{a.shape}.")
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"{name} must be finite numbers [{unit}], got a NaN or an "
                          "infinite value.")
    return np.broadcast_to(a, (n, width)).copy()


def flags(value, n, name):
    """``value`` (one bool, or one per particle) as a new (n,) bool array; ConfigError
    naming ``name`` otherwise."""
    a = np.asarray(value)
    if a.ndim == 0 and isinstance(a.item(), (bool, int)):
        return np.full(n, bool(a))
    if a.shape == (n,) and a.dtype == np.bool_:
        return a.copy()
    raise ConfigError(f"{name} must be True, False or one bool per particle (n = {n}), "
                      f"got {value!r}.")


def run_length(duration, steps) -> None:
    """ConfigError unless exactly one of ``duration`` [s] and ``steps`` is given, and it
    is a finite number >= 0 (a whole one for steps)."""
    if (duration is None) == (steps is None):
        raise ConfigError("give run() exactly one of duration [s] or steps.")
    if steps is not None and not (is_real(steps) and math.isfinite(steps)
                                  and steps == int(steps) and steps >= 0):
        raise ConfigError(f"steps must be a whole number >= 0, got {steps!r}.")
    if duration is not None and not (is_real(duration) and math.isfinite(duration)
                                     and duration >= 0):
        raise ConfigError(f"duration must be a finite number of seconds >= 0, got "
                          f"{duration!r}.")


def kept_particles(which, nb):
    """The keep mask of ``remove_particles(which)`` over ``nb`` particles (None: nothing
    to remove): ``which`` a boolean mask or indices (negative ones from the end)."""
    w = np.asarray(which)
    if w.dtype == np.bool_:
        if w.shape != (nb,):
            raise ConfigError(f"remove_particles: a mask needs one entry per particle "
                              f"({nb}), got shape {w.shape}.")
    elif w.size == 0:
        return None
    elif not np.issubdtype(w.dtype, np.integer):
        raise ConfigError(f"remove_particles: give particle indices (whole numbers) or "
                          f"a boolean mask, got {w.dtype} values.")
    else:
        bad = (w < -nb) | (w >= nb)
        if np.any(bad):
            raise ConfigError(f"remove_particles: index {int(w[bad].flat[0])} is out of "
                              f"range; there are {nb} particle(s) (indices 0 to "
                              f"{nb - 1}).")
    keep = np.ones(nb, bool)
    keep[w] = False
    return keep
