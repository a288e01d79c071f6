#!/usr/bin/env python3
"""A design's runs alone and as one ensemble on the cuda backend: same bits, wall times.

    python benchmarks/gpu/ensemble.py OUT.jsonl [--test impact] [--profile tiny] [--runs 8]
                                      [--factor particle.restitution --low 0.3 --high 0.7]

Runs ``--runs`` runs of one bench and profile, the factor spread evenly from ``--low`` to
``--high`` (seed 1 each), first one after another on the cuda backend, then together in
one :class:`~demcal.dem.cuda.ensemble.Ensemble`, and appends one JSON line: each run's
response alone and together (as text, every digit), whether they agree to the bit, the
wall time of each way, the ensemble's rounds and the most systems stepped in one round.

``--seeds N`` runs seeds 1..N at the profile's defaults instead (a seed series), and
``--cpu`` runs each once more on the cpu backend: the line then also holds each
response's mean and sd over the series on both backends and whether the means agree
within the series' standard error (issue 38: GPU and CPU seed-series means agree within
the seed spread; ten seeds of a quick bench, e.g. ``--test repose-funnel --profile quick
--seeds 10 --cpu``).
On a GPU, small runs are bound by the host's launches (docs/performance.md, "The cuda
backend"): an ensemble shares each launch among its systems. In numba-cuda's simulator
(``NUMBA_ENABLE_CUDASIM=1``) it checks the bits only; its times mean nothing.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("--test", default="impact")
    ap.add_argument("--profile", default="tiny")
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--factor", default="particle.restitution")
    ap.add_argument("--low", type=float, default=0.3)
    ap.add_argument("--high", type=float, default=0.7)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--seeds", type=int, default=0, help="a seed series 1..N at the defaults instead")
    ap.add_argument("--cpu", action="store_true", help="each run once more on the cpu backend")
    args = ap.parse_args(argv)

    from demcal.bench.common import on_backend
    from demcal.bench.registry import get_experiment
    from demcal.dem.cuda.ensemble import Ensemble

    experiment = get_experiment(args.test)
    if args.seeds:
        points = [({}, seed) for seed in range(1, args.seeds + 1)]
    else:
        n = args.runs
        points = [({args.factor: args.low + (args.high - args.low) * k / max(n - 1, 1)}, args.seed)
                  for k in range(n)]
    n = len(points)
    values = [dict(settings, seed=seed) for settings, seed in points]

    def job(point, backend="cuda"):
        settings, seed = point

        def run():
            with on_backend(backend):
                return experiment.run(settings, seed=seed, profile=args.profile)
        return run

    job(points[0])()   # compile the device kernels once, outside both timings
    t0 = time.perf_counter()
    alone = [job(p)() for p in points]
    t1 = time.perf_counter()
    ensemble = Ensemble()
    together = ensemble.run([job(p) for p in points])
    t2 = time.perf_counter()
    on_cpu = [job(p, "cpu")() for p in points] if args.cpu else None
    t3 = time.perf_counter()
    failed = [repr(r) for r in together if isinstance(r, BaseException)]

    def responses(results):
        return [{k: repr(float(v)) for k, v in r.responses.items()} if not isinstance(r, BaseException)
                else None for r in results]

    a, b = responses(alone), responses(together)
    row = {"test": args.test, "profile": args.profile, "runs": n, "factor": args.factor, "values": values,
           "same_bits": a == b, "errors": failed, "alone_s": t1 - t0, "together_s": t2 - t1,
           "speedup": (t1 - t0) / (t2 - t1), "rounds": ensemble.stats.rounds,
           "batches": ensemble.stats.batches,
           "most_systems_in_a_round": max(ensemble.stats.systems, default=0),
           "steps": [r.steps for r in alone], "alone": a, "together": b}
    if on_cpu is not None:
        import numpy as np

        row["cpu_s"] = t3 - t2
        row["cpu"] = responses(on_cpu)
        series = {}
        for name in experiment.responses:
            g = np.array([r.responses[name] for r in together if not isinstance(r, BaseException)])
            c = np.array([r.responses[name] for r in on_cpu])
            se = float(np.sqrt(g.var(ddof=1) / g.size + c.var(ddof=1) / c.size)) if min(g.size, c.size) > 1 \
                else float("nan")
            series[name] = {"cuda_mean": float(g.mean()), "cuda_sd": float(g.std(ddof=1)) if g.size > 1 else None,
                            "cpu_mean": float(c.mean()), "cpu_sd": float(c.std(ddof=1)) if c.size > 1 else None,
                            "se": se, "within_2se": bool(abs(g.mean() - c.mean()) <= 2 * se) if se == se else None}
        row["series"] = series
    with Path(args.out).open("a") as f:
        f.write(json.dumps(row) + "\n")
    print(f"{args.test} {args.profile} x{n}: alone {t1 - t0:.1f} s, together {t2 - t1:.1f} s "
          f"({row['speedup']:.2f}x), same bits {a == b}, rounds {ensemble.stats.rounds}")
    return 0 if a == b and not failed else 1


if __name__ == "__main__":
    sys.exit(main())
