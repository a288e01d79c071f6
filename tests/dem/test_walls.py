"""Walls: reported forces and prescribed motion.

* A particle at rest on a floor pushes on it with its weight m g (statics).
* A floor translating upwards at constant speed u carries a resting particle along:
  after the transient its velocity is u and the floor force is again m g.
* A plate rotating about a horizontal hinge moves its surface at omega x r; a particle
  resting on it far from the hinge is carried at that speed.
* A wall's reported torque about its origin is r x F, r from the origin to the contact.
* Only friction with a moving surface can drive a particle along that surface: a belt
  (a plane sliding in its own plane) and a turntable drag what rests on them.
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.dem.walltable import WallTable
from demcal.geometry import (Disk, FunctionMotion, Plane, Rect, Rotation, Translation,
                             WallSet)
from demcal.particles.materials import Interaction

from dem_helpers import RADIUS, SOFT, SOFT_WALL, sphere_mass

G = 9.81


def test_resting_sphere_loads_floor_with_its_weight(backend):
    # the sphere rests away from the floor's origin (its point): the floor's torque about
    # that origin is r x F, r from the origin to the contact point (mid-overlap)
    walls = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1, name="floor")])
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3), walls=walls,
                     backend=backend)
    x0, y0 = 0.03, -0.02
    sim.add_particles(RADIUS, [[x0, y0, RADIUS]])
    sim.run(duration=0.1)
    force, torque = sim.wall_forces()["floor"]
    m = sim.state.masses[0]
    assert force == pytest.approx([0, 0, -m * G], abs=1e-6 * m * G)
    p = sim.state.positions[0]
    delta = RADIUS - p[2]                       # overlap with the floor z = 0
    assert delta > 0
    r = p - np.array([0.0, 0.0, RADIUS - 0.5 * delta])
    expected = np.cross(r, force)               # = (-y0 m g, x0 m g, 0)
    assert np.abs(expected).max() > 0.5 * 0.02 * m * G
    assert torque == pytest.approx(expected, abs=1e-9 * m * G * np.linalg.norm(r))


def test_translating_floor_carries_particle(backend):
    u = 0.05
    walls = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1, name="lift",
                           motion=Translation(velocity=(0, 0, u), start=0.03))])
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3), walls=walls,
                     backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS]])
    sim.run(duration=0.15)
    assert sim.state.velocities[0, 2] == pytest.approx(u, rel=0.01)
    z_floor = u * (sim.time - 0.03)
    assert sim.state.positions[0, 2] - z_floor == pytest.approx(RADIUS, rel=0.01)
    force, _ = sim.wall_forces()["lift"]
    assert -force[2] == pytest.approx(sim.state.masses[0] * G, rel=0.01)


def test_motion_set_between_runs_is_picked_up(backend):
    # a static floor starts a lift after the sphere has settled, then drops away (a
    # finite disk: only walls near a sphere are in its contact list)
    u = 0.05
    walls = WallSet([Disk(centre=(0, 0, 0), normal=(0, 0, 1), radius=0.05, material=1,
                          name="lift")])
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3), walls=walls,
                     backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS]])
    sim.run(duration=0.05)
    t0 = sim.time
    walls.set_motion("lift", Translation(velocity=(0, 0, u), start=t0, stop=t0 + 0.1))
    sim.run(duration=0.1)
    # carried up with the floor, resting on it; the floor placed at the run's end
    assert sim.state.velocities[0, 2] == pytest.approx(u, rel=0.01)
    assert sim.state.positions[0, 2] - u * 0.1 == pytest.approx(RADIUS, rel=0.01)
    assert walls.origin[0, 2] == pytest.approx(u * (sim.time - t0), rel=1e-9)
    # the floor jumps down (to -t) and keeps sinking at 1 m/s: the sphere falls freely
    walls.set_motion("lift", Translation(velocity=(0, 0, -1.0), start=0.0, stop=1.0))
    z1, v1, t1 = sim.state.positions[0, 2], sim.state.velocities[0, 2], sim.time
    sim.run(duration=0.02)
    assert sim.state.velocities[0, 2] == pytest.approx(v1 - G * (sim.time - t1), rel=1e-9)
    assert sim.state.positions[0, 2] < z1
    assert abs(sim.wall_forces()["lift"][0][2]) == 0.0
    # the floor jumps up to touch the sphere, from out of the contact lists' reach: the
    # contact is there at the very next step, and the sphere comes to rest on it
    z_floor = sim.state.positions[0, 2] - 0.999 * RADIUS
    walls.set_motion("lift", FunctionMotion(function=lambda t: (0.0, 0.0, z_floor)))
    sim.run(steps=1)
    assert sim.wall_forces()["lift"][0][2] < 0.0
    sim.run(duration=0.2)
    assert sim.state.positions[0, 2] - z_floor == pytest.approx(RADIUS, rel=0.01)
    assert abs(sim.state.velocities[0, 2]) < 1e-3


def test_set_motion_names_the_walls_when_the_name_is_unknown():
    from demcal.errors import ConfigError
    walls = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), name="floor")])
    with pytest.raises(ConfigError, match="floor"):
        walls.set_motion("lid", Translation(velocity=(0, 0, 1.0)))


def test_rotating_plate_moves_particle_with_its_surface(backend):
    """A horizontal plate hinged on the y axis tilts at w; a particle resting on it at
    x = L rides up at w L (no slip while tan(w t) << mu_s)."""
    w = 0.2
    length = 0.05
    plate = Rect(centre=(length, 0, 0), u=(2 * length, 0, 0), v=(0, 0.02, 0), material=1,
                 name="plate",
                 motion=Rotation(point=(0, 0, 0), axis=(0, -1, 0), angular_speed=w,
                                 start=0.03))
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=0.9,
                                                    rolling_friction=0.5),
                     walls=WallSet([plate]), backend=backend)
    sim.add_particles(RADIUS, [[length, 0, RADIUS]])
    sim.run(duration=0.1)
    v = sim.state.velocities[0]
    speed = w * math.hypot(length, RADIUS)
    assert np.linalg.norm(v) == pytest.approx(speed, rel=0.03)
    assert v[2] > 0


def test_belt_drags_resting_sphere_into_rolling_at_two_sevenths_of_its_speed(backend):
    """A sphere at rest on a belt (a plane sliding in its own plane at u) is dragged by
    friction alone. In the belt's frame it is a ball launched sliding at -u without
    spin, which ends rolling at 5/7 of its launch speed (angular momentum about the
    contact point is conserved: m v R + I w with I = 2/5 m R^2; the bowling-ball
    problem, Kleppner & Kolenkow, An Introduction to Mechanics, ch. 7). Back in the lab
    its centre moves at 2/7 u and its contact point at u, the belt's velocity."""
    u = 0.05
    walls = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1, name="belt",
                           motion=Translation(velocity=(u, 0, 0), start=0.03))])
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=0.5,
                                                    rolling_friction=0.0),
                     walls=walls, backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS]])
    sim.run(duration=0.03)
    x0 = sim.state.positions[0, 0]
    sim.run(duration=0.05)          # slip ends after ~ 5/7 u / (mu g) = 7 ms
    st = sim.state
    v, w = st.velocities[0], st.omegas[0]
    contact = v + np.cross(w, [0.0, 0.0, -RADIUS])
    assert v == pytest.approx([2.0 / 7.0 * u, 0, 0], abs=0.005 * u)
    assert contact == pytest.approx([u, 0, 0], abs=0.005 * u)
    # dragged along: about 2/7 u t less the short slip phase
    assert st.positions[0, 0] - x0 == pytest.approx(2.0 / 7.0 * u * 0.05, rel=0.05)


def test_turntable_carries_block_round_with_its_surface(backend):
    """A flat block on a disk turning at W about the vertical axis co-rotates with it
    (friction supplies the centripetal force m W^2 r0 = 0.08 m/s^2 m, far below mu_s m g;
    Coulomb): its centre moves at the surface velocity W x r and it spins at W."""
    from scipy.spatial.transform import Rotation as R

    from demcal.particles.templates import ParticleTemplate

    r = RADIUS
    block = ParticleTemplate.from_spheres([[x, y, 0.0, r] for x in (-r, r) for y in (-r, r)],
                                          name="block", resolution=64)
    q = R.from_matrix(block.rotation).as_quat()     # thin direction along z
    w_table, r0, t_start = 2.0, 0.02, 0.03
    table = Disk(centre=(0, 0, 0), normal=(0, 0, 1), radius=0.05, material=1, name="table",
                 motion=Rotation(point=(0, 0, 0), axis=(0, 0, 1), angular_speed=w_table,
                                 start=t_start))
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=0.5,
                                                    rolling_friction=0.0),
                     walls=WallSet([table]), backend=backend)
    sim.add_particles(block, [[r0, 0, r]], orientations=[[q[3], q[0], q[1], q[2]]])
    sim.run(duration=t_start + 0.15)
    st = sim.state
    p, v, w = st.positions[0], st.velocities[0], st.omegas[0]
    surface = np.cross([0.0, 0.0, w_table], p)      # the table's velocity under the block
    assert np.linalg.norm(surface) == pytest.approx(w_table * r0, rel=0.01)
    assert v == pytest.approx(surface, abs=0.01 * w_table * r0)
    assert w == pytest.approx([0, 0, w_table], abs=0.01 * w_table)
    # it went round with the table (less a lag of ~0.01 rad from the start-up slip)
    assert math.atan2(p[1], p[0]) == pytest.approx(w_table * 0.15, abs=0.02)


def _lifted_cylinder(backend, threads=1):
    """Spheres in a capped cylinder that is lifted off a base plate, with a triangle
    pair (a square lid) lifted along with it."""
    from demcal.geometry import Cylinder, TriangleMesh

    rc, hc = 6 * RADIUS, 12 * RADIUS
    lift = Translation(velocity=(0, 0, 1.0), start=0.02, stop=0.06)
    lid = TriangleMesh([[-rc, -rc, hc + RADIUS], [rc, -rc, hc + RADIUS],
                        [rc, rc, hc + RADIUS], [-rc, rc, hc + RADIUS]],
                       [[0, 1, 2], [0, 2, 3]], material=1, name="lid", motion=lift)
    walls = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1, name="base"),
                     Cylinder(base=(0, 0, 0), axis=(0, 0, 1), radius=rc, length=hc,
                              top=True, material=1, name="tube", motion=lift), lid])
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=0.5,
                                                    rolling_friction=0.05),
                     walls=walls, backend=backend, threads=threads)
    rng = np.random.default_rng(4)
    pos = []
    while len(pos) < 30:
        p = rng.uniform((-rc, -rc, RADIUS), (rc, rc, hc - RADIUS))
        if math.hypot(p[0], p[1]) < rc - RADIUS and all(np.linalg.norm(p - q) > 2.1 * RADIUS
                                                        for q in pos):
            pos.append(p)
    sim.add_particles(RADIUS, np.array(pos))
    return sim


def test_translating_walls_placed_in_the_compiled_loop_as_from_python(backend, monkeypatch):
    # The step loop places constant-velocity translations itself (no return to Python
    # each step); the numbers must be those of placing them from Python every step.
    fast = _lifted_cylinder(backend)
    fast.run(duration=0.1)
    assert fast.walls.time == pytest.approx(fast.time)
    monkeypatch.setattr(WallTable, "compiled_motions", lambda self: None)
    slow = _lifted_cylinder(backend)
    slow.run(duration=0.1)
    for name in ("positions", "velocities", "angular_momenta"):
        assert np.array_equal(getattr(fast.state, name), getattr(slow.state, name)), name
    assert np.array_equal(fast.walls.params, slow.walls.params)
    # the tube went up by 40 mm and the heap spread under it
    assert fast.walls.params[fast.walls.rows_of("tube")][0, 2] == pytest.approx(0.04)
    assert fast.state.positions[:, 2].max() < 8 * RADIUS


def test_translating_walls_split_between_threads(backend):
    runs = []
    for threads in (1, 2):
        sim = _lifted_cylinder(backend, threads=threads)
        sim.parallel_threshold = 0
        sim.run(duration=0.1)
        runs.append(sim.state.positions.copy())
    assert np.array_equal(runs[0], runs[1])


def _drum(backend, turning=True, threads=None, n=200):
    """A horizontal drum (a closed cylinder about the y axis, about 40 % full) of ``n``
    spheres turning at 2 rad/s after 0.02 s (or standing still)."""
    from demcal.geometry import Static, closed_drum

    rd, length = 9 * RADIUS, 8 * RADIUS
    turn = (Rotation(point=(0, 0, 0), axis=(0, 1, 0), angular_speed=2.0, start=0.02)
            if turning else Static())
    walls = WallSet(closed_drum(rd, length, motion=turn, material=1))
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=0.5,
                                                    rolling_friction=0.05),
                     walls=walls, backend=backend, threads=threads)
    g = 2.05 * RADIUS
    cells = [(x, y, z) for z in np.arange(-rd + g, rd, g) for x in np.arange(-rd + g, rd, g)
             for y in np.arange(-length / 2 + g / 2, length / 2 - g / 4, g)
             if math.hypot(x, z) < rd - g / 2]
    sim.add_particles(RADIUS, np.array(cells[:n]))
    return sim


def test_rotating_walls_placed_in_the_compiled_loop_as_from_python(backend, monkeypatch):
    # A turning drum is placed by the compiled step loop at every step
    # (geometry.placement.place_moving); placing it from Python every step (the path of
    # walls moved by a function of time) uses the same arithmetic, so the walls agree to
    # the bit. The particles agree to rounding, not to the bit: the compiled loop knows
    # the drum turns about its own axis (its surface stays put, no travel), the Python
    # path bounds its travel by the current speed, so the lists are rebuilt at other
    # steps (measured: 15 and 21 rebuilds) and sum the same contacts in another order
    # (measured: 4e-13 m after 1,491 steps).
    fast = _drum(backend)
    fast.run(duration=0.08)
    monkeypatch.setattr(WallTable, "compiled_motions", lambda self: None)
    slow = _drum(backend)
    slow.run(duration=0.08)
    assert np.array_equal(fast.walls.params, slow.walls.params)
    assert np.array_equal(fast.walls.omega, slow.walls.omega)
    for name in ("positions", "velocities"):
        a, b = getattr(fast.state, name), getattr(slow.state, name)
        assert np.abs(a - b).max() < 1e-9, name
    # turning at 2 rad/s about +y since 0.02 s: the drum drags the bed along
    assert np.allclose(fast.walls.omega, (0.0, 2.0, 0.0))
    assert np.abs(fast.state.velocities).max() > 0.01


def test_rotating_wall_matches_the_motion(backend):
    # the rows placed by the compiled loop are the Rotation's transform of the
    # reference rows (Rodrigues' formula in motion.rotation_matrix), to rounding
    from demcal.geometry.walls import transform_rows

    sim = _drum(backend)
    sim.run(duration=0.05)
    w = sim.walls
    s = w.rows_of("drum-front")
    rot, trans = w.walls[1].motion.transform(sim.time)
    ref = transform_rows(w.kind[s], w._ref_params[s], rot, trans)
    assert np.allclose(w.params[s], ref, rtol=0, atol=1e-15)
    omega, _ = w.walls[1].motion.twist(sim.time)
    assert np.array_equal(w.omega[s][0], omega)
