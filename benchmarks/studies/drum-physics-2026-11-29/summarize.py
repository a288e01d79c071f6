"""This study's tables: each case's angle per seed, mean +- sd over seeds, the frames' sd
within a run, the Froude number and regime label, and the wall time.

    python benchmarks/studies/drum-physics-2026-11-29/summarize.py [FOLDER] [--frames OUT_DIR]

FOLDER holds ``results-*.jsonl`` (default: this study's folder; ``before-fix`` for the
runs with the outline read from above). ``--frames OUT_DIR`` first gathers every frame's
angle from the runs' ``drum.json`` under ``OUT_DIR`` (``bench_study.py --out``) into
``FOLDER/frames.jsonl`` (case, seed, angles, R^2).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REGIME = ["slumping", "rolling", "cascading", "cataracting"]


def _slug(case: str, seed: int) -> str:
    return f"{'-'.join(case.replace('/', ' ').split())}-seed{seed}"


def _rows(folder: Path):
    for results in sorted(folder.glob("results-*.jsonl")):
        for line in results.read_text().splitlines():
            if line.strip():
                yield json.loads(line)


def gather(folder: Path, out_dir: Path) -> None:
    rows = []
    for row in _rows(folder):
        path = out_dir / _slug(row["case"], row["seed"]) / "drum.json"
        if path.is_file():
            frames = json.loads(path.read_text())["frames"]
            rows.append({"case": row["case"], "seed": row["seed"],
                         "angles_deg": [round(f["angle_deg"], 2) for f in frames],
                         "r2": [round(f["r2"], 3) for f in frames]})
    (folder / "frames.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))


def table(folder: Path) -> str:
    lines = ["| case | Fr | regime | seeds | angle, each seed [°] | mean ± sd [°] | frames' sd in a run [°] | "
             "particles | wall s |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    cases: dict[str, list] = {}
    for row in _rows(folder):
        cases.setdefault(row["case"], []).append(row)
    for case, rows in cases.items():
        ok = [r for r in rows if "responses" in r]
        walls = ", ".join(f"{r['wall_s']:.0f}" for r in rows)
        if not ok:
            lines.append(f"| {case} | | | | failed: {rows[0]['error']} | | | | {walls} |")
            continue
        vals = np.array([r["responses"]["dynamic_angle_deg"] for r in ok])
        each = ", ".join(f"{v:.2f}" for v in vals)
        sd = f" ± {vals.std(ddof=1):.2f}" if len(vals) > 1 else ""
        within = np.mean([r["spread"]["dynamic_angle_deg"] for r in ok])
        res = ok[0]["responses"]
        lines.append(f"| {case} | {res['froude_number']:.2g} | {REGIME[int(res['regime_index'])]} | "
                     f"{', '.join(str(r['seed']) for r in ok)} | {each} | {vals.mean():.2f}{sd} | "
                     f"{within:.1f} | {ok[0]['particles']} | {walls} |")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, nargs="?", default=HERE)
    ap.add_argument("--frames", type=Path, metavar="OUT_DIR")
    a = ap.parse_args()
    if a.frames:
        gather(a.folder, a.frames)
    print(table(a.folder))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
