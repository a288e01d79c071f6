"""One contact, all four slots: the kernel the pair and wall drivers call.

History row layout (``HIST_WIDTH`` float64 per contact), laid out by
:mod:`.registry` from the declared fields: 0:3 tangential displacement [m], 3 residual
overlap delta0 [m] (Hysteretic Spring), 4:7 rolling spring torque [N m] (type C), 7 the
contact flag (1 while the contact holds: a rebuild carries only such rows).
"""

from numba import njit

from .damping import normal_damping
from .declare import FASTMATH
from .llvm_math import sqrt
from .normal import (NORMAL_JKR, P_GAMMA, critical_force, jkr_radius, loading_stiffness,
                     normal_force, secant_force)
from .pairs import (P_BETA, P_E, P_ESTAR, P_ETA_R, P_GSTAR, P_MU_R, P_MU_S, P_SQ_ST_SN,
                    P_XI, P_YMIN, P_ZETA)
from .registry import (H_FLAG, HIST_WIDTH, HISTORY_COLUMNS, NORMAL_HERTZ, NORMAL_HYSTERETIC,
                       TANGENTIAL_MINDLIN)
from .rolling import rolling_torque
from .tangential import tangential_force, tangential_stiffness

H_SLIP = HISTORY_COLUMNS["tangential_displacement"]
H_DELTA0 = HISTORY_COLUMNS["residual_overlap"]
H_ROLL = HISTORY_COLUMNS["rolling_spring_torque"]


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def reset_history(hist, h):
    """Clear contact h's history row (the contact has opened)."""
    for k in range(HIST_WIDTH):
        hist[h, k] = 0.0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def store_history(hist, h, s0, s1, s2, delta0, m0, m1, m2):
    """Write contact h's new history (as :func:`contact` returns it); mark it touching."""
    hist[h, H_SLIP] = s0
    hist[h, H_SLIP + 1] = s1
    hist[h, H_SLIP + 2] = s2
    hist[h, H_DELTA0] = delta0
    hist[h, H_ROLL] = m0
    hist[h, H_ROLL + 1] = m1
    hist[h, H_ROLL + 2] = m2
    hist[h, H_FLAG] = 1.0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def contact(normal, damping, tangential, rolling, table, mi, mj, hist, h, delta,
            nx, ny, nz, vrx, vry, vrz, wix, wiy, wiz, wjx, wjy, wjz,
            lever_i, lever_j, r_eff, m_eff, inv_ir, iso_i, iso_j, dt):
    """Force on i and rolling torques on i and j for one overlapping contact.

    Parameters
    ----------
    normal, damping, tangential, rolling : int
        Sub-model ids of the four slots, see ``registry``.
    table : float64[nmat, nmat, ncolumns]
        Material-pair constants (:mod:`.table`, columns ``pairs.P_*``);
        ``mi``, ``mj`` are the materials of the two sides.
    hist, h : history array and this contact's row (see the module docstring), read
        only: the caller stores the new history the kernel returns.
    delta : float
        Overlap [m]: > 0, or down to minus the normal sub-model's reach for one that
        acts beyond touching. ``n`` is the unit normal pointing from j to i.
    vr : relative velocity of i with respect to j at the contact point [m/s].
    wi, wj : angular velocities [rad/s] (``wj`` of a wall: what its rolling model sees,
        see ``forces.wall_forces``). lever_i, lever_j: centre of mass to contact
        point distances [m]. r_eff, m_eff: R* [m], m* [kg] (R_i and m_i against a wall).
        inv_ir: inverse rolling inertia 1/I_r [1/(kg m2)] (Ai et al. 2011 Eq. 15).
        iso_i, iso_j: the bodies' mean principal moments of inertia [kg m2] (0 for a
        wall), for the rolling moment limiter.

    Returns
    -------
    (fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz, sx, sy, sz, delta0, mx, my, mz)
        Contact force on i [N] (j gets the opposite), the rolling torques [N m], and the
        new history: tangential displacement [m], residual overlap [m], rolling spring
        torque [N m] (the stored values where the model keeps none).
    """
    e = table[mi, mj, P_E]
    beta = table[mi, mj, P_BETA]
    ymin = table[mi, mj, P_YMIN]
    estar = table[mi, mj, P_ESTAR]
    gstar = table[mi, mj, P_GSTAR]
    zeta = table[mi, mj, P_ZETA]
    xi = table[mi, mj, P_XI]
    sq_st_sn = table[mi, mj, P_SQ_ST_SN]
    mu_s = table[mi, mj, P_MU_S]
    mu_r = table[mi, mj, P_MU_R]
    eta_r = table[mi, mj, P_ETA_R]
    delta0 = hist[h, H_DELTA0]
    vn = vrx * nx + vry * ny + vrz * nz
    # the contact radius (sqrt(R* delta) for Hertz) is shared by the normal spring and
    # the Mindlin tangential spring
    sq = 0.0
    gamma = 0.0
    if normal == NORMAL_JKR:
        gamma = table[mi, mj, P_GAMMA]
        sq = jkr_radius(delta, r_eff, estar, gamma)
    elif normal == NORMAL_HERTZ or tangential == TANGENTIAL_MINDLIN:
        sq = sqrt(r_eff * delta)
    fs, k, d0 = normal_force(normal, delta, delta0, r_eff, sq, estar, ymin, e, gamma)
    sqkm = sqrt(k * m_eff) if k > 0.0 else 0.0
    fd = normal_damping(damping, beta, zeta, sqkm, vn)
    fn = fs + fd
    if normal == NORMAL_HYSTERETIC and fn < 0.0:
        fn = 0.0
    vtx = vrx - vn * nx
    vty = vry - vn * ny
    vtz = vrz - vn * nz
    k1 = loading_stiffness(r_eff, ymin)
    kt, ct = tangential_stiffness(tangential, sq, m_eff, gstar, beta, k1, xi,
                                  sqkm if normal == NORMAL_HERTZ or normal == NORMAL_JKR
                                  else 0.0, sq_st_sn)
    # the force that caps friction and rolling resistance (>= 0)
    fc = critical_force(normal, fn, table, mi, mj, r_eff)
    ftx, fty, ftz, sx, sy, sz = tangential_force(kt, ct, hist[h, H_SLIP], hist[h, H_SLIP + 1],
                                                 hist[h, H_SLIP + 2], nx, ny, nz, vtx, vty,
                                                 vtz, dt, mu_s, fc)
    fe = secant_force(normal, delta, fs, k1)
    kr = k if k > 0.0 else k1
    tix, tiy, tiz, tjx, tjy, tjz, mx, my, mz = rolling_torque(
        rolling, hist[h, H_ROLL], hist[h, H_ROLL + 1], hist[h, H_ROLL + 2], nx, ny, nz, wix,
        wiy, wiz, wjx, wjy, wjz, lever_i, lever_j, r_eff, mu_r, fc, fe, kr, eta_r, inv_ir, iso_i,
        iso_j, dt)
    return (fn * nx + ftx, fn * ny + fty, fn * nz + ftz, tix, tiy, tiz, tjx, tjy, tjz,
            sx, sy, sz, d0, mx, my, mz)
