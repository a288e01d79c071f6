"""What a user reads of a calibration (issue 40, items 6 and 7).

* The loop's record (notes, stop reasons, history) as the terminal and the report show
  it (:mod:`demcal.campaign.wording`): on the demo's stored campaigns
  (``tests/campaign/data``, replayed as test_loop_replay does), no response key and no
  digit beyond what the lab sd supports; the record itself is unchanged (the replay test
  compares it to the bit).
* A lab sd below the simulation's seed noise is said in one sentence
  (:func:`demcal.campaign.calibrate.lab_noise_warnings`): below it, and silent above.
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from demcal.campaign import wording
from demcal.campaign.calibrate import calibrate, describe, lab_noise_warnings
from demcal.campaign.noise import production_noise
from demcal.campaign.store import Store
from demcal.rounding import decimals

from loop_replay import build

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module", params=["demo-repose", "demo-repose-interrupted", "demo-sliding"])
def demo(request, tmp_path_factory):
    """A demo's stored campaign, laid out and replayed (nothing simulated)."""
    campaign = build(DATA / request.param, tmp_path_factory.mktemp(request.param))
    return campaign, calibrate(campaign, simulate=False, progress=False)


def _user_texts(campaign, cal) -> list[str]:
    """Every sentence of the loop's record a user reads, as the terminal and the report say it."""
    texts = []
    for result in cal.conditions:
        words = wording.Words(campaign, result.condition)
        texts.append(wording.stop(campaign, result))
        texts += wording.notes(campaign, result)
        texts += [wording.step(campaign, result.condition, step) for step in result.loop.history]
        texts += [words.plain(box.reason) for box in result.loop.boxes]
    return texts


def test_the_notes_of_a_demo_read_without_keys_or_spare_digits(demo):
    campaign, cal = demo
    texts = _user_texts(campaign, cal)
    recorded = " ".join(n for r in cal.conditions for n in r.notes + [r.loop.reason])
    keys = [r.name for r in campaign.responses]
    assert any(key in recorded for key in keys) or not any(r.notes for r in cal.conditions)
    # every lab sd of the demo (2.1 to 3.2 deg) and every interval (1.5 to 3.6 deg) supports one decimal
    places = max(decimals(t.sd) for c in campaign.conditions for t in c.targets)
    assert places == 1
    parameters = "|".join(re.escape(f.parameter) for f in campaign.factors)
    for text in texts:
        assert not any(key in text for key in keys), text
        # the parameter values a stop names are the runs' own (three significant digits)
        shown = re.sub(rf"(?:{parameters}) = [\d.]+", "", text)
        assert all(len(d) <= places for d in re.findall(r"\d+\.(\d+)", shown)), text
        assert "with the discrepancy" not in text and text.endswith(".")
    for line in describe(cal).splitlines():
        if not re.match(r"\s+\w+ = [-\d.]+ [+-]", line):  # the model's equation names its response
            assert not any(key in line for key in keys), line


def test_the_box_edge_note_as_a_user_reads_it(tmp_path):
    """The issue's sentence, recorded and said."""
    campaign = build(DATA / "demo-repose", tmp_path)
    condition = campaign.conditions[1]
    recorded = ("14.1 %: no path leads on from it, so box 0 reaches repose_angle_deg 15.97 to 38.25 with the "
                "discrepancy, into the lab window 39.88 ± 2.2 but not its middle half: solved at the box's edge")
    said = wording.Words(campaign, condition).plain(recorded)
    assert said == ("Box 0 reaches at most 38.2° (angle of repose β), inside the lab's 39.9 ± 2.2° but not its "
                    "middle half; no path leads further, so the parameters are solved at the box's edge.")
    # a sentence no template knows keeps its words, with labels, units and rounded pairs
    other = wording.Words(campaign, condition).plain("repose_angle_deg = 39.881 drifts by 33.2085 ± 2.02636")
    assert other == "Angle of repose β 39.9° drifts by 33.2 ± 2.0°."


def _with_sd(campaign, sd: float):
    """The campaign with every lab sd set to ``sd``."""
    conditions = tuple(dataclasses.replace(c, targets=tuple(dataclasses.replace(t, sd=sd) for t in c.targets))
                       for c in campaign.conditions)
    return dataclasses.replace(campaign, conditions=conditions)


def test_a_lab_sd_below_the_seed_noise_is_said_once_and_one_above_is_not(tmp_path):
    campaign = build(DATA / "demo-repose", tmp_path)
    with Store(campaign.store_path, readonly=True) as store:
        records = store.records()
    # the seed noise of the quick funnel, pooled over every replicated point in the store
    sd, df, _ = production_noise(campaign, records, "quick", ["repose_angle_deg"], kinds=None)["repose_angle_deg"]
    # pooled by hand: each replicated point's sample variance weighted by its n - 1
    points: dict[str, list[float]] = {}
    for r in records:
        if r.status == "done" and r.profile == "quick" and "repose_angle_deg" in r.responses:
            points.setdefault(json.dumps(r.settings, sort_keys=True), []).append(r.responses["repose_angle_deg"])
    replicated = [np.asarray(v) for v in points.values() if len(v) > 1]
    by_hand_df = sum(len(v) - 1 for v in replicated)
    by_hand = np.sqrt(sum(((v - v.mean()) ** 2).sum() for v in replicated) / by_hand_df)
    assert df == by_hand_df >= 10 and sd == pytest.approx(by_hand, rel=1e-12)
    assert lab_noise_warnings(_with_sd(campaign, 1.01 * sd), records) == []
    assert lab_noise_warnings(campaign, records) == []  # the paper's 2.1 and 2.2 deg lie above it
    below = lab_noise_warnings(_with_sd(campaign, sd / 3), records)
    assert len(below) == len(campaign.conditions)
    for condition, text in zip(campaign.conditions, below):
        assert text.startswith(f"{condition.name}: the lab sd of the angle of repose β, ")
        assert "below the simulation's seed noise at profile quick" in text
        assert "more than [calibration] max_replicates (16) allows, so this target cannot be verified" in text
        assert "at least three tests" in text and "\n" not in text and text.endswith(".")
    # a little below: verifiable, with more runs
    (near, _) = lab_noise_warnings(_with_sd(campaign, 0.9 * sd), records)
    assert "verifying it takes about" in near and "cannot be verified" not in near
    (zero, _) = lab_noise_warnings(_with_sd(campaign, 0.0), records)
    assert "no number of runs verifies it" in zero


def test_the_warning_reaches_the_terminal_and_the_report_but_not_calibration_json(tmp_path):
    import json

    from demcal.report.campaign_report import _summary
    from demcal.report.html import HtmlReport

    campaign = _with_sd(build(DATA / "demo-repose", tmp_path), 0.3)
    cal = calibrate(campaign, simulate=False, progress=False)
    assert len(cal.lab_noise) == 2
    lines = describe(cal).splitlines()
    assert lines[:2] == [f"warning: {w}" for w in cal.lab_noise]
    summary = _summary(HtmlReport("t", tmp_path / "report"), cal, several=False)
    assert summary["warnings"][-2:] == cal.lab_noise
    assert "lab_noise" not in json.dumps(cal.to_dict()) and cal.lab_noise[0] not in json.dumps(cal.to_dict())


def test_the_stored_studies_give_the_noise_before_any_run(tmp_path):
    """The paper-profile incline's stored seed noise (0.74 deg over 22 df) against the guide's
    old example, 0.33 deg from two tests."""
    campaign = build(DATA / "demo-sliding", tmp_path)
    paper = dataclasses.replace(campaign, calibration=dataclasses.replace(campaign.calibration, production="paper"))
    (text, *_) = lab_noise_warnings(_with_sd(paper, 0.33), [])
    assert "seed noise at profile paper, 0.74° (22 degrees of freedom" in text
    assert lab_noise_warnings(_with_sd(paper, 2.6), []) == []
