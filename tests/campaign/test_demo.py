"""`demcal demo` end to end on stand-in campaigns of the test double (the real example
campaigns need the virtual bench tests and run in `make demo`)."""

from __future__ import annotations

import shutil
from pathlib import Path

from conftest import CAMPAIGN

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "residual-film-soil"


def test_demo_runs_calibrates_and_reports(tmp_path, monkeypatch, capsys):
    import demcal.cli.demo as demo
    from demcal.cli import main

    source = tmp_path / "examples"
    source.mkdir()
    for name in ("paper_table4_repose_bbd.csv", "paper_table8_sliding_bbd.csv", "paper_verification.csv"):
        shutil.copy(EXAMPLES / name, source / name)
    for name, table in (("repose", "paper_table4_repose_bbd.csv"), ("sliding", "paper_table8_sliding_bbd.csv")):
        text = CAMPAIGN.format(sleep=0.01).replace('name = "test campaign"', f'name = "{name}"')
        text += f'\n[report]\ntitle = "{name} (test double)"\nreference_table = "{table}"\n'
        (source / f"{name}.toml").write_text(text)
    monkeypatch.setattr(demo, "examples_dir", lambda: source)

    assert main(["demo", "--out", str(tmp_path / "out"), "--profile", "tiny", "--workers", "2"]) == 0
    out = capsys.readouterr()
    path = Path(out.out.strip().splitlines()[-1].removeprefix("Report: "))
    assert path == tmp_path / "out" / "report" / "report.html"
    html = path.read_text()
    for text in ("repose (test double)", "sliding (test double)", "The reference paper re-analysed",
                 "Table 5 re-analysed", "Table 9 re-analysed", "4.54 %"):
        assert text in html, text
    assert "demo finished in" in out.err
    # A second demo resumes: nothing is simulated again.
    assert main(["demo", "--out", str(tmp_path / "out"), "--profile", "tiny", "--workers", "2"]) == 0
    assert "29 already done" in capsys.readouterr().err


def test_the_paper_demo_designs_the_incline_at_medium_and_the_funnel_at_quick():
    """`demcal demo --profile paper`: designs at the cheapest profile that stands in for
    the paper one (the incline's medium: within 1 deg of it, docs/validation-incline.md; the funnel
    has no medium and designs at quick), verification at paper; other profiles are both."""
    from demcal.campaign.config import load_campaign
    from demcal.cli.demo import _with_profiles, examples_dir

    sliding = load_campaign(examples_dir() / "sliding.toml")
    repose = load_campaign(examples_dir() / "repose.toml")
    for campaign, cheap in ((sliding, "medium"), (repose, "quick")):
        paper = _with_profiles(campaign, "paper")
        assert (paper.profile, paper.calibration.production) == (cheap, "paper")
        tiny = _with_profiles(campaign, "tiny")
        assert (tiny.profile, tiny.calibration.production) == ("tiny", "tiny")
