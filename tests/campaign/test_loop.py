"""The closed calibration loop on a two-fidelity test double (``loop_testbench.py``):
a known production response, a known bias of the cheap profile, known noise."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from demcal.campaign.calibrate import calibrate
from demcal.campaign.config import parse_campaign
from demcal.campaign.runner import run_campaign
from demcal.campaign.store import Store
from demcal.errors import ConfigError

import loop_testbench
from conftest import InlineExecutor
from loop_testbench import BIAS, true_angle

#: A parametrised case beyond the first, whose branch the fast suite walks elsewhere
#: (test_loop_states.py takes every transition of the loop in memory; the case kept here
#: reads the same code): each calibration is 15-50 s on the 2-core VM, most of it the
#: optimiser's calls of the discrepancy's Gaussian process, so `make test-slow` runs them.
SLOW = pytest.mark.slow

CAMPAIGN = """\
[campaign]
name = "loop test"

[experiment]
test = "test-fidelity"
profile = "tiny"
plugins = ["loop_testbench"]
{settings}
[[factors]]
name = "A"
parameter = "particle.restitution"
low = 0.5
high = 0.7
{hard_a}
[[factors]]
name = "B"
parameter = "particle.static_friction"
low = 0.3
high = 0.5
{hard_b}
[[factors]]
name = "C"
parameter = "particle.rolling_friction"
low = 0.1
high = 0.3
{hard_c}
[design]
type = "box-behnken"
center = 3

[runs]
seed = 11

[model]
order = "quadratic"

[[conditions]]
name = "inside"
targets = {{ repose_angle_deg = {{ mean = 33.0, sd = 1.5 }} }}

[[conditions]]
name = "outside"
targets = {{ repose_angle_deg = {{ mean = {outside}, sd = 1.5 }} }}

[verification]
replicates = 2

[calibration]
production = "quick"
box_moves = 4
{budget}
[executor]
workers = {workers}
"""


def write(folder: Path, outside: float = 45.0, hard: bool | str = False, budget: str = "", workers: int = 1,
          sleep: float = 0.0, bias_slope: float = 0.0, curvature: float = 0.0, calibration: str = "",
          fail_seed: int = 0) -> Path:
    """The loop campaign in ``folder``; ``hard``: hard limits on every factor (True) or on
    the factors named (e.g. "ac")."""
    hard_lines = {"hard_a": "hard_high = 0.75\n", "hard_b": "hard_high = 0.6\n", "hard_c": "hard_high = 0.35\n"}
    named = "abc" if hard is True else (hard or "")
    settings = "".join(f'"test.{k}" = {v}\n' for k, v in (("sleep_s", sleep), ("bias_slope", bias_slope),
                                                          ("curvature", curvature), ("fail_seed", fail_seed)) if v)
    text = CAMPAIGN.format(outside=outside, budget=calibration + budget, workers=workers,
                           settings="[experiment.settings]\n" + settings if settings else "",
                           **{k: (v if k[-1] in named else "") for k, v in hard_lines.items()})
    path = folder / "loop.toml"
    path.write_text(text)
    return path


def inline() -> InlineExecutor:
    """The runs executed in this process, one at a time, by the test double of an
    executor: each run is a pure function of its spec and seed, so the results are a
    worker's, without a pool to start and poll at every step of the loop (a test twice
    as fast). ``looped`` and the SIGKILL test run theirs in worker processes."""
    return InlineExecutor(workers=1)


def calibrated(folder: Path, **kw):
    """``write``'s campaign run and calibrated: ``(campaign, calibration)``."""
    path = write(folder, **kw)
    campaign = parse_campaign(path.read_text(), path)
    run_campaign(campaign, progress=False, executor=inline())
    return campaign, calibrate(campaign, progress=False, executor=inline())


@pytest.fixture(autouse=True)
def _double_on_path(monkeypatch):
    here = str(Path(loop_testbench.__file__).parent)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([here] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))


@pytest.fixture(scope="module")
def looped(tmp_path_factory):
    """``write``'s campaign run and calibrated; its runs sleep 0.05 s, as those of the
    calibration the SIGKILL test stops, whose uninterrupted run this is."""
    folder = tmp_path_factory.mktemp("loop")
    path = write(folder, sleep=0.05)
    campaign = parse_campaign(path.read_text(), path)
    assert run_campaign(campaign, workers=1, progress=False).done == 15
    return campaign, calibrate(campaign, workers=1, progress=False)


@pytest.fixture(scope="module")
def crossed(tmp_path_factory):
    """``calibrated(outside=40.5)``: box 0's path crosses the second target (two tests
    read it; one replays a copy of its store)."""
    return calibrated(tmp_path_factory.mktemp("crossed"), outside=40.5)


def copied(campaign, folder: Path):
    """``campaign``'s file and store copied into ``folder``, read from there."""
    shutil.copytree(campaign.path.parent, folder)
    path = folder / campaign.path.name
    return parse_campaign(path.read_text(), path)


def test_inside_target_verified_after_the_bias_is_learnt(looped):
    campaign, cal = looped
    result = cal.conditions[0]
    assert result.loop.status == "verified", result.loop.reason
    (verdict,) = result.verdicts
    assert abs(verdict.simulated_mean - 33.0) <= 1.5
    # the known answer: the production response at the chosen parameters
    assert true_angle(*result.chosen.values()) == pytest.approx(33.0, abs=1.0)
    # the first solve ignored the bias (production 3 deg high), the next learnt it
    production = [s for s in result.loop.history if s.stage == "production"]
    assert production[0].simulated == pytest.approx(33.0 + BIAS, abs=1.0)
    assert result.loop.discrepancy["repose_angle_deg"].bias == pytest.approx(BIAS, abs=0.6)
    assert [b.index for b in result.loop.boxes] == [0]


def test_box_moves_to_a_target_outside_it(looped):
    campaign, cal = looped
    result = cal.conditions[1]
    assert result.loop.status == "verified", result.loop.reason
    assert len(result.loop.boxes) >= 2 and result.loop.box.index >= 1
    stages = [s.stage for s in result.loop.history]
    assert "path" in stages and "design" in stages and stages[-1] == "production"
    # the chosen point lies outside the original box (mu there is at most 0.5)
    assert result.chosen["particle.static_friction"] > 0.5
    assert true_angle(*result.chosen.values()) == pytest.approx(45.0, abs=1.0)
    (verdict,) = result.verdicts
    assert abs(verdict.simulated_mean - 45.0) <= 1.5
    # (the path from box 0 reads short of 45 at all its steps: it crossed nothing)
    assert "the steepest path ran its length toward it without crossing it" in result.loop.boxes[1].reason
    data = cal.to_dict()["conditions"][1]
    assert data["status"] == "verified" and len(data["boxes"]) == len(result.loop.boxes)
    assert data["production_profile"] == "quick" and data["cheap_profile"] == "tiny"


def test_a_moved_box_takes_box_replicates_seeds_a_point(tmp_path):
    """[calibration] box_replicates = 2: each moved box's design runs two seeds a point
    (box 0 keeps [runs] replicates = 1), every seed its own, and the box's model is fitted
    to both; a bad value is one sentence."""
    from demcal.campaign.loop import fit_box

    campaign, cal = calibrated(tmp_path, calibration="box_replicates = 2\n")
    assert campaign.replicates == 1 and campaign.calibration.box_replicates == 2
    result = cal.conditions[1]
    assert result.loop.status == "verified", result.loop.reason
    designs = [s for s in result.loop.history if s.stage == "design"]
    assert designs and all("30 design runs" in s.text for s in designs)
    with Store(campaign.store_path, readonly=True) as store:
        box1 = [r for r in store.records() if r.kind == "design" and r.label.startswith("box 1 ")]
        table = fit_box(campaign, result.loop.boxes[1], store.records(), "tiny")[-1]
    assert len(box1) == 30 and len({r.seed for r in box1}) == 30
    assert sum(r.label.endswith(" r2") for r in box1) == 15
    assert len(table) >= 30  # both seeds of every point (and any path run inside the box)
    bad = tmp_path / "bad"
    bad.mkdir()
    path = write(bad, calibration="box_replicates = 0\n")
    with pytest.raises(ConfigError, match=r"'box_replicates' must be at least 1, got 0\.$"):
        parse_campaign(path.read_text(), path)


def test_production_replicates_come_in_batches_of_replicate_batch(tmp_path):
    """[calibration] replicate_batch = 2: the probe stays one run; every later production
    batch runs an even number of new seeds, the first at a point and the follow-up ones
    alike (a lab sd of 0.5 against a seed noise of 0.3 asks for more than the first
    batch), and the loop still verifies. A budget that the rounded batch would pass runs
    what the noise asks for; a bad value is one sentence."""
    text = write(tmp_path, calibration="replicate_batch = 2\nmax_replicates = 12\n").read_text()
    text = text.replace("mean = 33.0, sd = 1.5", "mean = 33.0, sd = 0.5")
    path = tmp_path / "loop.toml"
    path.write_text(text)
    campaign = parse_campaign(text, path)
    run_campaign(campaign, progress=False, executor=inline())
    cal = calibrate(campaign, progress=False, executor=inline())
    assert campaign.calibration.replicate_batch == 2
    assert [c.loop.status for c in cal.conditions] == ["verified", "verified"], [c.loop.reason for c in cal.conditions]
    steps = [s for c in cal.conditions for s in c.loop.history if s.stage == "production"]
    assert steps[0].runs == 1  # the probe
    assert all(s.runs % 2 == 0 for s in steps[1:]), [s.runs for s in steps]
    # a follow-up batch at a point that already had runs (its text counts all of them)
    counts = [int(re.search(r" x(\d+)", s.text)[1]) for s in steps]
    assert any(n > s.runs for n, s in zip(counts, steps) if s.runs), [(n, s.runs) for n, s in zip(counts, steps)]
    with Store(campaign.store_path, readonly=True) as store:
        records = store.records()
    assert len([r for r in records if r.kind == "verification"]) == sum(s.runs for s in steps)
    # the last batch (the second condition's one point, one run asked for, two run) with a
    # budget one run short of what the calibration used: it runs the one run and verifies
    assert steps[-1].runs == 2 and steps[-1].text.startswith("quick x2")
    tight = tmp_path / "tight"
    tight.mkdir()
    limited = text.replace("[executor]\n", f"[budget]\nruns = {len(records) - 1}\n\n[executor]\n")
    campaign = parse_campaign(limited, tight / "loop.toml")
    run_campaign(campaign, progress=False, executor=inline())
    cal = calibrate(campaign, progress=False, executor=inline())
    assert [c.loop.status for c in cal.conditions] == ["verified", "verified"], [c.loop.reason for c in cal.conditions]
    last = [s for s in cal.conditions[1].loop.history if s.stage == "production"][-1]
    assert last.runs == 1 and last.text.startswith("quick x1")
    with Store(campaign.store_path, readonly=True) as store:
        assert len(store.records()) == len(records) - 1
    bad = tmp_path / "bad"
    bad.mkdir()
    path = write(bad, calibration="replicate_batch = 0\n")
    with pytest.raises(ConfigError, match=r"'replicate_batch' must be at least 1, got 0\.$"):
        parse_campaign(path.read_text(), path)
    path = write(bad, calibration="replicate_batch = 12\n")
    with pytest.raises(ConfigError, match=r"'replicate_batch' \(12\) is above 'max_replicates' \(10\)"):
        parse_campaign(path.read_text(), path)


def test_replay_runs_nothing_and_finds_the_same(looped, tmp_path, monkeypatch):
    campaign, cal = looped
    markers = tmp_path / "markers"
    markers.mkdir()
    monkeypatch.setenv("DEMCAL_TEST_MARKERS", str(markers))
    again = calibrate(campaign, workers=1, progress=False)
    assert list(markers.iterdir()) == []
    assert [c.chosen for c in again.conditions] == [c.chosen for c in cal.conditions]
    report = calibrate(campaign, simulate=False, progress=False)
    assert [c.loop.status for c in report.conditions] == ["verified", "verified"]


def test_unreachable_within_hard_limits_stops_plainly(tmp_path):
    campaign, cal = calibrated(tmp_path, hard=True)
    result = cal.conditions[1]
    assert result.loop.status == "out of reach"
    assert "lies beyond what the test reaches within the parameters' physical limits" in result.loop.reason
    # it never ran beyond the hard limits
    with Store(campaign.store_path, readonly=True) as store:
        for record in store.records():
            assert record.parameters["particle.static_friction"] <= 0.6 + 1e-12
            assert record.parameters["particle.rolling_friction"] <= 0.35 + 1e-12


def test_budget_stops_plainly(tmp_path):
    campaign, cal = calibrated(tmp_path, budget="[budget]\nruns = 20\n")
    statuses = [c.loop.status for c in cal.conditions]
    assert "budget spent" in statuses
    reason = next(c.loop.reason for c in cal.conditions if c.loop.status == "budget spent")
    assert reason.startswith("the budget of 20 runs is spent (")
    with Store(campaign.store_path, readonly=True) as store:
        assert len(store.records()) <= 20


@pytest.mark.parametrize("least, first", [(1, 1), pytest.param(2, 2, marks=SLOW)])
def test_a_new_points_first_batch_is_what_the_pooled_noise_asks_for(tmp_path, least, first):
    """Once the first condition's last point has two runs (noise 0.3 deg, df 1), the
    second condition's first point needs one run against a lab sd of 5 deg (t(1) x 0.3 =
    3.8), however many `replicates` ask for at an unknown noise; `min_replicates` holds.
    The second condition has a fixed setting of its own: its noise is pooled with the
    first's all the same."""
    text = write(tmp_path, outside=34.0).read_text()
    text = text.replace("mean = 34.0, sd = 1.5", "mean = 34.0, sd = 5.0")
    text = text.replace('name = "outside"\n', 'name = "outside"\nsettings = { "test.sleep_s" = 0.001 }\n')
    text = text.replace("box_moves = 4\n", f"box_moves = 4\nmin_replicates = {least}\n")
    path = tmp_path / "loop.toml"
    path.write_text(text)
    campaign = parse_campaign(text, path)
    run_campaign(campaign, progress=False, executor=inline())
    cal = calibrate(campaign, progress=False, executor=inline())
    one, two = cal.conditions
    assert [c.loop.status for c in cal.conditions] == ["verified", "verified"], [c.loop.reason for c in cal.conditions]
    # the first condition: a probe, then [verification] replicates = 2 at an unknown noise
    assert [s.runs for s in one.loop.history if s.stage == "production"][:2] == [1, 2]
    production = [s for s in two.loop.history if s.stage == "production"]
    assert production[0].runs == first
    # pooled with the first condition's points (its own campaign's runs alone have df 0,
    # which would have asked for `replicates` = 2)
    assert int(re.search(r"pooled over the production points, df (\d+)", production[0].text)[1]) >= 1
    assert abs(production[-1].simulated - 34.0) <= 5.0


def test_a_stored_study_of_the_production_noise_sizes_the_first_point(tmp_path, monkeypatch):
    """A stored study that replicated the production profile (a stand-in here: seed sd
    0.3 deg over 20 df) is the noise before the campaign has any: the first point gets
    one run (t(20) x 0.3 = 0.63 against the lab sd 1.5), not a probe followed by
    [verification] replicates = 2, and its interval pools the study's df with the
    campaign's own. A campaign that fixes a setting other than a material value gets no
    stored noise, as it gets no stored bias."""
    import dataclasses

    from demcal.bench import profiles
    from demcal.campaign.noise import stored_noise

    # ten points of three seeds, sd 0.3 each: 0.3 over 20 df, at settings the campaign never runs
    stand_in = [({"particle.static_friction": 5.0 + i}, 3, 0.3) for i in range(10)]

    def fake(test, response, profile):
        return stand_in if (test, profile) == ("test-fidelity", "quick") else []

    monkeypatch.setattr(profiles, "noise_points", fake)
    campaign, cal = calibrated(tmp_path, outside=34.0)
    assert stored_noise(campaign, "quick", ["repose_angle_deg"]) == {"repose_angle_deg": stand_in}
    assert stored_noise(campaign, "tiny", ["repose_angle_deg"]) == {}
    fixed = dataclasses.replace(campaign, settings={**campaign.settings, "particles.count": 50})
    assert stored_noise(fixed, "quick", ["repose_angle_deg"]) == {}
    first = cal.conditions[0]
    assert first.loop.status == "verified", first.loop.reason
    production = [s for s in first.loop.history if s.stage == "production"]
    # (without the stored noise: a probe, then 2 at the re-solved point, then one more)
    assert [s.runs for s in production] == [1, 1]
    assert "± 0.63 (95 %" in production[0].text
    df = re.search(r"pooled over the production points and the stored study's, df (\d+)", production[-1].text)
    assert df is not None and int(df[1]) >= 20, production[-1].text
    assert abs(production[-1].simulated - 33.0) <= 1.5


@pytest.mark.parametrize("measured, said", [((0.30, 0.32), True), pytest.param((0.0, 2.0), False, marks=SLOW)])
def test_a_stored_bias_used_beyond_its_points_is_said(tmp_path, monkeypatch, measured, said):
    """The first production point leans on a stored bias (here a stand-in, measured over
    static friction `measured`); a point outside that range gets a note in the result."""
    from demcal.bench import profiles

    fake = profiles.ProfileBias(
        test="test-fidelity", response="repose_angle_deg", cheap="tiny", production="quick", bias=BIAS,
        se=0.1, sd_points=0.1, measured="test",
        points=tuple({"settings": {"particle.static_friction": mu}} for mu in measured))
    monkeypatch.setattr(profiles, "stored", lambda *args: fake)
    campaign, cal = calibrated(tmp_path, outside=34.0)
    first = cal.conditions[0]
    assert first.loop.status == "verified", first.loop.reason
    production = [s for s in first.loop.history if s.stage == "production"]
    assert "stored tiny → quick bias" in production[0].discrepancy
    mu = production[0].point["particle.static_friction"]
    notes = [n for n in first.notes if "stored tiny → quick bias" in n]
    assert bool(notes) is said and (not said or mu > 0.32)
    if said:
        assert notes == [f"inside: the first production point lies outside the points the stored tiny → quick "
                         f"bias of repose_angle_deg was measured at (particle.static_friction {mu:g} (measured "
                         f"0.3 to 0.32)): its run tests an extrapolation of that bias, and the loop learns the "
                         f"bias from it"]


def test_no_move_left_but_the_window_in_reach_is_solved_at_the_edge(tmp_path):
    """box_moves = 0: the box reaches about 36.2 at most (with the learnt discrepancy),
    inside the window 37.3 ± 1.5 but not its middle half (36.55 up); the loop solves at
    the edge and verifies there instead of stopping, and says so."""
    text = write(tmp_path, outside=37.3).read_text().replace("box_moves = 4", "box_moves = 0")
    path = tmp_path / "loop.toml"
    path.write_text(text)
    campaign = parse_campaign(text, path)
    run_campaign(campaign, progress=False, executor=inline())
    second = calibrate(campaign, progress=False, executor=inline()).conditions[1]
    assert any("box moves allowed are spent" in n and "solved at the box's edge" in n for n in second.notes)
    assert second.loop.status in ("verified", "out of reach"), second.loop.reason
    assert [s.stage for s in second.loop.history if s.stage == "production"]
    assert true_angle(*second.chosen.values()) > 36.0  # at the box's high edge


def test_the_path_looks_for_the_production_response_not_the_cheap_one(tmp_path):
    """Path points run at the cheap profile (here 3 deg below production). The target
    40.5 lies where the *production* response crosses it between path steps 2 and 3;
    the cheap responses alone never reach it on the path (they stop near 40), so a path
    that compared them with the lab target as they were would lay the new box at its
    last step (production about 42.6) instead. (verify_on_path off: the box is laid.)"""
    campaign, cal = calibrated(tmp_path, outside=40.5, calibration="verify_on_path = false\n")
    second = cal.conditions[1]
    (walk,) = [s for s in second.loop.history if s.stage == "path"]
    assert "at the tiny profile, read as" in walk.text and "at the quick profile" in walk.text
    cheap, production = (np.array([float(v) for v in re.findall(r"\d+\.\d+", part)])
                         for part in walk.text.split("gave ")[1].split(" at steps")[0].split("read as"))
    shift = production - cheap
    # the shift is the discrepancy learnt from the first condition: production - cheap = BIAS
    assert np.allclose(shift, shift[0]) and shift[0] == pytest.approx(BIAS, abs=0.6)
    assert cheap.max() < 40.5 < production.max()
    moved = second.loop.boxes[1]
    assert true_angle(*moved.centre) == pytest.approx(40.5, abs=1.2)
    assert second.loop.status == "verified", second.loop.reason
    assert second.loop.on_path is None


def test_a_target_the_path_crosses_is_verified_there_without_a_new_design(crossed, tmp_path):
    """The same target with verify_on_path (the default): the production runs go to the
    crossing, read off the path between steps 2 and 3, and meet the target there, so no
    box is laid (15 design runs saved); the result says it has no solution set."""
    campaign, cal = crossed
    second = cal.conditions[1]
    assert second.loop.status == "verified", second.loop.reason
    assert [b.index for b in second.loop.boxes] == [0]
    assert [s.stage for s in second.loop.history] == ["path"] + ["production"] * (len(second.loop.history) - 1)
    assert second.loop.on_path["steps"] == (2, 3) and second.loop.on_path["box"] == 0
    assert "on the path from box 0 (between steps 2 and 3)" in second.loop.history[1].text
    assert "no solution set" in second.loop.reason
    assert not any("nearest point" in n for n in second.notes)  # the old box's solve notes do not apply
    assert true_angle(*second.chosen.values()) == pytest.approx(40.5, abs=1.0)
    assert second.chosen["particle.static_friction"] > 0.5  # beyond the box
    assert second.factor_ranges == {} and np.isnan(second.desirability)
    (verdict,) = second.verdicts
    assert "on the path of steepest ascent" in verdict.confirmation  # no interval: no model there
    data = cal.to_dict()["conditions"][1]
    assert data["on_path"]["steps"] == [2, 3] and data["desirability"] is None
    assert data["chosen"] == second.chosen
    # replayed from the store (resume, `demcal report`): the same point, nothing run
    again = calibrate(campaign, simulate=False, progress=False).conditions[1]
    assert again.chosen == second.chosen and again.loop.on_path == second.loop.on_path
    from demcal.report.campaign_report import write_report

    html = write_report(campaign, tmp_path / "report", [cal], figure_files=False).read_text()
    assert "outside: verified at a point on the path of steepest ascent from box 0" in html
    assert "the target, on the path from box 0 (read off the path)" in html
    assert "Solving for inside" in html and "Solving for outside" not in html


@pytest.mark.parametrize("rule", [True, pytest.param(False, marks=SLOW)])
def test_a_path_that_reads_inside_the_window_without_crossing_is_verified_at_its_nearest_step(tmp_path,
                                                                                                monkeypatch, rule):
    """The response peaks in mu (curvature 40) just below the lab mean 38.7 ± 1.5: the
    path from box 0 reads 37.18, 37.98, 37.31, crossing nothing, its step 3 inside the
    window. The loop measures that step at the production profile first and is done
    (38.77, one run); without the rule it lays a 15-run box around the path's end."""
    from demcal.campaign import ascent

    if not rule:
        monkeypatch.setattr(ascent, "_nearest_in_window", lambda *args: None)
    campaign, cal = calibrated(tmp_path, outside=38.7, curvature=40.0, hard="ac")
    second = cal.conditions[1]
    assert second.loop.status == "verified", second.loop.reason
    if not rule:
        assert [s.stage for s in second.loop.history][:2] == ["path", "design"]
        return
    assert [(s.stage, s.runs) for s in second.loop.history] == [("path", 3), ("production", 1)]
    assert [b.index for b in second.loop.boxes] == [0]
    on_path = second.loop.on_path
    assert on_path["steps"] == (3, 3) and on_path["nearest"] and on_path["reading"] == pytest.approx(37.98, abs=0.01)
    assert "on the path from box 0 (step 3, its nearest to the target, read 37.98 inside the lab window)" in \
        second.loop.history[1].text
    assert "its step nearest the lab mean, which it did not cross" in second.loop.reason
    assert abs(second.loop.history[1].simulated - 38.7) <= 1.5
    again = calibrate(campaign, simulate=False, progress=False).conditions[1]  # replayed: the same
    assert again.chosen == second.chosen and again.loop.on_path == second.loop.on_path
    from demcal.report.campaign_report import write_report

    html = write_report(campaign, tmp_path / "report", [cal], figure_files=False).read_text()
    assert "the lab window, at the path&#39;s nearest step to the target from box 0 (read 37.98)" in html
    assert "outside: verified at the step of the path of steepest ascent from box 0 nearest the lab target" in html


@pytest.mark.slow  # 45-74 s; a missed point on the path lays its box in the fast suite too
def test_a_nearest_step_that_misses_lays_the_box_after_all(tmp_path):
    """The cheap bench's bias grows with mu (bias_slope 8), so the path reads 2-3 deg low:
    its nearest step, read 35.94 inside 36 ± 1.5, gives 38.99 at the production profile.
    The loop then lays the box the classic method lays, learns the discrepancy there and
    verifies on its corrected surface."""
    campaign, cal = calibrated(tmp_path, outside=36.0, curvature=40.0, hard="ac", bias_slope=8.0)
    second = cal.conditions[1]
    assert second.loop.status == "verified", second.loop.reason
    stages = [s.stage for s in second.loop.history]
    assert stages[:3] == ["path", "production", "design"] and second.loop.on_path is None
    assert "its nearest to the target, read 35.94 inside the lab window" in second.loop.history[1].text
    assert second.loop.history[1].simulated > 36.0 + 1.5  # the nearest step missed
    assert [b.index for b in second.loop.boxes] == [0, 1]
    assert abs(second.loop.history[-1].simulated - 36.0) <= 1.5


def test_a_crossing_after_a_failed_path_step_lays_the_box(tmp_path):
    """Step 2 of box 0's path fails (the double fails its seed) and step 3 crosses 40.5:
    the crossing is not bracketed by two readings, so nothing is verified on the path and
    the box is laid around it, as the classic method does (this crashed for a day in the
    nineteenth session, when the nearest-step rule was added)."""
    from demcal.campaign.seeds import PATH_SEED

    seed = 11 + PATH_SEED + 10 * 2  # [runs] seed + the path's offset + step 2 of box 0
    campaign, cal = calibrated(tmp_path, outside=40.5, fail_seed=seed)
    second = cal.conditions[1]
    assert second.loop.status == "verified", second.loop.reason
    assert [s.stage for s in second.loop.history][:2] == ["path", "design"]
    assert second.loop.on_path is None
    assert "the steepest path crossed it near" in second.loop.boxes[1].reason
    with Store(campaign.store_path, readonly=True) as store:
        assert [r.seed for r in store.records() if r.status == "failed"] == [seed]


def test_the_stored_noise_leaves_out_the_points_the_campaign_ran_and_can_be_switched_off(tmp_path):
    """A stored point whose settings the campaign's own production runs share counts once
    (its runs may be those very runs); `stored_noise = false` uses none."""
    import dataclasses

    from demcal.campaign.noise import production_noise, stored_noise
    from demcal.campaign.store import RunRecord

    path = write(tmp_path)
    campaign = parse_campaign(path.read_text(), path)
    base = dict(id=0, key="", kind="verification", label="v", test="test-fidelity", profile="quick",
                parameters={}, status="done", result={}, artifacts_dir=None, attempts=1, started_at=None,
                finished_at=None, wall_s=1.0, engine_version=None, error=None, owner=None, pid=None, host=None,
                heartbeat=None)
    mine = {"particle.static_friction": 0.4, "particle.restitution": 0.6, "test.sleep_s": 0.0}
    records = [RunRecord(**base, settings=mine, seed=s, responses={"angle": v}) for s, v in ((1, 30.0), (2, 31.0))]
    prior = {"angle": [({"particle.static_friction": 0.4}, 3, 2.0), ({"particle.static_friction": 0.5}, 3, 1.0)]}
    sd, df, own = production_noise(campaign, records, "quick", ["angle"], prior)["angle"]
    # own: one point, (30, 31): ss 0.5, df 1; the stored 0.5 point: ss 2 x 1.0^2, df 2; the 0.4 one left out
    assert (df, own) == (3, 1) and sd == pytest.approx(((0.5 + 2.0) / 3) ** 0.5)
    assert production_noise(campaign, records, "quick", ["angle"])["angle"][1:] == (1, 1)
    off = dataclasses.replace(campaign, calibration=dataclasses.replace(campaign.calibration, stored_noise=False))
    assert stored_noise(off, "paper", ["repose_angle_deg"]) == {}
    text = path.read_text().replace("box_moves = 4\n", "box_moves = 4\nstored_noise = false\n")
    assert parse_campaign(text, path).calibration.stored_noise is False


def test_a_stop_while_a_point_on_the_path_waits_names_that_point_and_no_runs(crossed, tmp_path):
    """The path point's production runs are not in the store (a calibration killed
    while they ran, replayed by `demcal report`): the condition stops unfinished at that
    point, with none of an earlier point's runs, and the report does not call it
    verified."""
    import sqlite3

    campaign, cal = crossed
    point = cal.conditions[1].chosen
    campaign = copied(campaign, tmp_path / "copy")  # the shared store stays whole
    with sqlite3.connect(campaign.store_path) as db:
        db.execute("DELETE FROM runs WHERE kind = 'verification' AND label LIKE 'verify outside%'")
    replay = calibrate(campaign, simulate=False, progress=False)
    second = replay.conditions[1]
    assert second.loop.status == "unfinished" and second.loop.on_path is not None
    assert second.chosen == point and second.verification == []
    from demcal.report.campaign_report import write_report

    html = write_report(campaign, tmp_path / "report", [replay], figure_files=False).read_text()
    assert "outside: the loop stopped at a point on the path" in html and "crosses the lab target. Unfinished" in html
    assert "outside: verified at a point" not in html
    assert "its loop stopped (unfinished) at a point on the path" in html  # the card's warning agrees


def test_a_point_on_the_path_that_misses_gets_its_box_after_all(tmp_path):
    """The cheap profile's bias grows beyond the box (test.bias_slope): the path, read
    with the bias learnt near the box, crosses 40.5 where production is about 2 deg
    higher (42.9); that point misses, so the new box's design is laid around the crossing and
    the loop goes on from it with what the point taught."""
    campaign, cal = calibrated(tmp_path, outside=40.5, bias_slope=4.0)
    second = cal.conditions[1]
    stages = [s.stage for s in second.loop.history]
    assert stages[:3] == ["path", "production", "design"], stages
    first = second.loop.history[1]
    assert "on the path from box 0" in first.text and abs(first.simulated - 40.5) > 1.5
    assert len(second.loop.boxes) >= 2 and second.loop.on_path is None
    assert second.loop.status == "verified", second.loop.reason
    assert true_angle(*second.chosen.values()) == pytest.approx(40.5, abs=1.5)


def test_a_path_that_turns_back_into_an_earlier_box_ends_the_moves(tmp_path):
    """The response peaks in mu within reach (test.curvature 40: at mu 0.71, at most
    about 39 deg with e and mu_r at their hard limits) and the target 45 lies above it.
    The path from box 0 ends beyond the peak; box 1's path leads back toward box 0 and
    reads no higher than box 1 reaches itself. Instead of laying box 0 again (and box 1
    after it, until the moves are spent), the loop stops there, out of reach, and says
    why."""
    campaign, cal = calibrated(tmp_path, outside=45.0, curvature=40.0, hard="ac")
    second = cal.conditions[1]
    assert second.loop.status == "out of reach", second.loop.reason
    assert "no higher than box 1 reaches itself" in second.loop.reason
    assert "the response peaks in box 1, so no box is laid beyond it" in second.loop.reason
    assert [s.stage for s in second.loop.history] == ["path", "design", "path"]
    assert [b.index for b in second.loop.boxes] == [0, 1]
    peak = max(true_angle(e, mu, mu_r, 40.0) for e in (0.75,) for mu in np.linspace(0.3, 1.2, 91) for mu_r in (0.35,))
    assert peak < 45.0 - 1.5


@pytest.mark.parametrize("edit, message", [
    (("production = \"quick\"", "production = \"paper\""),
     "loop.toml line 49: 'production' = 'paper' is not known; choose one of: tiny, quick."),
    (("box_moves = 4", "box_moves = 4\n[budget]\nruns = 0"), "loop.toml line 52: 'runs' must be at least 1, got 0."),
    (("box_moves = 4", "box_moves = 4\nmin_replicates = 3"),
     "loop.toml line 51: 'min_replicates' (3) is above the first production replicates (2); lower it or "
     "raise [calibration] replicates."),
    (("high = 0.5\n", "high = 0.5\nhard_high = 0.45\n"),
     "loop.toml line 20: factor 'particle.static_friction' has hard_high 0.45, which excludes part of its "
     "design box (0.3 to 0.5); hard limits must contain low and high."),
])
def test_bad_loop_settings_are_one_sentence(tmp_path, edit, message):
    text = write(tmp_path).read_text()
    assert edit[0] in text
    text = text.replace(edit[0], edit[1], 1)
    with pytest.raises(ConfigError) as info:
        parse_campaign(text, tmp_path / "loop.toml")
    assert str(info.value) == message


def _files(folder: Path) -> dict[str, bytes]:
    return {str(f.relative_to(folder)): f.read_bytes() for f in sorted(folder.rglob("*")) if f.is_file()}


@pytest.fixture(scope="module")
def designed(tmp_path_factory):
    """``write``'s campaign with its design runs done (no calibration yet)."""
    path = write(tmp_path_factory.mktemp("designed"))
    campaign = parse_campaign(path.read_text(), path)
    assert run_campaign(campaign, progress=False, executor=inline()).done == 15
    return campaign


@pytest.mark.parametrize("edit, args, message", [
    (('production = "quick"', 'production = "huge"'), [], "'production' = 'huge' is not known; choose one of: tiny, quick"),
    (None, ["--production", "huge"], "unknown profile 'huge' for test-fidelity; choose one of: tiny, quick."),
    (("box_moves = 4", "box_moves = 4\n[budget]\nruns = 0"), [], "'runs' must be at least 1, got 0."),
    (("box_moves = 4", "box_moves = 4\n[budget]\ncpu_hours = 0"), [], "'cpu_hours' must be positive, got 0"),
    (("high = 0.5\n", "high = 0.5\nhard_high = 0.45\n"), [], "hard limits must contain low and high."),
])
def test_bad_loop_input_exits_2_and_keeps_the_store(designed, tmp_path, edit, args, message):
    """Issue 17's bad inputs, through the command a user types: one sentence on stderr,
    exit status 2, no traceback, and the store of the campaign's finished runs byte for
    byte as it was."""
    campaign = copied(designed, tmp_path / "copy")  # each case edits its own copy
    path = campaign.path
    store = Path(campaign.store_path)
    folder = store if store.is_dir() else store.parent
    before = _files(folder)
    assert before
    if edit is not None:
        assert edit[0] in path.read_text()
        path.write_text(path.read_text().replace(edit[0], edit[1], 1))
    proc = subprocess.run([sys.executable, "-m", "demcal", "calibrate", str(path), *args],
                          capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert message in proc.stderr
    assert _files(folder) == before


def test_sigkill_mid_loop_resumes_without_rerunning(looped, tmp_path):
    """Kill `demcal calibrate` while the loop runs; the resumed loop runs no finished run
    again and ends where an uninterrupted one (``looped``: the same campaign file in a
    folder of its own) ends."""
    path = write(tmp_path, sleep=0.05)
    campaign = parse_campaign(path.read_text(), path)
    run_campaign(campaign, workers=1, progress=False)
    markers = tmp_path / "markers"
    markers.mkdir()
    env = dict(os.environ, DEMCAL_TEST_MARKERS=str(markers))
    proc = subprocess.Popen([sys.executable, "-m", "demcal", "calibrate", str(path), "--quiet"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 120
    while len(list(markers.iterdir())) < 12 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert proc.poll() is None, "the loop ended before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    with Store(campaign.store_path, readonly=True) as store:
        finished = {r.key for r in store.records() if r.status == "done"}
        tags = {f"{r.profile}-{r.seed}-" + "-".join(f"{r.parameters[p]:.4f}" for p in
                (f.parameter for f in campaign.factors)) for r in store.records() if r.key in finished}
    before = set(markers.iterdir())
    resumed = calibrate(campaign, workers=1, progress=False)
    again = {p.name.rsplit(".", 1)[0] for p in set(markers.iterdir()) - before}
    assert not (again & tags), "a finished run ran again"
    assert [c.loop.status for c in resumed.conditions] == ["verified", "verified"]
    fresh_campaign, fresh = looped
    assert fresh_campaign.path.read_text() == path.read_text()
    assert [c.chosen for c in resumed.conditions] == [c.chosen for c in fresh.conditions]


def test_discrepancy_is_a_bias_then_a_gaussian_process():
    from demcal.campaign.loop import Box, CorrectedSurface, Discrepancy

    rng = np.random.default_rng(0)
    few = [(np.zeros(3), 3.1), (np.zeros(3), 2.9)]
    d = Discrepancy(few)
    assert d.kind == "additive" and d(np.zeros(3)) == (pytest.approx(3.0), pytest.approx(0.1))
    # a discrepancy that grows along the first factor, seen at k + 2 = 5 or more points
    pts = rng.uniform(-1, 1, (12, 3))
    d = Discrepancy([(p, 3.0 + 1.5 * p[0]) for p in pts])
    assert d.kind == "gaussian process" and d.distinct == 12
    mean, sd = d(np.array([0.5, 0.0, 0.0]))
    assert mean == pytest.approx(3.75, abs=0.15) and sd < 0.5

    class Flat:  # a cheap model that predicts 30 everywhere
        factors, response, y = (), "r", np.array([30.0])

        def predict(self, x):
            x = np.asarray(x, float)
            return np.full(len(x), 30.0) if x.ndim == 2 else 30.0

        def gradient(self, x):
            return np.zeros_like(np.asarray(x, float))

    box0 = Box(0, (0.5, 0.3, 0.1), (0.7, 0.5, 0.3))
    moved = Box(1, (0.6, 0.3, 0.1), (0.8, 0.5, 0.3))  # box 0 moved by one half-width... twice
    surface = CorrectedSurface(Flat(), d, moved, box0)
    # coded 0 in the moved box is coded +1 along the first factor of box 0
    assert surface.predict(np.zeros(3)) == pytest.approx(30.0 + 3.0 + 1.5, abs=0.2)
    assert surface.gradient(np.zeros(3))[0] == pytest.approx(1.5, abs=0.3)
    assert surface.y[0] == pytest.approx(30.0 + d.bias)


def test_the_limits_stop_the_path_but_the_box_reaches_the_window_so_it_is_solved_at_its_edge(tmp_path):
    """Hard limits on every factor: from box 1 the path cannot move at all, and box 1
    reaches about 39 deg, into the window 40.5 ± 1.5 but not its middle half. The loop
    solves at the box's edge and verifies there (39.7 at the limits' corner), as when the
    moves are spent, instead of calling the target out of reach; a target whose window
    the box does not reach (45, the test above) still stops plainly."""
    campaign, cal = calibrated(tmp_path, outside=40.5, hard=True)
    second = cal.conditions[1]
    assert second.loop.status == "verified", second.loop.reason
    assert any("the parameters' limits stop the path from it, so box 1 reaches" in n
               and "solved at the box's edge" in n for n in second.notes), second.notes
    assert [s.stage for s in second.loop.history if s.stage == "production"]
    assert second.loop.on_path is None and [b.index for b in second.loop.boxes] == [0, 1]
    assert abs(np.mean(second.verdicts[0].simulated) - 40.5) <= 1.5


@pytest.mark.parametrize("mean, slope, outcome", [(40.5, 0.0, "verified"), (41.5, -5.0, "missed"),
                                                   pytest.param(45.0, 0.0, "not measured", marks=SLOW)])
def test_the_paths_end_at_the_limits_is_measured_when_the_window_is_within_its_noise(tmp_path, mean, slope,
                                                                                    outcome):
    """Five path points: the path from box 0 ends at the hard limits' corner (true angle
    39.7), read there as 39.4 at the production profile. A window 40.5 ± 1 lies within
    that reading's noise: the point is measured at production before the target is
    called out of reach, and meets it (no box laid, no solution set). With the cheap
    profile's bias shrinking as mu grows (slope -5) the path reads 40.3 there, within the
    noise of 41.5 ± 1, and the production runs (40.0) miss: out of reach, with that
    figure. For 45 ± 1 the window is beyond the noise, and the loop stops as before,
    with no production run."""
    path = write(tmp_path, outside=mean, hard=True, bias_slope=slope, calibration="path_points = 5\n")
    text = path.read_text().replace(f"mean = {mean}, sd = 1.5", f"mean = {mean}, sd = 1.0")
    assert text != path.read_text()
    path.write_text(text)
    campaign = parse_campaign(text, path)
    run_campaign(campaign, progress=False, executor=inline())
    cal = calibrate(campaign, progress=False, executor=inline())
    second = cal.conditions[1]
    production = [s for s in second.loop.history if s.stage == "production"]
    if outcome == "not measured":
        assert second.loop.status == "out of reach" and not production
        assert "the steepest path from box 0 ends at the limits" in second.loop.reason
        return
    if outcome == "missed":
        assert second.loop.status == "out of reach" and len(production) == 1
        assert re.search(r"the steepest path from box 0 ends at the limits at 40\.\d\d; its production runs there "
                         r"gave (\d+\.\d\d), outside 41\.5 ± 1$", second.loop.reason), second.loop.reason
        assert second.loop.on_path["limit"] and [b.index for b in second.loop.boxes] == [0]
        assert abs(np.mean(second.verdicts[0].simulated) - true_angle(0.75, 0.6, 0.35)) < 0.6
        return
    assert second.loop.status == "verified", second.loop.reason
    assert [b.index for b in second.loop.boxes] == [0]
    assert "at the end of the path of steepest ascent from box 0, where the parameters' limits stop it" \
        in second.loop.reason
    assert second.loop.on_path["limit"] and second.loop.on_path["steps"] == (5, 5)
    assert second.chosen == {"particle.restitution": 0.75, "particle.static_friction": 0.6,
                             "particle.rolling_friction": 0.35}
    assert "at the end of the path from box 0 (step 5, at the parameters' limits)" in production[0].text
    (verdict,) = second.verdicts
    assert verdict.predicted == pytest.approx(second.loop.on_path["reading"]) and verdict.predicted < 39.5
    assert "the end of the path of steepest ascent" in verdict.confirmation
    again = calibrate(campaign, simulate=False, progress=False).conditions[1]
    assert again.chosen == second.chosen and again.loop.on_path == second.loop.on_path
    assert (again.loop.status, again.loop.reason) == (second.loop.status, second.loop.reason)
    from demcal.report.campaign_report import write_report

    html = write_report(campaign, tmp_path / "report", [cal], figure_files=False).read_text()
    assert "outside: verified at the end of the path of steepest ascent from box 0: its step 5" in html
    assert "the nearest the test reaches: the end of the path from box 0" in html


@pytest.mark.parametrize("outside, verified", [(36.5, True), pytest.param(40.0, False, marks=SLOW)])
def test_a_path_that_falls_from_the_box_edge_lays_no_box(tmp_path, outside, verified):
    """The response peaks in mu at the box's edge (curvature 125: at mu 0.5), so no step
    of the path from box 0 reads higher than the box reaches itself. The classic method
    follows a path only while it rises: no box is laid beyond the peak. Box 0 reaches
    about 35.65 deg, into the window 36.5 ± 1.5 (not its middle half): solved at its edge
    and verified there. The window 40 ± 1.5 lies beyond it: out of reach."""
    campaign, cal = calibrated(tmp_path, outside=outside, curvature=125.0)
    second = cal.conditions[1]
    assert [b.index for b in second.loop.boxes] == [0]
    path = [s for s in second.loop.history if s.stage == "path"]
    assert len(path) == 1 and "design" not in [s.stage for s in second.loop.history]
    if verified:
        assert second.loop.status == "verified", second.loop.reason
        assert any("no path leads on from it, so box 0 reaches" in n and "solved at the box's edge" in n
                   for n in second.notes), second.notes
        assert second.chosen["particle.static_friction"] == pytest.approx(0.5, abs=0.02)
        (verdict,) = second.verdicts
        assert abs(verdict.simulated_mean - outside) <= 1.5
    else:
        assert second.loop.status == "out of reach", second.loop.reason
        assert "beyond the box, no higher than box 0 reaches itself" in second.loop.reason
        assert "the response peaks in box 0" in second.loop.reason
    again = calibrate(campaign, simulate=False, progress=False).conditions[1]  # replayed: the same
    assert again.loop.status == second.loop.status and again.chosen == second.chosen


@pytest.mark.parametrize("extra, limit", [("", 0.95), ("hard_high = 0.99\n", 0.99), ("hard_high = 0.8\n", 0.8)])
def test_restitution_stops_below_one_unless_the_factor_says_otherwise(tmp_path, extra, limit):
    """A path or a moved box takes restitution up to 0.95 at most (a granular material's
    restitution lies well below 1), or to the factor's own hard_high."""
    from demcal.campaign.box import physical_limits

    text = write(tmp_path).read_text().replace('parameter = "particle.restitution"\nlow = 0.5\nhigh = 0.7\n',
                                                'parameter = "particle.restitution"\nlow = 0.5\nhigh = 0.7\n' + extra)
    campaign = parse_campaign(text, tmp_path / "loop.toml")
    assert physical_limits(campaign, "tiny")[0, 1] == pytest.approx(limit)
