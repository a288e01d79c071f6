#!/usr/bin/env python3
"""The identical-heap table of a `lifted_cylinder.py` study: demcal against LIGGGHTS.

    python benchmarks/liggghts/heap_table.py STUDY.jsonl [--particles 3000]

For each (mu_s, mu_r) pair, each code's angles by seed, their means and standard
deviations, and the difference demcal - LIGGGHTS of the means with its standard error
from the two codes' seed spreads, sqrt(s_d^2/n_d + s_l^2/n_l); then the mean difference
over the pairs with its standard error. Issue 42's aim: the mean within +-0.3 deg, and
every pair's difference within two standard errors, with at least four seeds of each.

Rows of ``--code demcal-fresh-history`` (demcal with every contact's history zeroed at
the lift start, as LIGGGHTS starts) get a table of their own: how much the history that
LIGGGHTS cannot be given moves demcal's heap.

Each LIGGGHTS run starts from demcal's packing of the same seed (the harness), so the
per-seed differences are paired as well: their mean equals the difference of the means
where both codes have the same seeds, and their spread (``paired sd``) says how far the
two codes part from one start. Only rows with an angle count; failed runs are listed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np


def load(path: Path, particles: int) -> tuple[dict, list]:
    angles: dict = {}
    failed = []
    for line in path.read_text().splitlines():
        if not line.startswith("{"):
            continue
        try:
            r = json.loads(line)
        except json.JSONDecodeError:  # the last line, half written by a run that is ending
            continue
        if r.get("particles") != particles:
            continue
        key = (r["mus"], r["mur"])
        if r.get("angle_deg") is None:
            failed.append(r)
            continue
        angles.setdefault(key, {}).setdefault(r["code"], {})[r["seed"]] = r["angle_deg"]
    return angles, failed


def sd(values) -> float:
    return float(np.std(values, ddof=1)) if len(values) > 1 else math.nan


def table(angles: dict) -> tuple[list[str], dict]:
    lines = ["| mu_s / mu_r | demcal by seed | LIGGGHTS by seed | demcal mean (sd) | LIGGGHTS mean (sd) "
             "| demcal - LIGGGHTS | its se | within 2 se | paired sd |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    diffs, ses, within, counts = [], [], [], []
    for (mus, mur) in sorted(angles):
        by = angles[(mus, mur)]
        d, g = by.get("demcal", {}), by.get("liggghts", {})
        if not d or not g:
            continue
        dv, gv = list(d.values()), list(g.values())
        diff = float(np.mean(dv) - np.mean(gv))
        se = math.sqrt(sd(dv) ** 2 / len(dv) + sd(gv) ** 2 / len(gv)) if min(len(dv), len(gv)) > 1 else math.nan
        both = sorted(set(d) & set(g))
        paired = sd([d[s] - g[s] for s in both])
        ok = abs(diff) <= 2 * se if not math.isnan(se) else None
        diffs.append(diff)
        ses.append(se)
        within.append(ok)
        counts.append(min(len(dv), len(gv)))

        def seeds(x):
            return ", ".join(f"{x[s]:.2f}" for s in sorted(x))

        lines.append(f"| {mus:g} / {mur:g} | {seeds(d)} | {seeds(g)} | {np.mean(dv):.2f} ({sd(dv):.2f}) | "
                     f"{np.mean(gv):.2f} ({sd(gv):.2f}) | {diff:+.2f} | {se:.2f} | "
                     f"{'-' if ok is None else ('yes' if ok else 'no')} | {paired:.2f} |")
    summary = {"pairs": len(diffs), "mean_difference": float(np.mean(diffs)) if diffs else math.nan,
               "se_of_mean": math.sqrt(sum(s * s for s in ses)) / len(ses) if ses else math.nan,
               "within_2se": sum(1 for w in within if w), "fewest_seeds": min(counts) if counts else 0}
    return lines, summary


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study")
    ap.add_argument("--particles", type=int, default=3000)
    args = ap.parse_args(argv)
    angles, failed = load(Path(args.study), args.particles)
    lines, s = table(angles)
    print("\n".join(lines))
    print()
    print(f"pairs with both codes: {s['pairs']} of 6; mean difference {s['mean_difference']:+.2f} deg "
          f"(se {s['se_of_mean']:.2f}); within two se: {s['within_2se']} of {s['pairs']}; "
          f"fewest seeds of a code in a pair: {s['fewest_seeds']} (the aim needs 4)")
    fresh = [(key, by) for key, by in sorted(angles.items()) if "demcal-fresh-history" in by]
    if fresh:
        print()
        print("| mu_s / mu_r | demcal, history zeroed at the lift, by seed | its mean | demcal mean | "
              "LIGGGHTS mean | zeroed - carried, paired |")
        print("| --- | --- | --- | --- | --- | --- |")
        for (mus, mur), by in fresh:
            f, d, g = by["demcal-fresh-history"], by.get("demcal", {}), by.get("liggghts", {})
            both = sorted(set(f) & set(d))
            paired = np.mean([f[s] - d[s] for s in both]) if both else math.nan

            def mean(x):
                return f"{np.mean(list(x.values())):.2f}" if x else "-"

            print(f"| {mus:g} / {mur:g} | {', '.join(f'{f[s]:.2f}' for s in sorted(f))} | {mean(f)} | "
                  f"{mean(d)} | {mean(g)} | {paired:+.2f} ({len(both)} seeds) |")
    for r in failed:
        print(f"failed: {r['code']} mu_s {r['mus']:g} mu_r {r['mur']:g} seed {r['seed']}: {r.get('error')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
