#!/usr/bin/env python3
"""Engine throughput on a settled polydisperse packing (issue 3, acceptance 7).

Builds (once, cached under ``benchmarks/.packings/``) a packing of N particles --
spheres of radius 2.5 mm x U(0.5, 1.5), or the paper's two-sphere unit at 0.5 x that
scale distribution with ``--clumps`` -- poured into a square box (floor + four side
walls, width chosen so the bed is about 0.7 widths deep) and settled under gravity with
Hertz-Mindlin (no slip) + tangential history + rolling friction and the paper's soil
values (Table 2). Then times ``--steps`` steps of the settled bed and prints::

    {"particles": N, "threads": T, "steps": .., "particle_steps_per_s": ..,
     "compile_s": .., "bytes_per_particle": .., ...}

``compile_s`` is the time of the first step in this process (numba JIT, or loading
the on-disk cache when warm). ``bytes_per_particle`` counts the engine's arrays (bodies,
spheres, neighbour list with history, wall contacts) divided by N.

The sphere packing is also written in the format of ``benchmarks/liggghts/run_liggghts.py``
(``--liggghts`` runs that harness on it with the same dt, skin, model and materials).

Usage::

    python benchmarks/throughput.py --particles 5000 --threads 1 --json
    python benchmarks/throughput.py --particles 20000 --threads 2 --clumps --json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
R0 = 0.0025          # [m] sphere radius at scale 1 (as the LIGGGHTS harness)
SOLID_PER_PARTICLE = 1.7e-7  # [m3] bed volume per particle at ~0.6 packing fraction


def build(n, clumps, threads, rolling, settle_time, backend="cpu"):
    from demcal.dem import Simulation
    from demcal.geometry import Box, WallSet
    from demcal.particles.insertion import BoxRegion, insert
    from demcal.particles.materials import Interaction, soil
    from demcal.particles.sizes import Uniform

    scale = 1.0
    if clumps:
        from demcal.particles.templates import two_sphere_paper
        template = two_sphere_paper(resolution=96)
        # match the spheres' volume per particle: paper unit (4 + 5 mm) scaled down
        scale = (4 / 3 * math.pi * R0 ** 3 / template.volume) ** (1 / 3)
        template = template.scaled(scale)
    else:
        template = R0
    width = (n * SOLID_PER_PARTICLE / 0.7) ** (1 / 3)
    height = 2.5 * width  # insertion region: random insertion reaches ~30 % solids
    if clumps:  # insertion tests bounding spheres, which are larger than the clumps
        height *= (template.bounding_radius / R0) ** 3
    walls = WallSet([Box(lower=(0, 0, 0), upper=(width, width, height), material=0,
                         name="box")])
    inter = Interaction(restitution=0.6, static_friction=0.4, rolling_friction=0.2)
    sim = Simulation([soil()], inter, walls=walls, rolling_model=rolling, threads=threads,
                     backend=backend)
    ins = insert(BoxRegion((0, 0, 0), (width, width, height)), n, template=template,
                 sizes=Uniform(0.5, 1.5), seed=12345)
    # add the particles in spatial (cell) order: neighbours in space are neighbours in
    # memory, which the engine's loops profit from
    cell = 2.0 * R0
    key = np.floor(ins.positions / cell).astype(np.int64)
    order = np.lexsort((key[:, 0], key[:, 1], key[:, 2]))
    sim.add_particles(template, ins.positions[order], orientations=ins.orientations[order],
                      scales=ins.scales[order])
    return sim, width, height


BASE = 5000  # particles in the settled packing that larger ones are tiled from


def tiled(base, n, clumps, threads, rolling, backend="cpu"):
    """A settled packing of n = k * BASE particles: k copies of the settled BASE bed side
    by side in a k-times wider box (then relaxed briefly by the caller). Settling 100,000
    particles from scratch would take hours on two cores; tiling gives the same bed depth,
    contact density and polydispersity."""
    from demcal.dem import Simulation
    from demcal.geometry import Box, WallSet
    from demcal.particles.materials import Interaction, soil

    k = n // BASE
    nx = int(math.floor(math.sqrt(k)))
    while k % nx:
        nx -= 1
    ny = k // nx
    st = base.state
    width = base.walls.walls[0].upper[0]
    height = base.walls.walls[0].upper[2]
    walls = WallSet([Box(lower=(0, 0, 0), upper=(nx * width, ny * width, height),
                         material=0, name="box")])
    inter = Interaction(restitution=0.6, static_friction=0.4, rolling_friction=0.2)
    sim = Simulation([soil()], inter, walls=walls, rolling_model=rolling, threads=threads,
                     dt=base.dt, backend=backend)
    tpl = base.templates[0]
    for ix in range(nx):
        for iy in range(ny):
            sim.add_particles(tpl, st.positions + [ix * width, iy * width, 0.0],
                              orientations=st.quaternions, scales=st.scales)
    return sim, nx * width, height


def packing_path(n, clumps, rolling):
    return HERE / ".packings" / f"{'clumps' if clumps else 'spheres'}_{rolling}_{n}.npz"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--clumps", action="store_true", help="two-sphere particles")
    ap.add_argument("--rolling", default="cdt",
                    help="rolling model (cdt matches the LIGGGHTS harness)")
    ap.add_argument("--settle-time", type=float, default=0.6, help="[s] simulated")
    ap.add_argument("--rebuild", action="store_true", help="rebuild the cached packing")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--backend", default="cpu", help="cpu or cuda (threads: the host's)")
    ap.add_argument("--liggghts", action="store_true",
                    help="also time LIGGGHTS on the same packing (spheres only)")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    n_req = args.particles
    tile = n_req > BASE and n_req % BASE == 0
    sim, _, _ = build(BASE if tile else n_req, args.clumps, args.threads,
                      args.rolling, args.settle_time, args.backend)
    path = packing_path(BASE if tile else n_req, args.clumps, args.rolling)
    t1 = time.perf_counter()
    sim.run(steps=1)
    compile_s = time.perf_counter() - t1
    if path.exists() and not args.rebuild:
        sim.load_checkpoint(path)
    else:
        sim.run(duration=args.settle_time)
        path.parent.mkdir(exist_ok=True)
        sim.save_checkpoint(path)
    if tile:
        sim, _, _ = tiled(sim, n_req, args.clumps, args.threads, args.rolling, args.backend)
        path = packing_path(n_req, args.clumps, args.rolling)
        if path.exists() and not args.rebuild:
            sim.load_checkpoint(path)
        else:
            sim.run(duration=0.03)  # relax the seams between tiles
            sim.save_checkpoint(path)
    lpath = path.with_suffix(".liggghts.npz")
    if not args.clumps and (args.rebuild or not lpath.exists()):
        st = sim.state
        box = sim.walls.walls[0]
        np.savez(lpath, positions=st.positions, radii=st.radii, velocities=st.velocities,
                 box=np.concatenate([box.lower, box.upper]), dt=sim.dt, skin=sim.skin,
                 density=1687.85, shear_modulus=1e6, poisson_ratio=0.46, restitution=0.6,
                 static_friction=0.4, rolling_friction=0.2)
    ke = sim.kinetic_energy()
    sim.run(steps=50)  # warm-up (neighbour list, caches)
    rebuilds0 = sim.rebuilds
    split0 = dict(getattr(sim.engine_backend, "seconds", {}))
    t2 = time.perf_counter()
    sim.run(steps=args.steps)
    loop = time.perf_counter() - t2
    split = {k: round(v - split0[k], 3) for k, v in getattr(sim.engine_backend, "seconds", {}).items()}
    n = sim.n_particles
    nbytes = sim.nbytes
    ncontacts = len(sim.contacts()[0])
    out = {
        "particles": n,
        "threads": args.threads,
        "backend": args.backend,
        "steps": args.steps,
        "particle_steps_per_s": n * args.steps / loop,
        "compile_s": round(compile_s, 2),
        "bytes_per_particle": int(nbytes / n),
        "kind": "two-sphere clumps" if args.clumps else "spheres",
        "model": f"hertz_mindlin + tangential history + rolling {args.rolling}",
        "dt": sim.dt,
        "skin": sim.skin,
        "contacts_per_particle": round(2 * ncontacts / n, 2),
        "rebuilds": sim.rebuilds - rebuilds0,
        "kinetic_energy_J": ke,
        "loop_s": round(loop, 3),
        **({"backend_seconds": split} if split else {}),
        "total_s": round(time.perf_counter() - t0, 1),
    }
    if args.liggghts and not args.clumps:
        lp = path.with_suffix(".liggghts.npz")
        cmd = [sys.executable, str(HERE / "liggghts" / "run_liggghts.py"), "--packing", str(lp),
               "--steps", str(args.steps), "--json", "--procs", str(args.threads)]
        res = subprocess.run(cmd, capture_output=True, text=True)
        try:
            lg = json.loads(res.stdout.strip().splitlines()[-1])
            out["liggghts_particle_steps_per_s"] = lg["particle_steps_per_s"]
            out["ratio_vs_liggghts"] = out["particle_steps_per_s"] / lg["particle_steps_per_s"]
        except (ValueError, IndexError, KeyError):
            out["liggghts_error"] = (res.stderr or res.stdout)[-500:]
    if args.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:>28}: {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
