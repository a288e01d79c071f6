"""The engine's bits do not depend on the CPU model numba compiles for (issue 42).

Three guards:

* no compiled function of the engine takes a fast-math licence, and numba does not
  vectorise with Intel's SVML (cheap, nothing compiled): each licence lets LLVM choose
  the arithmetic per instruction set (docs/performance.md, "Portable bits");
* two tiny bench configurations give the responses stored below to the last bit;
* a small pour compiled for two targets (``NUMBA_CPU_NAME=generic`` and the host's own),
  each in its own process with its own empty ``NUMBA_CACHE_DIR``, ends in the same state
  to the bit (two compiles of the engine: ``make test-slow``).
"""

import importlib
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import numba
import pytest
from numba.core.dispatcher import Dispatcher

import demcal.dem
import demcal.geometry
import demcal.particles
from demcal.bench.registry import get_experiment

ROOT = Path(__file__).resolve().parents[2]

#: the packages that hold the engine's compiled functions (the CUDA backend, compiled by
#: another compiler with its own flags, is not walked here)
PACKAGES = (demcal.dem, demcal.geometry, demcal.particles)


def _engine_dispatchers():
    """Every numba dispatcher defined at module level in :data:`PACKAGES`."""
    found = {}
    for package in PACKAGES:
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            if ".cuda" in info.name:
                continue
            module = importlib.import_module(info.name)
            for name, obj in vars(module).items():
                if isinstance(obj, Dispatcher) and obj.py_func.__module__ == info.name:
                    found[f"{info.name}.{name}"] = obj
    return found


def test_no_engine_function_is_compiled_with_fast_math():
    dispatchers = _engine_dispatchers()
    assert len(dispatchers) >= 40, sorted(dispatchers)  # the walk found the engine
    licensed = {name: d.targetoptions["fastmath"] for name, d in dispatchers.items()
                if d.targetoptions.get("fastmath")}
    assert not licensed, ("target-dependent fast-math licences (reassoc, contract, arcp, "
                          f"nsz, fast) on: {licensed}")


def test_numba_does_not_vectorise_with_svml():
    assert os.environ.get("NUMBA_DISABLE_INTEL_SVML") == "1"
    assert not numba.config.USING_SVML


#: Responses at seed 1, tiny profile, default settings (``demcal bench incline --profile
#: tiny --seed 1 --json`` and ``demcal bench repose-funnel --profile tiny --seed 1
#: --json``), as float.hex. Produced 2026-11-28 on a 2-core AMD EPYC (Zen 3) VM with
#: numba 0.68.1 / llvmlite 0.50.0 / numpy 2.4.6, the same to the bit with
#: NUMBA_CPU_NAME=generic, haswell, znver2, host and unset (benchmarks/bits.py, each
#: target with its own NUMBA_CACHE_DIR; benchmarks/studies/portable-bits-2026-11-28). A
#: change of the engine that moves them must say so and store the new values from a run.
STORED = {
    ("incline", "sliding_angle_deg"): "0x1.3647acde8386ep+3",   # 9.696249422642918
    ("repose-funnel", "repose_angle_deg"): "0x1.05f7e8971e6d1p+4",  # 16.373024549778
}


@pytest.mark.parametrize("test, response", sorted(STORED))
def test_tiny_benches_give_the_stored_bits(test, response):
    got = get_experiment(test).run({}, seed=1, profile="tiny").responses[response]
    assert got.hex() == STORED[test, response], f"{got!r} = {got.hex()}"


#: A pour of 40 spheres into a box of five planes (Hertz-Mindlin, tangential history,
#: rolling friction; the pair loop, the walls and the neighbour rebuilds), 0.05 s; prints
#: a hash of the final positions, velocities and angular velocities.
POUR = """
import hashlib
import numpy as np
from demcal.dem import Simulation
from demcal.geometry import Box, WallSet
from demcal.particles.insertion import BoxRegion, insert
from demcal.particles.materials import Interaction, Material
from demcal.particles.sizes import Uniform
soft = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3, yield_strength=1.0e6)
w = 0.015
sim = Simulation([soft, soft], Interaction(restitution=0.3, static_friction=0.5,
                                           rolling_friction=0.1),
                 walls=WallSet([Box(lower=(0, 0, 0), upper=(w, w, 4 * w), material=1)]),
                 rolling_model="cdt", threads=1)
ins = insert(BoxRegion((0, 0, 0), (w, w, 3 * w)), 40, template=0.002, sizes=Uniform(0.75, 1.25),
             seed=1)
sim.add_particles(0.002, ins.positions, scales=ins.scales)
sim.run(duration=0.05)
st = sim.state
print(hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in
                              (st.positions, st.velocities, st.omegas))).hexdigest())
"""


def _pour(target, cache: Path) -> subprocess.Popen:
    """The pour compiled for ``target`` (``None``: numba's own choice, the host CPU)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="1")
    env.pop("NUMBA_CPU_NAME", None)
    env.pop("NUMBA_CPU_FEATURES", None)
    if target is not None:
        env["NUMBA_CPU_NAME"] = target
    return subprocess.Popen([sys.executable, "-c", POUR], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)


@pytest.mark.slow
def test_two_compile_targets_give_the_same_bits(tmp_path):
    """``generic`` is baseline x86-64 (SSE2, no FMA: numba passes no CPU features with
    it); the host's own target has its features (AVX2 and FMA on the 2-core AMD EPYC).
    Each process compiles the engine (about 50 s each there, the two side by side; 258 s
    with other jobs on the cores), so this runs in make test-slow; the fast suite keeps
    the two guards of its cause (no fast-math licence, no SVML) and the stored bits. The
    engine of f279479, with its fast-math licences, gives two different states here."""
    runs = [_pour(target, tmp_path / str(target)) for target in ("generic", None)]
    hashes = []
    for proc in runs:
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        hashes.append(out.split()[-1])
    assert hashes[0] == hashes[1]
