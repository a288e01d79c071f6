"""Oblique impact of a sphere on a flat wall (Chung & Ooi 2011, Granular Matter 13,
643-656, test 6; after Maw, Barber & Fawcett 1976 and Thornton et al.).

With Psi = (contact-point tangential velocity) / (normal velocity):

* gross sliding throughout the impact (large Psi1): rigid-body impulse balance gives
  v_t' = v_t - mu (1 + e) v_n and w' R = (5/2) mu (1 + e) v_n for a solid sphere, so the
  rebound spin plateaus and Psi2 = Psi1 - (7/2) mu (1 + e);
* small Psi1: the tangential (Mindlin) spring stores energy and the contact-point
  tangential velocity reverses, Psi2 < 0 (Maw et al. 1976);
* in between, w' R / v_n rises monotonically with Psi1 up to the plateau.
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.dem.timestep import hertz_contact_time
from demcal.particles.materials import Interaction

from dem_helpers import GLASS, RADIUS, WALL, floor, sphere_mass

MU = 0.3
E = 0.5
VN = 1.0


def rebound(backend, vt):
    tc = 1.3 * hertz_contact_time(sphere_mass(), RADIUS, 1.43e8, VN)
    dt = tc / 300
    sim = Simulation([GLASS, WALL], Interaction(restitution=E, static_friction=MU,
                                                rolling_friction=0.0),
                     walls=floor(), gravity=(0, 0, 0), dt=dt, backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS + 1e-9]], velocities=[[vt, 0, -VN]])
    sim.run(steps=600)
    v = sim.state.velocities[0]
    w = sim.state.omegas[0]
    return v[0], w[1], v[2]


def test_sliding_regime_closed_form(backend):
    vt = 5.0 * 3.5 * MU * (1 + E) * VN
    vtx, wy, vz = rebound(backend, vt)
    assert vz == pytest.approx(E * VN, rel=0.01)
    assert vtx == pytest.approx(vt - MU * (1 + E) * VN, rel=0.01)
    # the lever is R - delta/2 (contact point mid-overlap), about 1 % below R here
    assert wy * RADIUS == pytest.approx(2.5 * MU * (1 + E) * VN, rel=0.02)


def test_tangential_reversal_at_small_angles(backend):
    vt = 0.05 * VN
    vtx, wy, vz = rebound(backend, vt)
    psi2 = (vtx - wy * RADIUS) / vz
    assert psi2 < 0.0


def test_spin_rises_to_plateau(backend):
    plateau = 2.5 * MU * (1 + E) * VN
    vts = np.array([0.1, 0.3, 0.6, 1.0, 2.0, 4.0]) * VN
    spins = np.array([rebound(backend, vt)[1] * RADIUS for vt in vts])
    assert np.all(np.diff(spins) >= -1e-9 * plateau)
    assert spins[-1] == pytest.approx(plateau, rel=0.01)
    assert spins[0] < 0.5 * plateau
