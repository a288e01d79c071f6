"""Rolling resistance on a flat floor and on a slope.

Closed forms:

* Type A (EDEM constant directional torque, tau = -mu_r Fn R w/|w|): a solid sphere
  rolling without slip on a horizontal plane loses kinetic energy
  (1/2)(m + I/R^2) v^2 = (7/10) m v^2 at the rate mu_r m g R w = mu_r m g v, hence
  a = -(5/7) mu_r g (energy balance as in Ai et al. 2011, Powder Technol. 206, 269,
  section 3.1, their Eq. 20 for model A with I = 2/5 m R^2).
* The same holds for the relative-velocity model (cdt) against a fixed floor (R* = R).
* Type C (elastic-plastic spring-dashpot, Ai et al. 2011 model C) holds a sphere at rest
  on a slope while tan(theta) < mu_r (the limiting moment mu_r R Fn balances
  m g sin(theta) R with Fn = m g cos(theta)); above it the sphere rolls away.
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.particles.materials import Interaction

from dem_helpers import RADIUS, SOFT, SOFT_WALL, floor, tilted_gravity

G = 9.81


def settled(backend, rolling_model, mu_r, gravity=(0, 0, -G)):
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=0.8,
                                                    rolling_friction=mu_r),
                     walls=floor(), gravity=gravity, rolling_model=rolling_model,
                     backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS]])
    sim.run(duration=0.05)
    return sim


@pytest.mark.parametrize("rolling_model", ["type_a", "cdt"])
def test_rolling_deceleration(backend, rolling_model):
    mu_r = 0.1
    sim = settled(backend, rolling_model, mu_r)
    v0 = 0.5
    sim.state.velocities[0] = [v0, 0, 0]
    r_roll = RADIUS - (RADIUS - sim.state.positions[0, 2])  # centre height
    sim.state.angular_momenta[0] = [0, v0 / r_roll * sim.state.inertias[0, 0], 0]
    sim.state.omegas[0] = [0, v0 / r_roll, 0]
    ts, vs = [], []
    for _ in range(20):
        sim.run(duration=0.01)
        ts.append(sim.time)
        vs.append(sim.state.velocities[0, 0])
    a = np.polyfit(ts, vs, 1)[0]
    assert a == pytest.approx(-5.0 / 7.0 * mu_r * G, rel=0.02)


def test_type_c_rests_below_rolling_limit(backend):
    mu_r = 0.2
    theta = 0.7 * math.atan(mu_r)
    sim = settled(backend, "type_c", mu_r, gravity=tilted_gravity(theta))
    sim.state.velocities[0] = [0.05, 0, 0]
    sim.run(duration=0.3)
    assert abs(sim.state.velocities[0, 0]) < 1e-4
    assert abs(sim.state.omegas[0, 1]) * RADIUS < 1e-4


def test_type_c_rolls_above_rolling_limit(backend):
    mu_r = 0.2
    theta = 1.5 * math.atan(mu_r)
    sim = settled(backend, "type_c", mu_r, gravity=tilted_gravity(theta))
    sim.run(duration=0.3)
    assert sim.state.velocities[0, 0] > 0.1
