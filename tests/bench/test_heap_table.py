"""benchmarks/liggghts/heap_table.py: the identical-heap table's arithmetic, on rows made up
so that every figure is known by hand."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _row(code, mus, mur, seed, angle):
    return {"code": code, "mus": mus, "mur": mur, "seed": seed, "particles": 3000, "angle_deg": angle}


def test_the_table_states_differences_standard_errors_and_the_aim(tmp_path):
    rows = [_row("demcal", 0.3, 0.05, 1, 18.0), _row("demcal", 0.3, 0.05, 2, 20.0),
            _row("liggghts", 0.3, 0.05, 1, 19.0), _row("liggghts", 0.3, 0.05, 2, 21.0),
            _row("demcal", 0.5, 0.15, 1, 24.0), _row("liggghts", 0.5, 0.15, 1, 23.0),
            _row("demcal-fresh-history", 0.3, 0.05, 1, 17.5),
            _row("liggghts", 0.7, 0.05, 1, 20.0),                       # no demcal row: left out
            dict(_row("demcal", 0.7, 0.15, 1, None), error="not at rest"),
            dict(_row("demcal", 0.3, 0.05, 3, 99.0), particles=300)]   # another size: left out
    study = tmp_path / "study.jsonl"
    study.write_text("".join(json.dumps(r) + "\n" for r in rows) + '{"code": "demcal", "mu')  # a half line
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "liggghts" / "heap_table.py"), str(study)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    # means 19 and 20, sds sqrt(2) each: difference -1, se sqrt(2/2 + 2/2) = 1.41, paired sd 0
    assert "| 0.3 / 0.05 | 18.00, 20.00 | 19.00, 21.00 | 19.00 (1.41) | 20.00 (1.41) | -1.00 | 1.41 | yes | 0.00 |" in text
    # one seed a code: no spread, so no standard error and no verdict
    assert "| 0.5 / 0.15 | 24.00 | 23.00 | 24.00 (nan) | 23.00 (nan) | +1.00 | nan | - | nan |" in text
    assert "pairs with both codes: 2 of 6; mean difference +0.00 deg" in text
    assert "fewest seeds of a code in a pair: 1 (the aim needs 4)" in text
    assert "failed: demcal mu_s 0.7 mu_r 0.15 seed 1: not at rest" in text
    assert "| 0.3 / 0.05 | 17.50 | 17.50 | 19.00 | 20.00 | -0.50 (1 seeds) |" in text
    assert "99.00" not in text                                  # the 300-sphere row
