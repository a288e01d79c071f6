"""Run a bench study: one ``demcal bench`` run per (case, seed), one JSON line each.

    python benchmarks/bench_study.py PLAN.json RESULTS.jsonl [--threads 1]

``PLAN.json`` is a list of cases::

    [{"case": "funnel N1500 outlet 0.05", "test": "repose-funnel", "profile": "quick",
      "set": {"particles.count": 1500}, "seeds": [1, 2, 3, 4, 5]}, ...]

Each finished run is appended to ``RESULTS.jsonl`` as soon as it ends (its case, seed,
settings, responses, particles, steps and wall time), so a study that is stopped resumes
where it was: runs already in the file are skipped. Runs go one at a time, in plan order
with the seeds interleaved (every case gets its first seed before any gets its second), so
a study cut short still has every case. The tables in ``docs/validation*.md`` and the
studies' READMEs are written from these files by ``--summary``::

    python benchmarks/bench_study.py PLAN.json RESULTS.jsonl --summary

``--out DIR`` keeps each run's pictures and files (``demcal bench --out``) in
``DIR/<case>-seed<N>`` (the case's name with its spaces and slashes as dashes), e.g. the drum's
``drum.json`` with every frame's angle.

``--jobs N`` runs N of them at once (for a machine with more cores than the 2-core
reference machine); a case may name its own ``"threads"`` (numba threads of that run),
and ``--separate-caches DIR`` gives each concurrent slot its own numba cache under DIR, so
that runs compiling at the same time never share cache files.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

RESPONSE = {"repose-funnel": "repose_angle_deg", "repose-cylinder": "repose_angle_deg",
            "incline": "sliding_angle_deg", "impact": "restitution", "drum": "dynamic_angle_deg"}


def _done(results: Path) -> dict[tuple[str, int], dict]:
    out = {}
    if results.is_file():
        for line in results.read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                out[(row["case"], int(row["seed"]))] = row
    return out


def _order(plan: list[dict]) -> list[tuple[dict, int]]:
    depth = max(len(c["seeds"]) for c in plan)
    return [(c, c["seeds"][i]) for i in range(depth) for c in plan if i < len(c["seeds"])]


def run_one(case: dict, seed: int, threads: int, cache: Path | None = None,
            out: Path | None = None) -> dict:
    threads = int(case.get("threads", threads))
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    cmd = [sys.executable, "-m", "demcal", "bench", case["test"], "--profile", case["profile"],
           "--seed", str(seed), "--json"]
    for key, value in case.get("set", {}).items():
        cmd += ["--set", f"{key}={value}"]
    if out is not None:
        cmd += ["--out", str(out / f"{'-'.join(case['case'].replace('/', ' ').split())}-seed{seed}")]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    row = {"case": case["case"], "seed": seed, "test": case["test"], "profile": case["profile"],
           "set": case.get("set", {}), "threads": threads, "wall_s": round(wall, 1)}
    if proc.returncode == 0:
        out = json.loads(proc.stdout)
        row.update(responses=out["responses"], spread=out.get("spread", {}),
                   particles=out.get("particles"), steps=out.get("steps"),
                   simulated_s=out.get("simulated_s"))
    else:
        row["error"] = (proc.stderr.strip().splitlines() or ["exit %d" % proc.returncode])[-1]
    return row


def run(plan: list[dict], results: Path, threads: int, jobs: int = 1,
        separate_caches: Path | None = None, out: Path | None = None) -> None:
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    done = _done(results)
    todo = [(case, seed) for case, seed in _order(plan) if (case["case"], seed) not in done]
    free = list(range(jobs))
    running = {}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        while todo or running:
            while todo and free:
                slot = free.pop(0)
                case, seed = todo.pop(0)
                cache = separate_caches / f"slot-{slot}" if separate_caches else None
                running[pool.submit(run_one, case, seed, threads, cache, out)] = (case, slot)
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in finished:
                case, slot = running.pop(fut)
                free.append(slot)
                row = fut.result()
                # each finished run is on disk before the next one is reported
                with results.open("a") as fh:
                    fh.write(json.dumps(row) + "\n")
                print(f"{case['case']} seed {row['seed']}: "
                      + (f"{row['responses'][RESPONSE[case['test']]]:.2f}" if "responses" in row
                         else row["error"]) + f" ({row['wall_s']:.0f} s)", flush=True)


def summary(plan: list[dict], results: Path) -> str:
    import numpy as np

    done = _done(results)
    lines = ["| case | seeds | response, each seed [°] | mean | sd | particles | wall s (mean) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for case in plan:
        rows = [done[(case["case"], s)] for s in case["seeds"] if (case["case"], s) in done]
        ok = [r for r in rows if "responses" in r]
        if not rows:
            continue
        vals = np.array([r["responses"][RESPONSE[case["test"]]] for r in ok])
        each = ", ".join(f"{v:.2f}" for v in vals) + ("" if len(ok) == len(rows) else
                                                       f" ({len(rows) - len(ok)} failed)")
        sd = f"{vals.std(ddof=1):.2f}" if len(vals) > 1 else "--"
        mean = f"{vals.mean():.2f}" if len(vals) else "--"
        parts = ok[0]["particles"] if ok else "--"
        wall = f"{np.mean([r['wall_s'] for r in rows]):.0f}"
        lines.append(f"| {case['case']} | {', '.join(str(r['seed']) for r in rows)} | {each} | {mean} | "
                     f"{sd} | {parts} | {wall} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("plan", type=Path)
    ap.add_argument("results", type=Path)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1, help="runs at once (default 1)")
    ap.add_argument("--separate-caches", type=Path, metavar="DIR",
                    help="one numba cache folder per concurrent slot, under DIR")
    ap.add_argument("--out", type=Path, metavar="DIR", help="keep each run's files under DIR")
    ap.add_argument("--summary", action="store_true", help="print the results as a Markdown table")
    args = ap.parse_args(argv)
    plan = json.loads(args.plan.read_text())
    if args.summary:
        print(summary(plan, args.results))
    else:
        run(plan, args.results, args.threads, args.jobs, args.separate_caches, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
