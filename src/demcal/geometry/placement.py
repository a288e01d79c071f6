"""Placing moving walls at a time, compiled: constant-velocity translations and
constant-rate rotations about a fixed axis.

:func:`place_moving` rewrites the rows (``params``, ``origin``, ``velocity``,
``omega``) of every flagged wall from its reference rows, by the same arithmetic
whether the engine's compiled step loop calls it at every step
(:mod:`demcal.dem.stepper`) or :meth:`WallSet.update <demcal.geometry.WallSet.update>`
calls it from Python, so a run gives the same numbers either way. A rotating drum
then costs no Python call per step.

Rotation: ``x -> R (x - c) + c`` with Rodrigues' formula ``R = I + sin(t) K + (1 -
cos(t)) K^2`` for the unit axis ``a`` (``K`` its cross-product matrix, ``K^2 = a a^T -
I``) and the angle turned by then; points of a row move, its directions turn (the row
layouts of :mod:`demcal.geometry.kernels`); the wall's angular velocity is ``rate a``
while active and its velocity at a point x is ``omega x (x - c)``.
"""

from __future__ import annotations

import math

from numba import njit

from .kernels import RECT, TRIANGLE

#: Flags of :func:`place_moving`: not placed, a translation, a rotation.
STILL = 0
TRANSLATION = 1
ROTATION = 2


@njit(cache=True, nogil=True, error_model="numpy")
def _turn(r, x, y, z):
    return (r[0] * x + r[1] * y + r[2] * z, r[3] * x + r[4] * y + r[5] * z,
            r[6] * x + r[7] * y + r[8] * z)


@njit(cache=True, nogil=True, error_model="numpy")
def place_moving(time, flag, tvel, tstart, tstop, axis, point, rate, ref_params,
                 ref_origin, wkind, wparams, worigin, wvel, womega):
    """Place the flagged walls at ``time`` [s] (see the module docstring).

    ``flag[w]`` is :data:`TRANSLATION` (velocity ``tvel[w]`` [m/s]) or
    :data:`ROTATION` (about ``axis[w]``, a unit vector, through ``point[w]`` [m] at
    ``rate[w]`` [rad/s]), active for ``tstart[w] <= t < tstop[w]``; other rows are left
    alone."""
    for w in range(flag.shape[0]):
        f = flag[w]
        if f == STILL:
            continue
        at = min(max(time - tstart[w], 0.0), tstop[w] - tstart[w])
        moving = tstart[w] <= time < tstop[w]
        npts = 3 if wkind[w] == TRIANGLE else 1
        if f == TRANSLATION:
            # the very operations of WallSet.update: x = x_ref + v * t_active
            for k in range(3):
                d = tvel[w, k] * at
                for q in range(npts):
                    wparams[w, 3 * q + k] = ref_params[w, 3 * q + k] + d
                worigin[w, k] = ref_origin[w, k] + d
                wvel[w, k] = tvel[w, k] if moving else 0.0
            continue
        ax = axis[w, 0]
        ay = axis[w, 1]
        az = axis[w, 2]
        th = rate[w] * at
        s = math.sin(th)
        c1 = 1.0 - math.cos(th)
        r = (1.0 + c1 * (ax * ax - 1.0), -s * az + c1 * ax * ay, s * ay + c1 * ax * az,
             s * az + c1 * ax * ay, 1.0 + c1 * (ay * ay - 1.0), -s * ax + c1 * ay * az,
             -s * ay + c1 * ax * az, s * ax + c1 * ay * az, 1.0 + c1 * (az * az - 1.0))
        cx = point[w, 0]
        cy = point[w, 1]
        cz = point[w, 2]
        # points
        for q in range(npts):
            x, y, z = _turn(r, ref_params[w, 3 * q] - cx, ref_params[w, 3 * q + 1] - cy,
                            ref_params[w, 3 * q + 2] - cz)
            wparams[w, 3 * q] = x + cx
            wparams[w, 3 * q + 1] = y + cy
            wparams[w, 3 * q + 2] = z + cz
        # directions
        for slot in (3, 6, 9):
            if slot == 3 and npts == 3:
                continue   # a triangle's second vertex, moved above
            if slot == 6 and wkind[w] != RECT:
                continue
            if slot == 9 and wkind[w] != RECT and wkind[w] != TRIANGLE:
                continue
            x, y, z = _turn(r, ref_params[w, slot], ref_params[w, slot + 1],
                            ref_params[w, slot + 2])
            wparams[w, slot] = x
            wparams[w, slot + 1] = y
            wparams[w, slot + 2] = z
        ox, oy, oz = _turn(r, ref_origin[w, 0] - cx, ref_origin[w, 1] - cy,
                           ref_origin[w, 2] - cz)
        worigin[w, 0] = ox + cx
        worigin[w, 1] = oy + cy
        worigin[w, 2] = oz + cz
        om = rate[w] if moving else 0.0
        wx = om * ax
        wy = om * ay
        wz = om * az
        womega[w, 0] = wx
        womega[w, 1] = wy
        womega[w, 2] = wz
        # v = omega x (origin - c)
        wvel[w, 0] = wy * oz - wz * oy
        wvel[w, 1] = wz * ox - wx * oz
        wvel[w, 2] = wx * oy - wy * ox
