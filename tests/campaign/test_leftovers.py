"""Temporary run folders left by a killed runner or worker are removed on the next start,
unless the run is claimed by a runner that is still alive."""

from __future__ import annotations

from demcal.campaign.config import load_campaign
from demcal.campaign.runner import open_store, plan_design, run_campaign
from demcal.campaign.store import Store

from conftest import InlineExecutor


def _hidden(campaign) -> set[str]:
    return {p.name for p in (campaign.workdir / "runs").iterdir() if p.name.startswith(".")}


def test_stale_temp_folders_go_claimed_ones_stay(campaign_file):
    campaign = load_campaign(campaign_file())
    specs = plan_design(campaign).specs
    store = open_store(campaign)
    store.add(specs)
    runs = store.runs_dir
    # Run 15 was in flight when its runner was killed: its claim went stale, its folder stayed.
    stale = runs / f".{specs[14].dirname}.tmp-0badc0de"
    (stale / "nested").mkdir(parents=True)
    (stale / "nested" / "heap.txt").write_text("half written\n")
    (runs / f".{specs[3].dirname}.tmp-1badc0de").mkdir()  # a pending run too
    # Run 20 is being simulated right now by another live runner (this process, another owner).
    other = Store(campaign.store_path)
    claimed = other.claim([specs[19].key])
    assert claimed is not None and claimed.key == specs[19].key
    live = runs / f".{specs[19].dirname}.tmp-2badc0de"
    live.mkdir()
    (live / "run.json").write_text("{}")
    store.close()
    try:
        summary = run_campaign(campaign, progress=False, executor=InlineExecutor())
        assert (summary.done, summary.elsewhere) == (28, 1)
        assert _hidden(campaign) == {live.name}  # the live runner's folder is untouched
        assert (live / "run.json").is_file()
    finally:
        other.release()
        other.close()
    # Its runner gone (claim handed back), the next start removes that folder too.
    summary = run_campaign(campaign, progress=False, executor=InlineExecutor())
    assert summary.done == 29
    assert _hidden(campaign) == set()


def test_leftovers_of_a_done_run_are_removed_and_its_results_kept(campaign_file):
    campaign = load_campaign(campaign_file())
    assert run_campaign(campaign, progress=False, executor=InlineExecutor()).done == 29
    spec = plan_design(campaign).specs[0]
    runs = campaign.workdir / "runs"
    (runs / f".{spec.dirname}.tmp-3badc0de").mkdir()  # a worker died after a rename elsewhere
    (runs / f".{spec.dirname}.old-4badc0de").mkdir()  # publish_dir stopped before removing the old one
    unrelated = runs / ".keep-me"
    unrelated.mkdir()
    again = run_campaign(campaign, progress=False, executor=InlineExecutor())
    assert (again.ran, again.done) == (0, 29)
    assert _hidden(campaign) == {".keep-me"}
    assert {p.name for p in (runs / spec.dirname).iterdir()} == {"run.json", "result.json", "heap.txt"}
