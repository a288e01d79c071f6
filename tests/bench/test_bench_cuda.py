"""The bench tests' closed forms on the cuda backend, in numba-cuda's simulator.

``cuda_sim_closed_forms.py`` (a subprocess of its own, so that no other test process
imports numba.cuda in simulator mode) runs the Hertz-Mindlin impact at the quick profile
for three restitutions as one ensemble on the cuda backend: each rebound returns its set
restitution within 1 % (EDEM's Hertz-Mindlin damping, Tsuji et al. 1992, is built so that
a head-on impact rebounds with e: the closed-form check of tests/bench/test_bench_impact.py),
with the bits of the same run on the cpu backend.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from demcal.dem.cuda.backend import numba_cuda_installed

HERE = Path(__file__).resolve().parent


@pytest.mark.skipif(not numba_cuda_installed(), reason="numba-cuda not installed (demcal[cuda])")
def test_the_impact_returns_its_restitution_on_the_cuda_backend():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, str(HERE / "cuda_sim_closed_forms.py")], capture_output=True,
                         text=True, env=env, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    rows = [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]
    assert [r["set"] for r in rows] == [0.3, 0.6, 0.9]
    for r in rows:
        assert r["error"] is None, r
        assert float(r["cuda_ensemble"]) == pytest.approx(r["set"], rel=0.01)
        assert r["cuda_ensemble"] == r["cpu"]          # every digit
