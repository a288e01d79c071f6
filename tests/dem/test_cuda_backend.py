"""The cuda backend (demcal.dem.cuda) in numba-cuda's simulator, against the cpu backend.

The simulator runs the device kernels as Python: what it checks is the drivers (one
thread per sphere or body, the transposed half list, the deferred history, the device
rebuild of the lists, the rebuild flag) around the CPU kernels' own source, for every
normal and rolling sub-model and every wall kind. The engine compiles without fast-math
licences, so the two backends agree to the bit here; on a GPU the tolerance below
(1e-12 relative) is what the device's transcendental functions may cost
(benchmarks/gpu/check.py measures it there).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from dem_helpers import needs_numba_cuda

from demcal.errors import ConfigError

HERE = Path(__file__).resolve().parent
TOLERANCE = 1e-12
ALL_KINDS = {"plane", "disk", "cylinder", "cone", "rect", "triangle"}




#: The fast suite's cases (indices of ``cuda_sim_cases.CASES``): clumps with the
#: Hysteretic Spring and type A in the box of rectangles over a plane, and Hertz-Mindlin
#: spheres with EPSD in the vessel of every other wall kind (about 35 s in the simulator
#: on a 2-core VM); the slow test runs all six (about 2.5 min).
FAST_CASES = "1,2"


def _run_cases(which: str | None = None) -> list[dict]:
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, str(HERE / "cuda_sim_cases.py"), "30", *([which] if which else [])],
                         capture_output=True, text=True, env=env, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    return [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]


def _agree(cases: list[dict]) -> None:
    for c in cases:
        assert c["touching_pairs"] + c["touching_walls"] > 0, c["case"]
        for field, err in c["relative"].items():
            assert err <= TOLERANCE, (c["case"], field, err)
        assert c["history"] <= TOLERANCE, c["case"]
        assert c["same_lists"] and c["same_active"], c["case"]
        assert c["rebuilds"][0] == c["rebuilds"][1], c["case"]


@pytest.fixture(scope="module")
def cases():
    return _run_cases(FAST_CASES)


@needs_numba_cuda
def test_the_fast_cases_agree_with_the_cpu_backend(cases):
    assert len(cases) == 2
    _agree(cases)


@needs_numba_cuda
@pytest.mark.slow
def test_every_case_agrees_with_the_cpu_backend():
    """Every normal and rolling sub-model (``cuda_sim_cases.CASES``)."""
    every = _run_cases()
    assert len(every) == 6
    _agree(every)
    assert max(c["rebuilds"][1] for c in every) >= 3
    assert set().union(*(c["wall_kinds_touching"] for c in every)) == ALL_KINDS


@needs_numba_cuda
def test_the_device_rebuilds_the_lists_inside_its_step_loop(cases):
    # the beds are rebuilt within their 30 steps, each time on the device (the lists and
    # histories then still match the CPU's, test above)
    assert all(c["rebuilds"][1] >= 1 for c in cases) and max(c["rebuilds"][1] for c in cases) >= 2


@needs_numba_cuda
def test_the_cases_touch_every_wall_kind(cases):
    assert set().union(*(c["wall_kinds_touching"] for c in cases)) == ALL_KINDS


@needs_numba_cuda
def test_the_simulator_hands_a_block_one_shared_array():
    # numba-cuda's simulator may give two threads that reach a shared array together
    # an array each (then block_max reads memory no thread wrote: a rebuild falls due
    # at random, and the lists above differ run to run); demcal.dem.cuda.kernels locks
    # the allocation. The script widens the race's window so that it always happens.
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, str(HERE / "cuda_sim_shared.py")],
                         capture_output=True, text=True, env=env, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout)
    assert out["locked"] and out["demcal"] == 1, out
    assert out["simulator"] > 1, out   # the race is real where the lock is missing


def test_a_missing_numba_cuda_is_one_sentence(monkeypatch):
    from demcal.dem.cuda import backend
    monkeypatch.setitem(sys.modules, "numba.cuda", None)
    with pytest.raises(ConfigError, match=r"pip install 'demcal\[cuda\]'"):
        backend.cuda_module()


def _without_simulator() -> dict:
    return {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}


@needs_numba_cuda
def test_no_device_is_one_sentence():
    # a fresh process: this one may have numba.cuda in simulator mode already; on a
    # machine with a GPU the same code builds the simulation instead
    from demcal.dem.cuda.backend import device_present
    code = ("from demcal.dem import Simulation\n"
            "from demcal.particles.materials import Interaction, soil\n"
            "from demcal.errors import ConfigError\n"
            "try:\n"
            "    print('built', Simulation([soil()], Interaction(), backend='cuda').backend)\n"
            "except ConfigError as e:\n"
            "    print('ConfigError:', e)\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_without_simulator(), timeout=300)
    if device_present():
        assert "built cuda" in res.stdout, res.stderr
    else:
        assert "ConfigError: backend 'cuda' found no CUDA device" in res.stdout, res.stderr


@needs_numba_cuda
def test_the_bench_command_says_no_device_in_one_sentence():
    # with a GPU the command runs the bench instead (status 0, its JSON)
    from demcal.dem.cuda.backend import device_present
    res = subprocess.run([sys.executable, "-m", "demcal", "bench", "impact", "--backend", "cuda",
                          "--json"], capture_output=True, text=True, env=_without_simulator(),
                         timeout=600)
    if device_present():
        assert res.returncode == 0 and json.loads(res.stdout)["test"] == "impact", res.stderr
        return
    assert res.returncode == 2, res.stderr
    lines = [x for x in res.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "backend 'cuda' found no CUDA device" in lines[0], res.stderr
    assert "Traceback" not in res.stderr
