"""The rotating drum (demcal.bench.drum, demcal.measure.drum): the Froude number and
regimes, the surface measurement on a bed of known slope, the bad-input sentences. The
physics at the tiny profile: tests/bench/test_drum_physics.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from demcal.bench.registry import get_experiment
from demcal.errors import ConfigError
from demcal.measure.drum import froude, regime, surface_angle


def test_froude_number_and_regimes():
    # omega = 2 pi 5 / 60 = 0.5236 rad/s; omega^2 R / g at R = 0.15 m
    assert froude(5.0, 0.15) == pytest.approx(0.5236 ** 2 * 0.15 / 9.81, rel=1e-3)
    assert [regime(f)[1] for f in (1e-5, 1e-3, 0.05, 0.5, 2.0)] == \
        ["slumping", "rolling", "cascading", "cataracting", "centrifuging"]


def _bed(angle_deg, radius=0.15, width=0.06, r=0.004, seed=0):
    """Spheres on a square lattice (jittered) filling the drum below a plane through the
    axis inclined at ``angle_deg``, plus a few in flight above it."""
    rng = np.random.default_rng(seed)
    g = np.arange(-radius + r, radius - r, 2 * r)
    x, y, z = (a.ravel() for a in np.meshgrid(g, np.arange(-width / 2 + r, width / 2 - r, 2 * r), g))
    pts = np.c_[x, y, z] + rng.uniform(-2e-4, 2e-4, (x.size, 3))
    inside = np.hypot(pts[:, 0], pts[:, 2]) < radius - r
    below = pts[:, 2] < -math.tan(math.radians(angle_deg)) * pts[:, 0] - 0.02
    bed = pts[inside & below]
    flying = np.array([[0.0, 0.0, 0.09], [0.05, 0.0, 0.1]])
    pos = np.r_[bed, flying]
    return pos, np.full(len(pos), r)


@pytest.mark.parametrize("angle", [20.0, 35.0, 65.0, 80.0])
def test_surface_angle_of_a_bed_of_known_slope(angle):
    """The surface fit reads the bed's slope to within a degree (the lattice's steps),
    steep beds too (the outline is read along the bed's own normal, not from above); the
    spheres in flight are not part of the bed."""
    pos, rad = _bed(angle)
    fit = surface_angle(pos, rad, 0.15)
    assert fit.angle_deg == pytest.approx(angle, abs=1.0)
    assert fit.r2 > 0.95


@pytest.mark.parametrize("override, words", [
    ({"drum.rpm": 200.0}, "centrifuges its bed"),
    ({"geometry.drum_width": 0.03}, "narrower than two of the largest particles"),
    ({"geometry.fill": 0.001}, "geometry.fill"),
])
def test_bad_drum_is_one_sentence(override, words):
    with pytest.raises(ConfigError, match=words):
        get_experiment("drum").run(override, seed=1, profile="tiny")
