"""A test double of a virtual experiment, for the runner's mechanics.

``test-heap`` is a deterministic function of its settings and seed that takes a
fraction of a second: a known quadratic "angle" plus seed noise. It is registered
as a plugin (``[experiment] plugins = ["campaign_testbench"]``), so spawned pool
workers and Dask workers register it too. Each execution drops a marker file in
``$DEMCAL_TEST_MARKERS`` (if set), so tests can count how often a run executed.
"""

from __future__ import annotations

import os
import time
import uuid
from pathlib import Path

import numpy as np

from demcal.bench.registry import RunResult, Setting, register
from demcal.errors import SimulationError


def true_angle(e, mu, mu_r, zeta):
    """The response surface the test double simulates [deg]."""
    a, b, c, d = (e - 0.6) / 0.1, (mu - 0.4) / 0.1, (mu_r - 0.2) / 0.1, (zeta - 0.1) / 0.1
    return 40.0 - 0.5 * a + 3.0 * b + 6.0 * c + 1.9 * b * c - 1.7 * a * d - 1.5 * c * c


class HeapDouble:
    name = "test-heap"
    description = "test double: a known quadratic angle plus seed noise"
    responses = ("repose_angle_deg",)
    profiles = ("quick", "tiny")

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        return {
            "particle.restitution": Setting("particle.restitution", 0.6, "-", low=0.0, high=1.0),
            "particle.static_friction": Setting("particle.static_friction", 0.4, "-", low=0.0, high=2.0),
            "particle.rolling_friction": Setting("particle.rolling_friction", 0.2, "-", low=0.0, high=1.0),
            "particle.damping_factor": Setting("particle.damping_factor", 0.1, "-", low=0.0, high=1.0),
            "geometry.scale": Setting("geometry.scale", 4.0, "-", low=0.5, high=10.0),
            "test.sleep_s": Setting("test.sleep_s", 0.05 if profile == "tiny" else 0.2, "s", low=0.0),
            "test.noise_deg": Setting("test.noise_deg", 0.3, "deg", low=0.0),
            "test.fail_above_friction": Setting("test.fail_above_friction", 99.0, "-"),
        }

    def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
        from demcal.bench.registry import resolve_settings

        s = resolve_settings(self, settings, profile)
        markers = os.environ.get("DEMCAL_TEST_MARKERS")
        if markers:
            tag = f"{seed}-{s['particle.static_friction']:.4f}-{s['particle.rolling_friction']:.4f}"
            Path(markers, f"{tag}.{uuid.uuid4().hex[:8]}").touch()
        start = time.perf_counter()
        time.sleep(s["test.sleep_s"])
        if s["particle.static_friction"] > s["test.fail_above_friction"]:
            raise SimulationError("the heap blew up (test double: static friction above the set limit).")
        noise = np.random.default_rng(seed).normal(0.0, s["test.noise_deg"])
        angle = true_angle(s["particle.restitution"], s["particle.static_friction"],
                           s["particle.rolling_friction"], s["particle.damping_factor"]) + noise
        artifacts = {}
        if out_dir is not None:
            path = Path(out_dir, "heap.txt")
            path.write_text(f"angle {angle:.6f}\n")
            artifacts["heap"] = str(path)
        return RunResult(test=self.name, responses={"repose_angle_deg": float(angle)},
                         spread={"repose_angle_deg": 0.1}, particles=100, steps=1000,
                         simulated_s=1.0, wall_s=time.perf_counter() - start, artifacts=artifacts)


register(HeapDouble())
