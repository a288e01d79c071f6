"""What a finished calibration spent: the runs its loop read, by kind and profile, with
their recorded wall times, against a full design at the production profile.

    python benchmarks/calibration_cost.py CAMPAIGN.toml [--profile medium] [--production paper] [--full-runs 23 --run-s 269]

Nothing is run: the loop is replayed from the store (``calibrate(simulate=False)``),
which reads exactly the runs the loop asked for, in its order. The loop does not hand
out that list, so this script records the keys it reads from the store (a wrapper on
``Store.records`` for the replay's duration). Replaying a store with newer code gives
what that code would have spent, as long as every run it asks for is already there
(the engine is deterministic, so those runs are what a fresh calibration would run);
a run it would need and the store lacks leaves the condition unfinished, which the
output shows.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import sys
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("--profile", help="the design profile the calibration used (default: the campaign's)")
    ap.add_argument("--production", help="the production profile the calibration used (default: the campaign's)")
    ap.add_argument("--full-runs", type=int, help="runs of the full design to compare with (e.g. 17 + 6 = 23)")
    ap.add_argument("--run-s", type=float, help="run-seconds of one production run at the idle pace")
    args = ap.parse_args(argv)

    from demcal.campaign import store as S
    from demcal.campaign.calibrate import calibrate
    from demcal.campaign.config import load_campaign

    asked: set[str] = set()
    original = S.Store.records

    def records(self, keys=None):
        if keys is None:
            return original(self)
        asked.update(keys)
        return original(self, keys)

    campaign = load_campaign(args.campaign)
    if args.profile:
        campaign = campaign.with_profile(args.profile)
    if args.production:
        campaign = dataclasses.replace(campaign, calibration=dataclasses.replace(
            campaign.calibration, production=args.production))
    S.Store.records = records
    try:
        cal = calibrate(campaign, progress=False, simulate=False)
    finally:
        S.Store.records = original
    with S.Store(campaign.store_path, readonly=True) as store:
        used = [r for r in store.records() if r.key in asked and r.status == "done"]
    by = collections.defaultdict(lambda: [0, 0.0])
    for r in used:
        by[(r.kind, r.profile)][0] += 1
        by[(r.kind, r.profile)][1] += r.wall_s or 0.0
    total = 0.0
    for (kind, profile), (n, s) in sorted(by.items()):
        print(f"{kind:>12} {profile:>6}: {n:4d} runs, {s:9.1f} run-s")
        total += s
    print(f"{'in all':>20}: {sum(v[0] for v in by.values()):4d} runs, {total:9.1f} run-s")
    if args.full_runs and args.run_s:
        full = args.full_runs * args.run_s
        print(f"against a full design of {args.full_runs} x {args.run_s:g} s = {full:,.0f} run-s: {100 * total / full:.0f} %")
    for c in cal.conditions:
        steps = ", ".join(f"{s.stage} {s.runs}" for s in c.loop.history)
        print(f"{c.condition.name}: {c.loop.status} ({steps})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
