"""A rotating wall against a static one: a 224-sphere drum, 4,000 steps (issue 18).

    python benchmarks/drum.py [--steps 4000] [--repeat 3] [--json]

A horizontal closed drum (a cylinder and two end disks about the y axis, radius 40.5 mm,
depth 48 mm) holds 224 spheres of 4.5 mm; it turns at 2 rad/s, or stands still, while
the engine runs ``--steps`` steps on one thread. Before issue 18 a rotating wall sent
the engine back to one Python step per time step (19x the static drum's time); the
compiled step loop now places rotating walls itself. Prints the best of ``--repeat``
wall times of each and their ratio. Figures: docs/performance.md.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np


def drum(turning: bool, n: int = 224):
    from demcal.dem import Simulation
    from demcal.geometry import Rotation, Static, WallSet, closed_drum
    from demcal.particles.materials import Interaction, soil, steel

    r, rd, length = 0.0045, 0.0405, 0.048
    turn = (Rotation(point=(0, 0, 0), axis=(0, 1, 0), angular_speed=2.0) if turning
            else Static())
    walls = WallSet(closed_drum(rd, length, motion=turn, material=1))
    sim = Simulation([soil(), steel()], Interaction(restitution=0.5, static_friction=0.5,
                                                rolling_friction=0.05),
                     walls=walls, threads=1)
    g = 2.05 * r
    cells = [(x, y, z) for z in np.arange(-rd + g, rd, g) for x in np.arange(-rd + g, rd, g)
             for y in np.arange(-length / 2 + g / 2, length / 2 - g / 4, g)
             if math.hypot(x, z) < rd - g / 2]
    if len(cells) < n:
        raise SystemExit(f"the drum holds {len(cells)} spheres, fewer than {n}")
    sim.add_particles(r, np.array(cells[:n]))
    return sim


def timed(turning: bool, steps: int) -> float:
    sim = drum(turning)
    sim.run(steps=10)                      # compile (or load) and build the lists
    t = time.perf_counter()
    sim.run(steps=steps)
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    static = min(timed(False, a.steps) for _ in range(a.repeat))
    turning = min(timed(True, a.steps) for _ in range(a.repeat))
    out = dict(spheres=224, steps=a.steps, static_s=round(static, 4),
               rotating_s=round(turning, 4), ratio=round(turning / static, 2))
    print(json.dumps(out) if a.json else
          f"224-sphere drum, {a.steps} steps, one thread: static {static:.3f} s, "
          f"rotating {turning:.3f} s, ratio {turning / static:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
