"""The Hysteretic Spring model's tangential spring: k_t = xi K1.

Closed forms:

* Tangential stiffness of the Hysteretic Spring (HSCM) model: k_t = xi K1 with the
  loading stiffness K1 = 5 R* min(Y_i, Y_j) (Xie et al. 2020, IJABE 13(4), Eq. 3,
  doi:10.25165/j.ijabe.20201304.5586; EDEM Hysteretic Spring "stiffness factor"; K1
  after Walton & Braun 1986). For a sphere on a flat wall R* = R.
* A solid sphere (I = 2/5 m R^2) resting on a wall under a constant normal load, its
  contact stuck (|F_t| < mu F_n), is a tangential oscillator: with the contact-point
  displacement s = x - R theta_y, m x'' = F and I theta_y'' = -R F give
  s'' = F (1/m + R^2/I) = -(7/2) (k_t/m) s, so omega_t = sqrt(7 k_t / (2 m)) (the 3.5
  factor of Maw, Barber & Fawcett 1976, Wear 38, 101). Started at s = 0 with x' = v0
  and no spin: s = (v0/omega_t) sin(omega_t t) and F = -k_t s.

With e = 1 the model has no damping (beta = 0: K2 = K1, c_t = 0), and the sphere starts
at its normal equilibrium overlap m g / K1, so the normal load stays m g.
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.particles.materials import Interaction

from dem_helpers import GLASS, RADIUS, WALL, Trace, floor, sphere_mass

XI = 0.7     # a stiffness factor away from the default 0.95
MU = 0.5
G = 9.81     # [m/s2]
V0 = 1.0e-4  # [m/s]: peak F_t = V0 sqrt(k_t m / 3.5) ~ 0.13 mu m g, well inside Coulomb


def test_tangential_spring_is_xi_k1(backend):
    m = sphere_mass()
    k1 = 5.0 * RADIUS * min(GLASS.yield_strength, WALL.yield_strength)  # R* = R on a wall
    kt = XI * k1
    omega = math.sqrt(3.5 * kt / m)
    period = 2 * math.pi / omega
    dt = period / 400
    sim = Simulation([GLASS, WALL], Interaction(restitution=1.0, static_friction=MU,
                                                rolling_friction=0.0, damping_factor=0.0,
                                                stiffness_factor=XI),
                     walls=floor(), gravity=(0, 0, -G), dt=dt,
                     contact_model="hysteretic_spring", backend=backend)
    sim.add_particles(RADIUS, [[0.0, 0.0, RADIUS - m * G / k1]], velocities=[[V0, 0.0, 0.0]])

    tr = Trace(lambda s: (s.time, s.state.velocities[0, 0], s.state.omegas[0, 1],
                          s.state.forces[0, 0], s.state.forces[0, 2]))
    sim.run(steps=1200, reporters=[tr])  # three periods
    t, vx, wy, fx, fz = np.array(tr.rows).T
    assert np.all(np.abs(fz) < 1e-3 * m * G)  # the normal load stays m g
    # contact-point displacement s: the integral of x' - R theta_y' from s = 0 at t = 0
    vt = np.concatenate([[V0], vx - RADIUS * wy])
    tt = np.concatenate([[0.0], t])
    s = np.cumsum(0.5 * (vt[1:] + vt[:-1]) * np.diff(tt))
    # the spring itself: F_t = -k_t s = -xi K1 s over the oscillation
    assert -np.polyfit(s, fx, 1)[0] == pytest.approx(kt, rel=0.005)
    # its amplitude k_t v0 / omega_t and period 2 pi / omega_t as the closed form says
    assert np.abs(fx).max() == pytest.approx(kt * V0 / omega, rel=0.005)
    assert np.abs(fx).max() < 0.2 * MU * m * G  # stuck, never sliding
    sign = np.signbit(fx)
    i = np.nonzero(sign[1:] != sign[:-1])[0]
    crossings = t[i] - fx[i] * (t[i + 1] - t[i]) / (fx[i + 1] - fx[i])
    assert len(crossings) >= 5
    assert np.diff(crossings).mean() == pytest.approx(period / 2, rel=0.002)
