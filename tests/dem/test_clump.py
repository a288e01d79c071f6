"""Rigid multi-sphere particles: torque-free rotation and sliding onset.

* A torque-free rigid body conserves its angular momentum and kinetic energy (Euler's
  equations; Goldstein, Classical Mechanics, ch. 5). The engine's splitting
  (Dullweber, Leimkuhler & McLachlan 1997) keeps L exactly and the energy error bounded.
* A block on a plane tilted slowly starts to slide when tan(theta) = mu_s (Coulomb).
  The plane is tilted by rotating gravity, theta(t) = theta0 + rate t, which is exact
  for a plane through the origin and needs no moving wall.
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.dem.reporters import Callback
from demcal.particles.materials import Interaction
from demcal.particles.templates import ParticleTemplate, two_sphere_paper

from dem_helpers import GLASS, SOFT, SOFT_WALL, floor, tilted_gravity


def test_torque_free_clump_conserves_l_and_energy(backend):
    tpl = two_sphere_paper(resolution=96)
    sim = Simulation([GLASS], Interaction(), gravity=(0, 0, 0), dt=1e-5, backend=backend)
    sim.add_particles(tpl, [[0, 0, 0]], orientations=[[0.9, 0.1, 0.3, -0.2]],
                      angular_velocities=[[3.0, -7.0, 11.0]])
    st = sim.state
    l0 = st.angular_momenta[0].copy()
    e0 = sim.kinetic_energy()
    w0 = st.omegas[0].copy()
    sim.run(steps=10_000)
    # the body really tumbles: its angular velocity changed direction
    assert np.linalg.norm(sim.state.omegas[0] - w0) > 0.1 * np.linalg.norm(w0)
    assert np.linalg.norm(sim.state.angular_momenta[0] - l0) <= 1e-4 * np.linalg.norm(l0)
    assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-4)
    q = sim.state.quaternions[0]
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)


def test_block_slides_at_atan_mu(backend):
    mu = 0.4
    r = 0.004
    spheres = [[x, y, 0.0, r] for x in (-r, r) for y in (-r, r)]  # flat 2 x 2 block
    block = ParticleTemplate.from_spheres(spheres, name="block", resolution=64)
    theta0 = math.radians(19.0)
    rate = math.radians(2.0)  # [rad/s]
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=mu,
                                                    rolling_friction=0.0),
                     walls=floor(), gravity=tilted_gravity(theta0), backend=backend)
    # principal frame of the flat block: the smallest moments are in-plane; find the
    # orientation that puts the block's thin direction along z
    axes = block.rotation  # columns: principal axes in the frame the spheres were given in
    from scipy.spatial.transform import Rotation as R
    q = R.from_matrix(axes).as_quat()  # x, y, z, w: body -> given frame
    quat = [[q[3], q[0], q[1], q[2]]]
    sim.add_particles(block, [[0, 0, r]], orientations=quat)
    sim.run(duration=0.2)  # settle on the tilted plane (below the friction angle)
    assert abs(sim.state.velocities[0, 0]) < 1e-3
    x0 = sim.state.positions[0, 0]
    t0 = sim.time
    onset = []

    def tilt(s):
        theta = theta0 + rate * (s.time - t0)
        s.gravity[:] = tilted_gravity(theta)
        if not onset and s.state.velocities[0, 0] > 1e-3:
            onset.append(theta)

    sim.run(duration=2.0, reporters=[Callback(20, tilt)])
    assert onset, "the block never slid"
    assert math.degrees(onset[0]) == pytest.approx(math.degrees(math.atan(mu)), abs=0.5)
    assert sim.state.positions[0, 0] - x0 > 0.01
