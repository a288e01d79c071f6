"""Inclined plane: a rigid block slides at atan(mu) (issue 4, acceptance 2), and the
onset detection recovers the onset of a uniformly ramped block exactly."""

import math

import numpy as np
import pytest

from demcal.bench.incline import onset_angle
from demcal.bench.registry import get_experiment


def test_onset_extrapolation_is_exact_for_a_block_on_a_ramp():
    # block: v = 0.5 k (t - tc)^2 after the onset at tc; tilt 10 deg/s from 20 deg
    t = np.arange(0.0, 2.0, 0.005)
    angles = 20.0 + 10.0 * t
    tc = 1.2345
    v = np.where(t > tc, 0.5 * 2.0 * (t - tc) ** 2, 0.0)
    stop = int(np.argmax(v > 0.02)) + 1
    theta_c, theta_d = onset_angle(t[:stop], angles[:stop], v[:stop], 0.02)
    assert theta_c == pytest.approx(20.0 + 10.0 * tc, abs=0.01)
    assert theta_d > theta_c


@pytest.mark.parametrize("mu", [0.3, 0.5, 0.7])
def test_rigid_block_slides_at_atan_mu(mu):
    r = get_experiment("incline").run(
        {"incline.material": "block", "film.static_friction": mu, "incline.tilt_rate": 10.0},
        seed=0, profile="quick")
    theta = r.responses["sliding_angle_deg"]
    assert theta == pytest.approx(math.degrees(math.atan(mu)), abs=0.5)
    assert r.responses["equivalent_height_mm"] == pytest.approx(300 * math.sin(math.radians(theta)))
