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
* JKR (Johnson, Kendall & Roberts 1971, Proc. R. Soc. Lond. A 324, 301-313; Johnson
  1985, Contact Mechanics, section 5.5; EDEM "Hertz-Mindlin with JKR Cohesion"), with
  ``gamma`` the surface energy as EDEM names it (the work of adhesion per unit area
  [J/m2], so that the pull-off force is EDEM's ``1.5 pi gamma R*``): the contact
  radius ``a`` solves ``delta = a^2/R* - sqrt(2 pi gamma a / E*)`` and
  ``fn = 4 E* a^3 / (3 R*) - sqrt(8 pi gamma E* a^3)``; ``k = 2 E* a`` (Hertz's S_n,
  for the damping and, as the contact radius, for Mindlin's S_t = 8 G* a). A contact
  forms when the spheres touch and holds while ``delta > -delta_s`` (the reach):
  ``a_s = (pi gamma R*^2 / (8 E*))^(1/3)``, ``delta_s = 3 a_s^2 / R*``, where the
  stable branch ends (d delta / d a = 0) and the force is ``-5/6 pi gamma R*``. The
  force's minimum on the way there is the pull-off force ``-3/2 pi gamma R*``, at
  ``a_c = (9 pi gamma R*^2 / (8 E*))^(1/3)``. gamma = 0 is Hertz exactly.

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
from .declare import Coefficient, PairConstant
from .llvm_math import sqrt
from .pairs import ESTAR, P_E, P_ESTAR, P_YMIN, RESTITUTION, YMIN

# ids of the normal slot (the kernels dispatch on them)
NORMAL_HERTZ = 0
NORMAL_HYSTERETIC = 1
NORMAL_LINEAR = 2
NORMAL_JKR = 3

#: JKR's surface energy gamma [J/m2] (EDEM's name; the work of adhesion per unit area)
SURFACE_ENERGY = Coefficient(
    "surface_energy", "J/m2", 0.0, 0.0, bench=(0.0, 100.0),
    doc="JKR surface energy gamma (pull-off force 1.5 pi gamma R*)")
P_GAMMA = SURFACE_ENERGY.column
#: 2 F_c / R* = 3 pi gamma [N/m], JKR's critical-force offset per unit R* (0 in the pair
#: table of any other normal sub-model, so the kernel adds it without a branch)
PULL_OFF = PairConstant("pull_off", "N/m",
                        lambda mi, mj, it: 3.0 * math.pi * it.value("surface_energy", 0.0),
                        "2 F_c / R* = 3 pi gamma (Thornton & Yin 1991)", chosen_only=True)
P_PULL = PULL_OFF.column

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


@njit(cache=True, error_model="numpy", fastmath=FASTMATH)
def jkr_gap(estar, gamma, r_eff):
    """delta_s [m], the gap a JKR contact holds across: ``3 a_s^2 / R*`` with
    ``a_s = (pi gamma R*^2 / (8 E*))^(1/3)`` (module docstring)."""
    a_s = (math.pi * gamma * r_eff * r_eff / (8.0 * estar)) ** (1.0 / 3.0)
    return 3.0 * a_s * a_s / r_eff


@njit(cache=True, error_model="numpy", fastmath=FASTMATH)
def jkr_radius(delta, r_eff, estar, gamma):
    """The JKR contact radius a [m] at overlap ``delta`` [m] (negative down to
    ``-jkr_gap``), on the stable branch.

    With ``x = sqrt(a)`` and ``c = sqrt(2 pi gamma / E*)`` the relation is the quartic
    ``x^4 - c R* x - delta R* = 0``. Newton's method from
    ``x0 = (2 c R*)^(1/3) + (2 max(delta, 0) R*)^(1/4)``, where the quartic is positive
    and convex, comes down to the largest root monotonically. No library root finder
    can be called inside a compiled contact loop, hence the few lines here."""
    c = sqrt(2.0 * math.pi * gamma / estar)
    cr = c * r_eff
    dr = delta * r_eff
    x = (2.0 * cr) ** (1.0 / 3.0) + (2.0 * max(dr, 0.0)) ** 0.25
    for _ in range(60):
        x3 = x * x * x
        dx = (x3 * x - cr * x - dr) / (4.0 * x3 - cr)
        x -= dx
        if dx <= 1e-13 * x:
            break
    return x * x


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def jkr(a, r_eff, estar, gamma):
    """JKR force [N] and S_n = 2 E* a [N/m] at contact radius ``a``."""
    return (4.0 * estar * a * a * a / (3.0 * r_eff)
            - sqrt(8.0 * math.pi * gamma * estar * a * a * a)), 2.0 * estar * a


def _jkr_reach(row, r_eff):
    return jkr_gap(row[P_ESTAR], row[P_GAMMA], r_eff) if row[P_GAMMA] > 0.0 else 0.0


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
    # the contact radius feeds Tsuji's damping and Mindlin's spring, as in EDEM's
    # Hertz-Mindlin with JKR; the Hertz duration bounds the step
    SubModel("normal", "jkr", NORMAL_JKR, constants=(ESTAR, PULL_OFF),
             coefficients=(SURFACE_ENERGY,),
             reach=_jkr_reach, contact_time=_hertz_time, rayleigh_bound=True,
             requires=(("damping", ("tsuji", "none")), ("tangential", ("mindlin", "none"))),
             source="Johnson, Kendall & Roberts 1971; EDEM Hertz-Mindlin with JKR cohesion"),
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
def normal_force(model, delta, delta0, r_eff, sq, estar, ymin, e, gamma):
    """Dispatch on the normal slot; see the module docstring. ``sq`` is the contact
    radius, ``sqrt(R* delta)`` for Hertz and ``jkr_radius`` for JKR (computed once per
    contact by the caller when a slot needs it); ``gamma`` JKR's surface energy."""
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
    elif model == NORMAL_JKR:
        fn, k = jkr(sq, r_eff, estar, gamma)
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
    that does not pull. For JKR the force is measured from the pull-off state,
    ``F_n + 2 F_c`` with ``F_c = 1.5 pi gamma R*`` (Thornton & Yin 1991, Powder
    Technol. 65, 153-166; LAMMPS granular ``jkr``), clipped at 0. The offset is JKR's
    chosen-only pair constant ``PULL_OFF`` (0 for the other sub-models: ``fn + 0``
    is ``fn``), so no branch on the sub-model: one in this hot spot cost 15 % of the
    pair loop's speed (docs/performance.md)."""
    f = fn + table[mi, mj, P_PULL] * r_eff
    return f if f > 0.0 else 0.0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def reach(model, table, mi, mj, r_eff):
    """The gap [m] up to which a contact that touched holds (0: it opens when the
    surfaces part); see ``SubModel.reach``."""
    g = 0.0
    if model == NORMAL_JKR:
        gamma = table[mi, mj, P_GAMMA]
        if gamma > 0.0:
            g = jkr_gap(table[mi, mj, P_ESTAR], gamma, r_eff)
    return g
