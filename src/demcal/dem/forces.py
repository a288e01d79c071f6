"""Contact drivers: loop over the neighbour list and the wall candidates.

Only these loops iterate over contacts (over a range [lo, hi) of spheres, so the host can
split the work between threads); each contact is evaluated by ``contact.kernel.contact``,
which both drivers call with the same levers and slip (:func:`_relative_motion`). Their
first argument, ``chosen`` (:class:`~demcal.dem.contact.chosen.Chosen`), holds the
sub-model ids in its numba type: each combination gets its own compiled loops, in which
the ids are constants.

Where the results go (every sum is taken in a fixed order, so results are bitwise
identical for any number of threads):

* ``sacc[i]`` (per sphere i): the force on i and the torque on body(i) about its centre
  of mass: first the reactions of the slots where i is the j side (in row order), then
  row i's own contacts (summed in row order, added as one number), then i's wall
  contacts. :func:`pair_forces` scatters each reaction as it goes. When the spheres are
  split into chunks between threads, a slot whose j lies in a later chunk is evaluated
  twice, by its row's chunk and, as a *halo slot*, by j's chunk before its own rows,
  which keeps that order; its new history waits in a small buffer until
  :func:`commit_deferred`. :func:`wall_forces` adds the walls;
  ``integrator.gather_kick`` sums per body.
* ``pair_out[p]`` for an active pair slot p = (i, j): the force on i (j gets the
  opposite).
* ``wall_out[q]`` for an active wall slot: the force on the body and the torque on the
  wall about its origin (for :func:`wall_totals`).

Geometry: ``n`` points from j (or the wall) to i, the overlap is
``delta = r_i + r_j - |x_i - x_j|`` (walls: ``r_i - d``), and the contact point is the
middle of the overlap, ``x_c = x_i - (r_i - delta/2) n``. Velocities at the contact point
include the bodies' rotation about their centres of mass; R* = r_i r_j/(r_i + r_j) from
the sphere radii (r_i against a wall), m* from the body masses (m_i against a wall).
"""

from numba import njit

from demcal.geometry.kernels import wall_distance

from .contact.kernel import contact, reset_history, store_history
from .contact.llvm_math import sqrt
from .contact.normal import reach
from .contact.registry import (FASTMATH, H_FLAG, HIST_WIDTH, ROLLING_CONSTANT,
                               ROLLING_EPSD, ROLLING_LIMITED, ROLLING_RELATIVE, ROLLING_RVD)

ACC_WIDTH = 6        # sacc columns: force on the sphere (3), torque on its body (3)
PAIR_OUT_WIDTH = 3   # pair_out columns: force on i
OUT_WIDTH = 6        # wall_out columns: force on the sphere (3), torque on the wall (3)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _relative_motion(rolling, aix, aiy, aiz, ajx, ajy, ajz, vix, viy, viz, wix, wiy, wiz,
                     mi, iso_i, vjx, vjy, vjz, wjx, wjy, wjz, mj, iso_j):
    """Slip of one contact and, for the rolling models that need them, its lever lengths.

    ``a_i`` and ``a_j`` are the levers from i's centre of mass and from j's reference
    point (centre of mass, or a wall's origin) to the contact point; ``v``, ``w`` the
    velocities and angular velocities of the two sides; ``mj`` = 0 for a wall (no rolling
    inertia on that side). Returns the relative velocity of i against j at the contact
    point, the lever lengths and ``1/I_r`` summed over the bodies (``I = iso + m l^2``).
    """
    vrx = (vix + wiy * aiz - wiz * aiy) - (vjx + wjy * ajz - wjz * ajy)
    vry = (viy + wiz * aix - wix * aiz) - (vjy + wjz * ajx - wjx * ajz)
    vrz = (viz + wix * aiy - wiy * aix) - (vjz + wjx * ajy - wjy * ajx)
    li = 0.0
    lj = 0.0
    inv_ir = 0.0
    if rolling == ROLLING_CONSTANT or rolling == ROLLING_EPSD or rolling == ROLLING_LIMITED:
        li = sqrt(aix * aix + aiy * aiy + aiz * aiz)
        inv_ir = 1.0 / (iso_i + mi * li * li)
        if mj > 0.0:
            lj = sqrt(ajx * ajx + ajy * ajy + ajz * ajz)
            inv_ir += 1.0 / (iso_j + mj * lj * lj)
    return vrx, vry, vrz, li, lj, inv_ir


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def separation(xi, yi, zi, ri, j, spos, srad):
    """The gap of sphere i (at x_i, radius r_i [m]) to sphere j, as :func:`pair_contact`
    takes it: ``(j, r_j, r_i + r_j, |d|^2, d (3), x_j (3))`` with ``d = x_i - x_j``."""
    rj = srad[j]
    xj = spos[j, 0]
    yj = spos[j, 1]
    zj = spos[j, 2]
    dx = xi - xj
    dy = yi - yj
    dz = zi - zj
    rs = ri + rj
    return j, rj, rs, dx * dx + dy * dy + dz * dz, dx, dy, dz, xj, yj, zj


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def apart(gap, held, normal, table, mati, ri, sbody, bmat):
    """Whether the pair of :func:`separation`'s ``gap`` is apart: not overlapping, and
    not a contact that ``held`` at the last step whose gap is still within the normal
    sub-model's reach (0 for all but the cohesive ones)."""
    j, rj, rs, d2 = gap[0], gap[1], gap[2], gap[3]
    return d2 >= rs * rs and not (held and d2 < (rs + reach(
        normal, table, mati, bmat[sbody[j]], ri * rj / rs)) ** 2)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def pair_contact(normal, damping, tangential, rolling, table, dt, hist, p, side_i, gap,
                 sbody, bpos, bvel, bomega, bmass, biso, bmat):
    """One touching pair slot p = (i, j) (every driver's, CPU and GPU alike).

    ``side_i`` is i's side as the driver holds it: ``(r_i, o_i (3), v_i (3), w_i (3), m_i,
    iso_i, mat_i)``, the sphere's radius, its centre relative to its body's centre of
    mass, its body's velocity, spin, mass, rolling inertia and material; ``gap`` is
    ``(j, r_j, r_i + r_j, |d|^2, d (3), x_j (3))`` with the separation ``d = x_i - x_j``,
    ``|d|^2 < (r_i + r_j)^2`` (or within the normal sub-model's reach). (Two tuples: a
    call of more than 30 arguments compiles to a ``*args`` call, which numba cannot
    inline.) Returns the force on i
    [N], the torque terms it adds to i's body and to j's body about their centres of
    mass [N m] (lever x force plus the rolling torque), and the new history row (as
    ``contact.kernel.contact`` returns it, for the driver to store)."""
    ri, oix, oiy, oiz, vix, viy, viz, wix, wiy, wiz, mi, iso_i, mati = side_i
    j, rj, rs, d2, dx, dy, dz, xj, yj, zj = gap
    bj = sbody[j]
    mj = bmass[bj]
    d = sqrt(d2)
    inv_d = 1.0 / d
    delta = rs - d
    nx = dx * inv_d
    ny = dy * inv_d
    nz = dz * inv_d
    # levers to the middle of the overlap: x_c = x_i - a n = x_j + b n
    a = ri - 0.5 * delta
    b = rj - 0.5 * delta
    aix = oix - a * nx
    aiy = oiy - a * ny
    aiz = oiz - a * nz
    ajx = (xj - bpos[bj, 0]) + b * nx
    ajy = (yj - bpos[bj, 1]) + b * ny
    ajz = (zj - bpos[bj, 2]) + b * nz
    wjx = bomega[bj, 0]
    wjy = bomega[bj, 1]
    wjz = bomega[bj, 2]
    vrx, vry, vrz, li, lj, inv_ir = _relative_motion(
        rolling, aix, aiy, aiz, ajx, ajy, ajz, vix, viy, viz, wix, wiy, wiz, mi,
        iso_i, bvel[bj, 0], bvel[bj, 1], bvel[bj, 2], wjx, wjy, wjz, mj, biso[bj])
    (fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz,
     h0, h1, h2, h3, h4, h5, h6) = contact(
        normal, damping, tangential, rolling, table, mati, bmat[bj], hist, p, delta,
        nx, ny, nz, vrx, vry, vrz, wix, wiy, wiz, wjx, wjy, wjz,
        li, lj, ri * rj / rs, mi * mj / (mi + mj), inv_ir, iso_i, biso[bj], dt)
    return (fx, fy, fz,
            aiy * fz - aiz * fy + tix, aiz * fx - aix * fz + tiy, aix * fy - aiy * fx + tiz,
            -(ajy * fz - ajz * fy) + tjx, -(ajz * fx - ajx * fz) + tjy,
            -(ajx * fy - ajy * fx) + tjz, h0, h1, h2, h3, h4, h5, h6)


@njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH)
def pair_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                biso, bmat, row_start, nbr, hist, pair_out, active, sacc,
                halo_row, halo_slots, halo_slot, r0, r1, deferred, k0, lo, hi):
    """Pair contacts acting on spheres [lo, hi) (one chunk of a split; [0, n) unsplit).

    ``sacc[lo:hi]`` is set here: first the halo rows ``r0 <= r < r1`` (rows of earlier
    chunks, restricted to their slots ``halo_slot[halo_slots[r]:halo_slots[r + 1]]``
    whose j side is in this chunk) give those spheres their reactions, then rows
    [lo, hi) add their own sums and scatter their reactions within the chunk. A slot
    whose j side is in a later chunk is evaluated here and again, from the same inputs
    and by this same compiled loop, as a halo slot of that chunk; its new history goes
    to ``deferred[k]`` (k counting such slots from ``k0`` in slot order) for
    :func:`commit_deferred`, so that ``hist`` holds the step's old values until every
    chunk has read them. ``pair_out[p]`` gets the force on i of each active slot.
    ``biso[b]`` is the mean principal moment of inertia of body b (rolling inertia).
    """
    normal = chosen.normal
    damping = chosen.damping
    tangential = chosen.tangential
    rolling = chosen.rolling
    for i in range(lo, hi):
        for k in range(ACC_WIDTH):
            sacc[i, k] = 0.0
    k = k0
    for r in range(r0, r1 + hi - lo):
        halo = r < r1
        if halo:
            i = halo_row[r]
            t0 = halo_slots[r]
            t1 = halo_slots[r + 1]
        else:
            i = lo + (r - r1)
            t0 = row_start[i]
            t1 = row_start[i + 1]
        bi = sbody[i]
        ri = srad[i]
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        # sphere centre relative to its body's centre of mass (zero for a sphere)
        oix = xi - bpos[bi, 0]
        oiy = yi - bpos[bi, 1]
        oiz = zi - bpos[bi, 2]
        vix = bvel[bi, 0]
        viy = bvel[bi, 1]
        viz = bvel[bi, 2]
        wix = bomega[bi, 0]
        wiy = bomega[bi, 1]
        wiz = bomega[bi, 2]
        mi = bmass[bi]
        iso_i = biso[bi]
        mati = bmat[bi]
        fsx = 0.0
        fsy = 0.0
        fsz = 0.0
        tsx = 0.0
        tsy = 0.0
        tsz = 0.0
        for t in range(t0, t1):
            p = halo_slot[t] if halo else t
            j = nbr[p]
            here = j < hi   # the j side is in this chunk (halo slots always are)
            gap = separation(xi, yi, zi, ri, j, spos, srad)
            if apart(gap, active[p], normal, table, mati, ri, sbody, bmat):
                if not halo:
                    if not here:
                        reset_history(deferred, k)
                        k += 1
                    elif active[p]:
                        reset_history(hist, p)
                        active[p] = False
                continue
            (fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz,
             h0, h1, h2, h3, h4, h5, h6) = pair_contact(
                normal, damping, tangential, rolling, table, dt, hist, p,
                (ri, oix, oiy, oiz, vix, viy, viz, wix, wiy, wiz, mi, iso_i, mati), gap,
                sbody, bpos, bvel, bomega, bmass, biso, bmat)
            # a halo row's own sums are dropped below; the code that computes them is
            # the owner's, so both evaluate the contact with the same instructions
            fsx += fx
            fsy += fy
            fsz += fz
            tsx += tix
            tsy += tiy
            tsz += tiz
            if not halo:
                if here:
                    store_history(hist, p, h0, h1, h2, h3, h4, h5, h6)
                    active[p] = True
                else:
                    store_history(deferred, k, h0, h1, h2, h3, h4, h5, h6)
                    k += 1
                pair_out[p, 0] = fx
                pair_out[p, 1] = fy
                pair_out[p, 2] = fz
            if here:
                sacc[j, 0] -= fx
                sacc[j, 1] -= fy
                sacc[j, 2] -= fz
                sacc[j, 3] += tjx
                sacc[j, 4] += tjy
                sacc[j, 5] += tjz
        if not halo:
            sacc[i, 0] += fsx
            sacc[i, 1] += fsy
            sacc[i, 2] += fsz
            sacc[i, 3] += tsx
            sacc[i, 4] += tsy
            sacc[i, 5] += tsz


@njit(cache=True, nogil=True, error_model="numpy")
def commit_deferred(hist, active, deferred, halo_slot, halo_deferred, t0, t1):
    """After every chunk's :func:`pair_forces`: store the new history of the halo slots
    ``t0 <= t < t1`` (slot ``halo_slot[t]``, written to ``deferred[halo_deferred[t]]``
    by the chunk that owns its row) and mark them touching or open."""
    for t in range(t0, t1):
        p = halo_slot[t]
        k = halo_deferred[t]
        for c in range(HIST_WIDTH):
            hist[p, c] = deferred[k, c]
        active[p] = deferred[k, H_FLAG] != 0.0


@njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH)
def wall_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                biso, bmat, wall_start, wid, whist, wall_out, wactive, sacc,
                wkind, wparams, wvel, womega, worigin, wmat, lo, hi):
    """Wall contacts of spheres [lo, hi); adds to ``sacc`` (after :func:`pair_forces`)."""
    normal = chosen.normal
    damping = chosen.damping
    tangential = chosen.tangential
    rolling = chosen.rolling
    for i in range(lo, hi):
        q0 = wall_start[i]
        q1 = wall_start[i + 1]
        if q0 == q1:
            continue
        bi = sbody[i]
        ri = srad[i]
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        oix = xi - bpos[bi, 0]
        oiy = yi - bpos[bi, 1]
        oiz = zi - bpos[bi, 2]
        mi = bmass[bi]
        for q in range(q0, q1):
            w = wid[q]
            d, nx, ny, nz = wall_distance(wkind[w], wparams[w], xi, yi, zi)
            delta = ri - d
            if delta <= 0.0 and not (wactive[q] and
                                     delta > -reach(normal, table, bmat[bi], wmat[w], ri)):
                if wactive[q]:
                    reset_history(whist, q)
                    wactive[q] = False
                continue
            a = ri - 0.5 * delta
            aix = oix - a * nx
            aiy = oiy - a * ny
            aiz = oiz - a * nz
            ajx = (xi - worigin[w, 0]) - a * nx
            ajy = (yi - worigin[w, 1]) - a * ny
            ajz = (zi - worigin[w, 2]) - a * nz
            wix = bomega[bi, 0]
            wiy = bomega[bi, 1]
            wiz = bomega[bi, 2]
            vrx, vry, vrz, li, _, inv_ir = _relative_motion(
                rolling, aix, aiy, aiz, ajx, ajy, ajz, bvel[bi, 0], bvel[bi, 1], bvel[bi, 2],
                wix, wiy, wiz, mi, biso[bi], wvel[w, 0], wvel[w, 1], wvel[w, 2],
                womega[w, 0], womega[w, 1], womega[w, 2], 0.0, 0.0)
            # the wall's spin as the rolling model sees it: none for cdt, which takes
            # the particle's own angular velocity against a wall (as LIGGGHTS does), nor
            # for rvd (EDEM's particle-geometry v_t is R_i w_i x n_ij)
            wwx = womega[w, 0]
            wwy = womega[w, 1]
            wwz = womega[w, 2]
            if rolling == ROLLING_RELATIVE or rolling == ROLLING_RVD:
                wwx = 0.0
                wwy = 0.0
                wwz = 0.0
            fx, fy, fz, tix, tiy, tiz, _, _, _, h0, h1, h2, h3, h4, h5, h6 = contact(
                normal, damping, tangential, rolling, table, bmat[bi], wmat[w], whist, q,
                delta, nx, ny, nz, vrx, vry, vrz, wix, wiy, wiz, wwx, wwy, wwz, li, 0.0, ri,
                mi, inv_ir, biso[bi], 0.0, dt)
            store_history(whist, q, h0, h1, h2, h3, h4, h5, h6)
            wactive[q] = True
            sacc[i, 0] += fx
            sacc[i, 1] += fy
            sacc[i, 2] += fz
            sacc[i, 3] += aiy * fz - aiz * fy + tix
            sacc[i, 4] += aiz * fx - aix * fz + tiy
            sacc[i, 5] += aix * fy - aiy * fx + tiz
            # the wall takes the moment of -F about its origin and the reaction of i's
            # rolling torque
            wall_out[q, 0] = fx
            wall_out[q, 1] = fy
            wall_out[q, 2] = fz
            wall_out[q, 3] = -(ajy * fz - ajz * fy) - tix
            wall_out[q, 4] = -(ajz * fx - ajx * fz) - tiy
            wall_out[q, 5] = -(ajx * fy - ajy * fx) - tiz


@njit(cache=True, error_model="numpy")
def wall_totals(wall_start, wid, wall_out, wactive, nw, out):
    """Force and torque per wall row, ``out[w] = (F, T about origin)``, fixed order."""
    for w in range(nw):
        for k in range(6):
            out[w, k] = 0.0
    ns = wall_start.shape[0] - 1
    for q in range(wall_start[ns]):
        if not wactive[q]:
            continue
        w = wid[q]
        out[w, 0] -= wall_out[q, 0]
        out[w, 1] -= wall_out[q, 1]
        out[w, 2] -= wall_out[q, 2]
        out[w, 3] += wall_out[q, 3]
        out[w, 4] += wall_out[q, 4]
        out[w, 5] += wall_out[q, 5]
