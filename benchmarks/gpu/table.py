#!/usr/bin/env python3
"""The short table of a benchmarks/gpu/run.sh output folder (printed last by the script)."""

import json
import sys
from pathlib import Path


def rows(path):
    p = Path(path)
    return [json.loads(x) for x in p.read_text().splitlines() if x.startswith("{")] \
        if p.exists() else []


def main(folder) -> int:
    f = Path(folder)
    print((f / "machine.txt").read_text() if (f / "machine.txt").exists() else "")
    for r in rows(f / "check.jsonl"):
        worst = max(r["cuda_vs_cpu"].values())
        print(f"check {r['case']:38s} {r['steps']:5d} steps  cuda/cpu {worst:.2e}  "
              f"twice same bits {r['cuda_twice_same_bits']}  touching {r['touching_pairs']}")
    for r in rows(f / "throughput.jsonl"):
        if "error" in r:
            print(f"throughput {r['backend']:4s} {r['particles']:>8d}  error {r['error'][:100]}")
            continue
        print(f"throughput {r['backend']:4s} {r['particles']:>8d}  {r['particle_steps_per_s']:.3e} "
              f"p-steps/s  rebuilds {r['rebuilds']}  {r.get('backend_seconds', '')}")
    for r in rows(f / "cases.jsonl"):
        worst = max(r["relative"].values())
        print(f"case {r['case']:34s} cuda/cpu {worst:.2e} lists {r['same_lists']} "
              f"rebuilds {r['rebuilds']}")
    for r in rows(f / "ensemble-bits.jsonl"):
        if "system" in r:
            print(f"ensemble bits {r['system'][:40]:40s} same {r.get('same_bits')} rebuilds {r.get('rebuilds')}")
    for r in rows(f / "ensemble.jsonl"):
        print(f"ensemble {r['test']} {r['profile']} x{r['runs']}: alone {r['alone_s']:.1f} s, together "
              f"{r['together_s']:.1f} s ({r['speedup']:.2f}x), same bits {r['same_bits']}, rounds {r['rounds']}")
    if (f / "bits-cpu.json").exists():
        try:
            bits = json.loads((f / "bits-cpu.json").read_text())
            print(f"bits.py on this CPU: {len(bits)} configurations, "
                  f"{sum('error' in v for v in bits.values())} errors (bits-cpu.json)")
        except ValueError:
            print("bits.py on this CPU: bits-cpu.json unreadable (bits.log)")
    if (f / "funnel.txt").exists():
        print("funnel:", (f / "funnel.txt").read_text()[-600:].replace("\r", "\n").splitlines()[-3:])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
