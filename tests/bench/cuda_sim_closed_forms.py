"""The closed-form bench checks on the cuda backend, in numba-cuda's simulator.

Run as a script (``NUMBA_ENABLE_CUDASIM=1``, set by tests/bench/test_bench_cuda.py in a
subprocess of its own): the Hertz-Mindlin impact at the quick profile for e = 0.3, 0.6
and 0.9 (tests/bench/test_bench_impact.py: the rebound returns the set restitution
within 1 %), its three runs stepped together as one ensemble on the cuda backend, and
each again alone on the cpu backend. Prints one JSON line per run: the set and measured
restitution (every digit) on both backends.
"""

from __future__ import annotations

import json
import sys

RESTITUTIONS = (0.3, 0.6, 0.9)


def main() -> int:
    from demcal.bench.common import on_backend
    from demcal.bench.registry import get_experiment
    from demcal.dem.cuda.ensemble import Ensemble

    sys.setswitchinterval(1e-5)   # see tests/dem/cuda_sim_cases.py
    impact = get_experiment("impact")

    def job(e, backend):
        def run():
            with on_backend(backend):
                return impact.run({"contact.model": "hertz_mindlin", "particle.restitution": e},
                                  seed=0, profile="quick")
        return run

    together = Ensemble().run([job(e, "cuda") for e in RESTITUTIONS])
    for e, r in zip(RESTITUTIONS, together):
        alone = job(e, "cpu")()
        print(json.dumps({"set": e, "cuda_ensemble": None if isinstance(r, BaseException) else
                          repr(r.responses["restitution"]), "error": repr(r) if isinstance(r, BaseException)
                          else None, "cpu": repr(alone.responses["restitution"])}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
