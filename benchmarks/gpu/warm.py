#!/usr/bin/env python3
"""Compile (into numba's on-disk cache) the CPU engine for the contact models the GPU
script compares against, one process per model, all at once: on a many-core machine
the cold compiles then cost one compile's time, not one per model.

    python benchmarks/gpu/warm.py   # then the other scripts load the cache
"""

from __future__ import annotations

import subprocess
import sys

MODELS = [("hertz_mindlin", "cdt"), ("hysteretic_spring", "cdt"), ("hertz_mindlin", "epsd"),
          ("linear", "rvd"), ("hertz_mindlin_jkr", "type_a_limited"),
          ("hertz_mindlin", "none"), ("hysteretic_spring", "type_a"),
          ("hysteretic_spring", "type_c")]

ONE = """
from demcal.dem import Simulation
from demcal.geometry import Box, WallSet
from demcal.particles.materials import Interaction, soil
for split in (False, True):
    sim = Simulation([soil()], Interaction(), walls=WallSet([Box(lower=(0, 0, 0),
                     upper=(0.1, 0.1, 0.1))]), contact_model={0!r}, rolling_model={1!r},
                     threads=2)
    if split:
        sim.parallel_threshold = 0
    sim.add_particles(0.004, [[0.05, 0.05, 0.004], [0.05, 0.05, 0.0119]])
    sim.run(steps=3)
"""


def main() -> int:
    procs = [subprocess.Popen([sys.executable, "-c", ONE.format(m, r)]) for m, r in MODELS]
    return max(p.wait() for p in procs)


if __name__ == "__main__":
    sys.exit(main())
