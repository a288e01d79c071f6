"""Normal damping sub-models.

All are viscous, ``fd = c_factor * beta * sqrt(k m*) * vn`` with
``beta = ln e / sqrt(ln^2 e + pi^2)`` (< 0), ``vn`` the normal relative velocity
(negative while approaching) and ``k`` the stiffness returned by the normal slot, so
``fd`` opposes the normal motion:

* ``tsuji`` (EDEM Hertz-Mindlin, after Tsuji et al. 1992): c_factor = 2 sqrt(5/6),
  k = Sn. Unclamped, this gives exactly restitution e for the Hertz spring
  (Antypov & Elliott 2011, EPL 94, 50004), which the tests check.
* ``hysteretic`` (paper Eq. 3, second line, solved for F_n^d): c_factor = 2 zeta,
  k = K1 while loading and K2 while unloading. zeta = 0 leaves only the hysteresis,
  whose restitution is exactly e = sqrt(K1/K2) at any impact speed.
* ``viscous`` (linear spring-dashpot): c_factor = 2, giving restitution e exactly.
"""

import math

from numba import njit

from .declare import FASTMATH, SubModel
from .pairs import BETA, DAMPING_FACTOR, RESTITUTION

# ids of the damping slot
DAMPING_NONE = 0
DAMPING_TSUJI = 1        # EDEM Hertz-Mindlin: 2 sqrt(5/6) beta sqrt(Sn m*)
DAMPING_HYSTERETIC = 2   # paper Eq. 3: 2 zeta beta sqrt(K m*)
DAMPING_VISCOUS = 3      # linear spring-dashpot: 2 beta sqrt(k m*)

SQRT_5_6 = math.sqrt(5.0 / 6.0)

MODELS = (
    SubModel("damping", "none", DAMPING_NONE),
    SubModel("damping", "tsuji", DAMPING_TSUJI, coefficients=(RESTITUTION,), constants=(BETA,),
             source="Tsuji, Tanaka & Ishida 1992; EDEM Hertz-Mindlin"),
    SubModel("damping", "hysteretic", DAMPING_HYSTERETIC,
             coefficients=(RESTITUTION, DAMPING_FACTOR), constants=(BETA,),
             source="Xie et al. 2020, Eq. 3; EDEM Hysteretic Spring"),
    SubModel("damping", "viscous", DAMPING_VISCOUS, coefficients=(RESTITUTION,),
             constants=(BETA,), source="linear spring-dashpot (Cundall & Strack 1979)"),
)


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def normal_damping(model, beta, zeta, sqkm, vn):
    """Damping force [N] along the normal (positive = repulsive); ``sqkm`` is
    ``sqrt(k m*)`` with the normal slot's stiffness k (0 when k <= 0)."""
    fd = 0.0
    if model == DAMPING_TSUJI:
        fd = 2.0 * SQRT_5_6 * beta * sqkm * vn
    elif model == DAMPING_HYSTERETIC:
        fd = 2.0 * zeta * beta * sqkm * vn
    elif model == DAMPING_VISCOUS:
        fd = 2.0 * beta * sqkm * vn
    return fd
