"""`demcal calibrate` on a design that is not finished: refuse, say what to run;
failed design runs: calibrate, and say so on the first line."""

from __future__ import annotations

import pytest

from demcal.campaign.calibrate import calibrate, describe
from demcal.campaign.config import load_campaign
from demcal.campaign.runner import plan_design, run_campaign, run_specs
from demcal.campaign.store import Store
from demcal.cli import main
from demcal.errors import DataError

from conftest import InlineExecutor


@pytest.mark.parametrize("done", [12, 20])
def test_calibrate_refuses_while_design_runs_are_pending(campaign_file, capsys, done):
    path = campaign_file()
    campaign = load_campaign(path)
    assert run_specs(campaign, plan_design(campaign).specs[:done], progress=False,
                     executor=InlineExecutor()).done == done
    executor = InlineExecutor()
    with pytest.raises(DataError) as caught:
        calibrate(campaign, progress=False, executor=executor)
    message = str(caught.value)
    assert message.startswith(f"{29 - done} of 29 design runs are not done yet; finish them with "
                              f"`demcal run {path} --profile tiny`"), message
    assert "at least" not in message  # not the model's run count: the design is unfinished
    assert executor.ran == 0  # no verification run spent on an unfinished design
    assert not (campaign.workdir / "calibration.json").exists()
    with Store(campaign.store_path, readonly=True) as store:
        assert store.counts()["done"] == done and not [r for r in store.records() if r.kind == "verification"]

    assert main(["calibrate", str(path), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.splitlines() == [f"demcal: error: {message}"]


def test_failed_design_runs_are_the_first_line(campaign_file):
    path = campaign_file(replace={'"test.sleep_s" = 0.02': '"test.sleep_s" = 0.02\n"test.fail_above_friction" = 0.45'})
    campaign = load_campaign(path)
    summary = run_campaign(campaign, progress=False, executor=InlineExecutor())
    assert (summary.done, summary.failed) == (23, 6)
    calibration = calibrate(campaign, progress=False, executor=InlineExecutor())
    assert all(r.status == "done" for c in calibration.conditions for r in c.verification)  # as before
    first = describe(calibration).splitlines()[0]
    assert first.startswith("warning: 6 of 29 design runs failed") and "--retry-failed" in first, first
