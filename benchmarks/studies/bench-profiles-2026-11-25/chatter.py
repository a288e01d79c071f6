"""A settled bed at rest under type A and type C rolling: how fast it still moves, by
depth and rolling friction (the chatter hypothesis: docs/validation-repose.md, "Rolling
models at the paper's heap size"; its history in this folder's README). 432 spheres of
4.05-4.95 mm in a 55 mm open box, HSCM soil, 1 s, one thread:

    python benchmarks/studies/bench-profiles-2026-11-25/chatter.py [MODEL ...]   # default: type_a type_c
"""
import sys

import numpy as np
from demcal.dem import Simulation
from demcal.geometry import Box, WallSet
from demcal.particles.materials import Interaction, soil, steel

def bed(mu_r, model, n_side=6, layers=12, r=0.0045, t=1.0):
    L = n_side * 2.05 * r
    walls = WallSet([Box(lower=(0, 0, 0), upper=(L, L, 1.0), open_top=True, material=1, name="box")])

    sim = Simulation([soil(), steel()], Interaction(restitution=0.6, static_friction=0.4, rolling_friction=mu_r),
                     walls=walls, contact_model="hysteretic_spring", rolling_model=model, threads=1)
    rng = np.random.default_rng(1)
    g = 2.05 * r
    pos = [(g/2 + i*g + rng.uniform(-1e-4, 1e-4), g/2 + j*g, g/2 + k*g*1.02) for k in range(layers) for j in range(n_side) for i in range(n_side)]
    sim.add_particles(radii=r * rng.uniform(0.9, 1.1, len(pos)), positions=np.array(pos))
    sim.run(duration=t)
    st = sim.state
    w = np.linalg.norm(st.omegas, axis=1) * r
    z = st.positions[:, 2]
    top = z.max()
    deep = z < top / 3
    shallow = z > 2 * top / 3
    return np.sqrt((w[deep]**2).mean()), np.sqrt((w[shallow]**2).mean()), np.sqrt((np.linalg.norm(st.velocities,axis=1)**2).mean())

for model in (sys.argv[1:] or ("type_a", "type_c")):
    for mu_r in (0.1, 0.3):
        d, s, v = bed(mu_r, model)
        print(f"{model} mu_r {mu_r}: rms surface speed from spin, deep third {d*1e3:.3f} mm/s, top third {s*1e3:.3f} mm/s; rms speed {v*1e3:.3f} mm/s", flush=True)
