"""Two analytic test benches with known identifiability, for ``demcal identify``.

``test-pair`` measures ``y1 = 10 (a + b)`` (a and b only through their sum) and
``y2 = 8 b`` (b alone); ``test.c`` moves neither. ``test-c`` measures ``y3 = 5 c`` and
declares that it reads ``test.c`` (the :mod:`demcal.bench.reads` attribute). Each response
carries Gaussian seed noise of sd ``test.noise`` (0.2). A run costs nothing.

So a campaign of ``test-pair`` on a, b and c fitting ``y1`` alone must find c not pinned
and (a, b) not separately identifiable, and name ``test-c`` for c; fitting ``y1`` and
``y2`` it must pin a and b.
"""

from __future__ import annotations

import numpy as np

from demcal.bench.registry import RunResult, Setting, register

NOISE = 0.2


def _settings() -> dict[str, Setting]:
    return {
        "test.a": Setting("test.a", 0.5, "-", low=0.0, high=1.0),
        "test.b": Setting("test.b", 0.5, "-", low=0.0, high=1.0),
        "test.c": Setting("test.c", 0.5, "-", low=0.0, high=1.0),
        "test.noise": Setting("test.noise", NOISE, "-", low=0.0),
    }


class PairBench:
    name = "test-pair"
    description = "test double: y1 = 10 (a + b), y2 = 8 b, c moves nothing; Gaussian seed noise"
    responses = ("y1", "y2")
    profiles = ("tiny", "quick")
    measures = "a and b through their sum (y1), b alone (y2)"
    reads = ("test.a", "test.b")

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        return _settings()

    def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
        from demcal.bench.registry import resolve_settings

        s = resolve_settings(self, settings, profile)
        noise = np.random.default_rng(seed).normal(0.0, s["test.noise"], size=2)
        y1 = 10.0 * (s["test.a"] + s["test.b"]) + noise[0]
        y2 = 8.0 * s["test.b"] + noise[1]
        return RunResult(test=self.name, responses={"y1": float(y1), "y2": float(y2)}, particles=1, steps=1)


class CBench:
    name = "test-c"
    description = "test double: y3 = 5 c with Gaussian seed noise"
    responses = ("y3",)
    profiles = ("tiny", "quick")
    measures = "c alone"
    reads = ("test.c",)

    def settings(self, profile: str = "quick") -> dict[str, Setting]:
        return _settings()

    def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
        from demcal.bench.registry import resolve_settings

        s = resolve_settings(self, settings, profile)
        y3 = 5.0 * s["test.c"] + np.random.default_rng(seed).normal(0.0, s["test.noise"])
        return RunResult(test=self.name, responses={"y3": float(y3)}, particles=1, steps=1)


register(PairBench())
register(CBench())
