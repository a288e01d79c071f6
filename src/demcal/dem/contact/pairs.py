"""The pair-table vocabulary more than one sub-model reads.

Interaction coefficients (EDEM's interaction table, one value per material pair) and the
constants derived from the two materials (EDEM's mixing rules). A sub-model with a
coefficient of its own declares it next to its kernel (JKR's surface energy, say); each
declaration takes the next pair-table column (:mod:`.declare`).

The ranges of the interaction coefficients are those :class:`~demcal.particles.
materials.Interaction` checks; ``bench`` is what the bench settings accept
(``particle.restitution`` and so on).
"""

import math

from .declare import Coefficient, PairConstant


def _estar(mi, mj, it):
    return 1.0 / ((1 - mi.poisson_ratio ** 2) / mi.youngs_modulus
                  + (1 - mj.poisson_ratio ** 2) / mj.youngs_modulus)


def _gstar(mi, mj, it):
    return 1.0 / ((2 - mi.poisson_ratio) / mi.shear_modulus
                  + (2 - mj.poisson_ratio) / mj.shear_modulus)


def _beta(mi, mj, it):
    e = it.restitution
    if e >= 1.0:
        return 0.0
    le = math.log(e)
    return le / math.sqrt(le * le + math.pi * math.pi)


ESTAR = PairConstant("estar", "Pa", _estar,
                     "E* = [(1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j]^-1 (EDEM manual, Hertz-Mindlin)")
GSTAR = PairConstant("gstar", "Pa", _gstar,
                     "G* = [(2 - nu_i)/G_i + (2 - nu_j)/G_j]^-1 (EDEM manual, Hertz-Mindlin)")
BETA = PairConstant("beta", "-", _beta,
                    "beta = ln e / sqrt(ln^2 e + pi^2) (Tsuji et al. 1992; EDEM manual)")
RESTITUTION = Coefficient(
    "restitution", "-", 0.6, 0.0, 1.0, low_open=True, bench=(0.01, 1.0),
    doc="coefficient of restitution e")
STATIC_FRICTION = Coefficient(
    "static_friction", "-", 0.4, 0.0, bench=(0.0, 2.0),
    doc="coefficient of static (sliding) friction mu_s")
ROLLING_FRICTION = Coefficient(
    "rolling_friction", "-", 0.2, 0.0, bench=(0.0, 1.0),
    doc="coefficient of rolling friction mu_r")
YMIN = PairConstant("ymin", "Pa", lambda mi, mj, it: min(mi.yield_strength, mj.yield_strength),
                    "Y_min = min(Y_i, Y_j) (Walton 2006; EDEM Hysteretic Spring)")
DAMPING_FACTOR = Coefficient(
    "damping_factor", "-", 0.0, 0.0, bench=(0.0, 2.0),
    doc="Hysteretic Spring damping factor zeta (Xie et al. 2020, Eq. 3)")
STIFFNESS_FACTOR = Coefficient(
    "stiffness_factor", "-", 0.95, 0.0, low_open=True, bench=(0.01, 10.0),
    doc="tangential stiffness factor xi, k_t = xi K1 (Xie et al. 2020, Eq. 3)")
ROLLING_DAMPING = Coefficient(
    "rolling_damping", "-", 0.3, 0.0, 1.0, bench=(0.0, 1.0),
    doc="rolling viscous damping ratio eta_r (Ai et al. 2011, Eq. 14)")
SQ_ST_SN = PairConstant("sq_st_sn", "-",
                        lambda mi, mj, it: math.sqrt(4.0 * _gstar(mi, mj, it) / _estar(mi, mj, it)),
                        "sqrt(St/Sn) = sqrt(4 G*/E*) of Hertz-Mindlin (saves a square root)")

# the columns as compile-time integers for the kernels
P_ESTAR = ESTAR.column
P_GSTAR = GSTAR.column
P_BETA = BETA.column
P_E = RESTITUTION.column
P_MU_S = STATIC_FRICTION.column
P_MU_R = ROLLING_FRICTION.column
P_YMIN = YMIN.column
P_ZETA = DAMPING_FACTOR.column
P_XI = STIFFNESS_FACTOR.column
P_ETA_R = ROLLING_DAMPING.column
P_SQ_ST_SN = SQ_ST_SN.column
