"""Stored campaigns replayed through the calibration loop, and a digest of what it decided.

A fixture folder under ``tests/campaign/data/`` holds a campaign's files (its ``.toml``
and ``lab.toml``), its store's rows as JSON (``store.json.gz``: the ``campaign`` row and
every ``runs`` row, all columns) and ``expected.json``, the digest of
``calibrate(campaign, simulate=False)`` over that store. The digest keeps every number
exactly (JSON floats round-trip), so the test compares it to the bit.

Make a fixture from a finished (or interrupted) demo's ``campaigns`` folder::

    python tests/campaign/loop_replay.py make /path/to/campaigns repose tests/campaign/data/demo-repose

(it reads the store read-only and writes only the fixture folder).
"""

from __future__ import annotations

import gzip
import json
import math
import shutil
import sqlite3
import sys
from pathlib import Path
from typing import Any

#: the files of a campaign folder a replay reads besides the campaign file (the lab
#: records, and the tables its ``[report]`` names, which the loader checks exist)
SIDE_FILES = ("lab.toml", "*.csv")
#: the fixture's own files (the rest is the campaign folder's)
OWN = ("store.json.gz", "expected.json")


def dump_store(path: Path) -> dict[str, Any]:
    """Every row of a store's ``campaign`` and ``runs`` tables, read-only, as JSON data."""
    db = sqlite3.connect(Path(path).resolve().as_uri() + "?mode=ro", uri=True)
    db.row_factory = sqlite3.Row
    try:
        tables = {name: [dict(row) for row in db.execute(f"SELECT * FROM {name} ORDER BY id")]
                  for name in ("campaign", "runs")}
    finally:
        db.close()
    return tables


def load_store(data: dict[str, Any], path: Path) -> None:
    """A store at ``path`` (made by :class:`~demcal.campaign.store.Store`) holding ``data``'s rows."""
    from demcal.campaign.store import Store

    Store(path).close()  # the schema
    db = sqlite3.connect(path, isolation_level=None)
    try:
        db.execute("BEGIN")
        for table in ("campaign", "runs"):
            for row in data[table]:
                names = ", ".join(row)
                db.execute(f"INSERT INTO {table} ({names}) VALUES ({', '.join('?' * len(row))})",
                           tuple(row.values()))
        db.execute("COMMIT")
    finally:
        db.close()


def build(fixture: Path, folder: Path):
    """The fixture's campaign, with its store, laid out in ``folder``: the parsed campaign.

    The fixture holds the campaign folder's files at their places (an upstream
    campaign's file and ``calibration.json`` too, for a chained one); ``expected.json``
    names the campaign file where there are several."""
    from demcal.campaign.config import load_campaign

    for path in fixture.rglob("*"):
        if not path.is_file() or (path.parent == fixture and path.name in OWN):
            continue
        target = folder / path.relative_to(fixture)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(path, target)
    name = json.loads((fixture / "expected.json").read_text()).get("campaign")
    if name is None:
        (campaign_file,) = [p for p in fixture.glob("*.toml") if p.name not in SIDE_FILES]
        name = campaign_file.name
    with gzip.open(fixture / "store.json.gz", "rt", encoding="utf-8") as f:
        data = json.load(f)
    campaign = load_campaign(folder / name)
    campaign.store_path.parent.mkdir(parents=True, exist_ok=True)
    load_store(data, campaign.store_path)
    return campaign


def _plain(value: Any) -> Any:
    """JSON data of ``value``: floats kept exactly, NaN and infinities as their names."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # numpy scalars
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return repr(value)


def loop_digest(loop) -> dict[str, Any]:
    """What one condition's loop (a :class:`~demcal.campaign.loop.LoopResult`) decided:
    status, reason, boxes, history, notes, the chosen point's runs."""
    return {
        "status": loop.status,
        "reason": loop.reason,
        "boxes": [{"index": b.index, "low": b.low, "high": b.high, "reason": b.reason} for b in loop.boxes],
        "box": loop.box.index,
        "history": [step.to_dict() for step in loop.history],
        "notes": loop.notes,
        "cheap_target": loop.cheap_target,
        "on_path": loop.on_path,
        "discrepancy": {r: d.describe() for r, d in loop.discrepancy.items()},
        "production": [r.key for r in loop.production],
        "specs": [s.key for s in loop.specs],
    }


def digest(calibration, asked: list | None = None, folder: Path | None = None) -> dict[str, Any]:
    """What the loop decided for every condition of ``calibration`` (:func:`loop_digest`),
    with the chosen values and verdict numbers and, when given, ``asked`` (the loop's
    ``run`` calls: their description and spec keys, in order). ``folder`` is written
    ``<dir>`` in texts (a replay's place differs)."""
    out = []
    for result in calibration.conditions:
        out.append({
            "condition": result.condition.name,
            **loop_digest(result.loop),
            "chosen": result.chosen,
            "chosen_coded": result.chosen_coded,
            "desirability": result.desirability,
            "verdicts": [{"response": v.response, "target": v.target, "lab_sd": v.lab_sd, "predicted": v.predicted,
                          "simulated": v.simulated, "reachable": v.reachable, "parts": v.parts}
                         for v in result.verdicts],
        })
    return plain({"conditions": out, "asked": asked}, folder)


def plain(data: Any, folder: Path | None = None) -> Any:
    """``data`` as JSON data (:func:`_plain`), ``folder`` written ``<dir>`` in its texts."""
    data = _plain(data)
    if folder is not None:
        data = json.loads(json.dumps(data).replace(str(folder), "<dir>"))
    return data


def asking(monkeypatch) -> list:
    """Record every ``run`` call of :func:`demcal.campaign.loop.run_condition` (its
    description and spec keys) in the list returned."""
    from demcal.campaign import loop

    asked: list = []
    real = loop.run_condition

    def recorded(*args, run, **kw):
        def run_recorded(specs, desc):
            asked.append([desc, [s.key for s in specs]])
            return run(specs, desc)

        return real(*args, run=run_recorded, **kw)

    monkeypatch.setattr(loop, "run_condition", recorded)
    return asked


def replay(fixture: Path, folder: Path, monkeypatch) -> dict[str, Any]:
    """The digest of ``calibrate(simulate=False)`` over the fixture's store, laid out in ``folder``."""
    from demcal.campaign.calibrate import calibrate

    campaign = build(fixture, folder)
    asked = asking(monkeypatch)
    return digest(calibrate(campaign, simulate=False, progress=False), asked, folder)


def same(a: Any, b: Any) -> bool:
    """Whether two digests are equal to the bit (canonical JSON texts)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def make(campaigns: Path, name: str, fixture: Path) -> None:
    """Write a fixture of campaign ``name`` in a demo's ``campaigns`` folder, and its
    expected digest (with the campaign files it takes settings from, and their
    ``calibration.json``)."""
    import tempfile

    import pytest

    from demcal.campaign.config import load_campaign

    campaign = load_campaign(campaigns / f"{name}.toml")
    fixture.mkdir(parents=True, exist_ok=True)
    shutil.copy(campaign.path, fixture / campaign.path.name)
    for side in SIDE_FILES:
        for path in campaigns.glob(side):
            shutil.copy(path, fixture / path.name)
    upstreams = {c.upstream.path: c.upstream for c in campaign.conditions if c.upstream is not None}
    for other in upstreams.values():
        shutil.copy(other.path, fixture / other.path.name)
        workdir = fixture / other.workdir.relative_to(campaign.path.parent)
        workdir.mkdir(parents=True, exist_ok=True)
        shutil.copy(other.workdir / "calibration.json", workdir)
    with gzip.GzipFile(fixture / "store.json.gz", "wb", mtime=0) as raw:
        raw.write(json.dumps(dump_store(campaign.store_path), sort_keys=True).encode())
    (fixture / "expected.json").write_text(json.dumps({"campaign": campaign.path.name}) + "\n")
    with tempfile.TemporaryDirectory() as tmp, pytest.MonkeyPatch.context() as mp:
        data = replay(fixture, Path(tmp), mp)
    data["campaign"] = campaign.path.name
    (fixture / "expected.json").write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 5 or sys.argv[1] != "make":
        sys.exit(__doc__)
    sys.path.insert(0, str(Path(__file__).parent))
    make(Path(sys.argv[2]), sys.argv[3], Path(sys.argv[4]))
