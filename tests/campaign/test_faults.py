"""Faults (issue 20): a full disk, a damaged, junk or foreign store, a read-only folder,
a runner killed beside another, a worker killed under a runner.

Every case ends in one sentence (``demcal: error: ...``, exit status 2) or in a
completed campaign, and then :func:`settled` holds: the store passes its integrity
check; no row is ``running`` without a live owner (a row a full disk kept from being
handed back belongs to a runner that is gone and is taken back at once by the next
one); every finished run has its whole folder and no other run has one; no
temporary, 0-byte or partial file is left in ``runs/``. The markers of the test
double count executions: a run whose result reached the store never runs again, and
the only runs that run again are those in flight when the fault struck, whose
results could not be written.

All on the ``test-heap`` double (``campaign_testbench.py``), never a real DEM run.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import textwrap
import threading
import time
from collections import Counter
from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign
from demcal.campaign.runner import design_results, open_store, plan_design, run_campaign
from demcal.campaign.store import Store, StoreError
from demcal.cli import main

from conftest import InlineExecutor

FAIL_ABOVE = {'"test.sleep_s" = 0.02': '"test.sleep_s" = 0.02\n"test.fail_above_friction" = 0.45'}


# ---------------------------------------------------------------- helpers
@pytest.fixture
def inline(monkeypatch):
    """`demcal run` executes in this process (so that monkeypatched writers reach the runs)."""
    monkeypatch.setattr("demcal.campaign.executors.make_executor", lambda *a, **k: InlineExecutor(2))


def one_sentence(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("demcal: error: ") and err.endswith("."), err
    return err


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def settled(campaign) -> dict[str, set[int]]:
    """Check the invariants every case ends with; return the seeds of each status."""
    with Store(campaign.store_path, readonly=True) as store:
        assert store.integrity() == "ok"
        records = store.records()
    if any(r.status == "running" for r in records):  # only a runner that is gone may hold a claim
        with Store(campaign.store_path) as other:
            assert other.reclaim_stale(timeout_s=3600) == sum(r.status == "running" for r in records)
    runs = campaign.workdir / "runs"
    entries = {p.name for p in runs.iterdir()}
    assert not [name for name in entries if name.startswith(".")], entries  # no temporary or old folders
    empty = [str(p) for p in runs.rglob("*") if p.is_file() and p.stat().st_size == 0]
    assert not empty, empty
    dirnames = {s.key: s.dirname for s in plan_design(campaign).specs}
    for r in records:
        folder = runs / dirnames[r.key]
        if r.status == "done":
            assert r.artifacts_dir == folder.name
            assert {p.name for p in folder.iterdir()} == {"run.json", "result.json", "heap.txt"}
            assert json.loads((folder / "result.json").read_text())["responses"] == r.responses
        elif r.status == "failed" and r.artifacts_dir:
            assert r.artifacts_dir == folder.name
            assert {p.name for p in folder.iterdir()} == {"run.json", "error.txt"}
        else:  # a row that is not finished, or a run whose worker died, has no folder
            assert not folder.exists(), (r.label, r.status)
    return {status: {r.seed for r in records if r.status == status}
            for status in ("pending", "running", "done", "failed")}


def ran_again(counts: Counter) -> set[int]:
    assert max(counts.values()) <= 2, counts
    return {seed for seed, n in counts.items() if n > 1}


# ---------------------------------------------------------------- a full disk
def _full_disk_writer(fail_at: int):
    """``write_json_atomic`` on a disk that fills at its ``fail_at``-th call: it leaves the
    0-byte temporary file a real full disk leaves, then raises ENOSPC."""
    from demcal.campaign import store

    real = store.write_json_atomic
    calls = {"n": 0}

    def write(path, data):
        calls["n"] += 1
        if calls["n"] == fail_at:
            Path(path).with_name(f".{Path(path).name}.tmp-0badc0de").touch()
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real(path, data)

    return write


@pytest.mark.parametrize("fail_at, what", [(9, "run.json"), (10, "result.json")])
def test_full_disk_while_writing_a_run_is_one_sentence(campaign_file, markers, inline, monkeypatch, capsys,
                                                       fail_at, what):
    """The 5th run's ``run.json`` (before it simulates) or ``result.json`` (after) hits the full disk."""
    from demcal.campaign import store

    campaign = load_campaign(campaign_file())
    real = store.write_json_atomic
    monkeypatch.setattr(store, "write_json_atomic", _full_disk_writer(fail_at))
    assert main(["run", str(campaign.path), "--quiet"]) == 2
    err = one_sentence(capsys)
    runs = campaign.workdir / "runs"
    assert f"no space left on the disk that holds the run folders {runs}; free some space" in err, err
    seeds = settled(campaign)
    # The 5th run went back to pending; the 6th, in flight beside it, was recorded.
    assert seeds["done"] == {campaign.seed + i for i in (0, 1, 2, 3, 5)} and not seeds["running"]
    monkeypatch.setattr(store, "write_json_atomic", real)  # space freed
    assert main(["run", str(campaign.path), "--quiet"]) == 0
    final = settled(campaign)
    assert len(final["done"]) == 29
    # The 5th run simulated before its result.json failed runs again; nothing else does.
    assert ran_again(markers()) == (set() if what == "run.json" else {campaign.seed + 4})


class _FaultyConnection:
    """An SQLite connection whose statements fail like a full disk (or a read-only file)
    once ``fault`` is armed: those containing one of ``fault.statements``, or the COMMIT
    of a transaction that ran one (``fault.at_commit``)."""

    def __init__(self, real, fault):
        object.__setattr__(self, "_real", real)
        object.__setattr__(self, "_fault", fault)
        object.__setattr__(self, "_touched", False)

    def execute(self, sql, *args):
        fault = self._fault
        if fault.armed:
            hit = any(s in sql for s in fault.statements)
            if fault.at_commit:
                if hit:
                    object.__setattr__(self, "_touched", True)
                elif sql == "COMMIT" and self._touched:
                    object.__setattr__(self, "_touched", False)
                    fault.trip()
            elif hit:
                fault.trip()
        return self._real.execute(sql, *args)

    def executemany(self, sql, rows):
        return self._real.executemany(sql, rows)

    def __getattr__(self, name):
        return getattr(self._real, name)

    def __setattr__(self, name, value):
        setattr(self._real, name, value)


class _Fault:
    def __init__(self, statements, message="database or disk is full", at_commit=False, after=0):
        self.statements, self.message, self.at_commit, self.after = statements, message, at_commit, after
        self.armed, self.seen, self.raised = True, 0, 0

    def trip(self):
        self.seen += 1
        if self.seen > self.after:
            self.raised += 1
            raise sqlite3.OperationalError(self.message)


@pytest.fixture
def faulty_sqlite(monkeypatch):
    """Arm a :class:`_Fault` on every store connection opened from now on."""
    real_connect = sqlite3.connect
    faults = []

    def arm(fault: _Fault) -> _Fault:
        faults.append(fault)
        monkeypatch.setattr(sqlite3, "connect", lambda *a, **k: _FaultyConnection(real_connect(*a, **k), fault))
        return fault

    yield arm
    for fault in faults:
        fault.armed = False


SET_DONE, SET_FAILED, SET_PENDING = "SET status = 'done'", "SET status = 'failed'", "SET status = 'pending'"


@pytest.mark.parametrize("case", ["fail and release", "commit of a finished run", "read-only file"])
def test_store_write_faults_are_one_sentence_and_resume(campaign_file, markers, inline, faulty_sqlite, capsys,
                                                        case):
    """Issue 20: "database or disk is full" in store.fail and again in store.release left a
    published folder holding only error.txt while its row stayed 'running'."""
    campaign = load_campaign(campaign_file(replace=FAIL_ABOVE))  # the six points at B = +1 fail
    if case == "fail and release":
        fault = faulty_sqlite(_Fault((SET_FAILED, SET_PENDING)))
    elif case == "commit of a finished run":  # after the run's folder was moved into place
        fault = faulty_sqlite(_Fault((SET_DONE,), at_commit=True, after=3))
    else:
        fault = faulty_sqlite(_Fault((SET_DONE,), message="attempt to write a readonly database", after=3))
    assert main(["run", str(campaign.path), "--quiet"]) == 2
    fault.armed = False
    assert fault.raised >= 1
    err = one_sentence(capsys)
    store = campaign.store_path
    if case == "read-only file":
        assert f"cannot write the store {store}:" in err and "read-only" in err, err
    else:
        assert f"no space left on the disk that holds the store {store}; free some space" in err, err
    before = settled(campaign)
    if case == "fail and release":
        assert not before["failed"]  # the failure was not recorded: neither its row nor its folder
    assert main(["run", str(campaign.path), "--quiet"]) == 1  # completed, with the six failures
    capsys.readouterr()
    after = settled(campaign)
    assert len(after["done"]) == 23 and len(after["failed"]) == 6
    again = ran_again(markers())
    assert not again & before["done"] and len(again) <= 2  # only the two runs in flight ran again


# ---------------------------------------------------------------- damaged stores
def _write_junk(path: Path) -> None:
    path.write_bytes(bytes(range(256)) * 200)


def _write_foreign(path: Path) -> None:
    db = sqlite3.connect(path)
    db.execute("CREATE TABLE runs (x INTEGER)")
    db.commit()
    db.close()


@pytest.mark.parametrize("damage, words", [
    ("truncated", "is damaged (database disk image is malformed"),
    ("junk", "is damaged (file is not a database)"),
    ("folder", "is a folder, not a store file"),
    ("foreign", "is not a demcal store"),
], ids=["truncated", "junk", "folder", "foreign"])
def test_a_damaged_store_is_refused_by_name_and_left_as_it_is(campaign_file, inline, capsys, damage, words):
    campaign = load_campaign(campaign_file())
    store = campaign.store_path
    if damage == "truncated":  # `truncate -s` of a finished campaign's store
        assert run_campaign(campaign, progress=False, executor=InlineExecutor()).done == 29
        os.truncate(store, store.stat().st_size // 2)
    else:
        store.parent.mkdir(parents=True)
        {"junk": _write_junk, "folder": Path.mkdir, "foreign": _write_foreign}[damage](store)
    before = digest(store) if store.is_file() else None
    for argv in (["run", str(campaign.path), "--quiet"], ["run", str(campaign.path), "--quiet", "--retry-failed"]):
        assert main(argv) == 2
        err = one_sentence(capsys)
        assert f"{store} {words}" in err, err
        assert "move it away" in err and ("restore it from a backup" in err or damage in ("folder", "foreign"))
    with pytest.raises(StoreError, match=words.replace("(", r"\(").replace(")", r"\)")):
        design_results(campaign)  # what calibrate and report read
    if before is None:
        assert store.is_dir() and not list(store.iterdir())
    else:
        assert digest(store) == before  # never written to
    assert not [p.name for p in store.parent.iterdir() if p.name.endswith(("-wal", "-shm", "-journal"))]


# ---------------------------------------------------------------- a read-only folder
def _half_done(campaign) -> None:
    """A store with its runs planned and none run yet, closed cleanly."""
    store = open_store(campaign)
    store.add(plan_design(campaign).specs)
    store.close()


def _read_only_bind_works(folder: Path) -> bool:
    probe = subprocess.run(
        ["unshare", "--mount", "--propagation", "private", "sh", "-c",
         f'mount --bind "{folder}" "{folder}" && mount -o remount,bind,ro "{folder}" "{folder}" && '
         f'! touch "{folder}/probe" 2>/dev/null'],
        capture_output=True)
    return probe.returncode == 0 and not (folder / "probe").exists()


def test_a_read_only_folder_holding_a_store_is_one_sentence(campaign_file, capsys, monkeypatch):
    """As a user, the folder is made read-only with chmod. As root, chmod does not stop
    writes: the folder is then bind-mounted read-only in a private mount namespace
    (``unshare --mount``) around a `demcal run` subprocess; where that is not allowed
    either, the store's permission check is told the folder is read-only (what
    ``os.access`` answers for a user), so the sentence and the untouched store are still
    checked, though not the kernel's refusal."""
    campaign = load_campaign(campaign_file())
    _half_done(campaign)
    folder = campaign.store_path.parent
    before = digest(campaign.store_path)
    words = f"cannot write the store {campaign.store_path}: the folder {folder} is read-only; make it writable"
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            assert main(["run", str(campaign.path), "--quiet"]) == 2
            assert words in one_sentence(capsys)
        finally:
            folder.chmod(0o755)
    else:
        if not shutil.which("unshare") or not _read_only_bind_works(folder):
            from demcal.campaign import store as store_module

            real_access = os.access

            def access(path, mode, *args, **kwargs):
                inside = os.path.abspath(path).startswith(str(folder.resolve()))
                return False if inside and mode & os.W_OK else real_access(path, mode, *args, **kwargs)

            monkeypatch.setattr(store_module.os, "access", access)
            assert main(["run", str(campaign.path), "--quiet"]) == 2
            assert words in one_sentence(capsys)
            assert digest(campaign.store_path) == before
            return
        script = (f'mount --bind "{folder}" "{folder}" && mount -o remount,bind,ro "{folder}" "{folder}" && '
                  f'exec "{sys.executable}" -m demcal run "{campaign.path}" --quiet')
        done = subprocess.run(["unshare", "--mount", "--propagation", "private", "sh", "-c", script],
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 2, done.stderr
        err = done.stderr.strip()
        assert "Traceback" not in err and len(err.splitlines()) == 1 and words in err, err
    assert digest(campaign.store_path) == before
    assert settled(campaign)["pending"] == {s.seed for s in plan_design(campaign).specs}


# ---------------------------------------------------------------- killed runners and workers
def _demcal(*args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "demcal", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def test_a_runner_notices_another_runner_die_and_finishes_its_runs(campaign_file, markers):
    """Two `demcal run --workers 1`, one SIGKILLed: the survivor takes back the dead
    runner's claim while it runs and finishes the campaign (it said "1 still running in
    another runner" and exited 0)."""
    campaign = load_campaign(campaign_file(sleep=0.15))
    _half_done(campaign)
    survivor, victim = _demcal("run", campaign.path, "--workers", "1", "--quiet"), None
    try:
        victim = _demcal("run", campaign.path, "--workers", "1", "--quiet")
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            time.sleep(0.1)
            with Store(campaign.store_path, readonly=True) as store:
                records = store.records()
            if {r.pid for r in records if r.status == "running"} == {survivor.pid, victim.pid} and \
                    sum(r.status == "done" for r in records) >= 3:
                break
        assert victim.poll() is None and survivor.poll() is None
        os.kill(victim.pid, signal.SIGKILL)
        victim.wait()
        with Store(campaign.store_path, readonly=True) as store:
            done_at_kill = {r.seed for r in store.records() if r.status == "done"}
        out, err = survivor.communicate(timeout=120)
    finally:
        for process in (survivor, victim):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    assert survivor.returncode == 0, err
    assert "29 of 29 runs done" in out and "another runner" not in out, out
    final = settled(campaign)
    assert len(final["done"]) == 29
    again = ran_again(markers())
    assert len(again) <= 1 and not again & done_at_kill  # only the dead runner's run in flight


def test_a_claim_left_by_a_runner_that_is_gone_is_taken_back_while_running(campaign_file, monkeypatch):
    """The reclaim runs at every heartbeat, not only at start-up: a claim whose runner
    goes away mid-campaign is run next, not left to the end (or to the next start)."""
    monkeypatch.setattr("demcal.campaign.runner.HEARTBEAT_S", 0.01)
    campaign = load_campaign(campaign_file())
    first = plan_design(campaign).specs[0]
    _half_done(campaign)
    other = Store(campaign.store_path)  # another runner, in this process
    assert other.claim([first.key]).key == first.key

    class Recording(InlineExecutor):
        def __init__(self):
            super().__init__()
            self.labels: list[str] = []

        def submit(self, task):
            self.labels.append(task["label"])
            if len(self.labels) == 4:
                other.close()  # that runner is gone, its claim left behind
            return super().submit(task)

    executor = Recording()
    summary = run_campaign(campaign, progress=False, executor=executor)
    assert (summary.done, summary.elsewhere) == (29, 0)
    assert first.label in executor.labels[4:8], executor.labels  # taken back at the next beat
    assert len(settled(campaign)["done"]) == 29


def test_a_killed_worker_costs_only_its_own_run_which_is_retried(campaign_file, markers):
    """One local worker SIGKILLed mid-run: its run is retried on a fresh worker; the run
    in flight on the other worker is not touched (the pool broke as a whole, and both
    runs were marked failed)."""
    from demcal.campaign.executors import LocalExecutor

    campaign = load_campaign(campaign_file(sleep=0.3))
    executor = LocalExecutor(2, plugins=campaign.plugins)
    killed = {}
    folder = Path(os.environ["DEMCAL_TEST_MARKERS"])

    def started(seed: int) -> float:
        """Seconds since the run with ``seed`` began (inf if it has not)."""
        times = [p.stat().st_mtime for p in folder.glob(f"{seed}-*")]
        return time.time() - max(times) if times else float("inf")

    def kill_one() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            busy = [(w, w.task) for w in list(executor._pool) if w.task is not None]
            if len(busy) == 2 and sum(markers().values()) >= 4:
                worker, task = busy[0]
                if 0.05 < started(task.task["seed"]) < 0.15:  # well inside its 0.3 s run
                    killed.update(seed=task.task["seed"], other=busy[1][1].task["seed"])
                    os.kill(worker.process.pid, signal.SIGKILL)
            time.sleep(0.01)

    thread = threading.Thread(target=kill_one, daemon=True)
    thread.start()
    try:
        summary = run_campaign(campaign, progress=False, executor=executor)
    finally:
        executor.close()
        thread.join(5)
    assert killed, "no worker was killed"
    assert (summary.done, summary.failed) == (29, 0), summary.failures
    assert len(settled(campaign)["done"]) == 29
    assert ran_again(markers()) == {killed["seed"]}  # the other run in flight ran once, undisturbed


DYING_PLUGIN = '''
"""The test double, except that the run with seed $DEMCAL_TEST_DIE_SEED kills its worker."""
import os
import signal

from campaign_testbench import HeapDouble
from demcal.bench.registry import register


class DyingHeap(HeapDouble):
    name = "test-heap-dying"

    def run(self, settings=None, seed=0, **options):
        result = super().run(settings, seed, **options)
        if seed == int(os.environ.get("DEMCAL_TEST_DIE_SEED", "-1")):
            os.kill(os.getpid(), signal.SIGKILL)
        return result


register(DyingHeap())
'''


def test_a_run_that_kills_its_worker_twice_fails_with_its_cause(campaign_file, markers, tmp_path, monkeypatch):
    (tmp_path / "dying_testbench.py").write_text(textwrap.dedent(DYING_PLUGIN))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(tmp_path), os.environ["PYTHONPATH"]]))
    path = campaign_file(replace={'test = "test-heap"': 'test = "test-heap-dying"',
                                  'plugins = ["campaign_testbench"]': 'plugins = ["campaign_testbench", "dying_testbench"]'})
    campaign = load_campaign(path, import_plugins=True)  # it runs simulations: it imports the plugins
    monkeypatch.setenv("DEMCAL_TEST_DIE_SEED", str(campaign.seed + 9))
    summary = run_campaign(campaign, workers=2, progress=False)
    assert (summary.done, summary.failed) == (28, 1), summary.failures
    ((label, error),) = summary.failures
    assert label == "design 10"
    assert "the worker process running it died twice (killed by SIGKILL" in error and "--retry-failed" in error
    seeds = settled(campaign)
    assert seeds["failed"] == {campaign.seed + 9}
    assert ran_again(markers()) == {campaign.seed + 9}  # its one retry; every other run once
