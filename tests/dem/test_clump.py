"""Rigid multi-sphere particles: torque-free rotation and sliding onset.

* A torque-free rigid body conserves its angular momentum and kinetic energy (Euler's
  equations; Goldstein, Classical Mechanics, ch. 5). The engine's splitting
  (Dullweber, Leimkuhler & McLachlan 1997) keeps L exactly and the energy error bounded.
* A torque-free symmetric top (two equal principal moments I_p, axis moment I_a) turns
  as R(t) = exp(t [L / I_p]) R(0) exp(t W [e]), W = (1/I_a - 1/I_p) L.e: it precesses
  about L at |L|/I_p and spins about its axis at W (Landau & Lifshitz, Mechanics, §33).
  The engine uses that closed form for such bodies; the general splitting converges to
  it at second order in dt.
* A block on a plane tilted slowly starts to slide when tan(theta) = mu_s (Coulomb).
  The plane is tilted by rotating gravity, theta(t) = theta0 + rate t, which is exact
  for a plane through the origin and needs no moving wall.
"""

import math

import numpy as np
import pytest

from scipy.spatial.transform import Rotation

from demcal.dem import Simulation
from demcal.dem.integrator import symmetry_axis
from demcal.dem.reporters import Callback
from demcal.particles.materials import Interaction, Material
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


# a very soft material: its stable time step allows the coarse steps of the convergence
# test (a lone body never touches anything)
FREE = Material(density=2500.0, shear_modulus=1.0e4, poisson_ratio=0.3,
                yield_strength=1.0e3, name="free")


def _spin_up(tpl, dt, backend):
    sim = Simulation([FREE], Interaction(), gravity=(0, 0, 0), dt=dt, backend=backend)
    sim.add_particles(tpl, [[0, 0, 0]], orientations=[[0.9, 0.1, 0.3, -0.2]],
                      angular_velocities=[[3.0, -7.0, 11.0]])
    return sim


def _rotation(q):
    """scipy rotation of an engine quaternion (w, x, y, z)."""
    return Rotation.from_quat([q[1], q[2], q[3], q[0]])


def _closed_form_top(sim0, t):
    """Orientation of the torque-free symmetric top of ``sim0`` (axis 0) after t."""
    st = sim0.state
    l = st.angular_momenta[0].copy()
    r0 = _rotation(st.quaternions[0])
    i_a, i_p = sim0.state.inertias[0, 0], sim0.state.inertias[0, 1]
    w = (1.0 / i_a - 1.0 / i_p) * np.dot(l, r0.apply([1.0, 0.0, 0.0]))
    return Rotation.from_rotvec(t * l / i_p) * r0 * Rotation.from_rotvec([t * w, 0.0, 0.0])


def test_symmetric_top_follows_the_closed_form(backend):
    tpl = two_sphere_paper(resolution=96)
    assert symmetry_axis(*tpl.inertia_per_density) == 0  # a 4 mm + 5 mm pair: axis 0
    dt, steps = 1e-4, 2_000
    ref = _closed_form_top(_spin_up(tpl, dt, backend), dt * steps)
    sim = _spin_up(tpl, dt, backend)
    sim.run(steps=steps)
    err = (_rotation(sim.state.quaternions[0]) * ref.inv()).magnitude()
    turned = (_rotation(sim.state.quaternions[0])
              * _rotation(_spin_up(tpl, dt, backend).state.quaternions[0]).inv()).magnitude()
    assert turned > 1.0  # it really tumbled
    assert err < 1e-9


def test_general_splitting_converges_to_the_top_at_second_order(backend):
    # the same body with its moments made unequal by 1e-13: the general splitting
    tpl = two_sphere_paper(resolution=96)
    moments = tpl.inertia_per_density * np.array([1.0, 1.0, 1.0 + 1e-13])
    asym = ParticleTemplate(tpl.radii, tpl.centers, tpl.volume, moments, name="asym")
    assert symmetry_axis(*moments) == -1
    errors = []
    for dt in (4e-4, 2e-4):
        steps = round(0.2 / dt)
        ref = _closed_form_top(_spin_up(tpl, dt, backend), dt * steps)
        sim = _spin_up(asym, dt, backend)
        sim.run(steps=steps)
        errors.append((_rotation(sim.state.quaternions[0]) * ref.inv()).magnitude())
    assert 1e-7 < errors[1] < errors[0]
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.1)


def test_asymmetric_clump_conserves_l_and_energy(backend):
    # three unequal spheres in an L: three different principal moments
    tpl = ParticleTemplate.from_spheres([[0, 0, 0, 0.003], [0.004, 0, 0, 0.002],
                                         [0, 0.005, 0, 0.0025]], resolution=64)
    assert symmetry_axis(*tpl.inertia_per_density) == -1
    sim = _spin_up(tpl, 1e-5, backend)
    l0 = sim.state.angular_momenta[0].copy()
    e0 = sim.kinetic_energy()
    q0 = sim.state.quaternions[0].copy()
    w0 = sim.state.omegas[0].copy()
    sim.run(steps=10_000)
    # the body really tumbles (|omega| = 13.4 rad/s over 0.1 s: it turns by 1.33 rad and
    # omega moves by 0.16 |omega0|): a frozen orientation keeps L and E trivially
    turned = (_rotation(sim.state.quaternions[0]) * _rotation(q0).inv()).magnitude()
    assert turned > 1.0
    assert np.linalg.norm(sim.state.omegas[0] - w0) > 0.1 * np.linalg.norm(w0)
    assert np.linalg.norm(sim.state.angular_momenta[0] - l0) <= 1e-12 * np.linalg.norm(l0)
    assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-4)


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
