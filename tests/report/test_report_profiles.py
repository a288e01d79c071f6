"""`demcal report` (and calibrate) when the design runs exist under another profile:
the message says which profile has them and how to use it, not "run `demcal run`"."""

from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign
from demcal.campaign.runner import open_store, plan_design
from demcal.cli import main



def fake_results(campaign_file: Path, profile: str, count: int | None = None) -> int:
    """Store ``count`` (default all) design runs of ``profile`` as done, without simulating."""
    campaign = load_campaign(campaign_file).with_profile(profile)
    specs = plan_design(campaign).specs[:count]
    with open_store(campaign) as store:
        store.add(specs)
        while (record := store.claim([s.key for s in specs])) is not None:
            store.finish(record.id, {"responses": {"repose_angle_deg": 40.0 + record.id % 7}, "wall_s": 1.0},
                         None, "test")
    return len(specs)


def _error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("demcal: error: ") and len(err.splitlines()) == 1 and "Traceback" not in err
    return err


def test_report_names_the_profile_that_has_the_runs(example, capsys):
    assert fake_results(example / "repose.toml", "tiny") == 29
    assert main(["report", "repose.toml"]) == 2
    err = _error(capsys)
    assert "only 0 of 29" not in err
    assert "no design run is done under profile 'quick'" in err, err
    assert "29 are done under 'tiny'" in err and "--profile tiny" in err, err
    assert "demcal run repose.toml" in err


def test_report_with_another_profile_option(example, capsys):
    fake_results(example / "repose.toml", "tiny")
    assert main(["report", "repose.toml", "--profile", "paper"]) == 2
    err = _error(capsys)
    assert "no design run is done under profile 'paper'" in err and "29 are done under 'tiny'" in err, err


def test_some_done_here_and_more_elsewhere(example, capsys):
    fake_results(example / "repose.toml", "tiny")
    fake_results(example / "repose.toml", "quick", count=3)
    assert main(["calibrate", "repose.toml", "--quiet"]) == 2
    err = _error(capsys)
    assert "only 3 of 29 design runs are done under profile 'quick'" in err, err
    assert "29 are done under 'tiny'" in err and "--profile tiny" in err, err


def test_nothing_done_anywhere_keeps_the_plain_hint(example, capsys):
    fake_results(example / "repose.toml", "quick", count=0)
    assert main(["report", "repose.toml"]) == 2
    err = _error(capsys)
    assert "29 of 29 design runs are not done yet" in err, err
    assert "demcal run repose.toml --profile quick" in err, err
    assert "done under" not in err  # no other profile to point at
