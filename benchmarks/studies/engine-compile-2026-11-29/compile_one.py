"""One contact-model combination compiled and run: 60 spheres in a box, 200 steps.

``NUMBA_CACHE_DIR=DIR python compile_one.py MODEL ROLLING`` prints the import time, the
build-and-run time (a cold compile when DIR holds nothing for the combination) and the
first particle's position (the bits). See README.md.
"""

from __future__ import annotations

import sys
import time


def main(model: str, rolling: str) -> int:
    t0 = time.perf_counter()
    from demcal.dem import Simulation
    from demcal.geometry import Box, WallSet
    from demcal.particles.insertion import BoxRegion, insert
    from demcal.particles.materials import Interaction, Material
    from demcal.particles.sizes import Uniform

    soft = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3,
                    yield_strength=1.0e6, name="soft")
    t1 = time.perf_counter()
    sim = Simulation([soft, soft], Interaction(restitution=0.4, static_friction=0.5,
                                               rolling_friction=0.1),
                     walls=WallSet([Box(lower=(0, 0, 0), upper=(0.02, 0.02, 0.08), material=1)]),
                     contact_model=model, rolling_model=rolling, threads=1)
    ins = insert(BoxRegion((0, 0, 0), (0.02, 0.02, 0.06)), 60, template=0.002,
                 sizes=Uniform(0.8, 1.2), seed=1)
    sim.add_particles(0.002, ins.positions)
    sim.run(steps=200)
    t2 = time.perf_counter()
    print(f"{model} {rolling}: import {t1 - t0:.1f} s, build+run {t2 - t1:.1f} s, "
          f"pos {sim.state.positions[0].tolist()}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
