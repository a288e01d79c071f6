"""One replay, one answer (issue 40, item 1): ``demcal report`` replays the loop with the
profiles ``calibrate`` ran with (recorded in calibration.json), so the report's loop
status and verification agree with calibration.json and the card; ``--profile`` asking
for other runs, or an edited campaign file, is reported as the file says."""

from __future__ import annotations

import json

import pandas as pd
from demcal.campaign.calibrate import calibrate
from demcal.campaign.config import load_campaign
from demcal.campaign.runner import run_campaign
from demcal.cli import main

from conftest import CAMPAIGN, InlineExecutor


def test_the_report_replays_with_the_calibrations_profiles(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "campaign.toml"
    path.write_text(CAMPAIGN.format(sleep=0.0))
    campaign = load_campaign(path)  # designs at tiny, the file names no production profile
    assert run_campaign(campaign, progress=False, executor=InlineExecutor()).done == 29
    calibrate(campaign.with_production("quick"), progress=False, executor=InlineExecutor())
    saved = json.loads((campaign.workdir / "calibration.json").read_text())
    assert saved["production"] == "quick"

    assert main(["report", "campaign.toml"]) == 0
    out = capsys.readouterr().out
    assert "(replayed with the options calibrate ran with: verification at quick)" in out
    tables = campaign.workdir / "report" / "tables"
    verification = pd.read_csv(tables / "verification.csv", index_col=0)
    for condition in saved["conditions"]:
        (v,) = condition["verification"]
        row = verification.loc[condition["name"]]
        assert v["simulated"] and abs(row["simulated mean"] - v["simulated_mean"]) < 1e-9
    # the calibration's own design profile named: the same replay
    assert main(["report", "campaign.toml", "--profile", "tiny"]) == 0
    assert "verification at quick" in capsys.readouterr().out
    # an edited campaign file is reported as it stands (and the report says calibration.json is stale)
    path.write_text(path.read_text().replace("mean = 36.0", "mean = 37.0", 1))
    assert main(["report", "campaign.toml"]) == 0
    assert "replayed" not in capsys.readouterr().out
