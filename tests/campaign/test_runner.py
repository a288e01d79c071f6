"""The runner: resumable, failures recorded, kill -9 safe, local pool == Dask."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign
from demcal.campaign.runner import design_results, plan_design, run_campaign
from demcal.campaign.store import Store

from conftest import local_and_dask_results


def test_plan_is_the_papers_design(campaign_file):
    campaign = load_campaign(campaign_file())
    plan = plan_design(campaign)
    assert len(plan.specs) == 29  # Box-Behnken, 4 factors, 5 centre points (paper Table 4)
    assert len({s.seed for s in plan.specs}) == 29  # centre points differ by seed
    assert len({s.key for s in plan.specs}) == 29
    first = plan.specs[0]
    assert first.parameters == {"particle.restitution": 0.5, "particle.static_friction": 0.3,
                                "particle.rolling_friction": 0.2, "particle.damping_factor": 0.1}
    assert first.settings["test.sleep_s"] == 0.02


def test_run_resumes_and_skips_done_runs(campaign_file, markers):
    campaign = load_campaign(campaign_file())
    summary = run_campaign(campaign, workers=2, progress=False)
    assert (summary.total, summary.done, summary.ran, summary.failed) == (29, 29, 29, 0)
    assert sum(markers().values()) == 29
    again = run_campaign(campaign, workers=2, progress=False)
    assert (again.ran, again.skipped, again.done) == (0, 29, 29)
    assert sum(markers().values()) == 29
    table = design_results(campaign)
    assert list(table["run"]) == list(range(1, 30))
    assert (table["status"] == "done").all() and table["repose_angle_deg"].notna().all()
    folder = campaign.workdir / "runs" / table["artifacts_dir"][0]
    assert {p.name for p in folder.iterdir()} == {"run.json", "result.json", "heap.txt"}
    assert not [p for p in (campaign.workdir / "runs").iterdir() if p.name.startswith(".")]


def test_failures_are_recorded_and_retried_on_request(campaign_file, markers):
    path = campaign_file(replace={'"test.sleep_s" = 0.02': '"test.sleep_s" = 0.02\n"test.fail_above_friction" = 0.45'})
    campaign = load_campaign(path)
    summary = run_campaign(campaign, workers=2, progress=False)
    assert summary.failed == 6 and summary.done == 23  # the six points at B = +1
    assert all("blew up" in error for _, error in summary.failures)
    assert run_campaign(campaign, workers=2, progress=False).ran == 0
    retried = run_campaign(campaign, workers=2, progress=False, retry_failed=True)
    assert retried.ran == 6 and retried.failed == 6
    with Store(campaign.store_path, readonly=True) as store:
        failed = [r for r in store.records() if r.status == "failed"]
    assert {r.attempts for r in failed} == {2}
    assert sum(markers().values()) == 29 + 6


def _demcal(*args, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "demcal", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def test_sigkill_mid_campaign_loses_nothing_and_repeats_nothing(campaign_file, markers):
    """Issue 5, acceptance 3."""
    path = campaign_file(sleep=0.4)
    campaign = load_campaign(path)
    runner = _demcal("run", path, "--workers", "2", "--quiet")
    deadline = time.monotonic() + 240
    done_at_kill = set()
    while time.monotonic() < deadline:
        time.sleep(0.2)
        if campaign.store_path.exists():
            with Store(campaign.store_path, readonly=True) as store:
                records = store.records()
            done_at_kill = {r.seed for r in records if r.status == "done"}
            if len(done_at_kill) >= 4:
                break
    assert runner.poll() is None, runner.communicate()
    os.kill(runner.pid, signal.SIGKILL)
    runner.wait()
    with Store(campaign.store_path, readonly=True) as store:
        assert store.integrity() == "ok"
        records = store.records()
    done_after_kill = {r.seed for r in records if r.status == "done"}
    assert done_at_kill <= done_after_kill < {s.seed for s in plan_design(campaign).specs}
    assert any(r.status == "running" for r in records)  # the kill left claims behind

    rerun = _demcal("run", path, "--workers", "2", "--quiet")
    out, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err
    with Store(campaign.store_path, readonly=True) as store:
        assert store.integrity() == "ok"
        final = store.records()
    assert len(final) == 29 and all(r.status == "done" for r in final)
    # the temporary folders of the runs in flight at the kill are gone too
    assert not [p.name for p in (campaign.workdir / "runs").iterdir() if p.name.startswith(".")]
    counts = markers()
    assert set(counts) == {r.seed for r in final}
    assert all(counts[seed] == 1 for seed in done_after_kill)  # finished runs never run again
    assert max(counts.values()) <= 2  # only runs in flight at the kill ran twice
    by_seed = {r.seed: r for r in records}
    assert all(by_seed[s].responses == next(r for r in final if r.seed == s).responses for s in done_after_kill)


def test_two_runners_on_one_store_never_run_a_point_twice(campaign_file, markers):
    path = campaign_file(sleep=0.1)
    campaign = load_campaign(path)
    plan_design(campaign)
    from demcal.campaign.runner import open_store

    open_store(campaign).close()  # both runners find the store in place
    runners = [_demcal("run", path, "--workers", "1", "--quiet") for _ in range(2)]
    for runner in runners:
        out, err = runner.communicate(timeout=300)
        assert runner.returncode == 0, err
    counts = markers()
    assert len(counts) == 29 and set(counts.values()) == {1}


def test_local_pool_and_dask_give_identical_results(campaign_file, tmp_path):
    """Issue 5, acceptance 2 (the test double; the real tiny profile is in the slow tests)."""
    pytest.importorskip("distributed")
    a, b = local_and_dask_results(load_campaign(campaign_file()), tmp_path)
    assert list(a["status"]) == list(b["status"]) == ["done"] * 29
    assert list(a["key"]) == list(b["key"])
    assert list(a["repose_angle_deg"]) == list(b["repose_angle_deg"])  # bit for bit
