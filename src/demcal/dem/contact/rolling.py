"""Rolling-resistance sub-models. Each returns the torques on i and on j [N m].

``n`` is the unit contact normal (from j to i), ``w_r = w_i - w_j`` the relative angular
velocity and ``w_t = w_r - (w_r . n) n`` its part in the tangent plane (``w_j`` is 0
against a wall for ``cdt``, the wall's own angular velocity for ``type_c``).

* ``type_a`` / ``constant`` (EDEM standard rolling friction, after Sakaguchi, Ozaki &
  Igarashi 1993; EDEM Creator help, "Standard Rolling Friction Model"):
  ``tau_i = -mu_r Fn R_i w_i/|w_i|`` with R_i the distance from i's centre of mass to
  the contact point (the middle of the overlap) and w_i i's own angular velocity, the
  twisting component included; likewise for j (nothing on a wall). ``Fn`` is the total
  normal force (spring + damping) clipped at 0: EDEM's page does not say which normal
  force it takes (see docs/dem-contact.md).
* ``cdt`` / ``relative`` (LIGGGHTS-PUBLIC 3.8.0 ``rolling_model_cdt.h``, default
  ``torsionTorque off``):
  ``tau_i = -mu_r (k_n delta) R* w_t/|w_r|``, ``tau_j = -tau_i``. Three points fix it:
  the force is the elastic part ``k_n delta`` alone (``fe`` below, see
  ``normal.secant_force``: no damping, not clipped, so a separating contact keeps its
  torque); the torque is formed along the
  full ``w_r`` and its normal (twisting) component removed afterwards, so its size is
  ``mu_r k_n delta R* |w_t|/|w_r|`` (LIGGGHTS' documentation writes ``w_t/|w_t|``; its
  source, which the LIGGGHTS binary runs, divides by ``|w_r|``); the lever is R* for
  a pair and the sphere radius R against a wall (3.8.0 takes ``reff = radi`` there;
  older 3.x releases took the contact radius R - delta/2), with the
  particle's own angular velocity (LIGGGHTS' walls bring no rotation into the rolling
  model).
* ``type_c`` / ``epsd`` (elastic-plastic spring-dashpot, Ai, Chen, Rotter & Ooi 2011,
  Powder Technol. 206, 269-282, their model C; EDEM "Type C Rolling Friction"): rolling
  stiffness ``k_r = 2.25 k_n mu_r^2 R*^2`` (their Eq. 13), spring torque incremented by
  ``-k_r w_t dt`` and capped at ``M_m = mu_r R* Fn`` (Eq. 12, Fn as for type A),
  viscous torque ``-C_r w_t`` with ``C_r = 2 eta_r sqrt(I_r k_r)`` (Eq. 14-15) while the
  spring is below the cap (none once fully mobilised). The spring torque is kept in the
  tangent plane (by the caller, ``hist[h, 4:7]``).
* ``type_a_limited`` / ``constant_limited``: type A's torque with a moment limiter, in
  the form Simcenter STAR-CCM+ documents for its Constant Torque rolling-resistance
  method ("Rolling Resistance", Moment Limiter: the moment is at most a factor 0.08, its
  default, of the moment that would negate the rotation in the next time step). Applied
  to each side's own spin, since type A's torque acts against it:
  ``|tau_i| <= f I_i |w_i| / dt`` with ``I_i`` the body's mean principal moment of
  inertia, i.e. ``tau_i = -min(mu_r Fn R_i / |w_i|, f I_i / dt) w_i``. A torque that
  flips with a vanishing spin every step (type A's chatter on a particle at rest,
  docs/dem-contact.md) becomes a viscous torque that cannot reverse the spin; a particle that
  rolls faster than ``mu_r Fn R_i dt / (f I_i)`` feels type A's torque unchanged.
  With ``f`` = 0.08 a particle needs more than twelve such contacts to have its spin
  reversed in one step.
* ``rvd`` (EDEM Creator help, "RVD Rolling Friction Model", after Zhou et al. 1999; a 3D
  form of Ai et al.'s type A): ``tau_i = -mu_r Fn R* w^_rel`` and ``tau_j = tau_i`` (the
  page's equation, the same torque on both sides, not a reaction), with
  ``w^_rel = n_ij x v_t/|v_t|`` and ``v_t = 1/2 (w_i + w_j) x r_ij`` between particles,
  ``R_i w_i x n_ij`` against a geometry. Since ``n x (a x n)`` is ``a``'s tangential
  part, ``w^_rel`` is the unit vector along the tangential part of ``w_i + w_j`` (of
  ``w_i`` against a wall, whose spin the page leaves out): the torque opposes the
  spins' common rolling and vanishes for two spheres that roll on each other like
  gears (``w_i = -w_j``), where the surfaces do not slip. The page names neither the
  normal force (demcal: as type A, spring + damping clipped at 0) nor R* against a
  geometry (demcal: the sphere radius, R* with an infinite wall radius). The torque a
  wall reports (``sim.wall_forces``) is, as for every model, the reaction -tau_i; EDEM
  leaves rolling torque out of its geometry torque by default.
"""

from numba import njit

from .llvm_math import sqrt
from .declare import FASTMATH, HistoryField, SubModel
from .pairs import ROLLING_DAMPING, ROLLING_FRICTION
from .plane import to_tangent_plane

# ids of the rolling slot
ROLLING_NONE = 0
ROLLING_CONSTANT = 1     # EDEM type A: -mu_r Fn R_i w_i/|w_i|
ROLLING_RELATIVE = 2     # LIGGGHTS 3.8 cdt: -mu_r k_n delta R* w_t/|w_r|
ROLLING_EPSD = 3         # EDEM type C, Ai et al. 2011
ROLLING_LIMITED = 4      # type A with a moment limiter (STAR-CCM+'s constant torque form)
ROLLING_RVD = 5          # EDEM RVD: -mu_r Fn R* unit((w_i + w_j)_t) on both sides

#: the moment limiter's factor: STAR-CCM+'s default "Moment Limiter Factor" (0.08)
MOMENT_LIMITER = 0.08

#: rvd: the tangential part of w_i + w_j counts as none below this share of |w_i + w_j|^2
#: (1e-12 of the length: rounding, not rolling)
RVD_ROUNDING = 1e-24

#: the rolling spring torque [N m] on side i (type C)
ROLLING_SPRING_TORQUE = HistoryField("rolling_spring_torque", "N m", vector=True)

MODELS = (
    SubModel("rolling", "none", ROLLING_NONE),
    SubModel("rolling", "type_a", ROLLING_CONSTANT, aliases=("constant",),
             coefficients=(ROLLING_FRICTION,),
             source="Sakaguchi, Ozaki & Igarashi 1993; EDEM standard rolling friction"),
    SubModel("rolling", "cdt", ROLLING_RELATIVE, aliases=("relative",),
             coefficients=(ROLLING_FRICTION,),
             source="LIGGGHTS-PUBLIC 3.8.0 rolling_model_cdt.h"),
    SubModel("rolling", "type_c", ROLLING_EPSD, aliases=("epsd",),
             coefficients=(ROLLING_FRICTION, ROLLING_DAMPING),
             history=(ROLLING_SPRING_TORQUE,),
             source="Ai, Chen, Rotter & Ooi 2011, model C; EDEM type C rolling friction"),
    SubModel("rolling", "type_a_limited", ROLLING_LIMITED, aliases=("constant_limited",),
             coefficients=(ROLLING_FRICTION,),
             source="EDEM standard rolling friction with the moment limiter of Simcenter "
                    "STAR-CCM+'s Constant Torque method (factor 0.08)"),
    SubModel("rolling", "rvd", ROLLING_RVD, coefficients=(ROLLING_FRICTION,),
             source="EDEM Creator help, RVD Rolling Friction Model (after Zhou et al. 1999)"),
)


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def rolling_torque(model, mx, my, mz, nx, ny, nz, wix, wiy, wiz, wjx, wjy, wjz,
                   lever_i, lever_j, r_eff, mu_r, fn, fe, kn, eta_r, inv_ir, iso_i, iso_j,
                   dt):
    """Rolling torques on i and j and the new EPSD spring torque, given the stored one
    ``m``: ``(tix, tiy, tiz, tjx, tjy, tjz, mx, my, mz)``.

    ``fn`` is the normal force clipped at 0 [N], ``fe`` the elastic ``k_n delta`` of the
    normal slot [N] (``normal.secant_force``), ``kn`` its tangent stiffness [N/m];
    ``r_eff`` is R* for a pair and the sphere radius against a wall [m]; ``iso_i``,
    ``iso_j`` the bodies' mean principal moments of inertia [kg m2] (0 for a wall), which
    only the moment limiter reads."""
    # one exit (no early return), so that loops over contacts can be vectorised
    tix = 0.0
    tiy = 0.0
    tiz = 0.0
    tjx = 0.0
    tjy = 0.0
    tjz = 0.0
    if mu_r <= 0.0:
        pass
    elif model == ROLLING_RELATIVE:
        wrx = wix - wjx
        wry = wiy - wjy
        wrz = wiz - wjz
        wr = sqrt(wrx * wrx + wry * wry + wrz * wrz)
        if not wr <= 0.0:
            # along w_r scaled by 1/|w_r|, then the twisting component dropped
            a = -mu_r * fe * r_eff / wr
            tix = a * wrx
            tiy = a * wry
            tiz = a * wrz
            tn = tix * nx + tiy * ny + tiz * nz
            tix -= tn * nx
            tiy -= tn * ny
            tiz -= tn * nz
            tjx = -tix
            tjy = -tiy
            tjz = -tiz
    elif fn <= 0.0:
        pass
    elif model == ROLLING_CONSTANT or model == ROLLING_LIMITED:
        wi = sqrt(wix * wix + wiy * wiy + wiz * wiz)
        if wi > 0.0:
            a = -mu_r * fn * lever_i / wi
            if model == ROLLING_LIMITED:
                # |tau| = |a| |w|: the cap f I |w| / dt on the torque is f I / dt on |a|
                a = max(a, -MOMENT_LIMITER * iso_i / dt)
            tix = a * wix
            tiy = a * wiy
            tiz = a * wiz
        wj = sqrt(wjx * wjx + wjy * wjy + wjz * wjz)
        if wj > 0.0:
            b = -mu_r * fn * lever_j / wj
            if model == ROLLING_LIMITED:
                b = max(b, -MOMENT_LIMITER * iso_j / dt)
            tjx = b * wjx
            tjy = b * wjy
            tjz = b * wjz
    elif model == ROLLING_EPSD:
        # tangential part of the relative angular velocity (no twisting)
        wrx = wix - wjx
        wry = wiy - wjy
        wrz = wiz - wjz
        wn = wrx * nx + wry * ny + wrz * nz
        wrx -= wn * nx
        wry -= wn * ny
        wrz -= wn * nz
        mx, my, mz = to_tangent_plane(mx, my, mz, nx, ny, nz)
        kr = 2.25 * kn * mu_r * mu_r * r_eff * r_eff
        mx -= kr * wrx * dt
        my -= kr * wry * dt
        mz -= kr * wrz * dt
        mmax = mu_r * r_eff * fn
        m2 = mx * mx + my * my + mz * mz
        tix = mx
        tiy = my
        tiz = mz
        if m2 > mmax * mmax:
            sc = mmax / sqrt(m2)
            mx *= sc
            my *= sc
            mz *= sc
            tix = mx
            tiy = my
            tiz = mz
        elif inv_ir > 0.0:
            cr = 2.0 * eta_r * sqrt(kr / inv_ir)
            tix -= cr * wrx
            tiy -= cr * wry
            tiz -= cr * wrz
        tjx = -tix
        tjy = -tiy
        tjz = -tiz
    elif model == ROLLING_RVD:
        # w^_rel = n_ij x (1/2 (w_i + w_j) x r_ij)/|..| with n_ij and r_ij both from i
        # towards j (r_ij = |r_ij| n_ij, so only its length drops out) is the unit
        # tangential part of w_i + w_j, whichever way n points; wj is 0 against a wall
        ax = wix + wjx
        ay = wiy + wjy
        az = wiz + wjz
        a2 = ax * ax + ay * ay + az * az
        an = ax * nx + ay * ny + az * nz
        ax -= an * nx
        ay -= an * ny
        az -= an * nz
        at2 = ax * ax + ay * ay + az * az
        # a spin about the normal alone leaves a rounding residue of ~1e-16 |a| in the
        # tangent plane, whose unit vector would be a full torque in a random direction
        if at2 > RVD_ROUNDING * a2:
            at = sqrt(at2)
            a = -mu_r * fn * r_eff / at
            tix = a * ax
            tiy = a * ay
            tiz = a * az
            tjx = tix
            tjy = tiy
            tjz = tiz
    return tix, tiy, tiz, tjx, tjy, tjz, mx, my, mz
