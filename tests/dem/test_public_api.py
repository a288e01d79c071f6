"""The public forms of what a case of one's own needs (issue 18, item 6).

* ``remove_wall``: a particle held by a wall is free once the wall is removed mid-run;
  the other walls' contacts keep their history although their rows are renumbered.
* ``add_particles(rotation=False)``: a sphere that cannot turn slides on a floor at
  the Coulomb deceleration mu g (v = v0 - mu g t, the closed form of a sliding block),
  where a free one starts to roll; its omega stays exactly 0.
* ``add_particles(radii=...)``: single spheres of given radii, masses 4/3 pi r^3 rho.
* ``gravity_schedule``: gravity set once per window within its tolerance, runs bitwise
  the same however split; a block that cannot turn on a floor tilting at a constant
  rate slides at atan(mu_s) (Coulomb).
* ``run()`` returns a summary of what it did.
"""

import math

import numpy as np
import pytest

from demcal.dem import GravityRamp, GravityRotation, RunSummary, Simulation
from demcal.dem.reporters import Callback
from demcal.errors import ConfigError
from demcal.geometry import Cylinder, Plane, WallSet
from demcal.particles.materials import Interaction
from demcal.particles.templates import two_sphere_paper

from dem_helpers import RADIUS, SOFT, SOFT_WALL, Trace, sphere_mass

G = 9.81
MU = 0.3


def _floor_sim(backend, walls=None, **kw):
    walls = walls or WallSet([Plane(name="floor", material=1)])
    return Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.5, static_friction=MU,
                                                     rolling_friction=0.0),
                      walls=walls, backend=backend, **kw)


# ----------------------------------------------------------------------- remove_wall --
def test_remove_wall_mid_run_frees_the_particle_and_keeps_other_contacts(backend):
    theta = math.radians(10.0)       # below atan(MU) = 16.7 deg: a locked sphere sticks
    walls = WallSet([Cylinder(base=(0, 0, 0), radius=0.02, length=0.05, material=1,
                              name="cylinder"),
                     Plane(name="floor", material=1)])
    sim = _floor_sim(backend, walls,
                     gravity=(G * math.sin(theta), 0.0, -G * math.cos(theta)))
    # A leans on the cylinder from inside, B sticks on the floor far away (it cannot roll)
    sim.add_particles(positions=[[0.02 - RADIUS, 0, RADIUS], [0.3, 0, RADIUS]],
                      radii=RADIUS, rotation=[True, False])
    sim.run(duration=0.2)
    assert sim.wall_forces()["cylinder"][0][0] > 0.5 * sphere_mass() * G * math.sin(theta)
    xb = sim.state.positions[1, 0]
    removed = []

    def remove(s):
        if not removed:
            s.remove_wall("cylinder")
            removed.append(s.step_count)

    sim.run(duration=0.1, reporters=[Callback(50, remove)])
    assert removed and "cylinder" not in sim.wall_forces()
    assert set(sim.wall_forces()) == {"floor"}
    st = sim.state
    assert st.positions[0, 0] > 0.02                 # A's centre is past where the wall was
    # B kept its floor contact's tangential spring through the renumbering (row 1 -> 0):
    # with it reset, B would slip by F_t / k_t (about 1 um) to stretch it again
    assert abs(st.positions[1, 0] - xb) < 1e-9
    assert float(sim.wall_forces()["floor"][0][2]) == pytest.approx(
        -2 * sphere_mass() * G * math.cos(theta), rel=1e-3)


def test_remove_wall_unknown_name_is_one_sentence(backend):
    sim = _floor_sim(backend)
    with pytest.raises(ConfigError, match=r"no wall named 'lid'; the walls are floor\."):
        sim.remove_wall("lid")
    bare = Simulation([SOFT], Interaction(), backend=backend)
    with pytest.raises(ConfigError, match="has no walls"):
        bare.remove_wall("floor")


def test_remove_every_wall_leaves_free_fall(backend):
    sim = _floor_sim(backend)
    sim.add_particles(positions=[[0, 0, RADIUS]], radii=RADIUS)
    sim.run(steps=10)
    sim.remove_wall("floor")
    sim.run(duration=0.05)
    assert sim.wall_forces() == {}
    assert sim.state.velocities[0, 2] == pytest.approx(-G * 0.05, rel=0.02)


# ------------------------------------------------------------------ rotation=False --
def test_locked_sphere_slides_at_coulomb_deceleration_and_never_turns(backend):
    v0, t = 0.5, 0.1
    sim = _floor_sim(backend)
    sim.add_particles(positions=[[0, 0, RADIUS], [0.2, 0, RADIUS]], radii=RADIUS,
                      velocities=[v0, 0, 0], rotation=[False, True])
    spins = Trace(lambda s: s.state.omegas[0].copy())
    sim.run(duration=t, reporters=[spins])
    st = sim.state
    assert np.all(np.array(spins.rows) == 0.0)              # friction's torque turns nothing
    assert np.all(st.inertias[0] == np.inf)
    assert st.velocities[0, 0] == pytest.approx(v0 - MU * G * t, rel=0.01)
    assert abs(st.omegas[1, 1]) > 10.0                        # the free one rolls


def test_locked_clump_keeps_its_orientation(backend):
    sim = _floor_sim(backend)
    tpl = two_sphere_paper()
    q0 = np.array([0.9, 0.1, 0.3, 0.2]) / np.linalg.norm([0.9, 0.1, 0.3, 0.2])
    sim.add_particles(tpl, [[0, 0, 0.012]], orientations=q0, rotation=False,
                      velocities=[0.2, 0, 0])
    sim.run(duration=0.05)
    st = sim.state
    assert np.all(st.omegas == 0.0)
    np.testing.assert_allclose(st.quaternions[0], q0, atol=1e-15)
    assert st.velocities[0, 0] != 0.2                         # it did meet the floor
    with pytest.raises(ConfigError, match="angular_velocities must be 0"):
        sim.add_particles(tpl, [[0.1, 0, 0.05]], rotation=False,
                          angular_velocities=[0, 0, 1])


# ------------------------------------------------------------------------ radii= --
def test_radii_add_single_spheres(backend):
    sim = _floor_sim(backend)
    r = np.array([0.004, 0.005, 0.006])
    idx = sim.add_particles(positions=[[0, 0, 0.01], [0.02, 0, 0.01], [0.04, 0, 0.01]],
                            radii=r)
    st = sim.state
    np.testing.assert_array_equal(idx, [0, 1, 2])
    np.testing.assert_array_equal(st.radii, r)
    np.testing.assert_allclose(st.masses, 4 / 3 * math.pi * r ** 3 * SOFT.density,
                               rtol=1e-14)
    np.testing.assert_allclose(st.inertias[:, 0], 0.4 * st.masses * r ** 2, rtol=1e-14)
    with pytest.raises(ConfigError, match="radii must be one number or one per particle"):
        sim.add_particles(positions=[[0, 0.1, 0.01]], radii=[0.004, 0.005])
    with pytest.raises(ConfigError, match="radii must be finite numbers > 0"):
        sim.add_particles(positions=[[0, 0.1, 0.01]], radii=-0.004)
    with pytest.raises(ConfigError, match="give radii= alone"):
        sim.add_particles(0.004, [[0, 0.1, 0.01]], radii=0.004)
    with pytest.raises(ConfigError, match="needs a template"):
        sim.add_particles(positions=[[0, 0.1, 0.01]])


# ----------------------------------------------------------------------- summary --
def test_run_returns_a_summary(backend):
    sim = _floor_sim(backend)
    sim.add_particles(positions=[[0, 0, RADIUS], [0.02, 0, RADIUS]], radii=RADIUS)
    out = sim.run(steps=120, reporters=[Trace(lambda s: None, 7)])
    assert isinstance(out, RunSummary)
    assert (out.steps, out.particles, out.particle_steps) == (120, 2, 240)
    assert out.simulated_time == pytest.approx(120 * sim.dt, rel=1e-12)
    assert out.wall_time > 0 and out.particle_steps_per_second > 0
    with pytest.warns(DeprecationWarning, match="sim.step_count"):
        assert out.step_count == 120                 # run() used to return the simulation


# --------------------------------------------------------------- gravity schedule --
def test_gravity_schedule_is_within_tolerance_at_every_step(backend):
    tol = 2e-3
    tilt = GravityRotation((0, 0, -G), axis=(0, -1, 0), rate=math.radians(30),
                           start=0.01, tolerance=tol)
    sim = _floor_sim(backend, gravity=tilt)
    sim.add_particles(positions=[[0, 0, RADIUS]], radii=RADIUS, rotation=False)
    seen = Trace(lambda s: (s.time, s.gravity.copy()))
    sim.run(steps=2000, reporters=[seen])
    times = np.array([t for t, _ in seen.rows])
    applied = np.array([g for _, g in seen.rows])
    exact = np.array([tilt.at(t) for t in times])
    err = np.linalg.norm(applied - exact, axis=1)
    assert err.max() <= tol
    assert err.max() > 0.5 * tol                     # the windows are as long as allowed
    width = tilt.window(sim.dt)
    changes = np.count_nonzero(np.any(np.diff(applied, axis=0) != 0, axis=1))
    assert changes <= 2000 // width + 1


def test_gravity_schedule_runs_are_bitwise_the_same_however_split(backend):
    def run(parts, reporter_interval=None):
        sim = _floor_sim(backend)
        sim.gravity_schedule = GravityRamp((0, 0, -G), rate=(3.0, 0, 0), tolerance=1e-3)
        sim.add_particles(positions=[[0, 0, RADIUS], [0.03, 0, RADIUS]], radii=RADIUS)
        reporters = [Trace(lambda s: None, reporter_interval)] if reporter_interval else []
        for n in parts:
            sim.run(steps=n, reporters=reporters)
        return sim.state.positions.copy(), sim.gravity.copy()

    whole = run([3000])
    assert np.array_equal(whole[0], run([1000, 1234, 766])[0])
    assert np.array_equal(whole[0], run([3000], reporter_interval=7)[0])
    assert np.array_equal(whole[1], run([1500, 1500])[1])
    assert whole[1][0] > 0.0


def test_locked_block_on_a_tilting_floor_slides_at_atan_mu(backend):
    # Coulomb: a block that cannot turn slides once tan(theta) > mu_s
    rate = math.radians(5.0)
    theta0 = math.radians(12.0)
    g0 = (G * math.sin(theta0), 0.0, -G * math.cos(theta0))
    tilt = GravityRotation(g0, axis=(0, -1, 0), rate=rate, start=0.05)
    sim = _floor_sim(backend, gravity=tilt)
    sim.add_particles(positions=[[0, 0, RADIUS * 0.999]], radii=RADIUS, rotation=False)
    sim.run(duration=0.05)
    x0 = sim.state.positions[0, 0]
    while sim.state.positions[0, 0] - x0 < 1e-5:
        sim.run(duration=0.002)
        assert sim.time < 2.0
    onset = math.degrees(theta0 + tilt.angle(sim.time))
    assert onset == pytest.approx(math.degrees(math.atan(MU)), abs=0.5)


def test_gravity_schedule_input():
    with pytest.raises(ConfigError, match="gravity_schedule must be a GravityRamp"):
        Simulation([SOFT], Interaction()).gravity_schedule = lambda t: (0, 0, -G)
    with pytest.raises(ConfigError, match="tolerance must be a finite number > 0"):
        GravityRamp((0, 0, -G), (1, 0, 0), tolerance=0.0)
    with pytest.raises(ConfigError, match="stop must be a time"):
        GravityRotation((0, 0, -G), (0, 1, 0), 0.1, start=1.0, stop=0.5)
    sim = Simulation([SOFT], Interaction(), gravity=GravityRamp((0, 0, -G), (0.5, 0, 0),
                                                                start=-2.0))
    np.testing.assert_array_equal(sim.gravity, [1.0, 0, -G])
    sim.gravity_schedule = None
    np.testing.assert_array_equal(sim.gravity, [1.0, 0, -G])
