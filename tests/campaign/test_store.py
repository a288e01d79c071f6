"""The SQLite store: atomic claims, stale claims reclaimed, results in one transaction."""

from __future__ import annotations

import multiprocessing
import subprocess
import sys
import time

import pytest

from demcal.campaign.store import RunSpec, Store, publish_dir, run_key, temp_dir


def specs(n: int = 20) -> list[RunSpec]:
    return [RunSpec("design", f"design {i + 1}", "test-heap", "tiny", {"particle.static_friction": 0.3 + i / 100},
                    {"particle.static_friction": 0.3 + i / 100}, i) for i in range(n)]


def test_key_ignores_float_noise_and_order():
    a = run_key("t", "quick", {"x": 0.1 + 0.2, "y": 1}, 3)
    b = run_key("t", "quick", {"y": 1, "x": 0.3}, 3)
    assert a == b
    assert run_key("t", "quick", {"x": 0.3}, 4) != run_key("t", "quick", {"x": 0.3}, 3)
    assert run_key("t", "paper", {"x": 0.3}, 3) != run_key("t", "quick", {"x": 0.3}, 3)


def test_add_is_idempotent_and_claims_in_order(tmp_path):
    with Store(tmp_path / "store.sqlite") as store:
        assert store.add(specs(5)) == 5
        assert store.add(specs(5)) == 0
        assert store.db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        first = store.claim()
        assert first.label == "design 1" and first.status == "running" and first.attempts == 1
        assert first.owner == store.owner and first.pid == store.pid
        keys = [s.key for s in specs(5)]
        assert store.claim(keys[3:4]).label == "design 4"
        assert store.counts(keys) == {"pending": 3, "running": 2, "done": 0, "failed": 0}
        assert store.finish(first.id, {"responses": {"angle": 31.0}, "wall_s": 0.5}, "design-1", "v")
        assert store.records(keys[:1])[0].responses == {"angle": 31.0}
        assert not store.finish(first.id, {"responses": {}}, None, "v")  # not running any more


def test_another_owner_cannot_write_my_claim(tmp_path):
    with Store(tmp_path / "store.sqlite") as mine, Store(tmp_path / "store.sqlite") as theirs:
        mine.add(specs(2))
        record = mine.claim()
        assert not theirs.finish(record.id, {"responses": {"a": 1.0}}, None, "v")
        assert not theirs.fail(record.id, "boom", "v")
        assert mine.fail(record.id, "boom", "v")
        assert mine.records()[0].error == "boom" and mine.records()[0].status == "failed"
        assert theirs.retry_failed() == 1
        assert mine.counts()["pending"] == 2


def _claim_all(path, queue, barrier):
    store = Store(path)
    got = []
    barrier.wait(timeout=60)  # all workers start claiming at once, not one after another
    while (record := store.claim()) is not None:
        got.append(record.id)
        time.sleep(0.001)  # a little work per run, so that the claims interleave
        store.finish(record.id, {"responses": {"a": 1.0}}, None, "v")
    store.close()
    queue.put(got)


def test_concurrent_claims_never_overlap(tmp_path):
    path = tmp_path / "store.sqlite"
    with Store(path) as store:
        store.add(specs(200))
    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    workers = 4
    barrier = ctx.Barrier(workers)
    procs = [ctx.Process(target=_claim_all, args=(path, queue, barrier)) for _ in range(workers)]
    for p in procs:
        p.start()
    claimed = [queue.get(timeout=120) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    ids = [i for got in claimed for i in got]
    assert len(ids) == len(set(ids)), "a run was claimed twice"
    assert sorted(ids) == list(range(1, 201))  # each run claimed exactly once
    assert sum(1 for got in claimed if got) >= 3, [len(got) for got in claimed]  # they did compete
    with Store(path) as store:
        assert store.counts() == {"pending": 0, "running": 0, "done": 200, "failed": 0}
        assert store.integrity() == "ok"


def test_stale_claims_are_reclaimed(tmp_path):
    path = tmp_path / "store.sqlite"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    with Store(path) as store, Store(path) as other:
        store.add(specs(3))
        gone, old, alive = store.claim(), store.claim(), store.claim()
        store.db.execute("UPDATE runs SET pid = ? WHERE id = ?", (dead.pid, gone.id))
        store.db.execute("UPDATE runs SET pid = 1, heartbeat = ? WHERE id = ?", (time.time() - 600, old.id))
        store.db.execute("UPDATE runs SET pid = 1 WHERE id = ?", (alive.id,))  # pid 1 lives
        assert other.reclaim_stale(timeout_s=120) == 2
        status = {r.id: r.status for r in other.records()}
        assert status == {gone.id: "pending", old.id: "pending", alive.id: "running"}
        assert store.reclaim_stale() == 0  # never one's own claims


def test_release_hands_claims_back(tmp_path):
    with Store(tmp_path / "store.sqlite") as store:
        store.add(specs(3))
        a, b = store.claim(), store.claim()
        assert store.release([a.id]) == 1
        assert store.release() == 1
        assert store.counts()["pending"] == 3


def test_readonly_store_needs_results(tmp_path):
    from demcal.errors import DataError

    with pytest.raises(DataError, match="no results yet"):
        Store(tmp_path / "nothing.sqlite", readonly=True)


def test_artifact_folder_appears_whole(tmp_path):
    tmp = temp_dir(tmp_path, "run-1")
    (tmp / "heap.png").write_bytes(b"new")
    final = tmp_path / "run-1"
    final.mkdir()
    (final / "heap.png").write_bytes(b"old")
    publish_dir(tmp, final)
    assert (final / "heap.png").read_bytes() == b"new"
    assert [p.name for p in tmp_path.iterdir()] == ["run-1"]
