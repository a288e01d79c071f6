"""Ensembles on the cuda backend (demcal.dem.cuda.ensemble), in numba-cuda's simulator.

Five systems that differ in contact parameters, particles, walls (one turning, one
floor moved by a function of time, whose job steps on its own), time step, gravity and
(one) contact model, stepped as one ensemble, give the bits of each run alone on the cpu
backend, which the simulator's kernels give alone too (tests/dem/test_cuda_backend.py; on
a GPU, benchmarks/gpu/run.sh compares with the cuda backend alone). The script is
``cuda_sim_ensemble.py``, in a subprocess of its own: no other test process imports
numba.cuda in simulator mode. The lists of each system fall due at other steps,
so the ensemble hands systems back to their jobs one at a time and steps the rest on.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from dem_helpers import needs_numba_cuda

HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def lines():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, str(HERE / "cuda_sim_ensemble.py"), "--reference", "cpu"],
                         capture_output=True,
                         text=True, env=env, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    return [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]


@needs_numba_cuda
def test_an_ensemble_gives_each_run_alone_to_the_bit(lines):
    systems = [x for x in lines if "system" in x]
    assert len(systems) == 5
    for x in systems:
        assert "error" not in x, x
        assert x["same_bits"], x
        assert x["touching"] > 0, x          # the systems are in contact, not flying apart
        assert x["rebuilds"][0] == x["rebuilds"][1], x


@needs_numba_cuda
def test_the_systems_go_back_to_their_jobs_at_their_own_steps(lines):
    systems = [x for x in lines if "system" in x]
    stats = lines[-1]
    # rebuilds fall due at other steps in each system: more rounds than any one system's
    # rebuilds, and all three stepped together in some round
    assert len({x["rebuilds"][1] for x in systems}) >= 2
    assert stats["rounds"] > max(x["rebuilds"][1] for x in systems)
    # the three Hertz-Mindlin systems and the failing job's in its first rounds; the
    # fourth system's sub-models make a group of their own
    assert stats["most_systems_in_a_round"] == 4
    assert stats["groups"] == 2


@needs_numba_cuda
def test_a_job_that_fails_is_its_own_result_and_the_others_go_on(lines):
    (failing,) = [x for x in lines if "failing_job" in x]
    assert failing["failing_job"] == "RuntimeError(\"a job's own error after 5 steps\")"
