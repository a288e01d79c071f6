"""The campaign's result store: one SQLite file in WAL mode, one folder per run.

A run is identified by its *key*, a hash of what determines its result (virtual
test, profile, setting overrides, seed), so the store is content-addressed: a
planned run whose key is already ``done`` is skipped, and editing a campaign only
adds rows -- no stored result is ever overwritten or deleted.

Concurrency and crashes:

* a runner **claims** a pending run in one ``BEGIN IMMEDIATE`` transaction
  (``UPDATE ... WHERE status = 'pending'``), so two runners on one store never run
  the same point twice;
* a claim records the runner's owner token, pid, host and a heartbeat; a
  ``running`` row whose pid is gone on this host, or whose heartbeat is older than
  the timeout, is put back to ``pending`` by :meth:`Store.reclaim_stale`;
* a result (status, responses, timings, artifacts) is written in one
  transaction, so a ``kill -9`` leaves either the old row or the new one;
* artifacts go to ``runs/<name>.tmp-*`` and are renamed into ``runs/<name>`` when
  complete (:func:`publish_dir`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import shutil
import socket
import sqlite3
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence

from demcal.errors import DataError

STATUSES = ("pending", "running", "done", "failed")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS campaign (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    name TEXT NOT NULL,
    source TEXT NOT NULL,
    created_at REAL NOT NULL,
    updated_at REAL NOT NULL,
    demcal_version TEXT NOT NULL
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


class Store:
    """The SQLite store of one campaign (``store.sqlite`` in its work folder).

    Parameters
    ----------
    path : path of the SQLite file; its folder holds ``runs/`` with one folder per run.
    readonly : open without creating or changing anything.
    """

    def __init__(self, path: str | Path, readonly: bool = False):
        self.path = Path(path)
        self.root = self.path.parent
        self.runs_dir = self.root / "runs"
        self.owner = uuid.uuid4().hex
        self.pid = os.getpid()
        self.host = socket.gethostname()
        if readonly:
            if not self.path.is_file():
                raise DataError(f"no results yet at '{self.path}'; run `demcal run` on the campaign first.")
            self.db = sqlite3.connect(f"file:{self.path}?mode=ro", uri=True, timeout=60, isolation_level=None)
        else:
            self.runs_dir.mkdir(parents=True, exist_ok=True)
            self.db = sqlite3.connect(self.path, timeout=60, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")  # durable against process crashes in WAL mode
            with self.transaction() as db:
                for statement in _SCHEMA.split(";"):
                    if statement.strip():
                        db.execute(statement)
        self.db.execute("PRAGMA busy_timeout=60000")
        self.db.row_factory = sqlite3.Row

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @contextlib.contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """``BEGIN IMMEDIATE`` ... ``COMMIT`` (rolled back on any exception)."""
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield self.db
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    # ---------------------------------------------------------------- campaign
    def record_campaign(self, name: str, source: str, version: str) -> None:
        now = time.time()
        with self.transaction() as db:
            db.execute(
                "INSERT INTO campaign (id, name, source, created_at, updated_at, demcal_version) "
                "VALUES (1, ?, ?, ?, ?, ?) ON CONFLICT (id) DO UPDATE SET "
                "name = excluded.name, source = excluded.source, updated_at = excluded.updated_at, "
                "demcal_version = excluded.demcal_version",
                (name, source, now, now, version),
            )

    # ---------------------------------------------------------------- runs
    def add(self, specs: Iterable[RunSpec]) -> int:
        """Insert planned runs not yet in the store; returns how many were new."""
        now = time.time()
        rows = [
            (s.key, s.kind, s.label, s.test, s.profile, json.dumps(dict(s.parameters)),
             json.dumps(dict(s.settings)), int(s.seed), now)
            for s in specs
        ]
        with self.transaction() as db:
            before = db.total_changes
            db.executemany(
                "INSERT OR IGNORE INTO runs (key, kind, label, test, profile, parameters, settings, seed, created_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                rows,
            )
            return db.total_changes - before

    def claim(self, keys: Sequence[str] | None = None) -> RunRecord | None:
        """Atomically take one pending run (of ``keys``, if given) for this runner."""
        now = time.time()
        where, args = _key_filter(keys)
        with self.transaction() as db:
            row = db.execute(
                f"UPDATE runs SET status = 'running', owner = ?, pid = ?, host = ?, heartbeat = ?, "
                f"started_at = ?, attempts = attempts + 1, error = NULL "
                f"WHERE id = (SELECT id FROM runs WHERE status = 'pending'{where} ORDER BY id LIMIT 1) "
                f"AND status = 'pending' RETURNING *",
                (self.owner, self.pid, self.host, now, now, *args),
            ).fetchone()
        return _record(row) if row else None

    def heartbeat(self) -> None:
        """Tell other runners this runner's claims are alive."""
        with self.transaction() as db:
            db.execute("UPDATE runs SET heartbeat = ? WHERE status = 'running' AND owner = ?",
                       (time.time(), self.owner))

    def finish(self, run_id: int, result: Mapping[str, Any], artifacts_dir: str | None,
               engine_version: str) -> bool:
        """Store a finished run in one transaction; False if this runner no longer owns it."""
        responses = dict(result.get("responses", {}))
        with self.transaction() as db:
            cursor = db.execute(
                "UPDATE runs SET status = 'done', responses = ?, result = ?, artifacts_dir = ?, "
                "finished_at = ?, wall_s = ?, engine_version = ?, error = NULL, heartbeat = NULL "
                "WHERE id = ? AND status = 'running' AND owner = ?",
                (json.dumps(responses), json.dumps(dict(result)), artifacts_dir, time.time(),
                 float(result.get("wall_s", 0.0)), engine_version, run_id, self.owner),
            )
            return cursor.rowcount == 1

    def fail(self, run_id: int, error: str, engine_version: str, wall_s: float | None = None) -> bool:
        """Record a failed run with its error text; False if no longer owned."""
        with self.transaction() as db:
            cursor = db.execute(
                "UPDATE runs SET status = 'failed', error = ?, finished_at = ?, wall_s = ?, "
                "engine_version = ?, heartbeat = NULL WHERE id = ? AND status = 'running' AND owner = ?",
                (error, time.time(), wall_s, engine_version, run_id, self.owner),
            )
            return cursor.rowcount == 1

    def release(self, run_ids: Iterable[int] | None = None) -> int:
        """Put this runner's claims (all, or ``run_ids``) back to pending."""
        with self.transaction() as db:
            if run_ids is None:
                cursor = db.execute(
                    "UPDATE runs SET status = 'pending', owner = NULL, pid = NULL, host = NULL, heartbeat = NULL "
                    "WHERE status = 'running' AND owner = ?", (self.owner,))
                return cursor.rowcount
            count = 0
            for run_id in run_ids:
                count += db.execute(
                    "UPDATE runs SET status = 'pending', owner = NULL, pid = NULL, host = NULL, heartbeat = NULL "
                    "WHERE id = ? AND status = 'running' AND owner = ?", (run_id, self.owner)).rowcount
            return count

    def reclaim_stale(self, timeout_s: float = 120.0) -> int:
        """Put back to pending the runs claimed by runners that are gone.

        A claim is stale when its pid no longer exists on this host, or when its
        heartbeat is older than ``timeout_s`` (a runner on another host, or a pid
        reused by an unrelated process).
        """
        now = time.time()
        with self.transaction() as db:
            rows = db.execute("SELECT id, pid, host, heartbeat, owner FROM runs WHERE status = 'running'").fetchall()
            stale = [
                row["id"] for row in rows
                if row["owner"] != self.owner and (
                    (row["host"] == self.host and not _pid_alive(row["pid"]))
                    or row["heartbeat"] is None or now - row["heartbeat"] > timeout_s
                )
            ]
            for run_id in stale:
                db.execute(
                    "UPDATE runs SET status = 'pending', owner = NULL, pid = NULL, host = NULL, heartbeat = NULL "
                    "WHERE id = ? AND status = 'running'", (run_id,))
        return len(stale)

    def retry_failed(self, keys: Sequence[str] | None = None) -> int:
        """Put failed runs (of ``keys``, if given) back to pending."""
        where, args = _key_filter(keys)
        with self.transaction() as db:
            return db.execute(f"UPDATE runs SET status = 'pending' WHERE status = 'failed'{where}", args).rowcount

    def records(self, keys: Sequence[str] | None = None) -> list[RunRecord]:
        """Rows (of ``keys``, in that order, if given; else all by id)."""
        if keys is None:
            return [_record(r) for r in self.db.execute("SELECT * FROM runs ORDER BY id")]
        by_key = {}
        keys = list(keys)
        for start in range(0, len(keys), 500):
            chunk = keys[start:start + 500]
            marks = ",".join("?" * len(chunk))
            for row in self.db.execute(f"SELECT * FROM runs WHERE key IN ({marks})", chunk):
                by_key[row["key"]] = _record(row)
        return [by_key[k] for k in keys if k in by_key]

    def counts(self, keys: Sequence[str] | None = None) -> dict[str, int]:
        """Number of runs per status (of ``keys``, if given)."""
        where, args = _key_filter(keys)
        rows = self.db.execute(f"SELECT status, COUNT(*) FROM runs WHERE 1{where} GROUP BY status", args)
        counts = dict.fromkeys(STATUSES, 0)
        counts.update({status: n for status, n in rows})
        return counts

    def integrity(self) -> str:
        return self.db.execute("PRAGMA integrity_check").fetchone()[0]


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


def _pid_alive(pid: int | None) -> bool:
    if not pid:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    # A zombie (killed, not yet reaped by its parent) is gone for our purposes.
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return True


def temp_dir(runs_dir: Path, name: str) -> Path:
    """A fresh temporary folder for a run's artifacts, next to its final place."""
    path = runs_dir / f".{name}.tmp-{uuid.uuid4().hex[:8]}"
    path.mkdir(parents=True)
    return path


def publish_dir(tmp: Path, final: Path) -> None:
    """Move a completed artifact folder into place (replacing an older one)."""
    if final.exists():
        old = final.with_name(f".{final.name}.old-{uuid.uuid4().hex[:8]}")
        os.replace(final, old)
        os.replace(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, final)


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON to ``path`` through a temporary file and a rename."""
    tmp = path.with_name(f".{path.name}.tmp-{uuid.uuid4().hex[:8]}")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True, default=_json_default))
    os.replace(tmp, path)


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def finite_responses(responses: Mapping[str, Any]) -> str | None:
    """The name of the first response that is missing a finite value, else None."""
    for name, value in responses.items():
        try:
            if not math.isfinite(float(value)):
                return name
        except (TypeError, ValueError):
            return name
    return None
