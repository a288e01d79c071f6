"""Two analytic benches that share the particle's frictions, for the joint calibration.

``test-slope`` measures a heap-like angle that sees the two frictions only through a sum,
``slope_deg = 20 + 30 (mu - 0.4) + 30 (mu_r - 0.2)``; ``test-spin`` a drum-like angle that
sees the rolling friction alone, ``spin_deg = 30 + 40 (mu_r - 0.2)``. Each has Gaussian
seed noise of sd 0.3 deg and costs nothing. One slope angle leaves a line of (mu, mu_r)
solutions; the spin angle cuts it: the joint solution set must be smaller than either
test's alone and hold the truth. ``test-tilt`` (``tilt_deg = 25 + 20 (mu - 0.4)``) is
the hold-out: predicted with the calibrated values, never fitted.
"""

from __future__ import annotations

import numpy as np

from demcal.bench.registry import RunResult, Setting, register

NOISE = 0.3


def slope_deg(mu: float, mu_r: float) -> float:
    return 20.0 + 30.0 * (mu - 0.4) + 30.0 * (mu_r - 0.2)


def spin_deg(mu_r: float) -> float:
    return 30.0 + 40.0 * (mu_r - 0.2)


class _Bench:
    profiles = ("tiny", "quick")

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        return {
            "particle.static_friction": Setting("particle.static_friction", 0.4, "-", low=0.0, high=2.0),
            "particle.rolling_friction": Setting("particle.rolling_friction", 0.2, "-", low=0.0, high=1.0),
            "particles.count": Setting("particles.count", 100, "-", low=1, high=10_000),
        }

    def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
        from demcal.bench.registry import resolve_settings

        s = resolve_settings(self, settings, profile)
        value = self.angle(s["particle.static_friction"], s["particle.rolling_friction"])
        value += np.random.default_rng([seed, len(self.name)]).normal(0.0, NOISE)
        return RunResult(test=self.name, responses={self.responses[0]: float(value)},
                         particles=int(s["particles.count"]), steps=1)


class SlopeBench(_Bench):
    name = "test-slope"
    description = "test double: a heap angle of mu + mu_r"
    responses = ("slope_deg",)

    def angle(self, mu, mu_r):
        return slope_deg(mu, mu_r)


class SpinBench(_Bench):
    name = "test-spin"
    description = "test double: a drum angle of mu_r alone"
    responses = ("spin_deg",)

    def angle(self, mu, mu_r):
        return spin_deg(mu_r)


def tilt_deg(mu: float) -> float:
    return 25.0 + 20.0 * (mu - 0.4)


class TiltBench(_Bench):
    name = "test-tilt"
    description = "test double: an incline angle of mu alone (the hold-out)"
    responses = ("tilt_deg",)

    def angle(self, mu, mu_r):
        return tilt_deg(mu)


register(SlopeBench())
register(SpinBench())
register(TiltBench())
