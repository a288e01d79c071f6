"""A campaign's runs as one GPU ensemble (``[executor] ensemble``), in numba-cuda's simulator.

``cuda_sim_campaign.py`` runs a four-run impact campaign through the runner with
``backend = "cuda"`` and ``ensemble = 3`` (:class:`~demcal.campaign.pool.EnsembleExecutor`:
one worker process, each run joining the ensemble as it is claimed), in a subprocess of
its own so that no other test process imports numba.cuda in simulator mode, then runs
each again alone on the cpu backend: the store holds every run once, with the bits of
the run alone (the simulator's kernels give the CPU's bits, tests/dem/test_cuda_backend.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from demcal.campaign.config import parse_campaign
from demcal.dem.cuda.backend import numba_cuda_installed
from demcal.errors import ConfigError

HERE = Path(__file__).resolve().parent
needs_numba_cuda = pytest.mark.skipif(not numba_cuda_installed(), reason="numba-cuda not installed (demcal[cuda])")


@needs_numba_cuda
def test_a_campaign_run_as_one_ensemble_gives_each_run_alone():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, str(HERE / "cuda_sim_campaign.py")], capture_output=True,
                         text=True, env=env, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads([line for line in res.stdout.splitlines() if line.startswith("{")][-1])
    assert out["executor"] == "one GPU ensemble of up to 3 runs"
    assert out["status"] == ["done"] * 4
    assert out["backends"] == ["cuda"]
    assert out["together"] == out["alone"]          # every digit (repr of each float)
    assert len(set(out["together"])) == 4


@pytest.mark.parametrize("executor", ['backend = "cpu"\nensemble = 4',
                                      'backend = "cuda"\nkind = "dask"\nensemble = 4'])
def test_an_ensemble_without_the_cuda_backend_is_one_sentence(tmp_path, executor):
    text = ('[campaign]\nname = "x"\n\n[experiment]\ntest = "impact"\nprofile = "tiny"\n\n'
            '[[factors]]\nname = "A"\nparameter = "particle.restitution"\nlow = 0.3\nhigh = 0.7\n\n'
            '[design]\ntype = "full-factorial"\n\n[executor]\n' + executor + '\n\n'
            '[[conditions]]\nname = "dry"\ntargets = { restitution = { mean = 0.5, sd = 0.1 } }\n')
    with pytest.raises(ConfigError, match=r"'ensemble' \(4\) steps runs together on one GPU: it needs "
                                          r"backend = \"cuda\" and a local executor"):
        parse_campaign(text, tmp_path / "c.toml")


@needs_numba_cuda
def test_a_killed_ensemble_costs_only_its_runs_in_flight_which_are_retried_alone():
    """The ensemble worker SIGKILLed by one run (seed 12, early in it) each time it runs:
    the two runs in flight beside it the first time are tried again, each on its own, and
    recorded once; the killer fails after its retry with its cause; every other run ran
    once (`cuda_sim_campaign.py dying`)."""
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, str(HERE / "cuda_sim_campaign.py"), "dying"], capture_output=True,
                         text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads([line for line in res.stdout.splitlines() if line.startswith("{")][-1])
    assert (out["done"], out["failed"]) == (7, 1), out
    ((label, error),) = out["failures"]
    assert "the worker process running it died twice (killed by SIGKILL" in error
    status = dict(zip(out["seeds"], out["status"]))
    assert status.pop(12) == "failed" and set(status.values()) == {"done"}
    ran = {int(k): v for k, v in out["ran"].items()}
    assert 12 not in ran                                   # killed before its marker, both times
    assert sorted(ran.values()) == [1] * 5 + [2] * 2      # its two companions, once more each
