"""Point-by-point comparison of a study's funnel runs with the paper's Table 4.

    python compare_published.py RESULTS.jsonl [RESULTS.jsonl ...] [--store STORE.sqlite]

Each results file (bench_study.py's JSON lines) is matched to Table 4's design points by
its settings (the mean over seeds where a point has several); ``--store`` adds a
campaign store's design runs (e.g. ``make demo``'s ``demo-output/campaigns/repose-runs``)
as another column. Prints a Markdown table and, per column, the mean offset, RMS,
correlation and slope (demcal on paper) over the points it has.
"""

from __future__ import annotations

import argparse
import csv
import json
import sqlite3
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
TABLE4 = ROOT / "examples" / "residual-film-soil" / "paper_table4_repose_bbd.csv"
LEVELS = {"A": (0.5, 0.6, 0.7), "B": (0.3, 0.4, 0.5), "C": (0.1, 0.2, 0.3), "D": (0.0, 0.1, 0.2)}
KEYS = {"A": "particle.restitution", "B": "particle.static_friction",
        "C": "particle.rolling_friction", "D": "particle.damping_factor"}


def _point(settings: dict) -> tuple:
    return tuple(round(float(settings[KEYS[k]]), 6) for k in "ABCD")


def table4() -> dict:
    out = {}
    for row in csv.DictReader(TABLE4.open()):
        p = tuple(LEVELS[k][int(row[k]) + 1] for k in "ABCD")
        out.setdefault(p, {"runs": [], "values": []})
        out[p]["runs"].append(row["run"])
        out[p]["values"].append(float(row["repose_angle_deg"]))
    return out


def from_results(path: Path) -> dict:
    vals = {}
    for line in path.read_text().splitlines():
        row = json.loads(line)
        if "responses" in row and row["test"] == "repose-funnel":
            vals.setdefault(_point(row["set"]), []).append(row["responses"]["repose_angle_deg"])
    return vals


def from_store(path: Path) -> dict:
    vals = {}
    con = sqlite3.connect(path)
    for params, resp in con.execute("select parameters, responses from runs where kind = 'design' "
                                    "and status = 'done'"):
        vals.setdefault(_point(json.loads(params)), []).append(json.loads(resp)["repose_angle_deg"])
    return vals


def stats(pub, sim):
    pub, sim = np.asarray(pub), np.asarray(sim)
    d = sim - pub
    slope = np.polyfit(pub, sim, 1)[0] if len(pub) > 2 else float("nan")
    corr = np.corrcoef(pub, sim)[0, 1] if len(pub) > 2 else float("nan")
    return d.mean(), np.sqrt((d ** 2).mean()), corr, slope


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="*", type=Path)
    ap.add_argument("--store", type=Path, action="append", default=[])
    args = ap.parse_args(argv)
    published = table4()
    columns = [(p.stem, from_results(p)) for p in args.results]
    columns += [(f"store {p.parent.name}", from_store(p)) for p in args.store]
    head = "| runs | e, mu, gamma, zeta | published | " + " | ".join(c for c, _ in columns) + " |"
    print(head)
    print("|" + " --- |" * (3 + len(columns)))
    pairs = {c: ([], []) for c, _ in columns}
    for p, rec in published.items():
        pub = float(np.mean(rec["values"]))
        cells = []
        for name, vals in columns:
            v = vals.get(p)
            if v:
                cells.append(f"{np.mean(v):.2f}" + (f" ± {np.std(v, ddof=1):.2f} ({len(v)})" if len(v) > 1 else ""))
                pairs[name][0].append(pub)
                pairs[name][1].append(float(np.mean(v)))
            else:
                cells.append("")
        if any(cells):
            print(f"| {', '.join(rec['runs'][:3])}{'...' if len(rec['runs']) > 3 else ''} | "
                  f"{', '.join(f'{x:g}' for x in p)} | {pub:.2f} | " + " | ".join(cells) + " |")
    print()
    for name, (pub, sim) in pairs.items():
        if pub:
            m, rms, corr, slope = stats(pub, sim)
            print(f"{name}: {len(pub)} points, mean offset {m:+.2f}, RMS {rms:.2f}, "
                  f"correlation {corr:.2f}, slope {slope:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
