"""Cohesion as a factor: the funnel heap steepens with the JKR surface energy.

A particle of the paper's unit (mean solid volume 0.96 cm3 at 1687.85 kg/m3) weighs about
0.016 N; two of its 5 mm spheres in contact (R* = 2.5 mm) pull off at 1.5 pi gamma R*
(Johnson, Kendall & Roberts 1971), the weight at gamma = 1.4 J/m2. At 3 J/m2 a contact
holds about twice a particle's weight, so the heap must stand clearly steeper than the
cohesionless one; at 1.5 J/m2 in between.
"""

import numpy as np
import pytest

from demcal.bench.registry import get_experiment

pytestmark = pytest.mark.slow

JKR = {"contact.model": "hertz_mindlin_jkr"}


def _angle(surface_energy: float, seed: int) -> float:
    result = get_experiment("repose-funnel").run({**JKR, "particle.surface_energy": surface_energy},
                                                 seed=seed, profile="tiny")
    return result.responses["repose_angle_deg"]


def test_the_heap_angle_rises_with_surface_energy():
    angles = {g: np.mean([_angle(g, seed) for seed in (1, 2)]) for g in (0.0, 1.5, 3.0)}
    # tiny funnel seed noise is 2-3 deg: the gaps asked for are well above it
    assert angles[3.0] > angles[0.0] + 8.0, angles
    assert angles[0.0] < angles[1.5] < angles[3.0], angles
