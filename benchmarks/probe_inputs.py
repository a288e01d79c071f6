"""Re-run the bad-input and fault probes of "nothing destroyed, nothing escapes".

Each case runs ``demcal`` as a user would (a separate process) in a fresh copy of the
residual-film-soil example, with a calibration.json of the repose campaign (no
simulation) and a heap photo the campaign names. A case passes when demcal exits with
status 2, says one sentence (``demcal: error: ...``) without a traceback, and leaves
every file of the folder byte for byte as it was (FIFOs and device nodes stay what they
are). SIGTERM is probed by ``benchmarks/sigterm_kills.py``.

    python benchmarks/probe_inputs.py [--jsonl FILE]

Prints a table (case, status, verdict, the sentence) and the count passed; exit status
1 if any case fails.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "residual-film-soil"
CALIBRATION = {"campaign": "repose", "profile": "quick", "conditions": [
    {"name": "6.26 %", "chosen": {"particle.restitution": 0.58, "particle.static_friction": 0.312,
                                  "particle.rolling_friction": 0.105, "particle.damping_factor": 0.12},
     "verification": []}]}
RUNS_CSV = "A,B,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,5\n0,0,3\n0,0,3.1\n"


def prepare(folder: Path) -> None:
    """The example, a calibration.json carrying the campaign's hash, a store file, a photo,
    a FIFO, a link to a device, a runs CSV and a huge PNG header."""
    sys.path.insert(0, str(ROOT / "src"))
    from demcal.campaign.config import load_campaign
    from demcal.campaign.digest import as_calibrated, campaign_hash

    for path in EXAMPLE.iterdir():
        if path.is_file():
            shutil.copy2(path, folder / path.name)
    (folder / "photos").mkdir()
    (folder / "photos" / "heap-1.jpg").write_bytes(b"\xff\xd8\xff\xe0 a lab photo")
    campaign = folder / "repose.toml"
    campaign.write_text(campaign.read_text().replace('sample = "L"\n', 'sample = "L"\nphoto = "photos/heap-1.jpg"\n', 1))
    runs = folder / "repose-runs"
    runs.mkdir()
    data = dict(CALIBRATION, campaign_hash=campaign_hash(as_calibrated(load_campaign(campaign), CALIBRATION)))
    (runs / "calibration.json").write_text(json.dumps(data))
    (runs / "store.sqlite").write_bytes(b"SQLite format 3\x00" + bytes(100))
    os.mkfifo(folder / "pipe")
    (folder / "null-link").symlink_to(os.devnull)
    (folder / "runs.csv").write_text(RUNS_CSV)
    header = b"IHDR" + (30000).to_bytes(4, "big") * 2 + b"\x08\x02\x00\x00\x00"  # 30000 x 30000 RGB
    chunk = (13).to_bytes(4, "big") + header + zlib.crc32(header).to_bytes(4, "big")
    end = (0).to_bytes(4, "big") + b"IEND" + zlib.crc32(b"IEND").to_bytes(4, "big")
    (folder / "huge.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk + end)
    (folder / "nothing.toml").write_text('[S]\n[S.sliding]\nmethod = "incline"\n')


def edit(name: str, old: str, new: str):
    def apply(folder: Path) -> None:
        path = folder / name
        text = path.read_text()
        assert old in text, (name, old)
        path.write_text(text.replace(old, new, 1))
    return apply


def link(name: str):
    def apply(folder: Path) -> None:
        outside = folder.parent / "outside"
        outside.mkdir(exist_ok=True)
        (folder / "repose-runs" / name).symlink_to(outside, target_is_directory=True)
    return apply


def demo_edited(folder: Path) -> None:
    (folder / "d7" / "campaigns").mkdir(parents=True)
    (folder / "d7" / "campaigns" / "repose.toml").write_text("# my edited campaign\n")


#: (case, what is set up first or None, argv after `demcal`)
CASES = [
    ("export -o the store", None, ["export", "repose.toml", "-o", "repose-runs/store.sqlite"]),
    ("export -o the campaign file", None, ["export", "repose.toml", "-o", "repose.toml"]),
    ("export liggghts -o the lab file", None, ["export", "repose.toml", "--format", "liggghts", "-o", "lab.toml"]),
    ("export edem -o a lab photo", None, ["export", "repose.toml", "--format", "edem", "-o", "photos/heap-1.jpg"]),
    ("export -o the calibration", None, ["export", "repose.toml", "-o", "repose-runs/calibration.json"]),
    ("export -o a folder", None, ["export", "repose.toml", "-o", "photos"]),
    ("export -o a file demcal did not write", None, ["export", "repose.toml", "-o", "runs.csv"]),
    ("design -o a FIFO", None, ["design", "box-behnken", "-k", "3", "-o", "pipe"]),
    ("design -o a link to a device --force", None, ["design", "box-behnken", "-k", "3", "-o", "null-link", "--force"]),
    ("design -o its own input", None, ["design", "steepest-ascent", "runs.csv", "--response", "y", "-o", "runs.csv",
                                       "--force"]),
    ("optimize --plot its input", None, ["optimize", "runs.csv", "--response", "y", "--target", "3", "--plot",
                                         "runs.csv"]),
    ("demo bad profile", None, ["demo", "--out", "d7", "--profile", "bogus"]),
    ("demo over an edited campaign", demo_edited, ["demo", "--out", "d7", "--profile", "tiny"]),
    ("workdir/runs links outside", link("runs"), ["run", "repose.toml", "--profile", "tiny"]),
    ("workdir/report links outside", link("report"), ["report", "repose.toml"]),
    ("repose target 120 deg", edit("lab.toml", "mean_deg = 31.07", "mean_deg = 120"),
     ["run", "repose.toml", "--profile", "tiny"]),
    ("band_low > band_high", edit("repose.toml", 'profile = "quick"\n',
                                  'profile = "quick"\n[experiment.settings]\n"measure.band_low" = 0.8\n'
                                  '"measure.band_high" = 0.5\n'),
     ["run", "repose.toml", "--profile", "tiny"]),
    ("incline H = L = 1e308", None, ["measure", "incline", "--H", "1e308", "--L", "1e308"]),
    ("repose --mm-per-px nan", None, ["measure", "repose", "photos/heap-1.jpg", "--mm-per-px", "nan"]),
    ("optimize --max-solutions -1", None, ["optimize", "runs.csv", "--response", "y", "--target", "3",
                                           "--max-solutions", "-1"]),
    ("optimize --starts 1000000", None, ["optimize", "runs.csv", "--response", "y", "--target", "3",
                                         "--starts", "1000000"]),
    ("a huge PNG", None, ["measure", "repose", "huge.png"]),
    ("no command", None, []),
    ("export after a factor's range changed", edit("repose.toml", "low = 0.3\nhigh = 0.5", "low = 0.3\nhigh = 0.6"),
     ["export", "repose.toml", "-o", "card.json"]),
]


def digests(folder: Path) -> dict[str, str]:
    out = {}
    for path in sorted(folder.rglob("*")):
        if path.is_symlink():
            out[str(path.relative_to(folder))] = "link to " + os.readlink(path)
        elif path.is_fifo():
            out[str(path.relative_to(folder))] = "fifo"
        elif path.is_file():
            out[str(path.relative_to(folder))] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def run_case(name, setup, argv, root: Path) -> dict:
    folder = root / name.replace(" ", "_").replace("/", "_")
    folder.mkdir()
    work = folder / "campaign"
    work.mkdir()
    prepare(work)
    if setup is not None:
        setup(work)
    before = digests(work)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run([sys.executable, "-m", "demcal", *argv], cwd=work, env=env, capture_output=True,
                          text=True, timeout=600)
    lines = proc.stderr.strip().splitlines()
    sentence = lines[-1] if lines else ""
    unchanged = digests(work) == before
    outside = folder / "outside"
    escaped = outside.is_dir() and any(outside.iterdir())
    ok = (proc.returncode == 2 and "Traceback" not in proc.stderr and sentence.startswith("demcal: error: ")
          and sentence.endswith(".") and unchanged and not escaped)
    return {"case": name, "argv": argv, "status": proc.returncode, "ok": ok, "unchanged": unchanged,
            "sentence": sentence.removeprefix("demcal: error: ")}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jsonl", type=Path, help="append each case's result to this file")
    args = parser.parse_args()
    results = []
    with tempfile.TemporaryDirectory(prefix="demcal-probe-") as tmp:
        for name, setup, argv in CASES:
            result = run_case(name, setup, argv, Path(tmp))
            results.append(result)
            if args.jsonl:
                with open(args.jsonl, "a") as fh:
                    fh.write(json.dumps(result) + "\n")
            print(f"{'pass' if result['ok'] else 'FAIL'}  {name}", file=sys.stderr, flush=True)
    print("| case | status | inputs unchanged | verdict | sentence |")
    print("| --- | --- | --- | --- | --- |")
    for r in results:
        print(f"| {r['case']} | {r['status']} | {'yes' if r['unchanged'] else 'NO'} | "
              f"{'pass' if r['ok'] else 'FAIL'} | {r['sentence']} |")
    passed = sum(r["ok"] for r in results)
    print(f"\n{passed} of {len(results)} cases pass.")
    return 0 if passed == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
