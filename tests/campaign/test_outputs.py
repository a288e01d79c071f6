"""Nothing destroyed, nothing escapes (issue 37, items 1, 2, 4, 6 and 7): an output path
never replaces one of the campaign's inputs nor a node that is not a regular file, an
existing file only when demcal wrote one of its kind (or with ``--force``); the demo
checks its options before it copies anything and never replaces an edited campaign;
links in the workdir do not lead its results out of the campaign's folder; a file-system
error names the user's path; ``export`` refuses a calibration of another campaign.

Each command runs through :func:`demcal.cli.main` in this process, on the
residual-film-soil examples (no simulation) or the ``test-heap`` double.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
from pathlib import Path

import pytest

from demcal._files import write_atomic
from demcal.campaign.config import load_campaign
from demcal.campaign.digest import as_calibrated, campaign_hash
from demcal.cli import main
from demcal.errors import ConfigError

CALIBRATION = {"campaign": "repose", "profile": "quick", "conditions": [
    {"name": "6.26 %", "chosen": {"particle.restitution": 0.58, "particle.static_friction": 0.312,
                                  "particle.rolling_friction": 0.105, "particle.damping_factor": 0.12},
     "verification": []}]}


def one_sentence(capsys, argv) -> str:
    """``demcal argv`` exits 2 with one sentence on stderr, no traceback; returns it."""
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == 2, (status, err)
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("demcal: error: ") and lines[0].endswith("."), err
    return lines[0]


def digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every regular file below ``folder`` (links not followed)."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and not p.is_symlink()}


@pytest.fixture
def calibrated_example(example):
    """The examples with a calibration.json of the repose campaign (no runs), a store file
    and a heap photo the 6.26 % condition names."""
    runs = example / "repose-runs"
    runs.mkdir()
    (runs / "calibration.json").write_text(json.dumps(CALIBRATION))
    (runs / "store.sqlite").write_bytes(b"SQLite format 3\x00" + bytes(100))
    (example / "photos").mkdir()
    (example / "photos" / "heap-1.jpg").write_bytes(b"\xff\xd8\xff\xe0 not really a jpeg")
    path = example / "repose.toml"
    path.write_text(path.read_text().replace('sample = "L"\n', 'sample = "L"\nphoto = "photos/heap-1.jpg"\n', 1))
    return example


@pytest.mark.parametrize("fmt, target", [
    ("json", "repose-runs/store.sqlite"),
    ("json", "repose.toml"),
    ("liggghts", "lab.toml"),
    ("edem", "photos/heap-1.jpg"),
    ("json", "repose-runs/calibration.json"),
    ("json", "repose-runs/runs/card.json"),
])
def test_export_never_replaces_an_input(calibrated_example, capsys, fmt, target):
    before = digests(calibrated_example)
    line = one_sentence(capsys, ["export", "repose.toml", "--format", fmt, "-o", target])
    assert f"--out {target}" in line and "an input of the campaign" in line, line
    assert digests(calibrated_example) == before
    # --force replaces files demcal did not write, never an input
    assert "an input of the campaign" in one_sentence(capsys, ["export", "repose.toml", "-o", target, "--force"])
    assert digests(calibrated_example) == before


def test_export_through_a_link_to_an_input_is_refused(calibrated_example, capsys):
    (calibrated_example / "card.json").symlink_to("repose.toml")
    before = digests(calibrated_example)
    assert "an input of the campaign" in one_sentence(capsys, ["export", "repose.toml", "-o", "card.json"])
    assert digests(calibrated_example) == before and (calibrated_example / "card.json").is_symlink()


def test_export_replaces_its_own_card_and_asks_before_any_other_file(calibrated_example, capsys):
    assert main(["export", "repose.toml", "-o", "card.json"]) == 0
    assert main(["export", "repose.toml", "--format", "liggghts", "-o", "card.json"]) == 0  # a card: replaced
    assert main(["export", "repose.toml", "--format", "edem", "-o", "card.json"]) == 0
    capsys.readouterr()
    notes = calibrated_example / "notes.txt"
    notes.write_text("my own notes\n")
    line = one_sentence(capsys, ["export", "repose.toml", "-o", "notes.txt"])
    assert line == ("demcal: error: --out notes.txt exists and is not a material card that demcal wrote; give "
                    "another path, move that file away, or pass --force to replace it.")
    assert notes.read_text() == "my own notes\n"
    assert main(["export", "repose.toml", "-o", "notes.txt", "--force"]) == 0
    assert json.loads(notes.read_text())["card_version"] == 1


@pytest.mark.parametrize("make", ["fifo", "link to fifo", "link to device", "folder"])
def test_nodes_that_are_not_regular_files_are_never_replaced(tmp_path, monkeypatch, capsys, make):
    monkeypatch.chdir(tmp_path)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    target = tmp_path / "out.csv"
    if make == "fifo":
        target = fifo
    elif make == "link to fifo":
        target.symlink_to(fifo)
    elif make == "link to device":
        target.symlink_to(os.devnull)
    else:
        target.mkdir()
    line = one_sentence(capsys, ["design", "box-behnken", "-k", "3", "-o", target, "--force"])
    assert str(target) in line and ("not a regular file" in line or "is a folder" in line), line
    assert fifo.is_fifo() and Path(os.devnull).is_char_device()
    assert target.is_symlink() == make.startswith("link")
    with pytest.raises(ConfigError, match="not a regular file|a folder"):
        write_atomic(target, "x")  # the library's own writer refuses it too
    assert fifo.is_fifo()


def test_design_output_replaces_only_a_design(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["design", "box-behnken", "-k", "3", "-o", "d.csv"]) == 0
    assert main(["design", "ccd", "-k", "2", "-o", "d.csv"]) == 0  # demcal's own design: replaced
    assert Path("d.csv").read_text().startswith("# demcal design: ccd")
    capsys.readouterr()
    Path("runs.csv").write_text("A,B,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,5\n0,0,3\n")
    before = Path("runs.csv").read_bytes()
    line = one_sentence(capsys, ["design", "box-behnken", "-k", "3", "-o", "runs.csv"])
    assert "--force" in line and "runs.csv" in line
    line = one_sentence(capsys, ["design", "steepest-ascent", "runs.csv", "--response", "y", "-o", "runs.csv",
                                 "--force"])
    assert "an input" in line
    line = one_sentence(capsys, ["optimize", "runs.csv", "--response", "y", "--target", "3", "--plot", "runs.csv"])
    assert "--plot runs.csv" in line
    assert Path("runs.csv").read_bytes() == before


def test_a_bad_demo_option_writes_nothing_and_an_edited_campaign_is_kept(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    line = one_sentence(capsys, ["demo", "--out", "d7", "--profile", "bogus"])
    assert "bogus" in line and not Path("d7").exists()
    campaigns = Path("d7/campaigns")
    campaigns.mkdir(parents=True)
    (campaigns / "repose.toml").write_text("# my edited campaign\n")
    line = one_sentence(capsys, ["demo", "--out", "d7", "--profile", "bogus"])
    assert "bogus" in line
    line = one_sentence(capsys, ["demo", "--out", "d7", "--profile", "tiny"])  # refused before any run
    assert line == ("demcal: error: d7/campaigns/repose.toml is not the example's repose.toml (edited?), and the "
                    "demo never replaces a file of yours; move it away, or give the demo another --out folder.")
    assert (campaigns / "repose.toml").read_text() == "# my edited campaign\n"
    assert sorted(p.name for p in campaigns.iterdir()) == ["repose.toml"]


@pytest.mark.parametrize("name", ["runs", "report", "store.sqlite", "runs/run-0001"])
def test_a_link_in_the_workdir_does_not_lead_out_of_the_campaign(example, capsys, name):
    elsewhere = example.parent / f"{example.name}-elsewhere"
    elsewhere.mkdir()
    link = example / "repose-runs" / name
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(elsewhere, target_is_directory=True)
    for command in (["run", "repose.toml", "--profile", "tiny"], ["report", "repose.toml"]):
        line = one_sentence(capsys, command)
        assert f"'repose-runs/{name}' lies outside the campaign file's folder" in line, line
        assert "--allow-outside" in line
    assert list(elsewhere.iterdir()) == []


def test_file_system_errors_name_the_users_path_not_a_temporary_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)

    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device", str(src))

    with monkeypatch.context() as patch:
        patch.setattr(os, "replace", full)
        line = one_sentence(capsys, ["design", "box-behnken", "-k", "3", "-o", "d.csv"])
    assert line == "demcal: error: no space left on the disk that holds d.csv; free some space and run again."
    assert list(tmp_path.iterdir()) == []  # no temporary file left
    Path("afile").write_text("x")
    line = one_sentence(capsys, ["design", "box-behnken", "-k", "3", "-o", "afile/d.csv"])
    assert ".tmp" not in line and "afile" in line, line


# ------------------------------------------------------------------ a stale calibration


def test_export_refuses_a_calibration_of_another_campaign(calibrated_example, capsys):
    """calibration.json carries the hash of the campaign it was calibrated from (with its
    profiles; ``calibrate`` writes it, tests/campaign/test_calibrate.py); after a factor's
    range or a target is edited, ``export`` says to calibrate again instead of writing the
    old values. A calibration verified at another production profile than the file's
    (``calibrate --production``) is not stale."""
    path = calibrated_example / "repose.toml"
    saved = {**CALIBRATION, "profile": "tiny", "production": "paper"}
    calibration = calibrated_example / "repose-runs" / "calibration.json"
    saved["campaign_hash"] = campaign_hash(as_calibrated(load_campaign(path), saved))
    assert saved["campaign_hash"] != campaign_hash(load_campaign(path))
    calibration.write_text(json.dumps(saved))
    assert main(["export", "repose.toml", "-o", "card.json"]) == 0
    assert not any("changed since" in w for w in json.loads(Path("card.json").read_text())["warnings"])
    capsys.readouterr()
    card = Path("card.json").read_bytes()
    for edited, old, new in ((path, "low = 0.3\nhigh = 0.5", "low = 0.3\nhigh = 0.6"),
                             (calibrated_example / "lab.toml", "mean_deg = 31.07", "mean_deg = 31.5")):
        text = edited.read_text()
        assert old in text
        edited.write_text(text.replace(old, new, 1))
        line = one_sentence(capsys, ["export", "repose.toml", "-o", "card.json"])
        assert re.search(r"repose\.toml changed since .*calibration\.json was written", line), line
        assert "run `demcal calibrate repose.toml` again" in line
        assert Path("card.json").read_bytes() == card
        edited.write_text(text)
    assert main(["export", "repose.toml", "-o", "card.json"]) == 0


def test_measure_without_what_is_one_sentence(capsys):
    status = main(["measure"])
    err = capsys.readouterr().err
    assert status == 2 and err.strip().splitlines()[-1] == (
        "demcal: error: say what to measure: demcal measure repose PHOTO... or demcal measure incline --H ...; "
        "see demcal measure --help.")
