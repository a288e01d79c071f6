"""`demcal run` stopped by SIGTERM at random moments: nothing left running, no temporary
folder, and a resume that finishes the same runs with the same bits (issue 37).

    python benchmarks/sigterm_kills.py --kills 12 --out kills.jsonl

The campaign (by default examples/residual-film-soil/repose.toml at the ``tiny``
profile) is copied with its folder twice into a temporary folder. One copy is run
through without interruption: the reference, whose run also gives the time scale (its
first claim, its first result and its whole wall time). On the other copy, ``demcal
run`` is started again and again and each time sent SIGTERM at a random moment: a
fifth of them in the start-up (before the first claim), a fifth while the workers
start (claims held, no result yet), the others while runs finish and are published.
Some get a second SIGTERM a few milliseconds after the first (it lands in the clean-up
of the first), some go to the runner's whole process group, workers included, as
Slurm and systemd send it. After each kill the store is read: how many rows are left
``running`` (the claims must all be handed back) and how many ``.tmp-``/``.old-``
folders are left under ``runs/`` (none may be). A last ``demcal run`` then finishes
the campaign, and every run's responses are compared with the reference's, bit for bit
(the engine gives the same bits for the same seed). Run it with numba's cache warm (a
`demcal bench` of the campaign's test first): the time scale is the reference's.

Prints a table (one row per kill) and the verdict; ``--out`` writes one JSON line per
kill, one for the reference and one for the resume. Exit status 0 when every kill left
nothing behind and the resume gave the same bits, else 1.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "residual-film-soil" / "repose.toml"

#: What a run leaves while it is in flight or being published (runner.remove_leftovers).
TEMPORARY = re.compile(r"^\..+\.(tmp|old)-[0-9a-f]{8}$")

#: How long a stopped runner may take to exit [s].
EXIT_TIMEOUT_S = 120.0


def store_path(campaign: Path) -> Path:
    from demcal.campaign.config import load_campaign

    return load_campaign(campaign, import_plugins=True).store_path


def read_store(store: Path) -> dict:
    """Counts per status and each done run's responses, read without writing anything."""
    if not store.is_file():
        return {"counts": {}, "responses": {}}
    db = sqlite3.connect(store.resolve().as_uri() + "?mode=ro", uri=True, timeout=60)
    try:
        counts = dict(db.execute("SELECT status, COUNT(*) FROM runs GROUP BY status").fetchall())
        responses = dict(db.execute("SELECT key, responses FROM runs WHERE status = 'done'").fetchall())
    except sqlite3.OperationalError:  # the store is being created: no table yet
        return {"counts": {}, "responses": {}}
    finally:
        db.close()
    return {"counts": counts, "responses": responses}


def temporary_folders(store: Path) -> list[str]:
    runs = store.parent / "runs"
    return sorted(p.name for p in runs.iterdir() if TEMPORARY.match(p.name)) if runs.is_dir() else []


#: The runners started, so that a script stopped half way stops the one in flight too.
_STARTED: list[subprocess.Popen] = []


def start_runner(campaign: Path, profile: str, workers: int) -> subprocess.Popen:
    """`demcal run` in a session of its own (its process group: the runner and its workers)."""
    cmd = [sys.executable, "-m", "demcal", "run", str(campaign), "--workers", str(workers)]
    if profile:
        cmd += ["--profile", profile]
    process = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True, cwd=campaign.parent)
    _STARTED.append(process)
    return process


def finish(process: subprocess.Popen, timeout: float) -> tuple[int | None, str, str]:
    """Exit status, stdout and stderr; a runner that does not exit in time is killed (status None)."""
    try:
        out, err = process.communicate(timeout=timeout)
        return process.returncode, out, err
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        out, err = process.communicate()
        return None, out, err


def sentence(err: str) -> str:
    """The runner's last ``demcal: ...`` line on stderr, if any."""
    lines = [line for line in err.splitlines() if line.startswith("demcal:")]
    return lines[-1] if lines else ""


def reference_run(campaign: Path, profile: str, workers: int) -> dict:
    """Run the copy through; time its start-up (until the first claim) and its whole run."""
    store = store_path(campaign)
    start = time.monotonic()
    process = start_runner(campaign, profile, workers)
    first_claim = first_done = None
    while process.poll() is None:
        counts = read_store(store)["counts"] if first_done is None else {}
        if first_claim is None and (counts.get("running") or counts.get("done")):
            first_claim = time.monotonic() - start
        if first_done is None and counts.get("done"):
            first_done = time.monotonic() - start
        time.sleep(0.05)
    status, out, err = finish(process, EXIT_TIMEOUT_S)
    wall = time.monotonic() - start
    state = read_store(store)
    if status != 0:
        raise SystemExit(f"the reference run failed (status {status}): {err.strip()[-500:]}")
    first_claim = wall if first_claim is None else first_claim
    return {"what": "reference", "status": status, "wall_s": round(wall, 2), "first_claim_s": round(first_claim, 2),
            "first_done_s": round(first_done if first_done is not None else first_claim, 2),
            "done": state["counts"].get("done", 0), "responses": state["responses"]}


def one_kill(campaign: Path, profile: str, workers: int, delay: float, double: bool, group: bool) -> dict:
    """Start `demcal run`, send SIGTERM after ``delay`` seconds (to the runner, or to its
    process group), maybe a second one; wait for it to exit; read what it left."""
    store = store_path(campaign)
    process = start_runner(campaign, profile, workers)
    start = time.monotonic()
    while process.poll() is None and time.monotonic() - start < delay:
        time.sleep(0.01)
    row = {"what": "kill", "moment_s": round(time.monotonic() - start, 2), "to": "group" if group else "runner"}
    if process.poll() is not None:  # it finished the campaign first
        status, out, err = finish(process, EXIT_TIMEOUT_S)
        row.update(signals="none (finished first)", running_at_kill=0, status=status, sentence=sentence(err))
    else:
        row["running_at_kill"] = read_store(store)["counts"].get("running", 0)
        send = (lambda: os.killpg(process.pid, signal.SIGTERM)) if group else (
            lambda: process.send_signal(signal.SIGTERM))
        send()
        killed = time.monotonic()
        if double:
            gap = random.uniform(0.0, 0.02)
            time.sleep(gap)
            if process.poll() is None:
                send()
            row["signals"] = f"TERM+TERM {gap * 1000:.0f} ms"
        else:
            row["signals"] = "TERM"
        status, out, err = finish(process, EXIT_TIMEOUT_S)
        row.update(status=status, exit_s=round(time.monotonic() - killed, 2), sentence=sentence(err))
    state = read_store(store)
    row.update(running_after=state["counts"].get("running", 0), temp_after=len(temporary_folders(store)),
               done_after=state["counts"].get("done", 0), failed_after=state["counts"].get("failed", 0))
    row["ok"] = (row["running_after"] == 0 and row["temp_after"] == 0 and row["failed_after"] == 0
                 and row["status"] in (0, 128 + signal.SIGTERM, -signal.SIGTERM))
    return row


def table(rows: list[dict]) -> str:
    head = ("#", "moment [s]", "phase", "signal", "to", "running at kill", "exit", "exit after [s]",
            "running after", "temp after", "done after", "sentence")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for i, r in enumerate(rows, 1):
        cells = (i, f"{r['moment_s']:.2f}", r["phase"], r["signals"], r["to"], r["running_at_kill"], r["status"],
                 r.get("exit_s", ""), r["running_after"], r["temp_after"], r["done_after"],
                 f"`{r['sentence']}`" if r["sentence"] else "(none)")
        lines.append("| " + " | ".join(map(str, cells)) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", type=Path, default=EXAMPLE, help="campaign file (its folder is copied)")
    ap.add_argument("--profile", default="tiny", help="bench profile (default tiny; '' for the file's)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--kills", type=int, default=12, help="SIGTERMs to send (default 12)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the random moments")
    ap.add_argument("--double", type=float, default=0.3, help="share of kills with a second SIGTERM")
    ap.add_argument("--group", type=float, default=0.3, help="share sent to the whole process group")
    ap.add_argument("--out", type=Path, help="JSON lines: one per kill, the reference and the resume")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = ap.parse_args(argv)
    random.seed(args.seed)
    source = args.campaign.resolve()
    scratch = Path(tempfile.mkdtemp(prefix="sigterm-kills-"))
    try:
        copies = {}
        for name in ("reference", "killed"):
            shutil.copytree(source.parent, scratch / name,
                            ignore=shutil.ignore_patterns("*-runs", "__pycache__", "report*"))
            copies[name] = scratch / name / source.name
        print(f"campaign {source} (profile {args.profile or 'of the file'}, {args.workers} workers) in {scratch}",
              flush=True)
        reference = reference_run(copies["reference"], args.profile, args.workers)
        claim, done, wall = reference["first_claim_s"], reference["first_done_s"], reference["wall_s"]
        print(f"reference: {reference['done']} runs done in {wall:.1f} s, first claim after {claim:.1f} s, "
              f"first result after {done:.1f} s", flush=True)
        # A fifth of the kills in the start-up (before the first claim), a fifth while the workers
        # start (claims held, no result yet), the rest within `window` after the first result,
        # while runs finish and are published: each of those lets window / 2 of the runs' time
        # pass on average, all together half the campaign's, so that the resume has runs left.
        window = 0.5 * 2 * max(wall - done, 1.0) / max(0.6 * args.kills, 1)
        rows = []
        for i in range(args.kills):
            draw = random.random()
            phase, delay = (("start-up", random.uniform(0.0, claim)) if draw < 0.2 else
                            ("workers starting", random.uniform(claim, done)) if draw < 0.4 else
                            ("runs finishing", random.uniform(done, done + window)))
            row = one_kill(copies["killed"], args.profile, args.workers, delay,
                           double=random.random() < args.double, group=random.random() < args.group)
            row["phase"] = phase
            rows.append(row)
            print(f"kill {i + 1}: {json.dumps(row)}", flush=True)
            if row["signals"].startswith("none"):
                break
        store = store_path(copies["killed"])
        start = time.monotonic()
        status, out, err = finish(start_runner(copies["killed"], args.profile, args.workers), 3600.0)
        after = read_store(store)
        same = sum(after["responses"].get(k) == v for k, v in reference["responses"].items())
        resume = {"what": "resume", "status": status, "wall_s": round(time.monotonic() - start, 2),
                  "done": after["counts"].get("done", 0), "running": after["counts"].get("running", 0),
                  "temp": len(temporary_folders(store)), "same_bits": same, "of": len(reference["responses"]),
                  "sentence": out.strip().splitlines()[0] if out.strip() else sentence(err)}
        kills = [r for r in rows if not r["signals"].startswith("none")]
        ok = (all(r["ok"] for r in rows) and status == 0 and same == len(reference["responses"])
              and resume["done"] == reference["done"] and resume["temp"] == 0)
        print()
        print(table(rows))
        print()
        print(f"reference: {reference['done']} runs in {wall:.1f} s (first claim at {claim:.1f} s); "
              f"{len(kills)} kills; resume: exit {status}, {resume['done']} done in {resume['wall_s']:.1f} s, "
              f"{same} of {len(reference['responses'])} runs with the reference's bits; "
              f"rows left running after a kill: {sum(r['running_after'] for r in rows)}, "
              f"temporary folders: {sum(r['temp_after'] for r in rows)}; "
              f"{'OK' if ok else 'FAILED'}.")
        if args.out:
            with args.out.open("w") as f:
                f.write(json.dumps({k: v for k, v in reference.items() if k != "responses"}) + "\n")
                for row in rows:
                    f.write(json.dumps(row) + "\n")
                f.write(json.dumps(resume) + "\n")
        return 0 if ok else 1
    finally:
        for process in _STARTED:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
        if args.keep:
            print(f"kept {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
