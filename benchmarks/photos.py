#!/usr/bin/env python3
"""Lab photo measurement through the command line (issue 6, acceptance 4).

Renders N synthetic heap photos (800 x 600 px, angles 20-50 deg, with noise, blur,
uneven light, and every third with a shadow and a slightly tilted camera; see
:func:`demcal.measure.synthetic.synthetic_photo`) into a temporary folder as PNG files,
then times, as a user would run it, ::

    demcal measure repose PHOTO... --out DIR --json

in a fresh process, ``--repeats`` times, and prints one JSON object::

    {"photos": N, "wall_s": [..], "per_photo_s": [..], "import_s": ..,
     "max_error_deg": .., "load_average": [..], "cpus": .., "machine": ..}

``wall_s`` is each run's wall time (start-up, imports and the annotated PNG per photo
included); ``import_s`` the wall time of ``demcal measure repose --help`` (interpreter
start-up and imports of the command line); ``max_error_deg`` the largest difference
between a measured and a rendered angle in the last run.

Usage::

    python benchmarks/photos.py --photos 20 --repeats 3
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def render(folder: Path, n: int) -> list[float]:
    """Write ``n`` photos into ``folder``; returns their true angles [deg]."""
    import numpy as np
    from PIL import Image

    from demcal.measure.synthetic import synthetic_photo

    angles = list(np.linspace(20.0, 50.0, n)) if n > 1 else [30.0]
    for i, angle in enumerate(angles):
        photo = synthetic_photo(angle, seed=i, shadow=i % 3 == 0, tilt_deg=0.5 * (i % 3))
        Image.fromarray(photo.image).save(folder / f"heap{i:03d}.png")  # 8-bit RGB
    return [float(a) for a in angles]


def timed(args: list[str]) -> tuple[float, str]:
    start = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True, check=True)
    return time.perf_counter() - start, done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--photos", type=int, default=20, help="number of photos (default 20)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs (default 3)")
    args = parser.parse_args()
    demcal = [sys.executable, "-m", "demcal", "measure", "repose"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "photos").mkdir()
        angles = render(tmp / "photos", args.photos)
        paths = sorted(str(p) for p in (tmp / "photos").glob("*.png"))
        import_s = min(timed(demcal + ["--help"])[0] for _ in range(3))
        walls, out = [], ""
        for r in range(args.repeats):
            wall, out = timed(demcal + paths + ["--out", str(tmp / f"out{r}"), "--json"])
            walls.append(wall)
        measured = [p["angle_deg"] for p in json.loads(out)["photos"]]
    print(json.dumps({
        "photos": args.photos,
        "wall_s": [round(w, 2) for w in walls],
        "per_photo_s": [round(w / args.photos, 3) for w in walls],
        "import_s": round(import_s, 2),
        "max_error_deg": round(max(abs(m - a) for m, a in zip(measured, angles)), 3),
        "load_average": list(os.getloadavg()),
        "cpus": os.cpu_count(),
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
