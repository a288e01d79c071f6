#!/usr/bin/env python3
"""The engine's speed in several source trees, measured turn about in one sitting.

One run of ``throughput.py`` scatters by 10-15 % on a shared 2-core VM, more than most
engine changes are worth, so a before/after figure needs rounds: every tree runs once
per round, the order reversed every other round (so neither side always runs first),
each tree from its own source (``PYTHONPATH=TREE/src``) and its own numba cache (no tree
loads or overwrites another's kernels), and each with its own cached packing under
``TREE/benchmarks/.packings`` (an older engine cannot read a newer checkpoint format).
Every run is appended to ``--out`` as one JSON line as soon as it ends; the table at the
end gives each tree's mean, median and the mean ratio to the first tree, paired by round.

    git worktree add /tmp/before <commit>
    python benchmarks/compare_engines.py /tmp/before . --rounds 7 --out rounds.jsonl
    python benchmarks/compare_engines.py /tmp/before . --rounds 9 --liggghts   # the LIGGGHTS ratio

Trees without ``benchmarks/throughput.py`` of their own run this tree's copy against their
sources. ``--particles``, ``--threads`` and ``--steps`` go to ``throughput.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def run_once(tree: Path, args, cache_root: Path) -> dict:
    script = tree / "benchmarks" / "throughput.py"
    if not script.is_file():
        script = HERE / "throughput.py"
    env = dict(os.environ, PYTHONPATH=str(tree / "src"),
               NUMBA_CACHE_DIR=str(cache_root / tree.resolve().name))
    cmd = [sys.executable, str(script), "--particles", str(args.particles), "--threads",
           str(args.threads), "--steps", str(args.steps), "--json"]
    if args.liggghts:
        cmd.append("--liggghts")
    done = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    lines = [ln for ln in done.stdout.splitlines() if ln.startswith("{")]
    if done.returncode != 0 or not lines:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise SystemExit(f"compare_engines: {tree} failed: {tail}")
    return json.loads(lines[-1])


def summary(rows: list[dict], trees: list[str], key: str) -> str:
    by_round: dict[int, dict[str, float]] = {}
    for r in rows:
        by_round.setdefault(r["round"], {})[r["tree"]] = r["result"][key]
    out = [f"| tree | rounds | mean {key} | median | mean ratio to {trees[0]} (paired) |",
           "| --- | --- | --- | --- | --- |"]
    for t in trees:
        vals = [v[t] for v in by_round.values() if t in v]
        pairs = [v[t] / v[trees[0]] for v in by_round.values() if t in v and trees[0] in v]
        ratio = f"{statistics.mean(pairs):.3f}" if pairs else "--"
        out.append(f"| {t} | {len(vals)} | {statistics.mean(vals):.4g} | "
                   f"{statistics.median(vals):.4g} | {ratio} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs="+", type=Path, help="source trees (a checkout or worktree each)")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--particles", type=int, default=20000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--liggghts", action="store_true", help="also run LIGGGHTS each time (the ratio)")
    ap.add_argument("--out", type=Path, help="JSON lines, one per run, appended as they end")
    ap.add_argument("--cache", type=Path, help="folder for the per-tree numba caches "
                    "(default: a temporary one)")
    args = ap.parse_args(argv)
    for t in args.trees:
        if not (t / "src" / "demcal").is_dir():
            ap.error(f"{t} holds no src/demcal; name a demcal checkout or worktree")
    names = [str(t) for t in args.trees]
    if len(set(names)) < len(names):  # the same tree twice (a noise check): number them
        names = [f"{n} #{i + 1}" for i, n in enumerate(names)]
    cache_root = args.cache or Path(tempfile.mkdtemp(prefix="demcal-compare-"))
    rows = []
    for r in range(1, args.rounds + 1):
        order = list(zip(names, args.trees))
        for name, tree in (order if r % 2 else order[::-1]):
            row = {"round": r, "tree": name, "result": run_once(tree, args, cache_root)}
            rows.append(row)
            if args.out:
                with args.out.open("a") as f:
                    f.write(json.dumps(row) + "\n")
            print(f"round {r} {name}: {row['result']['particle_steps_per_s'] / 1e6:.3f} M "
                  "particle-steps/s", file=sys.stderr, flush=True)
    print(summary(rows, names, "particle_steps_per_s"))
    if args.liggghts:
        print()
        print(summary(rows, names, "ratio_vs_liggghts"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
