"""Issue 20: the hostile-user probe's classes of bad input, each one sentence with exit
status 2 and no traceback (``demcal.cli.main`` in this process, so the suite keeps its
time): campaign files that reach outside their folder, input files read with a size
limit, numbers out of range (run counts, seeds, workers, CSV values), a constant
response, a photo that is no heap, and the smaller wording cases."""

from __future__ import annotations

import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from demcal.cli import main

MAX_SEED = 2**63 - 1


def one_sentence(capsys, argv) -> str:
    """Run ``demcal argv``: exit status 2, one line on stderr naming the error, ending
    with a full stop, with no traceback and no control character; returns the line."""
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2, (status, err)
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("demcal: error: ") and lines[0].endswith("."), err
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", err), repr(err)
    return lines[0]


def edit(folder: Path, old: str, new: str, name: str = "repose.toml") -> Path:
    path = folder / name
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))
    return path


def outside(folder: Path) -> Path:
    """A folder beside the campaign's, which is outside it."""
    other = folder.parent / f"{folder.name}-outside"
    other.mkdir(exist_ok=True)
    return other


# --------------------------------------------------------------------------- campaign files

@pytest.mark.parametrize("key, old, new", [
    ("workdir", "[campaign]\n", '[campaign]\nworkdir = "../../escape_workdir"\n'),
    ("workdir", "[campaign]\n", '[campaign]\nworkdir = "/tmp/demcal-escape-workdir"\n'),
    ("lab file", 'lab = "lab.toml"', 'lab = "/dev/zero"'),
    ("lab file", 'lab = "lab.toml"', 'lab = "../lab.toml"'),
    ("reference_table", 'reference_table = "paper_table4_repose_bbd.csv"', 'reference_table = "/etc/passwd"'),
    ("photo", 'sample = "L"\n', 'sample = "L"\nphoto = "../heap.png"\n'),
])
@pytest.mark.parametrize("command", ["run", "report"])
def test_paths_outside_the_campaign_folder_are_refused(example, capsys, key, old, new, command):
    (example.parent / "lab.toml").write_text((example / "lab.toml").read_text())
    (example.parent / "heap.png").write_bytes(b"not looked at")
    edit(example, old, new)
    line = one_sentence(capsys, [command, "repose.toml", "--quiet"])
    assert f"{key} '" in line and "lies outside the campaign file's folder" in line, line
    assert "--allow-outside" in line
    assert not Path("/tmp/demcal-escape-workdir").exists() and not (example.parent / "escape_workdir").exists()


def test_photos_of_a_lab_record_outside_the_folder_are_refused(example, capsys):
    from PIL import Image

    from demcal.measure.synthetic import synthetic_photo

    other = outside(example)
    Image.fromarray(synthetic_photo(33.0, seed=1).image).save(other / "heap.png")
    lab = example / "lab.toml"
    lab.write_text(re.sub(r"\[L\.repose\]\nmean_deg = 31.07\nsd_deg = 2.1\nn = 20",
                          f'[L.repose]\nphotos = ["../{other.name}/*.png"]', lab.read_text()))
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    assert "heap.png' of sample 'L' lies outside the campaign file's folder" in line
    assert "--allow-outside" in line


def test_allow_outside_reads_them_with_the_size_limit(example, capsys):
    edit(example, 'lab = "lab.toml"', 'lab = "/dev/zero"')
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet", "--allow-outside"])
    assert "lab file '/dev/zero' holds more than 1 MiB" in line


def test_allow_outside_accepts_a_lab_file_beside_the_folder(example):
    from demcal.campaign.config import load_campaign

    (example.parent / "lab.toml").write_text((example / "lab.toml").read_text())
    edit(example, 'lab = "lab.toml"', 'lab = "../lab.toml"')
    campaign = load_campaign("repose.toml", allow_outside=True)
    assert campaign.conditions[0].target("repose_angle_deg").mean == 31.07


@pytest.mark.parametrize("name, content, words", [
    ("junk.bin", bytes(range(256)) * 8, "is not a text CSV file"),
    ("controls.csv", b"A,B,C,D,repose_angle_deg\n1,\x1b[2J,0,0,1\n", "control character '\\x1b'"),
    ("lab.toml", None, "has 4 fields, but the header has 1"),
])
def test_reference_table_is_read_and_checked(example, capsys, name, content, words):
    if content is not None:
        (example / name).write_bytes(content)
    edit(example, 'reference_table = "paper_table4_repose_bbd.csv"', f'reference_table = "{name}"')
    line = one_sentence(capsys, ["report", "repose.toml"])
    assert line.startswith("demcal: error: [report] reference_table of repose.toml: ") and words in line, line


def test_reference_table_outside_with_allow_outside_is_one_sentence(example, capsys):
    edit(example, 'reference_table = "paper_table4_repose_bbd.csv"', 'reference_table = "/etc/passwd"')
    line = one_sentence(capsys, ["report", "repose.toml", "--allow-outside"])
    assert "reference_table of repose.toml: " in line and "/etc/passwd" in line


@pytest.mark.parametrize("name", ["repose.toml", "lab.toml"])
def test_a_toml_file_with_a_byte_order_mark_names_it(example, capsys, name):
    path = example / name
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    assert f"{name} starts with a UTF-8 byte-order mark (BOM)" in line and "without BOM" in line


def test_a_campaign_file_above_the_size_limit_is_refused(example, capsys):
    path = example / "repose.toml"
    path.write_text(path.read_text() + "#" * (1 << 20) + "\n")
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    assert "campaign file 'repose.toml' holds more than 1 MiB" in line


def test_a_folder_given_as_the_campaign_file_is_named(example, capsys):
    line = one_sentence(capsys, ["report", str(example)])
    assert "is a folder; give the campaign file (TOML) itself" in line


def test_low_equal_to_high_is_not_told_to_swap(example, capsys):
    edit(example, "low = 0.3\nhigh = 0.5", "low = 0.3\nhigh = 0.3")
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    assert "low = high = 0.3, so it does not vary" in line and "swap" not in line


# --------------------------------------------------------------------------- plugins

def test_a_standard_library_module_is_no_plugin_and_is_not_imported(example, capsys):
    edit(example, 'test = "repose-funnel"', 'test = "repose-funnel"\nplugins = ["this"]')
    sys.modules.pop("this", None)
    for command in ("run", "report"):
        line = one_sentence(capsys, [command, "repose.toml", "--quiet"])
        assert "plugin 'this' is a module of Python's standard library" in line
    assert "this" not in sys.modules


@pytest.fixture
def marker_plugin(example, monkeypatch):
    """A plugin module in the campaign folder that leaves a file when it is imported."""
    name = f"marker_plugin_{example.name.replace('-', '_')}"
    (example / f"{name}.py").write_text(
        "from pathlib import Path\nPath(__file__).with_name('imported').write_text('yes')\n")
    monkeypatch.setattr(sys, "path", list(sys.path))
    yield name
    sys.modules.pop(name, None)


def test_report_never_imports_plugins(example, capsys, marker_plugin):
    edit(example, 'test = "repose-funnel"', f'test = "repose-funnel"\nplugins = ["{marker_plugin}"]')
    line = one_sentence(capsys, ["report", "repose.toml"])
    assert "has no results yet" in line
    assert not (example / "imported").exists()


def test_commands_that_simulate_import_plugins_from_the_campaign_folder(example, marker_plugin):
    from demcal.campaign.config import load_campaign

    edit(example, 'test = "repose-funnel"', f'test = "repose-funnel"\nplugins = ["{marker_plugin}"]')
    assert load_campaign("repose.toml").plugins == (marker_plugin,)
    assert not (example / "imported").exists()  # reading the file runs nothing
    load_campaign("repose.toml", import_plugins=True)
    assert (example / "imported").read_text() == "yes"


@pytest.mark.parametrize("plugins, words", [
    ('["no_such_plugin_module"]', "plugin 'no_such_plugin_module' is neither a module in the campaign folder"),
    ('["../evil"]', "plugin '../evil' is not a module name"),
    ('["broken_plugin"]', "plugin 'broken_plugin' failed while being imported (ZeroDivisionError"),
])
def test_a_plugin_that_cannot_be_imported_is_one_sentence(example, capsys, monkeypatch, plugins, words):
    monkeypatch.setattr(sys, "path", list(sys.path))
    (example / "broken_plugin.py").write_text("1 / 0\n")
    edit(example, 'test = "repose-funnel"', f'test = "repose-funnel"\nplugins = {plugins}')
    try:
        line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    finally:
        sys.modules.pop("broken_plugin", None)
    assert words in line, line


# --------------------------------------------------------------------------- numbers

def test_replicates_beyond_the_run_cap_are_refused_up_front(example, capsys):
    edit(example, "[runs]\nseed = 2020", "[runs]\nseed = 2020\nreplicates = 20000")
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    assert "29 design runs x 20,000 replicates has 580,000 runs, more than the 100,000" in line
    assert not (example / "repose-runs").exists()


@pytest.mark.parametrize("old, new, name", [
    ("seed = 2020", f"seed = {MAX_SEED}", "[runs] seed"),
    ("seed = 2020", f"seed = {MAX_SEED + 1}", "[runs] seed"),
    ("replicates = 3", f"replicates = 3\nseed = {MAX_SEED - 10}", "[verification] seed"),
])
def test_seeds_whose_runs_leave_the_seed_range_are_refused(example, capsys, old, new, name):
    edit(example, old, new)
    line = one_sentence(capsys, ["run", "repose.toml", "--quiet"])
    assert f"{name} = " in line and "2^63 - 1 (9223372036854775807)" in line and "give a seed of at most" in line
    assert not (example / "repose-runs").exists()


@pytest.mark.parametrize("argv", [
    ["bench", "repose-funnel", "--seed", "-1"],
    ["bench", "repose-funnel", "--seed", str(MAX_SEED + 1)],
    ["design", "box-behnken", "-k", "3", "--seed", "-5"],
    ["optimize", "runs.csv", "--response", "y", "--target", "1", "--seed", "-1"],
])
def test_seeds_outside_the_range_are_one_sentence(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    line = one_sentence(capsys, argv)
    assert "--seed must lie in 0 .. 2^63 - 1 (9223372036854775807)" in line


@pytest.mark.parametrize("argv", [
    ["measure", "repose", "photo.png", "--workers", "-3"],
    ["run", "campaign.toml", "--workers", "-1"],
    ["demo", "--workers", "-2"],
])
def test_workers_below_zero_are_one_sentence(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    line = one_sentence(capsys, argv)
    assert "--workers must be 1 or more, or 0 for one per core" in line


# --------------------------------------------------------------------------- run tables

BBD3 = [(-1, -1, 0), (1, -1, 0), (-1, 1, 0), (1, 1, 0), (-1, 0, -1), (1, 0, -1), (-1, 0, 1), (1, 0, 1),
        (0, -1, -1), (0, 1, -1), (0, -1, 1), (0, 1, 1), (0, 0, 0), (0, 0, 0), (0, 0, 0)]


def write_runs(path: Path, ys, extra: str = "") -> Path:
    rows = [f"{a},{b},{c},{y}" for (a, b, c), y in zip(BBD3, ys)]
    path.write_text("A,B,C,y\n" + "\n".join(rows) + "\n" + extra)
    return path


@pytest.mark.parametrize("mode", [[], ["--json"]])
@pytest.mark.parametrize("command", ["analyze", "optimize"])
def test_a_constant_response_is_one_sentence(tmp_path, capsys, mode, command):
    path = write_runs(tmp_path / "const.csv", [5.0] * len(BBD3))
    goal = ["--target", "5"] if command == "optimize" else []
    line = one_sentence(capsys, [command, str(path), "--response", "y", *goal, *mode])
    assert "response 'y'" in line and "has the same value (5) in all 15 runs" in line


@pytest.mark.parametrize("value, words", [("1e308", "holds 1e+308 in row 4, which is beyond ±1e+100"),
                                          ("-1e200", "holds -1e+200 in row 4"),
                                          ("inf", "holds inf in row 4, which is not a finite number")])
def test_values_too_large_to_fit_are_one_sentence(tmp_path, capsys, value, words):
    ys = [float(i) for i in range(len(BBD3))]
    path = write_runs(tmp_path / "big.csv", ys)
    text = path.read_text().splitlines()
    text[4] = text[4].rsplit(",", 1)[0] + f",{value}"
    path.write_text("\n".join(text) + "\n")
    with warnings.catch_warnings():  # no screen of overflow warnings before the sentence
        warnings.simplefilter("error", RuntimeWarning)
        line = one_sentence(capsys, ["analyze", str(path), "--response", "y"])
    assert "column 'y'" in line and words in line, line


def test_a_short_row_is_not_an_empty_cell(tmp_path, capsys):
    path = tmp_path / "short.csv"
    path.write_text("A,B,C,y\n-1,-1,0,1\n1,-1\n-1,1,0,3\n1,1,0,4\n0,0,0,2\n0,0,0,2.1\n")
    line = one_sentence(capsys, ["analyze", str(path), "--response", "y", "--model", "linear"])
    assert "row 2 of " in line and "has 2 fields, but the header has 4" in line and "empty cell" not in line


@pytest.mark.parametrize("content, words", [
    (b"A,B,y\n-1,\x01\x02\x1b[31m,1\n1,1,2\n", "line 2 holds the control character '\\x01'"),
    (b"\x00\x07\x1b[2J\x00,\x01\n\x02\x03,\x04\n", "line 1 holds the control character '\\x00'"),
    (bytes(range(128, 256)) * 4, "is not UTF-8"),
])
def test_a_binary_csv_is_named_without_echoing_its_bytes(tmp_path, capsys, content, words):
    path = tmp_path / "binary.csv"
    path.write_bytes(content)
    line = one_sentence(capsys, ["analyze", str(path), "--response", "y"])
    assert "binary.csv is not a text CSV file" in line and words in line, line


def test_a_device_as_csv_is_read_with_the_size_limit(capsys):
    line = one_sentence(capsys, ["analyze", "/dev/zero", "--response", "y"])
    assert "CSV file '/dev/zero' holds more than 64 MiB" in line


def test_a_csv_with_a_byte_order_mark_is_read(tmp_path, capsys):
    path = write_runs(tmp_path / "bom.csv", [float(i % 4) for i in range(len(BBD3))])
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert main(["analyze", str(path), "--response", "y", "--model", "linear", "--json"]) == 0


# --------------------------------------------------------------------------- photos

def test_a_folder_of_photos_is_named_a_folder(tmp_path, capsys):
    (tmp_path / "heap1.png").write_bytes(b"")
    line = one_sentence(capsys, ["measure", "repose", str(tmp_path)])
    assert f"'{tmp_path}' is a folder, not a photo; give the photos in it, e.g. {tmp_path}/*.png" in line
    assert "does not exist" not in line


def test_a_device_is_no_photo(capsys):
    line = one_sentence(capsys, ["measure", "repose", "/dev/zero"])
    assert "photo '/dev/zero' is not a regular file" in line


def noise(path: Path) -> Path:
    from PIL import Image

    Image.fromarray((np.random.default_rng(5).random((600, 800, 3)) * 255).astype(np.uint8)).save(path)
    return path


def test_a_picture_of_noise_is_not_measured(tmp_path, capsys):
    line = one_sentence(capsys, ["measure", "repose", str(noise(tmp_path / "noise.png"))])
    assert "no heap found in photo" in line and "flank fits have R² 0." in line and "below the 0.9 " in line


def test_a_picture_of_noise_is_its_own_error_row(tmp_path):
    from PIL import Image

    from demcal.measure.photo import MIN_R2, measure_photos
    from demcal.measure.synthetic import synthetic_photo

    Image.fromarray(synthetic_photo(33.0, seed=1).image).save(tmp_path / "heap.png")
    batch = measure_photos([tmp_path / "heap.png", noise(tmp_path / "noise.png")])
    good, bad = batch.rows
    assert good["error"] is None and good["r2"] >= MIN_R2
    assert bad["error"] and "flank fits have R² 0." in bad["error"] and np.isnan(bad["angle_deg"])
    assert batch.summary.n == 1
    # the threshold is the caller's to lower
    assert measure_photos([tmp_path / "noise.png"], min_r2=0.5).rows[0]["error"] is None
