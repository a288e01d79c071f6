"""Velocity Verlet for rigid bodies made of spheres.

One step of length dt (as in LIGGGHTS ``nve/sphere`` and ``rigid``):

1. ``drift``: half kick ``v += dt/2 F/m``, ``L += dt/2 T`` with the forces of the last
   evaluation, then ``x += dt v`` and the free rotation of the orientation over dt; the
   world positions of the spheres are refreshed and their squared displacement since the
   last neighbour build is written for the skin test.
2. forces at the new positions (``forces.py``), with the half-step velocities.
3. ``gather_kick``: sum the pair and wall contributions per body (fixed order, so the
   result does not depend on the number of threads), add gravity and kick again.

Rotation keeps the angular momentum ``L`` in the world frame. A body with equal
principal moments (a sphere) rotates about ``w = L / I`` exactly. A symmetric top (two
equal moments ``I_p``, the third ``I_a`` about its axis ``e``: every two-sphere clump,
such as the paper's unit) also turns exactly, by the closed form of the free symmetric
top (Landau & Lifshitz, Mechanics, §33): ``R(t + dt) = exp(dt [L / I_p]) R(t)
exp(dt W [e_b])`` with ``W = (1/I_a - 1/I_p) L.e``, constant, i.e. a precession about
``L`` at ``|L| / I_p`` and a spin about its own axis at ``W``. Any other body uses the
symplectic splitting of the free rigid body of Dullweber, Leimkuhler & McLachlan (1997,
J. Chem. Phys. 107, 5840): with ``L_b`` in the principal frame, rotations about body
axes 1, 2, 3, 2, 1 over dt/2, dt/2, dt, dt/2, dt/2; each is exact, keeps ``|L|`` and
the world ``L`` unchanged and the scheme keeps the energy error bounded (second order;
the tests check it against the symmetric top's closed form). The moments must be
exactly equal for the closed form; templates built along a symmetry axis give that.
Quaternions are (w, x, y, z) and map body to world. The orientation of a
single-sphere particle does not affect its motion and is not integrated (it stays as
inserted); its angular velocity is always ``L / I``.
"""

import math

from numba import njit


@njit(cache=True, error_model="numpy")
def quat_rotate(q0, q1, q2, q3, x, y, z):
    """R(q) (x, y, z): body-frame vector to world frame."""
    # t = 2 q_v x v ; v' = v + q0 t + q_v x t
    tx = 2.0 * (q2 * z - q3 * y)
    ty = 2.0 * (q3 * x - q1 * z)
    tz = 2.0 * (q1 * y - q2 * x)
    return (x + q0 * tx + (q2 * tz - q3 * ty),
            y + q0 * ty + (q3 * tx - q1 * tz),
            z + q0 * tz + (q1 * ty - q2 * tx))


@njit(cache=True, error_model="numpy")
def quat_rotate_inv(q0, q1, q2, q3, x, y, z):
    """R(q)^T (x, y, z): world-frame vector to body frame."""
    return quat_rotate(q0, -q1, -q2, -q3, x, y, z)


@njit(cache=True, error_model="numpy")
def quat_mul(a0, a1, a2, a3, b0, b1, b2, b3):
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


# 1/(2k (2k + 1)) and 1/((2k - 1) 2k): the ratios of successive Taylor terms of sin, cos
_S1, _S2, _S3 = 1.0 / 6.0, 1.0 / 20.0, 1.0 / 42.0
_C1, _C2, _C3, _C4 = 0.5, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0


@njit(cache=True, error_model="numpy")
def cos_sin(x):
    """``(cos x, sin x)``; Taylor polynomials for |x| < 0.05 (the angle a body turns in
    one step is far below that; truncation < 1e-17 relative), libm otherwise. The
    polynomials multiply by rounded reciprocals: a division in the Horner chain costs
    three times the latency of a multiplication, and the rounding (1e-16 of a term
    below 4e-4) is far under the truncation."""
    if -0.05 < x < 0.05:
        x2 = x * x
        s = x * (1.0 - x2 * _S1 * (1.0 - x2 * _S2 * (1.0 - x2 * _S3)))
        c = 1.0 - x2 * _C1 * (1.0 - x2 * _C2 * (1.0 - x2 * _C3 * (1.0 - x2 * _C4)))
        return c, s
    return math.cos(x), math.sin(x)


@njit(cache=True, error_model="numpy")
def _axis_rotation(k, phi, q0, q1, q2, q3, l0, l1, l2):
    """Free rotation about principal axis k by angle phi: q <- q (x) exp(phi e_k / 2),
    L_b <- R_k(-phi) L_b."""
    c, s = cos_sin(0.5 * phi)
    cf = 1.0 - 2.0 * s * s   # cos(phi)
    sf = 2.0 * s * c         # sin(phi)
    if k == 0:
        q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, c, s, 0.0, 0.0)
        l1, l2 = cf * l1 + sf * l2, -sf * l1 + cf * l2
    elif k == 1:
        q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, c, 0.0, s, 0.0)
        l2, l0 = cf * l2 + sf * l0, -sf * l2 + cf * l0
    else:
        q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, c, 0.0, 0.0, s)
        l0, l1 = cf * l0 + sf * l1, -sf * l0 + cf * l1
    return q0, q1, q2, q3, l0, l1, l2


@njit(cache=True, error_model="numpy")
def symmetry_axis(i0, i1, i2):
    """The principal axis a body is symmetric about: -1 if its three principal moments
    differ, 3 if all are equal (isotropic), else the axis (0, 1, 2) whose moment is the
    odd one out (the other two are exactly equal)."""
    if i0 == i1:
        return 3 if i1 == i2 else 2
    if i1 == i2:
        return 0
    if i0 == i2:
        return 1
    return -1


@njit(cache=True, error_model="numpy")
def _body_axis(q0, q1, q2, q3, k):
    """World direction of principal axis k (column k of R(q))."""
    if k == 0:
        return (1.0 - 2.0 * (q2 * q2 + q3 * q3), 2.0 * (q1 * q2 + q0 * q3),
                2.0 * (q1 * q3 - q0 * q2))
    if k == 1:
        return (2.0 * (q1 * q2 - q0 * q3), 1.0 - 2.0 * (q1 * q1 + q3 * q3),
                2.0 * (q2 * q3 + q0 * q1))
    return (2.0 * (q1 * q3 + q0 * q2), 2.0 * (q2 * q3 - q0 * q1),
            1.0 - 2.0 * (q1 * q1 + q2 * q2))


@njit(cache=True, error_model="numpy")
def _top(q0, q1, q2, q3, lx, ly, lz, i0, i1, i2, k):
    """A symmetric top about principal axis k: its perpendicular moment ``I_p``,
    ``1/I_a - 1/I_p``, ``L.e`` (its spin rate about its own axis is their product, W)
    and the axis ``e`` in the world frame."""
    ia = i0 if k == 0 else (i1 if k == 1 else i2)
    ip = i1 if k == 0 else i0
    ex, ey, ez = _body_axis(q0, q1, q2, q3, k)
    return ip, 1.0 / ia - 1.0 / ip, lx * ex + ly * ey + lz * ez, ex, ey, ez


@njit(cache=True, error_model="numpy")
def angular_velocity(q0, q1, q2, q3, lx, ly, lz, i0, i1, i2):
    """World angular velocity w = R diag(1/I) R^T L."""
    k = symmetry_axis(i0, i1, i2)
    if k == 3:
        return lx / i0, ly / i0, lz / i0
    if k >= 0:
        # symmetric top: w = L / I_p + W e
        ip, dj, le, ex, ey, ez = _top(q0, q1, q2, q3, lx, ly, lz, i0, i1, i2, k)
        w = dj * le
        return lx / ip + w * ex, ly / ip + w * ey, lz / ip + w * ez
    b0, b1, b2 = quat_rotate_inv(q0, q1, q2, q3, lx, ly, lz)
    return quat_rotate(q0, q1, q2, q3, b0 / i0, b1 / i1, b2 / i2)


@njit(cache=True, error_model="numpy")
def _world_rotation(h, wx, wy, wz, q0, q1, q2, q3):
    """q <- exp(h w / 2) (x) q: rotation by the angle |w| h about w, in the world frame."""
    w = math.sqrt(wx * wx + wy * wy + wz * wz)
    if w == 0.0:
        return q0, q1, q2, q3
    ca, sa = cos_sin(0.5 * w * h)
    s = sa / w
    return quat_mul(ca, s * wx, s * wy, s * wz, q0, q1, q2, q3)


@njit(cache=True, error_model="numpy")
def free_rotation(dt, q0, q1, q2, q3, lx, ly, lz, i0, i1, i2):
    """Orientation after a torque-free rotation over dt (see module docstring)."""
    k = symmetry_axis(i0, i1, i2)
    if k == 3:
        q0, q1, q2, q3 = _world_rotation(dt, lx / i0, ly / i0, lz / i0, q0, q1, q2, q3)
    elif k >= 0:
        # symmetric top, exact: R(t) = exp(t [L / I_p]) R(0) exp(t W [e_k]), W constant
        # (module docstring)
        ip, dj, le, _, _, _ = _top(q0, q1, q2, q3, lx, ly, lz, i0, i1, i2, k)
        c, s = cos_sin(0.5 * dt * dj * le)
        if k == 0:
            q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, c, s, 0.0, 0.0)
        elif k == 1:
            q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, c, 0.0, s, 0.0)
        else:
            q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, c, 0.0, 0.0, s)
        q0, q1, q2, q3 = _world_rotation(dt, lx / ip, ly / ip, lz / ip, q0, q1, q2, q3)
    else:
        l0, l1, l2 = quat_rotate_inv(q0, q1, q2, q3, lx, ly, lz)
        h = 0.5 * dt
        q0, q1, q2, q3, l0, l1, l2 = _axis_rotation(0, h * l0 / i0, q0, q1, q2, q3, l0, l1, l2)
        q0, q1, q2, q3, l0, l1, l2 = _axis_rotation(1, h * l1 / i1, q0, q1, q2, q3, l0, l1, l2)
        q0, q1, q2, q3, l0, l1, l2 = _axis_rotation(2, dt * l2 / i2, q0, q1, q2, q3, l0, l1, l2)
        q0, q1, q2, q3, l0, l1, l2 = _axis_rotation(1, h * l1 / i1, q0, q1, q2, q3, l0, l1, l2)
        q0, q1, q2, q3, l0, l1, l2 = _axis_rotation(0, h * l0 / i0, q0, q1, q2, q3, l0, l1, l2)
    n = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return q0 * n, q1 * n, q2 * n, q3 * n


@njit(cache=True, nogil=True, error_model="numpy")
def _displacement(spos, sref, dsq, s, mx):
    """Store sphere s's squared displacement since the last build; return the running max."""
    ex = spos[s, 0] - sref[s, 0]
    ey = spos[s, 1] - sref[s, 1]
    ez = spos[s, 2] - sref[s, 2]
    d = ex * ex + ey * ey + ez * ez
    dsq[s] = d
    if d != d:
        return math.inf
    return d if d > mx else mx


@njit(cache=True, nogil=True, error_model="numpy")
def drift(dt, bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia,
          bfixed, bstart, soffset, spos, sref, dsq, lo, hi):
    """Half kick, drift and rotation of every body; refresh sphere positions.

    Returns the largest squared displacement of a sphere since the last neighbour build
    over the range (infinite if a position is NaN, so the host rebuilds and reports it)."""
    h = 0.5 * dt
    mx = 0.0
    for b in range(lo, hi):
        if bfixed[b]:
            for s in range(bstart[b], bstart[b + 1]):
                dsq[s] = 0.0
            continue
        im = 1.0 / bmass[b]
        for k in range(3):
            bvel[b, k] += h * bforce[b, k] * im
            bangmom[b, k] += h * btorque[b, k]
            bpos[b, k] += dt * bvel[b, k]
        s0 = bstart[b]
        if bstart[b + 1] - s0 == 1:
            # single sphere: isotropic, orientation irrelevant to the physics (not
            # integrated, stays as inserted); w = L / I
            ii = 1.0 / binertia[b, 0]
            bomega[b, 0] = bangmom[b, 0] * ii
            bomega[b, 1] = bangmom[b, 1] * ii
            bomega[b, 2] = bangmom[b, 2] * ii
            for k in range(3):
                spos[s0, k] = bpos[b, k]
            mx = _displacement(spos, sref, dsq, s0, mx)
            continue
        i0 = binertia[b, 0]
        i1 = binertia[b, 1]
        i2 = binertia[b, 2]
        q0, q1, q2, q3 = free_rotation(dt, bquat[b, 0], bquat[b, 1], bquat[b, 2], bquat[b, 3],
                                       bangmom[b, 0], bangmom[b, 1], bangmom[b, 2], i0, i1, i2)
        bquat[b, 0] = q0
        bquat[b, 1] = q1
        bquat[b, 2] = q2
        bquat[b, 3] = q3
        wx, wy, wz = angular_velocity(q0, q1, q2, q3, bangmom[b, 0], bangmom[b, 1],
                                      bangmom[b, 2], i0, i1, i2)
        bomega[b, 0] = wx
        bomega[b, 1] = wy
        bomega[b, 2] = wz
        for s in range(bstart[b], bstart[b + 1]):
            ox = soffset[s, 0]
            oy = soffset[s, 1]
            oz = soffset[s, 2]
            if ox != 0.0 or oy != 0.0 or oz != 0.0:
                ox, oy, oz = quat_rotate(q0, q1, q2, q3, ox, oy, oz)
            spos[s, 0] = bpos[b, 0] + ox
            spos[s, 1] = bpos[b, 1] + oy
            spos[s, 2] = bpos[b, 2] + oz
            mx = _displacement(spos, sref, dsq, s, mx)
    return mx


@njit(cache=True, nogil=True, error_model="numpy")
def gather_kick(dt, gravity, bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                binertia, bfixed, bstart, sacc, kick, lo, hi):
    """Sum the contact forces and torques of each body's spheres (``sacc``, complete
    after ``forces.pair_forces``, ``forces.commit_deferred`` and ``forces.wall_forces``) in
    sphere order, add gravity, half kick (if ``kick``)."""
    h = 0.5 * dt
    for b in range(lo, hi):
        m = bmass[b]
        fx = m * gravity[0]
        fy = m * gravity[1]
        fz = m * gravity[2]
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for s in range(bstart[b], bstart[b + 1]):
            fx += sacc[s, 0]
            fy += sacc[s, 1]
            fz += sacc[s, 2]
            tx += sacc[s, 3]
            ty += sacc[s, 4]
            tz += sacc[s, 5]
        bforce[b, 0] = fx
        bforce[b, 1] = fy
        bforce[b, 2] = fz
        btorque[b, 0] = tx
        btorque[b, 1] = ty
        btorque[b, 2] = tz
        if kick and not bfixed[b]:
            im = 1.0 / m
            bvel[b, 0] += h * fx * im
            bvel[b, 1] += h * fy * im
            bvel[b, 2] += h * fz * im
            bangmom[b, 0] += h * tx
            bangmom[b, 1] += h * ty
            bangmom[b, 2] += h * tz
            wx, wy, wz = angular_velocity(bquat[b, 0], bquat[b, 1], bquat[b, 2], bquat[b, 3],
                                          bangmom[b, 0], bangmom[b, 1], bangmom[b, 2],
                                          binertia[b, 0], binertia[b, 1], binertia[b, 2])
            bomega[b, 0] = wx
            bomega[b, 1] = wy
            bomega[b, 2] = wz
