"""runs.csv of the campaign's store: every run with its factors, both angles and wall time.

    python benchmarks/studies/joint-funnel-drum-quarter-turn-2026-11-29/runs_csv.py STORE.sqlite > runs.csv
"""

from __future__ import annotations

import csv
import sys

from demcal.campaign.store import Store


def main(path: str) -> None:
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["kind", "label", "seed", "mu", "gamma", "funnel_deg", "drum_deg", "wall_s", "status"])
    with Store(path, readonly=True) as store:
        for r in sorted(store.records(), key=lambda r: r.id):
            out.writerow([r.kind, r.label, r.seed, r.parameters.get("particle.static_friction"),
                          r.parameters.get("particle.rolling_friction"), r.responses.get("repose_angle_deg"),
                          r.responses.get("dynamic_angle_deg"), None if r.wall_s is None else round(r.wall_s, 1),
                          r.status])


if __name__ == "__main__":
    main(sys.argv[1])
