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
* artifacts go to ``runs/.<name>.tmp-*`` and are renamed into ``runs/<name>`` inside
  the transaction that records the run (``publish=`` of :meth:`Store.finish` and
  :meth:`Store.fail`): a row and its folder change together or not at all;
* Ctrl-C, SIGTERM and SIGHUP are held back (:func:`held_signals`) while a run is
  settled and while a stopping runner hands its claims back (:meth:`Store.release`),
  so that a signal, a second one during the clean-up of the first included, leaves
  no row ``running`` and no temporary folder once the process has exited.

Faults: an existing store must pass ``PRAGMA quick_check`` before anything touches
it, and every SQLite or file-system error (a damaged file, a folder where the file
should be, a read-only folder, a full disk, a lock held too long) is raised as one
:class:`StoreError` sentence that names the file and the fix.

The store's tables and run rows are in :mod:`demcal.campaign.records`, its error
sentences in :mod:`demcal.campaign.faults`, the run folders' temporary names and
moves in :mod:`demcal.campaign.folders`, and :func:`held_signals` in
:mod:`demcal.campaign.signals`; every public name of theirs is importable from here.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import socket
import sqlite3
import time
import uuid
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence

from demcal.campaign.faults import BUSY_TIMEOUT_S, StoreError, _writable, store_error
from demcal.campaign.folders import _Swap, publish_dir, temp_dir, temp_name, write_json_atomic  # noqa: F401
from demcal.campaign.records import _RUN_COLUMNS, _SCHEMA, STATUSES, RunRecord, RunSpec, _key_filter, _record
from demcal.campaign.records import run_key  # noqa: F401
from demcal.campaign.signals import STOP_SIGNALS, held_signals  # noqa: F401
from demcal.errors import DataError

#: Owners of the stores open in this process. A claim made from this process by an
#: owner not in here was left by a store that closed without handing it back (its
#: write failed on a full disk), so it is as stale as a dead process's claim.
_OPEN_OWNERS: set[str] = set()


class Store:
    """The SQLite store of one campaign (``store.sqlite`` in its work folder).

    Parameters
    ----------
    path : path of the SQLite file; its folder holds ``runs/`` with one folder per run.
    readonly : open without creating or changing anything.

    Raises
    ------
    StoreError : the file is damaged (it fails ``PRAGMA quick_check``; nothing is
        written to it), is a folder or another program's database, its folder is
        read-only, the disk is full. Every later SQLite error is a ``StoreError`` too.
    """

    def __init__(self, path: str | Path, readonly: bool = False):
        self.path = Path(path)
        self.root = self.path.parent
        self.runs_dir = self.root / "runs"
        self.owner = uuid.uuid4().hex
        self.pid = os.getpid()
        self.host = socket.gethostname()
        self.db: sqlite3.Connection | None = None
        try:
            self._open(readonly)
        except BaseException as exc:
            self._close_db()
            if isinstance(exc, (sqlite3.Error, OSError)):
                raise store_error(exc, self.path) from exc
            raise
        _OPEN_OWNERS.add(self.owner)

    def _open(self, readonly: bool) -> None:
        if self.path.is_dir():
            raise StoreError(f"{self.path} is a folder, not a store file; move it away or choose another "
                             f"work folder.")
        exists = self.path.exists()
        if readonly and not exists:
            raise DataError(f"no results yet at '{self.path}'; run `demcal run` on the campaign first.")
        if exists:
            if not readonly and not (_writable(self.root) and _writable(self.path)):
                raise store_error(PermissionError(errno.EACCES, "read-only", str(self.path)), self.path)
            self._check(empty_ok=not readonly)  # before anything is written to it
        if readonly:
            uri = self.path.resolve().as_uri() + "?mode=ro"
            if not _writable(self.root) and not self._wal_in_use():
                uri += "&immutable=1"  # no -shm can be made, and no writer can be at work in a read-only folder
            self.db = sqlite3.connect(uri, uri=True, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        else:
            self.runs_dir.mkdir(parents=True, exist_ok=True)
            if not exists:
                self._create()
            self.db = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")  # durable against process crashes in WAL mode
            with self.transaction() as db:
                for statement in _SCHEMA.split(";"):
                    if statement.strip():
                        db.execute(statement)
                if "path" not in {row[1] for row in db.execute("PRAGMA table_info(campaign)")}:
                    db.execute("ALTER TABLE campaign ADD COLUMN path TEXT")  # a store of an older demcal
        self.db.execute(f"PRAGMA busy_timeout={int(BUSY_TIMEOUT_S * 1000)}")
        self.db.row_factory = sqlite3.Row

    def _create(self) -> None:
        """Make a new store whole under another name and link it into place, so that
        a reader never finds a store file without its tables. Two runners starting
        at once: the first link wins and both use that file."""
        tmp = self.path.with_name(f".{self.path.name}.new-{uuid.uuid4().hex[:8]}")
        try:
            db = sqlite3.connect(tmp, isolation_level=None)
            try:
                db.execute("PRAGMA journal_mode=WAL")  # kept in the file's header
                db.executescript(_SCHEMA)
            finally:
                db.close()
            try:
                os.link(tmp, self.path)
            except FileExistsError:
                pass
            except OSError:  # a file system without hard links: created in place below
                pass
        finally:
            for leftover in (tmp, tmp.with_name(tmp.name + "-wal"), tmp.with_name(tmp.name + "-shm")):
                with contextlib.suppress(OSError):
                    leftover.unlink()

    def _wal_in_use(self) -> bool:
        """Whether the write-ahead log holds pages (a runner at work, or one that crashed)."""
        wal = self.path.with_name(self.path.name + "-wal")
        try:
            return wal.stat().st_size > 0
        except OSError:
            return False

    def _check(self, empty_ok: bool) -> None:
        """Refuse a damaged file (``PRAGMA quick_check``) or another program's database.

        The check has a connection of its own, read-only; with no write-ahead log in
        use it opens the file as immutable, so that even SQLite's ``-wal`` and
        ``-shm`` files are not created next to a file that turns out to be damaged.
        """
        uri = self.path.resolve().as_uri() + ("?mode=ro" if self._wal_in_use() else "?mode=ro&immutable=1")
        db = sqlite3.connect(uri, uri=True, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        try:
            rows = db.execute("PRAGMA quick_check").fetchall()  # "file is not a database": raised
            verdict = rows[0][0] if rows else "no answer to the check"
            if verdict != "ok":
                problem = " ".join(str(verdict).split())[:120]
                if len(rows) > 1:
                    problem += f", and {len(rows) - 1} more problems"
                raise store_error(sqlite3.DatabaseError(f"database disk image is malformed: {problem}"), self.path)
            if not db.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchone():  # a store being created
                if empty_ok:
                    return
                raise DataError(f"no results yet at '{self.path}'; run `demcal run` on the campaign first.")
            columns = {row[1] for row in db.execute("PRAGMA table_info(runs)")}
        finally:
            db.close()
        missing = sorted(_RUN_COLUMNS - columns)
        if missing:
            raise StoreError(f"{self.path} is not a demcal store (its 'runs' table lacks "
                             f"{', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}); move it away "
                             f"or choose another work folder.")

    def _close_db(self) -> None:
        if self.db is not None:
            with contextlib.suppress(sqlite3.Error):
                self.db.close()

    def close(self) -> None:
        _OPEN_OWNERS.discard(self.owner)
        self._close_db()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @contextlib.contextmanager
    def guard(self) -> Iterator[None]:
        """Turn an SQLite error into one :class:`StoreError` sentence."""
        try:
            yield
        except sqlite3.Error as exc:
            raise store_error(exc, self.path) from exc

    @contextlib.contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """``BEGIN IMMEDIATE`` ... ``COMMIT``; rolled back on any exception, the failed
        ``COMMIT`` of a full disk included."""
        with self.guard():
            try:  # BEGIN inside: an interrupt just after it still rolls back
                self.db.execute("BEGIN IMMEDIATE")
                yield self.db
                self.db.execute("COMMIT")
            except BaseException:
                if self.db.in_transaction:
                    with contextlib.suppress(sqlite3.Error):
                        self.db.execute("ROLLBACK")
                raise

    # ---------------------------------------------------------------- campaign
    def record_campaign(self, name: str, source: str, version: str, path: str | None = None) -> None:
        """Record the campaign that last wrote here: its name, file text and file
        (``path``, relative to the store's folder)."""
        now = time.time()
        with self.transaction() as db:
            db.execute(
                "INSERT INTO campaign (id, name, source, created_at, updated_at, demcal_version, path) "
                "VALUES (1, ?, ?, ?, ?, ?, ?) ON CONFLICT (id) DO UPDATE SET "
                "name = excluded.name, source = excluded.source, updated_at = excluded.updated_at, "
                "demcal_version = excluded.demcal_version, path = excluded.path",
                (name, source, now, now, version, path),
            )

    def campaign(self) -> dict[str, Any] | None:
        """The recorded campaign (``name``, ``source``, ``path``; ``path`` None in a store
        of an older demcal), or None before any was recorded."""
        with self.guard():
            columns = {row[1] for row in self.db.execute("PRAGMA table_info(campaign)")}
            if not columns:
                return None
            path = "path" if "path" in columns else "NULL"
            row = self.db.execute(f"SELECT name, source, {path} FROM campaign WHERE id = 1").fetchone()
        return None if row is None else {"name": row[0], "source": row[1], "path": row[2]}

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
               engine_version: str, publish: tuple[Path, Path] | None = None) -> bool:
        """Store a finished run in one transaction; False if this runner no longer owns it.

        ``publish=(tmp, final)`` moves the run's artifact folder into place inside that
        transaction: if the row cannot be written (a full disk), the folder is moved back.
        """
        responses = dict(result.get("responses", {}))
        return self._settle(
            "UPDATE runs SET status = 'done', responses = ?, result = ?, artifacts_dir = ?, "
            "finished_at = ?, wall_s = ?, engine_version = ?, error = NULL, heartbeat = NULL "
            "WHERE id = ? AND status = 'running' AND owner = ?",
            (json.dumps(responses), json.dumps(dict(result)), artifacts_dir, time.time(),
             float(result.get("wall_s", 0.0)), engine_version, run_id, self.owner), publish)

    def fail(self, run_id: int, error: str, engine_version: str, wall_s: float | None = None,
             publish: tuple[Path, Path] | None = None, artifacts_dir: str | None = None) -> bool:
        """Record a failed run with its error text; False if no longer owned (``publish``
        as for :meth:`finish`)."""
        return self._settle(
            "UPDATE runs SET status = 'failed', error = ?, finished_at = ?, wall_s = ?, "
            "engine_version = ?, artifacts_dir = COALESCE(?, artifacts_dir), heartbeat = NULL "
            "WHERE id = ? AND status = 'running' AND owner = ?",
            (error, time.time(), wall_s, engine_version, artifacts_dir, run_id, self.owner), publish)

    def _settle(self, sql: str, args: tuple, publish: tuple[Path, Path] | None) -> bool:
        """Write a run's row and move its folder into place, together or not at all.

        Only the wait for the store's lock may be interrupted; from there to the end,
        an undo included, Ctrl-C, SIGTERM and SIGHUP are held back (:func:`held_signals`),
        so a signal cannot leave a row ``done`` without its folder, or the folder moved
        and the row still ``running``.
        """
        swap, committed = None, False
        try:
            with self.guard():
                self.db.execute("BEGIN IMMEDIATE")  # may wait for another runner's write: a signal stops it here
                with held_signals():
                    if self.db.execute(sql, args).rowcount != 1:
                        return False
                    if publish is not None:
                        swap = _Swap(*publish)
                    self.db.execute("COMMIT")
                    committed = True
                    if swap is not None:
                        swap.keep()
        except OSError as exc:  # the folder could not be moved: the row is rolled back below
            raise store_error(exc, exc.filename or publish[1], "the run folder") from exc
        finally:
            if not committed:
                with held_signals():
                    self._roll_back()
                    if swap is not None:
                        swap.undo()
        return True

    def _roll_back(self) -> None:
        """End a transaction an error or an interrupt left open on this connection."""
        if self.db is not None and self.db.in_transaction:
            with contextlib.suppress(sqlite3.Error):
                self.db.execute("ROLLBACK")

    def release(self, run_ids: Iterable[int] | None = None) -> int:
        """Put this runner's claims (all, or ``run_ids``) back to pending, in one transaction.

        Made for clean-up after an interrupt: a transaction the interrupt left open on
        this connection (it never committed) is rolled back first. Call it inside
        :func:`held_signals` so that a second signal cannot stop it half way; a runner
        killed outright (``kill -9``) leaves its claims to :meth:`reclaim_stale`.
        """
        self._roll_back()
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

        A claim is stale when its pid no longer exists on this host (or is this
        process, whose store that made the claim is closed), or when its heartbeat is
        older than ``timeout_s`` (a runner on another host, or a pid reused by an
        unrelated process). Runners call this while they run, not only at start-up.
        """
        now = time.time()
        me = os.getpid()

        def gone(row) -> bool:
            if row["owner"] == self.owner:
                return False
            if row["host"] == self.host and (
                    not _pid_alive(row["pid"]) or (row["pid"] == me and row["owner"] not in _OPEN_OWNERS)):
                return True
            return row["heartbeat"] is None or now - row["heartbeat"] > timeout_s

        with self.guard():
            rows = self.db.execute("SELECT id, pid, host, heartbeat, owner FROM runs WHERE status = 'running'")
            if not any(gone(row) for row in rows.fetchall()):
                return 0  # the usual case: no write, so a full disk or a busy store costs nothing here
        with self.transaction() as db:
            rows = db.execute("SELECT id, pid, host, heartbeat, owner FROM runs WHERE status = 'running'").fetchall()
            stale = [row["id"] for row in rows if gone(row)]
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
        with self.guard():
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
        counts = dict.fromkeys(STATUSES, 0)
        with self.guard():
            rows = self.db.execute(f"SELECT status, COUNT(*) FROM runs WHERE 1{where} GROUP BY status", args)
            counts.update({status: n for status, n in rows})
        return counts

    def running_keys(self) -> set[str]:
        """Keys of the runs some runner holds a claim on."""
        with self.guard():
            return {row[0] for row in self.db.execute("SELECT key FROM runs WHERE status = 'running'")}

    def integrity(self) -> str:
        with self.guard():
            return self.db.execute("PRAGMA integrity_check").fetchone()[0]


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


def finite_responses(responses: Mapping[str, Any]) -> str | None:
    """The name of the first response that is missing a finite value, else None."""
    for name, value in responses.items():
        try:
            if not math.isfinite(float(value)):
                return name
        except (TypeError, ValueError):
            return name
    return None
