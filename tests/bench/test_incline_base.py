"""The incline's base kinematics: how the bed moves at the detection of sliding."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from demcal.bench.incline import base_kinematics


def _state(v, omega_y, z_top=None):
    """Spheres of radius 5 mm on the film (z = 5 mm), one per body, plus one body on top."""
    r = 0.005
    pos = np.array([[0.0, 0.0, r], [0.02, 0.0, r]] + ([[0.01, 0.0, z_top]] if z_top else []))
    n = len(pos)
    vel = np.zeros((n, 3))
    vel[:2, 0] = v
    if z_top:
        vel[2, 0] = 2 * v
    om = np.zeros((n, 3))
    om[:2, 1] = omega_y
    return SimpleNamespace(positions=pos, velocities=vel, omegas=om, masses=np.ones(n),
                           sphere_positions=pos.copy(), radii=np.full(n, r), sphere_body=np.arange(n))


def test_sliding_without_rotation_is_all_slip():
    out = base_kinematics(_state(0.01, 0.0))
    assert out["base_slip_ratio"] == pytest.approx(1.0)
    assert out["base_velocity_ratio"] == pytest.approx(1.0) and out["base_mass_fraction"] == 1.0


def test_rolling_without_slip_is_no_slip():
    # v = omega_y R rolls along +x without slipping (contact point at rest): v + omega_y (-R) = 0
    out = base_kinematics(_state(0.01, 0.01 / 0.005))
    assert out["base_slip_ratio"] == pytest.approx(0.0, abs=1e-12)


def test_a_bed_that_shears_above_its_base():
    # the top body moves twice as fast as the two basal ones: the base carries 2/3 of the mass
    out = base_kinematics(_state(0.01, 0.0, z_top=0.02))
    assert out["base_mass_fraction"] == pytest.approx(2 / 3)
    assert out["base_velocity_ratio"] == pytest.approx(0.01 / (0.04 / 3))
