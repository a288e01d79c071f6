"""Tangential sub-models with history (the accumulated tangential displacement).

The history vector ``s`` [m] is kept by the caller (``hist[h, 0:3]``). Each step it is
first rotated into the current tangent plane (its normal component removed, its length
kept, as in LAMMPS ``granular``; LIGGGHTS 3.8 removes the normal component after the
increment and does not rescale), then incremented by ``vt dt``. The force is
``ft = -kt s + c beta sqrt(kt m*) vt`` and, if ``|ft| > mu_s Fn``, it is scaled to the
Coulomb limit and the spring alone is set to carry it, ``s = -ft / kt`` (as LIGGGHTS'
``tangential_history`` drops the damping while sliding). Keeping the damping part in
``s`` instead (LAMMPS) lets the stored spring reverse the friction force late in an
impact when the damping exceeds mu_s Fn; the oblique-impact tests catch that.

* ``mindlin`` (EDEM Hertz-Mindlin no slip): ``kt = St = 8 G* sqrt(R* delta)``,
  damping factor c = 2 sqrt(5/6).
* ``linear`` (paper Eq. 3, third line; EDEM HSCM "stiffness factor"): ``kt = xi K1``
  and ``F_t^d = 2 |beta| sqrt(m* kt) vt``, which is exactly Eq. 3 solved for F_t^d:
  xi = (F_t^d)^2 (ln^2 e + pi^2) / (4 vt^2 m* K ln^2 e) with kt = xi K.
"""

import math

from numba import njit

from .llvm_math import sqrt
from .declare import FASTMATH, HistoryField, SubModel
from .pairs import BETA, GSTAR, SQ_ST_SN, STATIC_FRICTION, STIFFNESS_FACTOR, YMIN
from .plane import to_tangent_plane

# ids of the tangential slot
TANGENTIAL_NONE = 0
TANGENTIAL_MINDLIN = 1   # St = 8 G* sqrt(R* delta), EDEM no-slip
TANGENTIAL_LINEAR = 2    # kt = xi K1, paper Eq. 3

SQRT_5_6 = math.sqrt(5.0 / 6.0)

#: the accumulated tangential displacement s [m] of side i
TANGENTIAL_DISPLACEMENT = HistoryField("tangential_displacement", "m", vector=True)

MODELS = (
    SubModel("tangential", "none", TANGENTIAL_NONE),
    SubModel("tangential", "mindlin", TANGENTIAL_MINDLIN,
             coefficients=(STATIC_FRICTION,), constants=(GSTAR, BETA, SQ_ST_SN),
             history=(TANGENTIAL_DISPLACEMENT,),
             source="Mindlin 1949; EDEM Hertz-Mindlin (no slip)"),
    SubModel("tangential", "linear", TANGENTIAL_LINEAR,
             coefficients=(STATIC_FRICTION, STIFFNESS_FACTOR), constants=(YMIN, BETA),
             history=(TANGENTIAL_DISPLACEMENT,),
             source="Xie et al. 2020, Eq. 3; EDEM Hysteretic Spring stiffness factor"),
)


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def tangential_stiffness(model, sq, m_eff, gstar, beta, k1, xi, hertz_sqkm, sq_st_sn):
    """``(kt, ct)``: spring stiffness [N/m] and damping coefficient [N s/m].

    ``sq = sqrt(R* delta)``. When the normal slot is Hertz, ``hertz_sqkm`` is its
    ``sqrt(Sn m*)`` and ``sq_st_sn = sqrt(St/Sn) = sqrt(4 G*/E*)``, so that
    ``sqrt(St m*)`` needs no square root of its own; otherwise ``hertz_sqkm`` is 0.
    """
    kt = 0.0
    ct = 0.0
    if model == TANGENTIAL_MINDLIN:
        kt = 8.0 * gstar * sq
        if hertz_sqkm > 0.0:
            ct = 2.0 * SQRT_5_6 * beta * hertz_sqkm * sq_st_sn
        else:
            ct = 2.0 * SQRT_5_6 * beta * sqrt(kt * m_eff)
    elif model == TANGENTIAL_LINEAR:
        kt = xi * k1
        ct = 2.0 * beta * sqrt(kt * m_eff)
    return kt, ct


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def tangential_force(kt, ct, sx, sy, sz, nx, ny, nz, vtx, vty, vtz, dt, mu_s, fn):
    """Tangential force on particle i [N] (spring ``kt``, damping ``ct`` from
    :func:`tangential_stiffness`) and the new spring displacement, given the stored one
    ``s``: ``(fx, fy, fz, sx, sy, sz)``."""
    fx = 0.0
    fy = 0.0
    fz = 0.0
    if not kt <= 0.0:
        sx, sy, sz = to_tangent_plane(sx, sy, sz, nx, ny, nz)
        sx += vtx * dt
        sy += vty * dt
        sz += vtz * dt
        dx = ct * vtx
        dy = ct * vty
        dz = ct * vtz
        fx = -kt * sx + dx
        fy = -kt * sy + dy
        fz = -kt * sz + dz
        fmax = mu_s * fn
        if fmax < 0.0:
            fmax = 0.0
        f2 = fx * fx + fy * fy + fz * fz
        if f2 > fmax * fmax:
            fm = sqrt(f2)
            r = fmax / fm
            fx *= r
            fy *= r
            fz *= r
            ikt = 1.0 / kt
            sx = -fx * ikt
            sy = -fy * ikt
            sz = -fz * ikt
    return fx, fy, fz, sx, sy, sz
