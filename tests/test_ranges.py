"""Issue 37: values refused against their declared ranges before anything is written or
simulated, each in one sentence (exit status 2) naming the key or option, its line in
the campaign or lab file where it has one, and the range: lab and campaign angle targets
in [0°, 90°), a flank band with band_low < band_high (and the other ordered pairs of
bench settings), inclined-plane readings below 90°, the photo options and files of
`demcal measure repose`, and the counts of `demcal optimize`."""

from __future__ import annotations

import re
import struct
import zlib
from pathlib import Path

import pytest

from demcal.errors import ConfigError
from test_hostile_inputs import edit, one_sentence


def files_of(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def line_of(path: Path, text: str, after: str = "") -> int:
    """The 1-based line of the first ``text`` in ``path`` below the first ``after``."""
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if after in line)
    return next(i for i, line in enumerate(lines) if i >= start and text in line) + 1


@pytest.fixture
def refused(example, capsys, monkeypatch):
    """``refused(command, campaign)``: the sentence of ``demcal command campaign``,
    checked to leave every file of the folder as it was, create no results' folder and
    start no run."""
    import demcal.campaign.runner as runner

    def no_run(*args, **kwargs):
        raise AssertionError("a run started")

    monkeypatch.setattr(runner, "run_campaign", no_run)

    def check(command: str = "run", campaign: str = "repose.toml") -> str:
        before = files_of(example)
        line = one_sentence(capsys, [command, campaign, "--quiet"])
        assert files_of(example) == before
        assert not any(p.is_dir() for p in example.iterdir()), list(example.iterdir())
        return line

    return check


# --------------------------------------------------------------------------- angle targets

@pytest.mark.parametrize("command", ["run", "calibrate"])
@pytest.mark.parametrize("old, new, key, words", [
    ("mean_deg = 31.07", "mean_deg = 120", "mean_deg", "[L] repose: 'mean_deg' = 120 is outside its allowed "
                                                        "range [0, 90)."),
    ("mean_deg = 31.07", "mean_deg = 90", "mean_deg", "'mean_deg' = 90 is outside its allowed range [0, 90)."),
    ("sd_deg = 2.1", "sd_deg = -1", "sd_deg", "'sd_deg' = -1 is outside its allowed range [0, 90]."),
    ("sd_deg = 2.1", "sd_deg = nan", "sd_deg", "'sd_deg' must be a finite number, got nan."),
])
def test_lab_repose_angles_out_of_range(example, refused, command, old, new, key, words):
    edit(example, old, new, "lab.toml")
    line = refused(command)
    assert line.startswith(f"demcal: error: lab.toml line {line_of(example / 'lab.toml', key)} [L] repose: ")
    assert line.endswith(words), line


def test_lab_sliding_angle_out_of_range(example, refused):
    edit(example, "mean_deg = 25.42", "mean_deg = 95", "lab.toml")
    line = refused("run", "sliding.toml")
    n = line_of(example / "lab.toml", "mean_deg = 95")
    assert line.endswith(f"lab.toml line {n} [L] sliding: 'mean_deg' = 95 is outside its allowed range [0, 90)."), line


@pytest.mark.parametrize("target", ["{ mean = 120, sd = 2 }", "-3", "90.0"])
@pytest.mark.parametrize("command", ["run", "calibrate"])
def test_campaign_angle_target_out_of_range(example, refused, command, target):
    path = edit(example, 'sample = "L"\n', f'sample = "L"\n[conditions.targets]\nrepose_angle_deg = {target}\n')
    line = refused(command)
    mean = re.search(r"-?[\d.]+", target).group()
    assert line == (f"demcal: error: repose.toml line {line_of(path, 'repose_angle_deg = ')}: condition '6.26 %' has "
                    f"a target of {float(mean):g}° for 'repose_angle_deg', but an angle target must lie in "
                    "[0°, 90°); give the lab's angle in degrees."), line


def test_an_angle_by_its_unit_is_checked():
    """A response is an angle by its unit too: a plugin's response named without _deg."""
    from demcal.campaign.config import Response, _is_angle

    assert _is_angle(Response("tilt", unit="°")) and _is_angle(Response("tilt", unit="degrees"))
    assert not _is_angle(Response("restitution")) and not _is_angle(Response("heap_height_mm", unit="mm"))


@pytest.mark.parametrize("sd, words", [("-1", "target sd of 'repose_angle_deg' must not be negative."),
                                       ("nan", "'sd' must be a finite number, got nan."),
                                       ("inf", "'sd' must be a finite number, got inf.")])
def test_campaign_target_sd(example, refused, sd, words):
    path = edit(example, 'sample = "L"\n',
                f'sample = "L"\n[conditions.targets]\nrepose_angle_deg = {{ mean = 30, sd = {sd} }}\n')
    line = refused()
    assert line.startswith(f"demcal: error: repose.toml line {line_of(path, 'sd = ')}: ") and line.endswith(words)


# --------------------------------------------------------------------------- incline readings in the lab file

@pytest.mark.parametrize("readings, words", [
    ("H_mm = []", "there are no inclined-plane readings H to convert; give the heights read on the ruler [mm], "
                  "e.g. H_mm = [128, 131, 127]."),
    ("H_mm = [128, 300]", "reading 2: H = 300.0 mm is impossible with L = 300.0 mm; each H must lie between 0 "
                          "and L, L excluded (a plate at 90 deg has no sliding angle)."),
    ("H_mm = [128, 130, 131]\nrepeats = 2", "3 readings cannot be split into groups of 2 repeats."),
])
def test_lab_incline_readings(example, refused, readings, words):
    lab = edit(example, "[L.sliding]\nmean_deg = 25.42\nsd_deg = 2.6\nn = 10",
               f"[L.sliding]\n{readings}\nL_mm = 300", "lab.toml")
    line = refused("run", "sliding.toml")
    assert line.endswith(f"lab.toml line {line_of(lab, 'H_mm')} [L] sliding: {words}"), line


def test_readings_of_a_record_built_in_code_name_the_sample():
    from demcal.errors import DataError
    from demcal.measure.lab import InclineReadings, LabRecord, resolve_targets

    record = LabRecord("L", incline=InclineReadings(()))
    with pytest.raises(DataError, match=r"^the inclined-plane readings of sample 'L': there are no "
                                        r"inclined-plane readings H to convert\.$"):
        resolve_targets(record)


# --------------------------------------------------------------------------- ordered settings

BAND = ("must be below 'measure.band_high' = {}; give measure.band_low from 0 to 0.9 and measure.band_high from "
        "0.1 to 1, with measure.band_low < measure.band_high.")


@pytest.mark.parametrize("old, new, low, high", [
    ('profile = "quick"\n', 'profile = "quick"\n[experiment.settings]\n"measure.band_low" = 0.6\n'
                            '"measure.band_high" = 0.5\n', 0.6, 0.5),
    ('profile = "quick"\n', 'profile = "quick"\n[experiment.settings]\n"measure.band_low" = 0.5\n'
                            '"measure.band_high" = 0.5\n', 0.5, 0.5),
    ('sample = "I"\n', 'sample = "I"\n[conditions.settings]\n"measure.band_high" = 0.1\n'
                       '"measure.band_low" = 0.1\n', 0.1, 0.1),
])
def test_band_low_not_below_band_high_is_refused_at_load(example, refused, old, new, low, high):
    path = edit(example, old, new)
    line = refused()
    n = line_of(path, '"measure.band_low"')
    assert line == (f"demcal: error: repose.toml line {n}: setting 'measure.band_low' = {low:g} "
                    + BAND.format(f"{high:g}")), line


def test_band_low_as_a_factor_above_band_high(example, refused):
    text = (example / "repose.toml").read_text()
    text = text.replace('parameter = "particle.damping_factor"\nlow = 0.0\nhigh = 0.2',
                        'parameter = "measure.band_low"\nlow = 0.3\nhigh = 0.8')
    text = re.sub(r'"particle.damping_factor" = 0\.\d+\n', "", text)
    text = text.replace('profile = "quick"\n', 'profile = "quick"\n[experiment.settings]\n"measure.band_high" = 0.7\n')
    (example / "repose.toml").write_text(text)
    line = refused()
    assert line == (f"demcal: error: repose.toml line {line_of(example / 'repose.toml', 'high = 0.8')}: setting "
                    "'measure.band_low' = 0.8 must be below 'measure.band_high' = 0.7; give measure.band_low from 0 "
                    "to 0.9 and measure.band_high from 0.1 to 1, with measure.band_low < measure.band_high."), line


def test_hard_high_of_band_low_counts(example, refused):
    text = (example / "repose.toml").read_text()
    text = text.replace('parameter = "particle.damping_factor"\nlow = 0.0\nhigh = 0.2',
                        'parameter = "measure.band_low"\nlow = 0.1\nhigh = 0.3\nhard_high = 0.9')
    (example / "repose.toml").write_text(re.sub(r'"particle.damping_factor" = 0\.\d+\n', "", text))
    line = refused()
    n = line_of(example / "repose.toml", "hard_high = 0.9")
    assert line.startswith(f"demcal: error: repose.toml line {n}: setting 'measure.band_low' = 0.9 must be below "
                           "'measure.band_high' = 0.9;"), line


def test_a_valid_band_loads(example):
    from demcal.campaign.config import load_campaign

    edit(example, 'profile = "quick"\n',
         'profile = "quick"\n[experiment.settings]\n"measure.band_low" = 0.9\n"measure.band_high" = 1.0\n')
    assert load_campaign("repose.toml").settings["measure.band_low"] == 0.9


@pytest.mark.parametrize("sets, words", [
    (["measure.band_low=0.6", "measure.band_high=0.5"],
     "setting 'measure.band_low' = 0.6 must be below 'measure.band_high' = 0.5; give measure.band_low from 0 to 0.9 "
     "and measure.band_high from 0.1 to 1, with measure.band_low < measure.band_high."),
    (["particles.scale_min=2"],
     "setting 'particles.scale_min' = 2 must be at most 'particles.scale_max' = 1.5; give particles.scale_min from "
     "0.05 to 10 and particles.scale_max from 0.05 to 10, with particles.scale_min <= particles.scale_max."),
    (["geometry.outlet_diameter=0.2"],
     "setting 'geometry.outlet_diameter' = 0.2 must be below 'geometry.funnel_diameter' = 0.1; give "
     "geometry.outlet_diameter from 0.001 to 1 m and geometry.funnel_diameter from 0.002 to 2 m, with "
     "geometry.outlet_diameter < geometry.funnel_diameter."),
])
def test_bench_refuses_an_unordered_pair_before_it_simulates(tmp_path, capsys, monkeypatch, sets, words):
    from demcal.bench.experiment import BenchExperiment

    def no_run(*args, **kwargs):
        raise AssertionError("a simulation started")

    monkeypatch.setattr(BenchExperiment, "run", no_run)
    argv = ["bench", "repose-funnel", "--profile", "tiny", "--out", str(tmp_path / "out")]
    for item in sets:
        argv += ["--set", item]
    assert one_sentence(capsys, argv) == f"demcal: error: {words}"
    assert not (tmp_path / "out").exists()


def test_one_value_alone_is_not_refused_for_its_pair():
    """A campaign checks each value against the test's range alone, and the pairs once
    every value is known: band_low = 0.9 next to band_high = 1.0 is a valid run."""
    from demcal.bench.registry import get_experiment, resolve_settings

    experiment = get_experiment("repose-funnel")
    resolve_settings(experiment, {"measure.band_low": 0.9}, "tiny", ordered=False)
    assert resolve_settings(experiment, {"measure.band_low": 0.9, "measure.band_high": 1.0}, "tiny")
    with pytest.raises(ConfigError, match="must be below 'measure.band_high' = 0.9"):
        resolve_settings(experiment, {"measure.band_low": 0.9}, "tiny")


# --------------------------------------------------------------------------- demcal measure incline

@pytest.mark.parametrize("argv, words", [
    (["--H", "1e308", "--L", "1e308"], "reading 1: H = 1e+308 mm is impossible with L = 1e+308 mm; each H must lie "
                                       "between 0 and L, L excluded (a plate at 90 deg has no sliding angle)."),
    (["--H", "300"], "reading 1: H = 300.0 mm is impossible with L = 300.0 mm; each H must lie between 0 and L, "
                     "L excluded (a plate at 90 deg has no sliding angle)."),
    (["--H", "100", "--L", "nan"], "--L must be a positive, finite number of mm (the distance from the starting "
                                   "point to the spindle), got nan."),
    (["--H", "100", "--L", "0"], "--L must be a positive, finite number of mm (the distance from the starting "
                                 "point to the spindle), got 0.0."),
    (["--H", "100", "--H0", "inf"], "--H0 must be a finite number of mm >= 0 (0: the paper's Eq. 5), got inf."),
    (["--H", "100", "--repeats", "0"], "--repeats must be at least 1 reading per group, got 0."),
])
def test_measure_incline_ranges(capsys, argv, words):
    assert one_sentence(capsys, ["measure", "incline"] + argv) == f"demcal: error: {words}"


# --------------------------------------------------------------------------- demcal measure repose

@pytest.fixture
def photo(tmp_path, monkeypatch):
    from PIL import Image

    from demcal.measure.synthetic import synthetic_photo

    monkeypatch.chdir(tmp_path)
    Image.fromarray(synthetic_photo(33.0, seed=1).image).save("heap.png")
    return tmp_path / "heap.png"


@pytest.mark.parametrize("argv, words", [
    (["--mm-per-px", "nan"], "--mm-per-px must be a positive, finite number of mm per pixel, got nan."),
    (["--mm-per-px", "inf"], "--mm-per-px must be a positive, finite number of mm per pixel, got inf."),
    (["--mm-per-px", "0"], "--mm-per-px must be a positive, finite number of mm per pixel, got 0.0."),
    (["--band", "0.9,0.1"], "--band must be two fractions LOW,HIGH of the heap height with 0 <= LOW < HIGH <= 1 "
                            "(e.g. 0.1,0.9), got '0.9,0.1'."),
    (["--band", "nan,0.9"], "--band must be 2 comma-separated finite numbers, got 'nan,0.9'."),
    (["--base-y", "nan"], "--base-y must be a row of the photo, a number of pixels >= 0, got nan."),
    (["--roi", "0,0,inf,5"], "--roi must be 4 comma-separated finite numbers, got '0,0,inf,5'."),
])
def test_measure_repose_options(photo, capsys, argv, words):
    before = photo.read_bytes()
    assert one_sentence(capsys, ["measure", "repose", "heap.png", "--out", "out"] + argv) == f"demcal: error: {words}"
    assert photo.read_bytes() == before and not Path("out").exists()


def test_photo_options_are_checked_by_the_library_too():
    from demcal.measure.photo import check_options, measure_photos

    with pytest.raises(ConfigError, match=r"^mm_per_px must be a positive number of mm per pixel, got nan\.$"):
        measure_photos(["no-such.png"], mm_per_px=float("nan"))
    with pytest.raises(ConfigError, match=r"the height band \(0.5, 0.5\) must be two fractions"):
        check_options(band=(0.5, 0.5))


def test_an_unreadable_photo_says_permission_denied(photo, capsys, monkeypatch):
    import os

    import demcal.measure.photo as photo_module

    if os.geteuid() == 0:  # root reads a chmod 000 file: the same error, raised where the file is opened
        def denied(path, *args, **kwargs):
            raise PermissionError(13, "Permission denied", str(path))

        monkeypatch.setattr(photo_module, "open", denied, raising=False)
    else:
        photo.chmod(0)
    line = one_sentence(capsys, ["measure", "repose", "heap.png"])
    assert line == ("demcal: error: cannot read photo 'heap.png': permission denied; give yourself read access "
                    "(chmod u+r) or copy the photo."), line


def huge_png(path: Path, width: int, height: int) -> Path:
    """A valid PNG header declaring a ``width`` x ``height`` grey 1-bit image (its
    pixels are never reached: the size is refused first)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0"))
                     + chunk(b"IEND", b""))
    return path


@pytest.mark.parametrize("width, height, held", [
    (30000, 30000, "is 900 megapixels"),  # beyond twice Pillow's limit: Pillow refuses to open it
    (12000, 8000, "is 12000 x 8000 px, 96 megapixels"),  # Pillow would only warn
    (10000, 8500, "is 10000 x 8500 px, 85 megapixels"),  # below Pillow's warning, above demcal's limit
])
def test_a_huge_photo_is_too_large_not_a_bad_png(tmp_path, capsys, monkeypatch, width, height, held):
    monkeypatch.chdir(tmp_path)
    huge_png(tmp_path / "huge.png", width, height)
    line = one_sentence(capsys, ["measure", "repose", "huge.png"])
    assert line == (f"demcal: error: photo 'huge.png' {held}, more than the 80 megapixels demcal reads for a photo; "
                    "crop it to the heap or scale it down."), line


def test_a_photo_out_of_memory_is_too_large(photo, capsys, monkeypatch):
    from PIL import Image

    def no_memory(self):
        raise MemoryError

    monkeypatch.setattr(Image.Image, "__array_interface__", property(no_memory))
    line = one_sentence(capsys, ["measure", "repose", "heap.png"])
    assert line == ("demcal: error: photo 'heap.png' is too large to decode in the memory at hand; crop it to the "
                    "heap or scale it down."), line


# --------------------------------------------------------------------------- demcal optimize and analyze

@pytest.fixture
def table(example) -> list[str]:
    return ["paper_table4_repose_bbd.csv", "--response", "repose_angle_deg"]


@pytest.mark.parametrize("argv, words", [
    (["--target", "31", "--max-solutions", "-1"], "--max-solutions must be at least 1 (the best solution), got -1."),
    (["--target", "31", "--max-solutions", "0"], "--max-solutions must be at least 1 (the best solution), got 0."),
    (["--target", "31", "--starts", "1000000"], "--starts must be a whole number from 1 to 10,000 (each start is one "
                                                "local search; more find nothing new), got 1000000."),
    (["--target", "31", "--starts", "0"], "--starts must be a whole number from 1 to 10,000 (each start is one "
                                          "local search; more find nothing new), got 0."),
    (["--target", "nan"], "--target of 'repose_angle_deg' must be a finite number, got nan."),
    (["--target", "31", "--reduce", "7"], "--reduce takes a significance level between 0 and 1, not 7.0."),
    (["--target", "31", "--threshold", "nan"], "--threshold must lie in (0, 1], not nan."),
])
def test_optimize_options(table, capsys, monkeypatch, argv, words):
    import demcal.optimize.search as search

    def no_search(*args, **kwargs):
        raise AssertionError("the search started")

    monkeypatch.setattr(search, "optimize", no_search)
    assert one_sentence(capsys, ["optimize"] + table + argv) == f"demcal: error: {words}"


def test_analyze_reduce_is_checked_before_the_table_is_read(capsys):
    line = one_sentence(capsys, ["analyze", "no-such-table.csv", "--response", "y", "--reduce", "7"])
    assert line == "demcal: error: --reduce takes a significance level between 0 and 1, not 7.0."


def test_optimize_library_bounds_and_finite_goals():
    from demcal.optimize.desirability import Goal
    from demcal.optimize.search import MAX_STARTS, optimize

    with pytest.raises(ConfigError, match=f"n_starts must be a whole number from 1 to {MAX_STARTS:,}"):
        optimize({}, [], n_starts=MAX_STARTS + 1)
    with pytest.raises(ConfigError, match=r"^the target of y must be a finite number, not nan\.$"):
        Goal("y", "target", float("nan"))
    with pytest.raises(ConfigError, match=r"^the low of y must be a finite number, not -inf\.$"):
        Goal("y", "max", low=float("-inf"))
