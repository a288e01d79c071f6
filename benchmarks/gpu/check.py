#!/usr/bin/env python3
"""The cuda backend against the cpu backend on one machine, then against itself.

A pour of polydisperse spheres or two-sphere clumps into a box (``tests/dem/test_pour.py``'s
builder), settled on the CPU and stirred (random velocities of 1 m/s, so that contacts
open, close and the lists are rebuilt), then run for ``--steps`` steps on each backend
from that checkpoint and compared field by field (positions, velocities, angular
velocities, forces, torques) as the largest difference over the largest value; then the
cuda run again, compared to the bit. One JSON line per case and horizon::

    python benchmarks/gpu/check.py --particles 300 --steps 400 1000 3000 --out results.jsonl

Cases: Hertz-Mindlin with rolling type A, C (cdt) and EPSD, the Hysteretic Spring with
type C, spheres and clumps.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "dem"))

FIELDS = ("positions", "velocities", "omegas", "forces", "torques")

CASES = [
    ("hertz_mindlin", "cdt", False),
    ("hysteretic_spring", "cdt", True),
    ("hertz_mindlin", "type_a", False),
    ("hertz_mindlin", "epsd", True),
]


def pour(backend, n, model, rolling, clumps, threads):
    from test_pour import pour as _pour

    from demcal.particles.templates import two_sphere_paper
    template = two_sphere_paper(resolution=48).scaled(0.25) if clumps else 0.0015
    return _pour(backend, n, 0.03, template=template, model=model, rolling=rolling,
                 threads=threads, fill=4.0)


def errors(a, b) -> dict:
    out = {}
    for f in FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        scale = float(np.max(np.abs(x))) or 1.0
        out[f] = float(np.max(np.abs(x - y))) / scale
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--particles", type=int, default=300)
    ap.add_argument("--steps", type=int, nargs="+", default=[100, 400, 1500])
    ap.add_argument("--threads", type=int, default=4)
    ap.add_argument("--out", default="-")
    ap.add_argument("--cases", type=int, default=len(CASES), help="the first N cases")
    args = ap.parse_args(argv)
    sink = sys.stdout if args.out == "-" else open(args.out, "a")
    for model, rolling, clumps in CASES[:args.cases]:
        base = pour("cpu", args.particles, model, rolling, clumps, args.threads)
        base.run(duration=0.2)
        rng = np.random.default_rng(5)
        base.state.velocities[:] += rng.normal(0.0, 0.6, (base.n_particles, 3))
        path = Path(tempfile.mkdtemp()) / "start.npz"
        base.save_checkpoint(path)
        sims = {}
        for backend in ("cpu", "cuda", "cuda"):
            sim = pour(backend, args.particles, model, rolling, clumps, args.threads)
            sim.load_checkpoint(path)
            sims.setdefault(backend, []).append(sim)
        done = 0
        for steps in args.steps:
            walls = {}
            for backend, runs in sims.items():
                for sim in runs:
                    t0 = time.perf_counter()
                    sim.run(steps=steps - done)
                    walls.setdefault(backend, []).append(time.perf_counter() - t0)
            done = steps
            cpu, (gpu, again) = sims["cpu"][0], sims["cuda"]
            sa, sb, sc = cpu.state, gpu.state, again.state
            row = {"case": f"{model} + {rolling} {'clumps' if clumps else 'spheres'}",
                   "particles": cpu.n_particles, "steps": steps,
                   "touching_pairs": int(cpu._store.pairs.act.sum()),
                   "cuda_vs_cpu": errors(sa, sb),
                   "cuda_twice_same_bits": all(np.array_equal(getattr(sb, f), getattr(sc, f))
                                               for f in FIELDS),
                   "rebuilds": [cpu.rebuilds, gpu.rebuilds],
                   "wall_s": {k: [round(v, 3) for v in w] for k, w in walls.items()}}
            print(json.dumps(row), file=sink, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
