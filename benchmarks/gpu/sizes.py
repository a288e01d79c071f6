#!/usr/bin/env python3
"""benchmarks/throughput.py at several sizes in one process (the cuda kernels compile
once), each result a JSON line in OUT as it finishes (throughput.py adds the cuda
backend's split of the timed loop: upload, device steps, download).

    python benchmarks/gpu/sizes.py OUT --backend cuda --particles 100000 1000000 --steps 200
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import throughput  # noqa: E402  (benchmarks/throughput.py)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("--backend", default="cuda")
    ap.add_argument("--particles", type=int, nargs="+", default=[100000, 1000000])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--threads", type=int, default=16)
    ap.add_argument("--clumps", action="store_true")
    args = ap.parse_args(argv)
    for n in args.particles:
        t0 = time.perf_counter()
        buf = io.StringIO()
        argv_n = ["--particles", str(n), "--steps", str(args.steps), "--threads",
                  str(args.threads), "--backend", args.backend, "--json"]
        if args.clumps:
            argv_n.append("--clumps")
        try:
            with contextlib.redirect_stdout(buf):
                throughput.main(argv_n)
            row = json.loads(buf.getvalue().strip().splitlines()[-1])
        except Exception as exc:  # a size that does not fit is a row, not the end
            row = {"particles": n, "backend": args.backend, "error": repr(exc)[-400:]}
        row["wall_s"] = round(time.perf_counter() - t0, 1)
        with open(args.out, "a") as f:
            f.write(json.dumps(row) + "\n")
        print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
