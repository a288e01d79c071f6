"""Point-by-point comparison of study runs with the paper's Tables 4 (funnel) and 8 (incline).

    python compare_published.py RESULTS.jsonl [RESULTS.jsonl ...] [--store STORE.sqlite]
                                [--bias paper-quick]

Each results file (bench_study.py's JSON lines) is matched to the design points of Table 4
(``repose-funnel`` runs) or Table 8 (``incline`` runs) by its settings. Runs are grouped
into columns by test, profile and rolling model, over all files given, and a point's value
is the mean over its seeds. ``--store`` adds a campaign store's design runs (e.g.
``make demo``'s ``demo-output/campaigns/repose-runs``) as another column. Prints a
Markdown table per test and, per column, the mean offset, RMS, correlation and slope
(demcal on paper) over the points it has. ``--bias paper-quick`` also prints, for each
rolling model, the paper-profile minus quick-profile difference at every point run at both.
"""

from __future__ import annotations

import argparse
import csv
import json
import sqlite3
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
TABLES = {
    "repose-funnel": dict(
        csv=ROOT / "examples" / "residual-film-soil" / "paper_table4_repose_bbd.csv",
        response="repose_angle_deg",
        levels={"A": (0.5, 0.6, 0.7), "B": (0.3, 0.4, 0.5), "C": (0.1, 0.2, 0.3), "D": (0.0, 0.1, 0.2)},
        keys={"A": "particle.restitution", "B": "particle.static_friction",
              "C": "particle.rolling_friction", "D": "particle.damping_factor"}),
    "incline": dict(
        csv=ROOT / "examples" / "residual-film-soil" / "paper_table8_sliding_bbd.csv",
        response="sliding_angle_deg",
        levels={"E": (0.5, 0.6, 0.7), "F": (0.4, 0.5, 0.6), "G": (0.05, 0.15, 0.25)},
        keys={"E": "film.restitution", "F": "film.static_friction", "G": "film.rolling_friction"}),
}
# every setting other than the design factors and the rolling model makes a run a different
# experiment; such runs are left out of the table
EXTRA_OK = {"rolling.model"}


def _point(test: str, settings: dict) -> tuple | None:
    t = TABLES[test]
    if set(settings) - set(t["keys"].values()) - EXTRA_OK:
        return None
    try:
        return tuple(round(float(settings[t["keys"][k]]), 6) for k in t["levels"])
    except KeyError:
        return None


def published(test: str) -> dict:
    t = TABLES[test]
    out = {}
    for row in csv.DictReader(t["csv"].open()):
        p = tuple(t["levels"][k][int(row[k]) + 1] for k in t["levels"])
        out.setdefault(p, {"runs": [], "values": []})
        out[p]["runs"].append(row["run"])
        out[p]["values"].append(float(row[t["response"]]))
    return out


def from_results(paths: list[Path]) -> dict:
    """{(test, column name): {point: [values]}} over all files."""
    cols: dict = {}
    seen = set()
    for path in paths:
        for line in path.read_text().splitlines():
            row = json.loads(line)
            if "responses" not in row or row["test"] not in TABLES:
                continue
            p = _point(row["test"], row["set"])
            if p is None:
                continue
            name = f"{row['profile']}, {row['set'].get('rolling.model', 'type_a')}"
            if (row["test"], name, p, row["seed"]) in seen:
                continue  # the same run in two files (rerun on another machine) counts once
            seen.add((row["test"], name, p, row["seed"]))
            value = row["responses"][TABLES[row["test"]]["response"]]
            cols.setdefault((row["test"], name), {}).setdefault(p, []).append(value)
    return cols


def from_store(path: Path) -> dict:
    cols: dict = {}
    con = sqlite3.connect(path)
    for params, resp in con.execute("select parameters, responses from runs where kind = 'design' "
                                    "and status = 'done'"):
        params, resp = json.loads(params), json.loads(resp)
        for test, t in TABLES.items():
            p = _point(test, params)
            if p is not None and t["response"] in resp:
                cols.setdefault((test, f"store {path.parent.name}"), {}).setdefault(p, []).append(
                    resp[t["response"]])
    return cols


def stats(pub, sim):
    pub, sim = np.asarray(pub), np.asarray(sim)
    d = sim - pub
    slope = np.polyfit(pub, sim, 1)[0] if len(pub) > 2 else float("nan")
    corr = np.corrcoef(pub, sim)[0, 1] if len(pub) > 2 else float("nan")
    return d.mean(), np.sqrt((d ** 2).mean()), corr, slope


def _cell(v: list[float]) -> str:
    return f"{np.mean(v):.2f}" + (f" ± {np.std(v, ddof=1):.2f} ({len(v)})" if len(v) > 1 else "")


def table(test: str, columns: dict) -> list[str]:
    pub_points = published(test)
    names = sorted(name for t, name in columns if t == test)
    if not names:
        return []
    factors = ", ".join(TABLES[test]["keys"][k].split(".")[-1] for k in TABLES[test]["levels"])
    out = [f"### {test}", "", f"| runs | {factors} | published | " + " | ".join(names) + " |",
           "|" + " --- |" * (3 + len(names))]
    pairs = {n: ([], []) for n in names}
    for p, rec in pub_points.items():
        pub = float(np.mean(rec["values"]))
        cells = []
        for n in names:
            v = columns[(test, n)].get(p)
            cells.append(_cell(v) if v else "")
            if v:
                pairs[n][0].append(pub)
                pairs[n][1].append(float(np.mean(v)))
        if any(cells):
            out.append(f"| {', '.join(rec['runs'][:3])}{'...' if len(rec['runs']) > 3 else ''} | "
                       f"{', '.join(f'{x:g}' for x in p)} | {pub:.2f} | " + " | ".join(cells) + " |")
    out.append("")
    for n, (pub, sim) in pairs.items():
        m, rms, corr, slope = stats(pub, sim)
        out.append(f"- {test}, {n}: {len(pub)} points, mean offset {m:+.2f}, RMS {rms:.2f}, "
                   f"correlation {corr:.2f}, slope {slope:.2f}")
    return out + [""]


def paper_minus_quick(test: str, columns: dict) -> list[str]:
    out = []
    models = sorted({n.split(", ")[1] for t, n in columns if t == test and n.startswith("paper")})
    for model in models:
        paper, quick = columns.get((test, f"paper, {model}"), {}), columns.get((test, f"quick, {model}"), {})
        both = [p for p in paper if p in quick]
        if not both:
            continue
        out += [f"{test}, {model}: paper - quick", ""]
        d = []
        for p in both:
            diff = np.mean(paper[p]) - np.mean(quick[p])
            d.append(diff)
            out.append(f"- {', '.join(f'{x:g}' for x in p)}: paper {_cell(paper[p])}, quick "
                       f"{_cell(quick[p])}, difference {diff:+.2f}")
        out.append(f"- mean {np.mean(d):+.2f}, sd between points "
                   f"{np.std(d, ddof=1) if len(d) > 1 else float('nan'):.2f} ({len(d)} points)")
        out.append("")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="*", type=Path)
    ap.add_argument("--store", type=Path, action="append", default=[])
    ap.add_argument("--bias", choices=["paper-quick"])
    args = ap.parse_args(argv)
    columns = from_results(args.results)
    for store in args.store:
        columns.update(from_store(store))
    lines = []
    for test in TABLES:
        lines += table(test, columns)
        if args.bias:
            lines += paper_minus_quick(test, columns)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
