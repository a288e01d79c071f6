"""The cuda backend against the cpu backend, run in numba-cuda's simulator.

Run as a script (``NUMBA_ENABLE_CUDASIM=1``, set by tests/dem/test_cuda_backend.py in a
subprocess of its own, so that no other test process imports numba.cuda in simulator
mode): each case builds a small bed on the CPU, settles it, stirs it (random velocities,
so that the lists are rebuilt inside the device's step loop) and runs it on both
backends from one checkpoint. Prints one JSON line per case with each field's largest
difference over its largest value, the rebuilds on each side, whether the lists and
contact histories agree, and the wall kinds in touch.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from demcal.dem import Simulation
from demcal.geometry import Box, Cone, Cylinder, Plane, Rect, TriangleMesh, WallSet
from demcal.geometry.kernels import KIND_NAMES
from demcal.particles.insertion import BoxRegion, insert
from demcal.particles.materials import Interaction, Material
from demcal.particles.sizes import Uniform
from demcal.particles.templates import two_sphere_paper

SOFT = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3,
                yield_strength=1.0e6, name="soft")
SOFT_WALL = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3,
                     yield_strength=1.0e6, name="soft_wall")
FIELDS = ("positions", "velocities", "omegas", "quaternions", "forces", "torques")


def box_walls():
    """A box of rectangles whose floor lies under a plane (the bed rests on the plane)."""
    return WallSet([Box(lower=(-0.012, -0.012, -0.001), upper=(0.012, 0.012, 0.06),
                        material=1),
                    Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1)])


def vessel_walls():
    """Every wall kind: a cylinder with its disk floor, a cone sunk in the floor, a
    leaning rectangle and a two-triangle mesh ramp."""
    ramp = TriangleMesh(np.array([[-0.02, -0.02, 0.0], [0.0, -0.02, 0.0],
                                  [0.0, 0.02, 0.008], [-0.02, 0.02, 0.008]]),
                        np.array([[0, 1, 2], [0, 2, 3]]), material=1)
    return WallSet([Cylinder(base=(0, 0, 0), axis=(0, 0, 1), radius=0.015, length=0.06,
                             bottom=True, material=1),
                    Cone(base=(0.008, 0.0, 0.0), axis=(0, 0, 1), r1=0.0, r2=0.005,
                         length=0.004, material=1),
                    Rect(centre=(0.0, 0.01, 0.01), u=(0.008, 0.0, 0.0),
                         v=(0.0, 0.003, 0.01), material=1),
                    ramp])


#: (name, contact model, rolling model, clumps, walls, particles, stir speed [m/s]):
#: every normal sub-model but ``linear`` and every rolling one but ``none`` (their
#: drivers are the others'), in combinations the rest of the suite compiles for the CPU
#: too, so that a cold cache pays no compile for this file alone
CASES = [
    ("hertz cdt spheres box", "hertz_mindlin", "cdt", False, box_walls, 30, 6.0),
    ("hysteretic type_a clumps box", "hysteretic_spring", "type_a", True, box_walls, 16, 3.0),
    ("hertz epsd spheres vessel", "hertz_mindlin", "epsd", False, vessel_walls, 30, 1.0),
    ("hertz rvd spheres box", "hertz_mindlin", "rvd", False, box_walls, 24, 3.0),
    ("jkr type_a spheres box", "hertz_mindlin_jkr", "type_a", False, box_walls, 24, 3.0),
    ("hertz type_a_limited clumps vessel", "hertz_mindlin", "type_a_limited", True,
     vessel_walls, 16, 1.0),
]


def build(backend, model, rolling, clumps, walls, n):
    template = two_sphere_paper(resolution=32).scaled(0.25) if clumps else 0.002
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.4, static_friction=0.5,
                                                    rolling_friction=0.1),
                     walls=walls(), contact_model=model, rolling_model=rolling, threads=1,
                     backend=backend)
    a = 0.009 if walls is vessel_walls else 0.01
    ins = insert(BoxRegion((-a, -a, 0.012), (a, a, 0.05)), n, template=template,
                 sizes=Uniform(0.8, 1.2), seed=7)
    sim.add_particles(template, ins.positions, orientations=ins.orientations,
                      scales=ins.scales)
    return sim


def touching_kinds(sim) -> set:
    """Names of the wall kinds some sphere touches."""
    q = sim._store.walls
    return {KIND_NAMES[k] for k in sim._walls.rows.kind[q.other[:q.size][q.act[:q.size]]]}


def relative(a, b) -> float:
    scale = float(np.max(np.abs(a))) or 1.0
    return float(np.max(np.abs(a - b))) / scale


def run_case(name, model, rolling, clumps, walls, n, stir, steps, folder) -> dict:
    base = build("cpu", model, rolling, clumps, walls, n)
    base.run(duration=0.12)
    settled = touching_kinds(base)
    rng = np.random.default_rng(11)
    base.state.velocities[:] += rng.normal(0.0, stir / math.sqrt(3.0), (base.n_particles, 3))
    path = Path(folder) / f"{abs(hash(name))}.npz"
    base.save_checkpoint(path)
    sims = {}
    for backend in ("cpu", "cuda"):
        sim = build(backend, model, rolling, clumps, walls, n)
        sim.load_checkpoint(path)
        r0 = sim.rebuilds
        sim.run(steps=steps)
        sims[backend] = (sim, sim.rebuilds - r0)
    (a, ra), (b, rb) = sims["cpu"], sims["cuda"]
    sa, sb = a.state, b.state
    pa, pb, qa, qb = a._store.pairs, b._store.pairs, a._store.walls, b._store.walls
    return {
        "case": name, "steps": steps, "rebuilds": [ra, rb],
        "touching_pairs": int(pa.act.sum()), "touching_walls": int(qa.act.sum()),
        "wall_kinds_touching": sorted(settled | touching_kinds(a)),
        "relative": {f: relative(getattr(sa, f), getattr(sb, f)) for f in FIELDS},
        "same_lists": bool(np.array_equal(pa.start, pb.start)
                           and np.array_equal(pa.other[:pa.size], pb.other[:pb.size])
                           and np.array_equal(qa.start, qb.start)
                           and np.array_equal(qa.other[:qa.size], qb.other[:qb.size])),
        "history": max(relative(pa.hist[:pa.size], pb.hist[:pb.size]),
                       relative(qa.hist[:qa.size], qb.hist[:qb.size])),
        "same_active": bool(np.array_equal(pa.act, pb.act) and np.array_equal(qa.act, qb.act)),
    }


def main(argv=None) -> int:
    """``cuda_sim_cases.py [STEPS [INDEX,INDEX,...]]``: the cases of :data:`CASES` (all by
    default), one JSON line each with its wall time."""
    import time

    # the simulator runs each CUDA thread as a Python thread, and they hand the GIL to
    # each other at every barrier: at Python's default switch interval (5 ms) each hand-off
    # waits, at 10 us the simulator tests run 2-3 times faster
    sys.setswitchinterval(1e-5)
    args = argv or sys.argv[1:]
    steps = int(args[0]) if args else 30
    chosen = [int(i) for i in args[1].split(",")] if len(args) > 1 else range(len(CASES))
    with tempfile.TemporaryDirectory() as folder:
        for index in chosen:
            start = time.perf_counter()
            result = run_case(*CASES[index], steps, folder)
            print(json.dumps({**result, "seconds": round(time.perf_counter() - start, 1)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
