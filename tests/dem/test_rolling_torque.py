"""Each rolling model's torque on one contact, computed by hand from its definition.

Two fixed spheres (fixed bodies keep their positions, velocities and spins, so one step
evaluates the contact at exactly the given state), or one fixed sphere on a wall. The
sliding friction is 0, so the torque on a sphere is its rolling torque alone (the normal
force passes through the centres). Hertz-Mindlin unless said otherwise; ``n`` is the unit
normal from j to i, ``w_r = w_i - w_j``, ``w_t = w_r - (w_r . n) n``.

* ``cdt``, LIGGGHTS-PUBLIC 3.8.0 ``rolling_model_cdt.h`` (``torsionTorque off``, its
  default): ``tau_i = -mu_r k_n delta R* w_t/|w_r|``, ``tau_j = -tau_i``, with
  ``k_n delta = 4/3 E* sqrt(R*) delta^1.5`` (``normal_model_hertz.h``: ``kn = 4/3 Yeff
  sqrt(R* delta)``); against a wall R* is the sphere radius R (``reff = radi``) and the
  spin is the particle's own. Each of the three points is tested where it matters: a
  damping force (the contact is approaching or separating: the torque stays the same),
  a twisting component (w_r . n is 0.87 |w_r| here; twisting alone gives no torque), and
  the lever against a wall. For the Hysteretic Spring, which LIGGGHTS lacks, k_n is the
  loading stiffness K1 (its ``hooke/hysteresis`` passes the loading stiffness as ``kn``).
* ``type_a``, EDEM standard rolling friction: ``tau_i = -mu_r Fn R_i w_i/|w_i|`` with
  Fn = max(spring + damping, 0) and R_i = r_i - delta/2 (centre to the middle of the
  overlap); likewise for j.
* ``type_c``, Ai et al. 2011 model C (Powder Technol. 206, 269, Eq. 12-15): from a
  relaxed spring, one evaluation of the contact kernel gives ``M = -k_r w_t dt``
  (below the cap mu_r R* Fn) and ``tau_i = M - C_r w_t`` with
  ``k_r = 2.25 S_n mu_r^2 R*^2`` (S_n = 2 E* sqrt(R* delta), the Hertz tangent
  stiffness), ``C_r = 2 eta_r sqrt(I_r k_r)`` and
  ``1/I_r = 1/(I_i + m_i R_i^2) + 1/(I_j + m_j R_j^2)``.
* ``type_a_limited``: type A's torque (EDEM standard rolling friction, above) with the
  moment limiter of Simcenter STAR-CCM+'s Constant Torque method (STAR-CCM+ theory guide,
  "Rolling Resistance", Constant Torque Method: the moment is at most the Moment Limiter
  Factor, default 0.08, times the moment that negates the rotation in the next time
  step), applied to each side's own spin: ``|tau_i| <= f I_i |w_i| / dt`` with I_i the
  body's mean principal moment of inertia, i.e. ``tau_i = -min(mu_r Fn R_i / |w_i|,
  f I_i / dt) w_i``; likewise for j, and nothing on a wall (I_j = 0). A spin above
  ``mu_r Fn R_i dt / (f I_i)`` (0.04 rad/s for i here) feels type A's torque bit for
  bit; one below it a viscous torque ``-f I_i w_i / dt``.
* ``rvd``, EDEM's RVD rolling friction (EDEM Creator help, "RVD Rolling Friction
  Model"): ``tau_i = -mu_r Fn R* w^_rel``, ``tau_j = tau_i``, ``w^_rel = n_ij x v_t /
  |v_t|`` with ``v_t = 1/2 (w_i + w_j) x r_ij`` (pair) or ``R_i w_i x n_ij`` (geometry),
  i.e. the unit tangential part of ``w_i + w_j`` (of ``w_i`` on a wall); Fn as type A's,
  the lever R* for a pair and R_i on a wall.

The pair and the floor below were also run in LIGGGHTS-PUBLIC 3.8.0 (Debian
3.8.0+repack1, ``liggghts -in``), same numbers, ``run 0`` and a dump of the torques::

    atom_style sphere
    atom_modify map array
    boundary f f f
    newton off
    communicate single vel yes
    units si
    read_data pair.data    # i: d 0.01, rho 2500, x = 0.0079 (2, -1, 2)/3,
                           #    v (-0.02, 0.01, -0.03), w (30, -10, 20);
                           # j: d 0.006, x = 0, v (0.01, 0, 0.02), w (-5, 15, 10)
    fix m1 all property/global youngsModulus peratomtype 2.6e7 2.6e7
    fix m2 all property/global poissonsRatio peratomtype 0.3 0.3
    fix m3 all property/global coefficientRestitution peratomtypepair 2 0.3 0.3 0.3 0.3
    fix m4 all property/global coefficientFriction peratomtypepair 2 0.0 0.0 0.0 0.0
    fix m5 all property/global coefficientRollingFriction peratomtypepair 2 0.1 0.1 0.1 0.1
    pair_style gran model hertz tangential history rolling_friction cdt tangential_damping off
    pair_coeff * *
    neighbor 0.002 bin
    timestep 1e-7
    fix integr all nve/sphere
    dump d all custom 1 pair.dump id tqx tqy tqz
    # (tangential_damping off: run 0 does not update the shear history, so LIGGGHTS
    # would add the tangential dashpot with mu_s = 0; demcal scales it away)
    # floor case: one sphere d 0.01 at z = 0.0049, v (0.01, 0, -0.02), w (20, -30, 40) and
    # fix floor all wall/gran model hertz tangential history rolling_friction cdt &
    #     primitive type 2 zplane 0.0 tangential_damping off
    run 0
    # dump columns id tqx tqy tqz, pair approaching:
    # 1 -3.3075141838780729e-05 4.2803124732539764e-05 5.4476704205050607e-05
    # 2 3.3075141838780729e-05 -4.2803124732539764e-05 -5.4476704205050607e-05
    # pair separating at 1 m/s along n (total normal force -0.283 N): the same torques
    # floor:
    # 1 -0.00025010749116137726 0.00037516123674206583 0
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.dem.contact.kernel import HIST_WIDTH, H_DELTA0, contact
from demcal.dem.contact.registry import DAMPING, NORMAL, ROLLING, TANGENTIAL
from demcal.dem.contact.rolling import MOMENT_LIMITER
from demcal.geometry import Cylinder, WallSet
from demcal.geometry.motion import Rotation
from demcal.dem.contact.table import pair_table
from demcal.particles.materials import Interaction, MaterialTable

from dem_helpers import SOFT, SOFT_WALL, floor

MU_R = 0.1
E = 0.3
INTER = Interaction(restitution=E, static_friction=0.0, rolling_friction=MU_R)
R_I, R_J = 0.005, 0.003
DELTA = 1.0e-4
N = np.array([2.0, -1.0, 2.0]) / 3.0
W_I = np.array([30.0, -10.0, 20.0])
W_J = np.array([-5.0, 15.0, 10.0])
V_J = np.array([0.01, 0.0, 0.02])
APPROACH = np.array([-0.02, 0.01, -0.03])   # v_i: v_n = -0.0567 m/s
SEPARATE = V_J + 1.0 * N                      # v_i: v_n = +1 m/s
#: LIGGGHTS-PUBLIC 3.8.0's torque on i (module docstring)
LIGGGHTS_PAIR = np.array([-3.3075141838780729e-05, 4.2803124732539764e-05,
                          5.4476704205050607e-05])
LIGGGHTS_FLOOR = np.array([-0.00025010749116137726, 0.00037516123674206583, 0.0])
REL = 1e-10

E_STAR = 1.0 / (2.0 * (1.0 - SOFT.poisson_ratio ** 2) / SOFT.youngs_modulus)
BETA = math.log(E) / math.sqrt(math.log(E) ** 2 + math.pi ** 2)


def mass(r):
    return 4.0 / 3.0 * math.pi * r ** 3 * SOFT.density


def hertz(r_eff, delta):
    """(k_n delta, S_n): Hertz spring force [N] and tangent stiffness [N/m]."""
    return (4.0 / 3.0 * E_STAR * math.sqrt(r_eff) * delta ** 1.5,
            2.0 * E_STAR * math.sqrt(r_eff * delta))


#: the pair's reduced mass m* [kg]
M_EFF = mass(R_I) * mass(R_J) / (mass(R_I) + mass(R_J))


def tangential(w):
    return w - (w @ N) * N


def pair(rolling, v_i, w_i=W_I, w_j=W_J, model="hertz_mindlin"):
    """Torques on i and j and the force on i after one step of the fixed pair."""
    sim = Simulation([SOFT, SOFT_WALL], INTER, gravity=(0, 0, 0), dt=1e-7,
                     contact_model=model, rolling_model=rolling)
    sim.add_particles(R_I, [(R_I + R_J - DELTA) * N], velocities=[v_i],
                      angular_velocities=[w_i], fixed=True)
    sim.add_particles(R_J, [[0.0, 0.0, 0.0]], velocities=[V_J], angular_velocities=[w_j],
                      fixed=True)
    sim.run(steps=1)
    return sim.state.torques[0].copy(), sim.state.torques[1].copy(), sim.state.forces[0].copy()


def cdt_pair_torque(fe, w_i=W_I, w_j=W_J):
    w_r = w_i - w_j
    return -MU_R * fe * (R_I * R_J / (R_I + R_J)) * tangential(w_r) / np.linalg.norm(w_r)


def test_cdt_pair_takes_the_elastic_force_and_drops_twisting():
    fe, sn = hertz(R_I * R_J / (R_I + R_J), DELTA)
    ti, tj, f = pair("cdt", APPROACH)
    expected = cdt_pair_torque(fe)
    assert ti == pytest.approx(expected, rel=REL)
    assert tj == pytest.approx(-expected, rel=REL)
    assert ti == pytest.approx(LIGGGHTS_PAIR, rel=1e-12)
    # the test means something: the contact's normal force carries a damping part the
    # torque must not see, and the twisting part of w_r is large
    m_eff = M_EFF
    vn = (APPROACH - V_J) @ N
    fd = 2.0 * math.sqrt(5.0 / 6.0) * BETA * math.sqrt(sn * m_eff) * vn
    assert f == pytest.approx((fe + fd) * N, rel=REL)
    assert fd > 0.05 * fe
    w_r = W_I - W_J
    assert abs(w_r @ N) > 0.8 * np.linalg.norm(w_r)


def test_cdt_torque_does_not_depend_on_the_normal_velocity():
    """A separating contact (total normal force < 0) keeps the elastic torque, as in
    LIGGGHTS; type A, which takes max(Fn, 0), has none."""
    fe, _ = hertz(R_I * R_J / (R_I + R_J), DELTA)
    ti, tj, f = pair("cdt", SEPARATE)
    assert f @ N < 0.0
    assert ti == pytest.approx(cdt_pair_torque(fe), rel=REL)
    assert ti == pytest.approx(LIGGGHTS_PAIR, rel=1e-12)
    ta, tb, _ = pair("type_a", SEPARATE)
    assert np.abs(ta).max() < 1e-12 * fe * R_I and np.abs(tb).max() < 1e-12 * fe * R_I


def test_cdt_twisting_alone_gives_no_torque():
    ti, tj, _ = pair("cdt", APPROACH, w_i=W_J + 40.0 * N)
    assert np.abs(ti).max() < 1e-12 * hertz(R_I, DELTA)[0] * R_I
    assert np.abs(tj).max() < 1e-12 * hertz(R_I, DELTA)[0] * R_I


def type_a_fn():
    """Type A's normal force for the approaching pair: spring + Tsuji damping."""
    fe, sn = hertz(R_I * R_J / (R_I + R_J), DELTA)
    return fe + 2.0 * math.sqrt(5.0 / 6.0) * BETA * math.sqrt(sn * M_EFF) * ((APPROACH - V_J) @ N)


def test_type_a_pair_torque():
    """EDEM standard: each body's own spin and lever, Fn with its damping part."""
    fn = type_a_fn()
    ti, tj, _ = pair("type_a", APPROACH)
    assert ti == pytest.approx(-MU_R * fn * (R_I - DELTA / 2) * W_I / np.linalg.norm(W_I),
                               rel=REL)
    assert tj == pytest.approx(-MU_R * fn * (R_J - DELTA / 2) * W_J / np.linalg.norm(W_J),
                               rel=REL)


def test_type_c_first_step_torque():
    """Ai et al. 2011 model C from a relaxed spring: spring increment plus dashpot (the
    kernel itself, so that exactly one increment is taken)."""
    r_eff = R_I * R_J / (R_I + R_J)
    _, sn = hertz(r_eff, DELTA)
    dt = 1e-7
    k_r = 2.25 * sn * MU_R ** 2 * r_eff ** 2
    w_t = tangential(W_I - W_J)
    inertia = [0.4 * mass(r) * r * r + mass(r) * (r - DELTA / 2) ** 2 for r in (R_I, R_J)]
    inv_ir = 1.0 / inertia[0] + 1.0 / inertia[1]
    c_r = 2.0 * INTER.rolling_damping * math.sqrt(k_r / inv_ir)
    spring = -k_r * w_t * dt
    m_eff = M_EFF
    out = contact(NORMAL["hertz"], DAMPING["tsuji"], TANGENTIAL["mindlin"], ROLLING["type_c"],
                  pair_table(MaterialTable([SOFT], INTER)), 0, 0, np.zeros((1, HIST_WIDTH)), 0,
                  DELTA, *N, *(APPROACH - V_J), *W_I, *W_J, R_I - DELTA / 2,
                  R_J - DELTA / 2, r_eff, m_eff, inv_ir, 0.0, 0.0, dt)
    assert np.array(out[3:6]) == pytest.approx(spring - c_r * w_t, rel=REL)
    assert np.array(out[6:9]) == pytest.approx(-(spring - c_r * w_t), rel=REL)
    assert np.array(out[13:16]) == pytest.approx(spring, rel=REL)   # the stored spring


def on_floor(rolling, w=(20.0, -30.0, 40.0)):
    sim = Simulation([SOFT, SOFT_WALL], INTER, walls=floor(), gravity=(0, 0, 0), dt=1e-7,
                     rolling_model=rolling)
    sim.add_particles(R_I, [[0.0, 0.0, R_I - DELTA]], velocities=[[0.01, 0.0, -0.02]],
                      angular_velocities=[w], fixed=True)
    sim.run(steps=1)
    return sim.state.torques[0].copy()


def test_cdt_wall_lever_is_the_sphere_radius():
    """LIGGGHTS 3.8.0: reff = radi against a wall (older 3.x releases took the contact
    radius R - delta/2, which is 1 % smaller here)."""
    w = np.array([20.0, -30.0, 40.0])
    fe, _ = hertz(R_I, DELTA)
    expected = -MU_R * fe * R_I * np.array([w[0], w[1], 0.0]) / np.linalg.norm(w)
    t = on_floor("cdt")
    assert t == pytest.approx(expected, rel=REL, abs=1e-15 * abs(expected).max())
    assert t == pytest.approx(LIGGGHTS_FLOOR, rel=1e-12, abs=1e-15 * abs(expected).max())


DRUM_SPIN = np.array([5.0, 3.0, 2.0])


def in_drum(rolling):
    """Torque on a fixed sphere (spin ``DRUM_SPIN``) lying on the inside of a drum that
    turns about its own axis x at 10 rad/s: the drum's spin lies in the contact plane."""
    r_drum = 0.02
    drum = WallSet([Cylinder(base=(-0.05, 0, 0), axis=(1, 0, 0), radius=r_drum, length=0.1,
                             material=1, name="drum",
                             motion=Rotation(point=(0, 0, 0), axis=(1, 0, 0),
                                             angular_speed=10.0))])
    sim = Simulation([SOFT, SOFT_WALL], INTER, walls=drum, gravity=(0, 0, 0), dt=1e-7,
                     rolling_model=rolling)
    sim.add_particles(R_I, [[0.0, 0.0, -(r_drum - R_I + DELTA)]],
                      angular_velocities=[DRUM_SPIN], fixed=True)
    sim.run(steps=1)
    return sim.state.torques[0].copy()


def test_cdt_does_not_see_a_wall_spin():
    """LIGGGHTS' cdt forms the torque from the particle's spin alone."""
    w = DRUM_SPIN
    fe, _ = hertz(R_I, DELTA)
    expected = -MU_R * fe * R_I * np.array([w[0], w[1], 0.0]) / np.linalg.norm(w)
    t = in_drum("cdt")
    assert t == pytest.approx(expected, rel=REL, abs=1e-15 * abs(expected).max())


def rvd_expected(fn, r_eff, a):
    """EDEM's RVD torque on i from the spins' sum ``a``, computed as the page writes
    it: n x v_t / |v_t| with v_t = 1/2 a x r_ij (r_ij along the normal)."""
    r_ij = -(R_I + R_J - DELTA) * N          # from i's centre to j's
    v_t = 0.5 * np.cross(a, r_ij)
    n_ij = -N                                 # from i towards the contact point
    w_rel = np.cross(n_ij, v_t) / np.linalg.norm(v_t)
    return -MU_R * fn * r_eff * w_rel


def test_rvd_pair_torque_is_the_same_on_both_sides():
    fn = type_a_fn()
    r_eff = R_I * R_J / (R_I + R_J)
    ti, tj, _ = pair("rvd", APPROACH)
    expected = rvd_expected(fn, r_eff, W_I + W_J)
    assert ti == pytest.approx(expected, rel=REL)
    assert tj == pytest.approx(expected, rel=REL)
    # the page's unit vector is the tangential part of w_i + w_j, made unit; the twist
    # it drops is most of w_i + w_j here, so keeping it would fail the checks above
    a_t = tangential(W_I + W_J)
    assert ti == pytest.approx(-MU_R * fn * r_eff * a_t / np.linalg.norm(a_t), rel=REL)
    assert np.linalg.norm(a_t) < 0.5 * np.linalg.norm(W_I + W_J)


def test_rvd_gears_and_twisting_give_no_torque():
    """Spheres rolling on each other like gears (w_j = -w_i: the surfaces do not slip)
    or twisting about the normal feel no RVD torque; co-rotating ones do."""
    scale = hertz(R_I, DELTA)[0] * R_I
    for w_j in (-W_I, -W_I + 25.0 * N):
        ti, tj, _ = pair("rvd", APPROACH, w_i=W_I, w_j=w_j)
        assert np.abs(ti).max() < 1e-12 * scale and np.abs(tj).max() < 1e-12 * scale
    ti, _, _ = pair("rvd", APPROACH, w_i=W_I, w_j=W_I)
    assert np.linalg.norm(ti) == pytest.approx(MU_R * type_a_fn() * R_I * R_J / (R_I + R_J),
                                               rel=REL)


def test_rvd_on_a_wall_takes_the_particle_spin_and_its_radius():
    """Particle-geometry: v_t = R_i w_i x n_ij, the lever the sphere radius; a turning
    drum's spin is not seen (the page's v_t has no wall term)."""
    w = np.array([20.0, -30.0, 40.0])
    fe, sn = hertz(R_I, DELTA)
    fn = fe + 2.0 * math.sqrt(5.0 / 6.0) * BETA * math.sqrt(sn * mass(R_I)) * -0.02
    expected = -MU_R * fn * R_I * np.array([w[0], w[1], 0.0]) / np.linalg.norm(w[:2])
    t = on_floor("rvd")
    assert t == pytest.approx(expected, rel=REL, abs=1e-15 * abs(expected).max())
    w = DRUM_SPIN
    t = in_drum("rvd")
    assert t[2] == pytest.approx(0.0, abs=1e-15)
    assert t[:2] / np.linalg.norm(t[:2]) == pytest.approx(-w[:2] / np.linalg.norm(w[:2]),
                                                          rel=1e-12)


def test_cdt_hysteretic_spring_takes_k1_delta():
    """Unloading branch of the Hysteretic Spring: the spring force K2 (delta - delta0)
    is half of K1 delta here; cdt takes K1 delta, type A (and type_a_limited, whose
    limiter does not bind here) the force with its damping."""
    mats = MaterialTable([SOFT, SOFT_WALL],
                         Interaction(restitution=E, static_friction=0.0,
                                     rolling_friction=MU_R, damping_factor=0.2))
    r_eff = R_I * R_J / (R_I + R_J)
    m_eff = M_EFF
    k1 = 5.0 * r_eff * SOFT.yield_strength
    k2 = k1 / E ** 2
    delta0 = 1.05 * DELTA * (1.0 - E ** 2)      # the dent of an earlier, deeper overlap
    hist = np.zeros((1, HIST_WIDTH))
    hist[0, H_DELTA0] = delta0
    v_r = APPROACH - V_J
    vn = v_r @ N
    lever_i = R_I - DELTA / 2
    torques = {}
    for rolling in ("cdt", "type_a", "type_a_limited"):
        out = contact(NORMAL["hysteretic"], DAMPING["hysteretic"], TANGENTIAL["linear"],
                      ROLLING[rolling], pair_table(mats), 0, 0, hist, 0, DELTA, *N, *v_r, *W_I,
                      *W_J, lever_i, R_J - DELTA / 2, r_eff, m_eff, 0.0, ISO_I, ISO_J, 1e-7)
        torques[rolling] = np.array(out[3:6])
    fs = k2 * (DELTA - delta0)
    assert 0.4 * k1 * DELTA < fs < 0.6 * k1 * DELTA
    assert torques["cdt"] == pytest.approx(cdt_pair_torque(k1 * DELTA), rel=REL)
    fd = 2.0 * 0.2 * BETA * math.sqrt(k2 * m_eff) * vn
    assert torques["type_a"] == pytest.approx(
        -MU_R * (fs + fd) * lever_i * W_I / np.linalg.norm(W_I), rel=REL)
    # the limiter does not bind at this spin: type_a_limited reads type A's force
    assert np.array_equal(torques["type_a_limited"], torques["type_a"])


# ------------------------------------------------- type A with the moment limiter --

DT = 1e-7
ISO_I = 0.4 * mass(R_I) * R_I ** 2          # solid spheres: I = 2/5 m r^2
ISO_J = 0.4 * mass(R_J) * R_J ** 2
SLOW = 1e-5                                 # W_I, W_J scaled by this: the cap binds


def kernel_rolling(rolling, w_i, w_j, iso_i=ISO_I, iso_j=ISO_J):
    """Rolling torques on i and j from one call of the contact kernel (the approaching
    pair above, no sliding friction)."""
    m_eff = M_EFF
    out = contact(NORMAL["hertz"], DAMPING["tsuji"], TANGENTIAL["mindlin"], ROLLING[rolling],
                  pair_table(MaterialTable([SOFT], INTER)), 0, 0, np.zeros((1, HIST_WIDTH)), 0,
                  DELTA, *N, *(APPROACH - V_J), *w_i, *w_j, R_I - DELTA / 2, R_J - DELTA / 2,
                  R_I * R_J / (R_I + R_J), m_eff, 0.0, iso_i, iso_j, DT)
    return np.array(out[3:6]), np.array(out[6:9])


def test_type_a_limited_is_type_a_above_the_cap():
    """EDEM standard rolling friction, tau_i = -mu_r Fn R_i w_i/|w_i|, untouched where
    it is below STAR-CCM+'s moment limiter f I_i |w_i| / dt (module docstring)."""
    fn = type_a_fn()
    ti, tj = kernel_rolling("type_a_limited", W_I, W_J)
    ta, tb = kernel_rolling("type_a", W_I, W_J)
    assert np.array_equal(ti, ta) and np.array_equal(tj, tb)
    assert ti == pytest.approx(-MU_R * fn * (R_I - DELTA / 2) * W_I / np.linalg.norm(W_I),
                               rel=REL)
    assert tj == pytest.approx(-MU_R * fn * (R_J - DELTA / 2) * W_J / np.linalg.norm(W_J),
                               rel=REL)
    # the test means something: each side is well below its cap (by 50x or more)
    assert np.linalg.norm(ti) < MOMENT_LIMITER * ISO_I * np.linalg.norm(W_I) / DT / 50
    assert np.linalg.norm(tj) < MOMENT_LIMITER * ISO_J * np.linalg.norm(W_J) / DT / 50


def test_type_a_limited_caps_a_slow_spin_at_the_moment_limiter():
    """STAR-CCM+'s Constant Torque moment limiter (module docstring): below the
    threshold spin the torque is -f I w / dt on each side, from its own inertia; a side
    above its threshold keeps type A's torque; a wall (I_j = 0) takes none."""
    w_i, w_j = SLOW * W_I, SLOW * W_J
    ti, tj = kernel_rolling("type_a_limited", w_i, w_j)
    assert ti == pytest.approx(-MOMENT_LIMITER * ISO_I / DT * w_i, rel=1e-12)
    assert tj == pytest.approx(-MOMENT_LIMITER * ISO_J / DT * w_j, rel=1e-12)
    # the test means something: type A's torque on either side is far above the cap
    ta, tb = kernel_rolling("type_a", w_i, w_j)
    assert np.linalg.norm(ta) > 50 * np.linalg.norm(ti)
    assert np.linalg.norm(tb) > 50 * np.linalg.norm(tj)
    # each side is capped by its own spin and inertia: slow i, fast j
    ti, tj = kernel_rolling("type_a_limited", w_i, W_J)
    assert ti == pytest.approx(-MOMENT_LIMITER * ISO_I / DT * w_i, rel=1e-12)
    assert np.array_equal(tj, kernel_rolling("type_a", w_i, W_J)[1])
    # no inertia on the j side (a wall): no torque there, i unchanged
    ti, tj = kernel_rolling("type_a_limited", w_i, w_j, iso_j=0.0)
    assert np.all(tj == 0.0)
    assert ti == pytest.approx(-MOMENT_LIMITER * ISO_I / DT * w_i, rel=1e-12)


def test_type_a_limited_through_the_engine():
    """The drivers pass each body's own mean principal moment (unequal spheres, so that
    i's and j's could not be swapped unseen), for a pair and against a floor."""
    w_i, w_j = SLOW * W_I, SLOW * W_J
    ti, tj, _ = pair("type_a_limited", APPROACH, w_i=w_i, w_j=w_j)
    assert ti == pytest.approx(-MOMENT_LIMITER * ISO_I / DT * w_i, rel=1e-12)
    assert tj == pytest.approx(-MOMENT_LIMITER * ISO_J / DT * w_j, rel=1e-12)
    ta, tb, _ = pair("type_a", APPROACH)
    assert all(np.array_equal(a, b) for a, b in zip((ta, tb), pair("type_a_limited", APPROACH)))
    w = SLOW * np.array([20.0, -30.0, 40.0])
    assert on_floor("type_a_limited", w) == pytest.approx(-MOMENT_LIMITER * ISO_I / DT * w,
                                                          rel=1e-12)
