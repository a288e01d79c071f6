"""A two-fidelity test double for the calibration loop.

``test-fidelity`` answers ``true_angle(e, mu, mu_r)`` plus seed noise at the ``quick``
(production) profile, and the same minus a known bias at the ``tiny`` (cheap) profile,
so tests know the answer the loop must find. Each execution drops a marker file in
``$DEMCAL_TEST_MARKERS`` (if set), named after the run's seed and parameters.
"""

from __future__ import annotations

import os
import time
import uuid
from pathlib import Path

import numpy as np

from demcal.bench.registry import RunResult, Setting, register

#: production - cheap [deg]
BIAS = 3.0
NOISE = 0.3


def true_angle(e, mu, mu_r, curvature=8.0):
    """The production profile's response [deg]: what the loop must hit. A larger
    ``curvature`` (``test.curvature``) makes it peak in mu within reach (at 0.71 for 40)."""
    return 20.0 + 25.0 * mu + 10.0 * mu_r + 2.0 * e - curvature * (mu - 0.4) ** 2


class FidelityDouble:
    name = "test-fidelity"
    description = "test double: a known angle, a known bias between two profiles, known noise"
    responses = ("repose_angle_deg",)
    profiles = ("tiny", "quick")

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        return {
            "particle.restitution": Setting("particle.restitution", 0.6, "-", low=0.01, high=1.0),
            "particle.static_friction": Setting("particle.static_friction", 0.4, "-", low=0.0, high=2.0),
            "particle.rolling_friction": Setting("particle.rolling_friction", 0.2, "-", low=0.0, high=1.0),
            "test.sleep_s": Setting("test.sleep_s", 0.0, "s", low=0.0),
            # the cheap profile's bias grows by this much per unit of mu above 0.4 (a
            # discrepancy the loop cannot know from the points near the box)
            "test.bias_slope": Setting("test.bias_slope", 0.0, "deg", low=-100.0),
            "test.curvature": Setting("test.curvature", 8.0, "deg", low=0.0),
            # a run with this seed fails (0: none), e.g. one path step
            "test.fail_seed": Setting("test.fail_seed", 0, "-", low=0),
        }

    def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
        from demcal.bench.registry import resolve_settings

        s = resolve_settings(self, settings, profile)
        e, mu, mu_r = s["particle.restitution"], s["particle.static_friction"], s["particle.rolling_friction"]
        markers = os.environ.get("DEMCAL_TEST_MARKERS")
        if markers:
            Path(markers, f"{profile}-{seed}-{e:.4f}-{mu:.4f}-{mu_r:.4f}.{uuid.uuid4().hex[:8]}").touch()
        time.sleep(s["test.sleep_s"])
        if s["test.fail_seed"] and seed == s["test.fail_seed"]:
            raise RuntimeError("the test double fails this seed")
        bias = BIAS + s["test.bias_slope"] * max(mu - 0.4, 0.0)
        angle = true_angle(e, mu, mu_r, s["test.curvature"]) - (bias if profile == "tiny" else 0.0)
        angle += np.random.default_rng(seed).normal(0.0, NOISE)
        return RunResult(test=self.name, responses={"repose_angle_deg": float(angle)}, spread={},
                         particles=10, steps=100, simulated_s=0.1, wall_s=0.01, artifacts={})


register(FidelityDouble())
