"""The store's tables and the rows of its ``runs`` table.

:data:`_SCHEMA` is the SQL that makes a store's tables (:class:`~demcal.campaign.store.Store`
runs it on every store it opens for writing, and adds there the columns an older
store lacks); a run is planned as a :class:`RunSpec` and read back as a
:class:`RunRecord`, and its *key* (:func:`run_key`) is a hash of what determines its
result.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

STATUSES = ("pending", "running", "done", "failed")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS campaign (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    name TEXT NOT NULL,
    source TEXT NOT NULL,
    created_at REAL NOT NULL,
    updated_at REAL NOT NULL,
    demcal_version TEXT NOT NULL,
    path TEXT
);
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY,
    key TEXT NOT NULL UNIQUE,
    kind TEXT NOT NULL,
    label TEXT NOT NULL,
    test TEXT NOT NULL,
    profile TEXT NOT NULL,
    parameters TEXT NOT NULL,
    settings TEXT NOT NULL,
    seed INTEGER NOT NULL,
    status TEXT NOT NULL DEFAULT 'pending'
        CHECK (status IN ('pending', 'running', 'done', 'failed')),
    responses TEXT,
    result TEXT,
    artifacts_dir TEXT,
    attempts INTEGER NOT NULL DEFAULT 0,
    created_at REAL NOT NULL,
    started_at REAL,
    finished_at REAL,
    wall_s REAL,
    engine_version TEXT,
    error TEXT,
    owner TEXT,
    pid INTEGER,
    host TEXT,
    heartbeat REAL
);
CREATE INDEX IF NOT EXISTS runs_status ON runs (status);
"""


@dataclass(frozen=True)
class RunSpec:
    """One planned simulation: what to run and under which label."""

    kind: str  #: "design" or "verification"
    label: str  #: e.g. "design 7" or "verify 6.26 % #2"
    test: str
    profile: str
    parameters: Mapping[str, float]  #: the factor settings of this point
    settings: Mapping[str, Any]  #: every override passed to the experiment
    seed: int

    @property
    def key(self) -> str:
        return run_key(self.test, self.profile, self.settings, self.seed)

    @property
    def dirname(self) -> str:
        """The run's artifact folder under ``runs/``."""
        slug = "".join(c if c.isalnum() else "-" for c in self.label).strip("-").lower()
        return f"{slug}-{self.key[:10]}"


@dataclass(frozen=True)
class RunRecord:
    """One row of the runs table."""

    id: int
    key: str
    kind: str
    label: str
    test: str
    profile: str
    parameters: dict[str, float]
    settings: dict[str, Any]
    seed: int
    status: str
    responses: dict[str, float]
    result: dict[str, Any]
    artifacts_dir: str | None
    attempts: int
    started_at: float | None
    finished_at: float | None
    wall_s: float | None
    engine_version: str | None
    error: str | None
    owner: str | None
    pid: int | None
    host: str | None
    heartbeat: float | None


def run_key(test: str, profile: str, settings: Mapping[str, Any], seed: int) -> str:
    """SHA-256 of the canonical JSON of what determines a run's result."""
    blob = json.dumps({"test": test, "profile": profile, "settings": _canonical(settings), "seed": int(seed)},
                      sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def _canonical(settings: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in settings.items():
        if isinstance(value, float):
            value = float(f"{value:.12g}")  # 0.1 + 0.2 and 0.3 are one point
        out[key] = value
    return out


def _schema_columns() -> frozenset[str]:
    """The columns a store's ``runs`` table has (a file of another program lacks them)."""
    db = sqlite3.connect(":memory:")
    try:
        db.executescript(_SCHEMA)
        return frozenset(row[1] for row in db.execute("PRAGMA table_info(runs)"))
    finally:
        db.close()


_RUN_COLUMNS = _schema_columns()


def _key_filter(keys: Sequence[str] | None) -> tuple[str, tuple]:
    if keys is None:
        return "", ()
    keys = tuple(keys)
    if not keys:
        return " AND 0", ()
    return f" AND key IN ({','.join('?' * len(keys))})", keys


def _record(row: sqlite3.Row) -> RunRecord:
    def load(text, default):
        return json.loads(text) if text else default

    return RunRecord(
        id=row["id"], key=row["key"], kind=row["kind"], label=row["label"], test=row["test"],
        profile=row["profile"], parameters=load(row["parameters"], {}), settings=load(row["settings"], {}),
        seed=row["seed"], status=row["status"], responses=load(row["responses"], {}),
        result=load(row["result"], {}), artifacts_dir=row["artifacts_dir"], attempts=row["attempts"],
        started_at=row["started_at"], finished_at=row["finished_at"], wall_s=row["wall_s"],
        engine_version=row["engine_version"], error=row["error"], owner=row["owner"], pid=row["pid"],
        host=row["host"], heartbeat=row["heartbeat"],
    )
