"""Normal-force sub-models (elastic/plastic part, without damping).

Each returns ``(fn, k, delta0)``: the spring force [N] (positive = repulsive), the
stiffness ``k`` [N/m] the damping slot uses, and the updated residual overlap [m].

* Hertz (EDEM manual, Hertz-Mindlin no slip): ``fn = 4/3 E* sqrt(R*) delta^1.5``,
  ``k = Sn = 2 E* sqrt(R* delta)``.
* Hysteretic spring (Walton & Braun 1986; EDEM HSCM; paper Eq. 1-2):
  ``K1 = 5 R* min(Y_i, Y_j)``, ``K2 = K1 / e^2``,
  ``fn = max(0, min(K1 delta, K2 (delta - delta0)))``. On the loading branch the
  residual overlap follows ``delta0 = delta (1 - K1/K2)`` (the point where the unloading
  line from the current state meets fn = 0); on unloading/reloading it stays fixed.
  ``k`` is the branch slope (K1 loading, K2 unloading), 0 once the spring is slack.
  The engine resets ``delta0`` to 0 when the contact opens.
* Linear spring (EDEM linear spring uses the yield strength too): ``k = 5 R* Y``,
  ``fn = k delta``.

Contact durations (the automatic time step, :mod:`demcal.dem.timestep`):

* Hertz (Johnson 1985, Contact Mechanics, section 11.4, Eq. 11.24): an elastic impact
  at speed v lasts ``t_H = 2.9432 (15 m* / (16 E* sqrt(R*)))^(2/5) v^(-1/5)`` where
  2.9432 = 2 sqrt(pi) Gamma(7/5) / Gamma(9/10); the Rayleigh time bounds the step too.
* Linear / hysteretic spring: half a period of the stiffest branch,
  ``t_s = pi sqrt(m* / K2)`` with ``K2 = K1 / e^2``, ``K1 = 5 R* Y_min`` (for the
  linear spring, whose stiffness is K1, this is on the safe side by the factor e).
"""

import math

from numba import njit

from .declare import FASTMATH, HistoryField, SubModel
from .pairs import ESTAR, P_E, P_ESTAR, P_YMIN, RESTITUTION, YMIN

# ids of the normal slot (the kernels dispatch on them)
NORMAL_HERTZ = 0
NORMAL_HYSTERETIC = 1
NORMAL_LINEAR = 2

#: the residual overlap delta0 [m] of the Hysteretic Spring
RESIDUAL_OVERLAP = HistoryField("residual_overlap", "m", vector=False)

GAMMA_FACTOR = 2.0 * math.sqrt(math.pi) * math.gamma(1.4) / math.gamma(0.9)  # 2.9432


def hertz_contact_time(m_eff, r_eff, estar, speed):
    """Duration [s] of an elastic Hertz impact at relative speed ``speed`` (Johnson 1985)."""
    return GAMMA_FACTOR * (15.0 * m_eff / (16.0 * estar * math.sqrt(r_eff))) ** 0.4 \
        * speed ** -0.2


def spring_contact_time(m_eff, stiffness):
    """Half period pi sqrt(m*/k) [s] of a linear spring."""
    return math.pi * math.sqrt(m_eff / stiffness)


def _hertz_time(row, r_eff, m_eff, speed):
    return hertz_contact_time(m_eff, r_eff, row[P_ESTAR], speed)


def _spring_time(row, r_eff, m_eff, speed):
    k2 = 5.0 * r_eff * row[P_YMIN] / row[P_E] ** 2
    return spring_contact_time(m_eff, k2)


MODELS = (
    SubModel("normal", "hertz", NORMAL_HERTZ, constants=(ESTAR,),
             contact_time=_hertz_time, rayleigh_bound=True,
             source="Hertz 1882; EDEM Hertz-Mindlin (no slip)"),
    SubModel("normal", "hysteretic", NORMAL_HYSTERETIC,
             coefficients=(RESTITUTION,), constants=(YMIN,),
             history=(RESIDUAL_OVERLAP,),
             contact_time=_spring_time,
             source="Walton & Braun 1986; EDEM Hysteretic Spring; Xie et al. 2020 Eq. 1-2"),
    SubModel("normal", "linear", NORMAL_LINEAR, constants=(YMIN,),
             coefficients=(RESTITUTION,), contact_time=_spring_time,
             source="EDEM linear spring (K = 5 R* Y)"),
)


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def hertz(delta, sq, estar):
    """Hertz spring force and Sn, given ``sq = sqrt(R* delta)``."""
    return 4.0 / 3.0 * estar * sq * delta, 2.0 * estar * sq


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def hysteretic(delta, delta0, r_eff, ymin, e):
    k1 = 5.0 * r_eff * ymin
    k2 = k1 / (e * e)
    f1 = k1 * delta
    f2 = k2 * (delta - delta0)
    # one exit (no early return), so that loops over contacts can be vectorised
    if f1 <= f2:
        fn = f1
        k = k1
        d0 = delta * (1.0 - k1 / k2)
    elif f2 > 0.0:
        fn = f2
        k = k2
        d0 = delta0
    else:
        fn = 0.0
        k = 0.0
        d0 = delta0
    return fn, k, d0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def normal_force(model, delta, delta0, r_eff, sq, estar, ymin, e):
    """Dispatch on the normal slot; see the module docstring. ``sq`` is
    ``sqrt(R* delta)`` (computed once per contact by the caller when a slot needs it)."""
    fn = 0.0
    k = 0.0
    d0 = delta0
    if model == NORMAL_HERTZ:
        fn, k = hertz(delta, sq, estar)
    elif model == NORMAL_HYSTERETIC:
        fn, k, d0 = hysteretic(delta, delta0, r_eff, ymin, e)
    elif model == NORMAL_LINEAR:
        k = 5.0 * r_eff * ymin
        fn = k * delta
    return fn, k, d0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def loading_stiffness(r_eff, ymin):
    """K1 = 5 R* min(Y_i, Y_j) [N/m] (Walton 2006, EDEM HSCM)."""
    return 5.0 * r_eff * ymin


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def secant_force(model, delta, fn, k1):
    """``k_n delta`` [N], the elastic normal force LIGGGHTS' rolling model ``cdt`` takes
    (``sidata.kn * sidata.deltan`` in ``rolling_model_cdt.h``, LIGGGHTS-PUBLIC 3.8.0).

    ``k_n`` is the stiffness the normal model hands on: for Hertz LIGGGHTS' ``kn =
    4/3 E* sqrt(R* delta)``, so ``k_n delta`` is the Hertz spring force ``fn``; for the
    linear spring ``k delta = fn``. LIGGGHTS 3.8 has no Walton-Braun Hysteretic Spring;
    its own hysteretic model (``hooke/hysteresis``, a different one: see docs/export.md)
    hands its loading stiffness on as ``k_n``, and we do the same: ``K1 delta`` (= ``fn``
    while loading, larger while unloading). A judgement, since no LIGGGHTS model is ours.
    """
    fe = fn
    if model == NORMAL_HYSTERETIC:
        fe = k1 * delta
    return fe


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def critical_force(model, fn, table, mi, mj, r_eff):
    """The normal force [N] that caps friction (``mu_s F``) and rolling resistance
    (``mu_r F R``): the total normal force clipped at 0, for every normal sub-model
    that does not pull."""
    return fn if fn > 0.0 else 0.0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def reach(model, table, mi, mj, r_eff):
    """The gap [m] up to which a contact that touched holds (0: it opens when the
    surfaces part); see ``SubModel.reach``."""
    return 0.0
