"""Three systems stepped as one ensemble against each run alone, in numba-cuda's simulator.

Run as a script (``NUMBA_ENABLE_CUDASIM=1``, set by tests/dem/test_cuda_ensemble.py in a
subprocess of its own): five small beds that differ in everything an ensemble must keep
apart (contact parameters, particle counts and kinds, walls, a wall turning at its own
rate, a floor moved by a function of time, the time step, gravity, and for one the
contact model) are settled on the CPU, stirred and checkpointed; each is then run alone
on the cuda backend (``--reference cpu``: the cpu backend) and the five together in an
:class:`~demcal.dem.cuda.ensemble.Ensemble`, from the same checkpoints,
beside a sixth job that fails after 5 steps. Prints the failing job's result, then one
JSON line per system: whether every field, list and contact history is the same to the
bit, and the rebuilds on each side; then one line of the ensemble's rounds.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from demcal.dem import Simulation
from demcal.geometry import Box, Cylinder, FunctionMotion, Plane, Rotation, WallSet
from demcal.particles.insertion import BoxRegion, insert
from demcal.particles.materials import Interaction, Material
from demcal.particles.templates import two_sphere_paper
from demcal.particles.sizes import Uniform

from cuda_sim_cases import FIELDS, SOFT, box_walls

STEEL = Material(density=7800.0, shear_modulus=7.0e10, poisson_ratio=0.3,
                 yield_strength=1.0e9, name="steel")


def shaken_box():
    # the box's floor plane moved by a function of time: its job steps on its own (drift
    # and forces from Python) while the others are stepped in rounds
    walls = WallSet([Box(lower=(-0.012, -0.012, -0.001), upper=(0.012, 0.012, 0.06), material=1),
                     Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1, name="floor")])
    walls.set_motion("floor", FunctionMotion(
        function=lambda t: np.array([0.0, 0.0, 0.0005 * math.sin(300.0 * t)])))
    return walls


def turning_cylinder():
    # a closed cup turning about its own axis once the run starts (a compiled rotation)
    walls = WallSet([Cylinder(base=(0, 0, 0), axis=(0, 0, 1), radius=0.014, length=0.06,
                              bottom=True, material=1, name="cup")])
    walls.set_motion("cup", Rotation(point=(0, 0, 0), axis=(0, 0, 1), angular_speed=20.0,
                                     start=0.0))
    return walls


#: (name, interaction, clumps, walls, particles, seed, dt or None, gravity, stir [m/s],
#: contact and rolling models): the last has other sub-models, so it is stepped as a
#: group of its own in each round
HM = ("hertz_mindlin", "cdt")
SYSTEMS = [
    ("spheres in a box", Interaction(restitution=0.4, static_friction=0.5, rolling_friction=0.1),
     False, box_walls, 30, 7, None, (0.0, 0.0, -9.81), 1.5, HM),
    ("clumps in a box, other friction, tilted gravity",
     Interaction(restitution=0.6, static_friction=0.3, rolling_friction=0.05), True, box_walls, 14, 8,
     None, (1.5, 0.0, -9.7), 1.0, HM),
    ("spheres in a turning cup, another step",
     Interaction(restitution=0.5, static_friction=0.7, rolling_friction=0.2), False,
     turning_cylinder, 24, 9, 2.0e-6, (0.0, 0.0, -9.81), 2.0, HM),
    ("clumps in a box, another contact model",
     Interaction(restitution=0.4, static_friction=0.5, rolling_friction=0.1), True, box_walls, 16, 10,
     None, (0.0, 0.0, -9.81), 1.0, ("hysteretic_spring", "type_a")),
    ("spheres on a shaken floor", Interaction(restitution=0.5, static_friction=0.4, rolling_friction=0.1),
     False, shaken_box, 20, 11, None, (0.0, 0.0, -9.81), 0.5, HM),
]


def build(backend, system):
    name, inter, clumps, walls, n, seed, dt, gravity, _, (model, rolling) = system
    template = two_sphere_paper(resolution=32).scaled(0.25) if clumps else 0.002
    sim = Simulation([SOFT, STEEL], {(0, 0): inter, (0, 1): inter}, walls=walls(), dt=dt,
                     gravity=gravity, contact_model=model, rolling_model=rolling,
                     threads=1, backend=backend)
    ins = insert(BoxRegion((-0.009, -0.009, 0.012), (0.009, 0.009, 0.05)), n, template=template,
                 sizes=Uniform(0.8, 1.2), seed=seed)
    sim.add_particles(template, ins.positions, orientations=ins.orientations, scales=ins.scales)
    return sim


def snapshot(sim) -> dict:
    st = sim.state
    p, q = sim._store.pairs, sim._store.walls
    out = {f: np.array(getattr(st, f)) for f in FIELDS}
    out.update(pair_start=p.start.copy(), pair_other=p.other[:p.size].copy(),
               pair_hist=p.hist[:p.size].copy(), pair_act=p.act[:p.size].copy(),
               wall_start=q.start.copy(), wall_other=q.other[:q.size].copy(),
               wall_hist=q.hist[:q.size].copy(), wall_act=q.act[:q.size].copy(),
               time=np.array([sim.time]), steps=np.array([sim.step_count]))
    return out


def run_from(path, system, steps, backend="cuda"):
    sim = build(backend, system)
    sim.load_checkpoint(path)
    r0 = sim.rebuilds
    sim.run(steps=steps)
    return snapshot(sim), sim.rebuilds - r0


def main(argv=None) -> int:
    from demcal.dem.cuda.ensemble import Ensemble

    # the simulator runs each CUDA thread as a Python thread, and they hand the GIL to
    # each other at every barrier: at Python's default switch interval (5 ms) each hand-off
    # waits, at 10 us the simulator tests run 2-3 times faster
    sys.setswitchinterval(1e-5)
    args = list(argv or sys.argv[1:])
    # the runs alone on the cuda backend (on a GPU), or on the cpu backend, whose bits the
    # simulator's kernels give (tests/dem/test_cuda_backend.py): half the simulator's work
    reference = "cuda"
    if "--reference" in args:
        i = args.index("--reference")
        reference = args[i + 1]
        del args[i:i + 2]
    steps = [int(v) for v in args[0].split(",")] if args else [40, 25, 40, 30, 20]
    with tempfile.TemporaryDirectory() as folder:
        paths = []
        for k, system in enumerate(SYSTEMS):
            base = build("cpu", system)
            base.run(duration=0.12)
            rng = np.random.default_rng(11 + k)
            base.state.velocities[:] += rng.normal(0.0, system[8] / math.sqrt(3.0),
                                                   (base.n_particles, 3))
            path = Path(folder) / f"system{k}.npz"
            base.save_checkpoint(path)
            paths.append(path)
        alone = [run_from(p, s, n, reference) for p, s, n in zip(paths, SYSTEMS, steps)]

        def failing():
            # a job that fails part way: its error is its result, the others go on
            sim = build("cuda", SYSTEMS[0])
            sim.load_checkpoint(paths[0])
            sim.run(steps=5)
            raise RuntimeError("a job's own error after 5 steps")

        ensemble = Ensemble()
        together = ensemble.run([(lambda p=p, s=s, n=n: run_from(p, s, n))
                                 for p, s, n in zip(paths, SYSTEMS, steps)] + [failing])
        print(json.dumps({"failing_job": repr(together.pop())}), flush=True)
    for system, (a, ra), res in zip(SYSTEMS, alone, together):
        if isinstance(res, BaseException):
            print(json.dumps({"system": system[0], "error": repr(res)}), flush=True)
            continue
        b, rb = res
        differ = sorted(k for k in a if not np.array_equal(a[k], b[k]))
        print(json.dumps({"system": system[0], "same_bits": not differ, "differ": differ,
                          "rebuilds": [ra, rb], "time": [float(a["time"][0]), float(b["time"][0])],
                          "touching": int(a["pair_act"].sum() + a["wall_act"].sum())}), flush=True)
    s = ensemble.stats
    print(json.dumps({"rounds": s.rounds, "batches": s.batches, "groups": s.groups,
                      "most_systems_in_a_round": max(s.systems) if s.systems else 0}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
