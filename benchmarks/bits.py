"""The quick benches' responses to the last bit, before and after a change of the engine.

The brief's rule for refactors: the quick benches with fixed seeds give the same bits
before and after. This runs the configurations the sessions check (seed 1, one thread,
each in its own process as `demcal bench` does) and writes every response, the step
count and the simulated time as JSON; with ``--compare FILE`` it also says which differ
from an earlier run of this script (exit status 1 if any). Each printed line ends with
the command's wall time (compilation included where the cache is cold).

    python benchmarks/bits.py --out /tmp/bits-after.json --compare /tmp/bits-before.json

For "before", run the same script with ``PYTHONPATH=<worktree of the old commit>/src``.
Takes about two minutes on the 2-core machine (the quick funnel and cylinder dominate).
"""

from __future__ import annotations

import argparse
import json
import sys

from bench_study import run_one  # benchmarks/: the script's own folder is on sys.path

#: (label, bench, profile, extra --set values)
CONFIGS = [
    ("incline quick", "incline", "quick", []),
    ("impact particle", "impact", "quick", []),
    ("impact wall", "impact", "quick", ["impact.target=wall"]),
    ("cylinder quick", "repose-cylinder", "quick", []),
    ("funnel quick", "repose-funnel", "quick", []),
    ("incline tiny follow", "incline", "tiny", []),
    ("incline tiny rigid", "incline", "tiny", ["incline.container=rigid"]),
    ("incline tiny remove", "incline", "tiny", ["incline.container=remove"]),
    ("incline tiny free", "incline", "tiny", ["incline.container=free", "incline.container_mass=0.5",
                                              "incline.container_wall_friction=0.6",
                                              "incline.container_friction=0.5"]),
    ("incline tiny block", "incline", "tiny", ["incline.material=block"]),
    ("funnel tiny", "repose-funnel", "tiny", []),
    ("cylinder tiny", "repose-cylinder", "tiny", []),
]


def run(label: str, bench: str, profile: str, sets: list[str]) -> dict:
    """One configuration through the bench study's runner (its own process, one thread):
    what determines the bits, or the error."""
    case = {"case": label, "test": bench, "profile": profile,
            "set": dict(item.split("=", 1) for item in sets)}
    row = run_one(case, seed=1, threads=1)
    keys = ("responses", "spread", "particles", "steps", "simulated_s", "error")
    return {k: row[k] for k in keys if k in row}, row["wall_s"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="JSON file for this run's figures")
    ap.add_argument("--compare", help="an earlier run's JSON file to compare with")
    ap.add_argument("--only", help="run only the configurations whose label contains this")
    args = ap.parse_args(argv)
    figures = {}
    for label, bench, profile, sets in CONFIGS:
        if args.only and args.only not in label:
            continue
        figures[label], wall = run(label, bench, profile, sets)
        print(f"{label}: {json.dumps(figures[label].get('responses', figures[label]))} ({wall} s)",
              flush=True)
    with open(args.out, "w") as f:
        json.dump(figures, f, indent=1, sort_keys=True)
    if not args.compare:
        return 0
    with open(args.compare) as f:
        before = json.load(f)
    differ = [k for k in figures if k in before and before[k] != figures[k]]
    for k in differ:
        print(f"DIFFERS {k}: {before[k]} -> {figures[k]}")
    print(f"{len(figures) - len(differ)} of {len(figures)} configurations the same to the bit")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
