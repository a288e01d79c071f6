"""Each spin-up run's frames by quarter turn: the mean and sd of the frames in each window
of the turn after the drum starts, and the lag-1 autocorrelation of the frames after a
quarter turn.

    python benchmarks/studies/drum-quick-time-2026-11-29/windows.py [RUNS_DIR]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

WINDOWS = ((0.0, 0.125), (0.125, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 1.0), (0.5, 1.0))


def main(folder: Path) -> None:
    print("| run | " + " | ".join(f"turns {lo:g}-{hi:g}" for lo, hi in WINDOWS) + " | lag-1 after 0.25 |")
    print("| --- " * (len(WINDOWS) + 2) + "|")
    for path in sorted(folder.glob("*/drum.json")):
        angles = np.array([f["angle_deg"] for f in json.loads(path.read_text())["frames"]])
        turns = np.linspace(0.0, 1.0, len(angles))
        cells = []
        for lo, hi in WINDOWS:
            inside = (turns >= lo - 1e-9) & ((turns < hi - 1e-9) if hi < 1.0 else (turns <= 1.0))
            cells.append(f"{angles[inside].mean():.2f} ± {angles[inside].std(ddof=1):.2f} ({inside.sum()})")
        steady = angles[turns >= 0.25 - 1e-9] - angles[turns >= 0.25 - 1e-9].mean()
        lag1 = float(np.sum(steady[1:] * steady[:-1]) / np.sum(steady * steady))
        print(f"| {path.parent.name} | " + " | ".join(cells) + f" | {lag1:.2f} |")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "runs-spinup")
