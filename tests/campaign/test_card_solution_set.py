"""The material card carries the solution set: per condition the range of each calibrated
value over the settings that meet the lab targets on the fitted surface
(:mod:`demcal.export.solution`), in the JSON card, the LIGGGHTS comments and the EDEM
tables; a condition without one (verified on the path, no setting meeting the targets,
an older calibration.json) is said to have none.

The calibrations are calibration.json as written: the hand-written one of
tests/campaign/test_export.py and the demo's (tests/campaign/data/demo-sliding), which
`demcal calibrate` wrote.
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign
from demcal.cli import main
from demcal.export.card import build_card
from demcal.export.solution import DIGITS, THRESHOLD, outward
from tests.campaign.test_export import REPOSE_CALIBRATION, _calibrate, _card, _export

DEMO = Path(__file__).parent / "data" / "demo-sliding" / "repose-runs" / "calibration.json"

ON_PATH = {"point": {}, "steps": [], "way": "ascent", "reading": 39.5}


def _flat(text: str) -> str:
    return " ".join(line.lstrip("# ") for line in text.splitlines())


def test_the_threshold_is_the_one_the_calibration_solves_with():
    from demcal.optimize import optimize

    assert inspect.signature(optimize).parameters["threshold"].default == THRESHOLD


@pytest.mark.parametrize("value, down, expected", [
    (0.31573540898, True, 0.315), (0.49585535565, False, 0.496), (0.16045389162, False, 0.161),
    (0.52, False, 0.52), (0.7, True, 0.7), (0.0, True, 0.0), (9.996, False, 10.0), (2.3456e6, True, 2.34e6),
    (-0.1234, True, -0.124),
])
def test_ends_are_rounded_outward(value, down, expected):
    assert outward(value, down) == expected


@pytest.mark.parametrize("source", ["hand-written", "demo"])
def test_json_card_holds_each_calibrated_range_around_its_point(example, source):
    calibration = REPOSE_CALIBRATION if source == "hand-written" else json.loads(DEMO.read_text())
    card = build_card(load_campaign("repose.toml"), calibration)
    raw = {c["name"]: c for c in calibration["conditions"]}
    assert len(card["conditions"]) == 2
    for condition in card["conditions"]:
        ranges = condition["solution_set"]
        recorded = raw[condition["name"]]["factor_ranges"]
        assert set(ranges) == set(raw[condition["name"]]["chosen"]) | {"meaning"}
        for key, r in ranges.items():
            if key == "meaning":
                continue
            value = condition["parameters"][key]["value"]
            assert condition["parameters"][key]["source"] == "calibrated"
            assert r["low"] <= value <= r["high"], (key, value, r)
            assert r["unit"] == condition["parameters"][key]["unit"] == "-"
            low, high = recorded[key]  # rounded outward: the card's range holds calibration.json's
            assert r["low"] <= low and r["high"] >= high
            assert r["low"] == float(f"{r['low']:.{DIGITS}g}") and r["high"] == float(f"{r['high']:.{DIGITS}g}")
        # every digit stays in the record the card keeps as written
        assert condition["calibration"]["factor_ranges"] == recorded
    meaning = card["conditions"][0]["solution_set"]["meaning"]
    for words in ("last design box", f"desirability >= {THRESHOLD:g}", "within 1 %",
                  "not widened for the lab sd, the model's prediction interval or the seed noise",
                  "not every combination"):
        assert words in meaning
    assert not any("solution set" in w for w in card["warnings"])
    if source == "demo":  # the 14.1 % set of the demo, outward: 0.4438... -> 0.443, 0.4958... -> 0.496
        wet = card["conditions"][1]["solution_set"]["particle.static_friction"]
        assert (wet["low"], wet["high"]) == (0.443, 0.496)


def test_liggghts_and_edem_texts_carry_the_ranges(example, capsys):
    _calibrate(example, "repose", json.loads(DEMO.read_text()))
    ligg = _export(capsys, "repose.toml", "--format", "liggghts", "--condition", "14.1 %")
    flat = _flat(ligg)
    assert "solution set: each calibrated value with its range" in flat
    assert "not widened for the lab sd, the model's prediction interval or the seed noise" in flat
    # the comments as a reader reads them (demcal.rounding.ranged: the width's second digit)
    assert "\n#   particle.static_friction = 0.470, range 0.443 to 0.496\n" in ligg
    assert "\n#   particle.rolling_friction = 0.300, range 0.286 to 0.300\n" in ligg
    assert "\n#   particle.restitution = 0.60, range 0.50 to 0.70\n" in ligg
    assert all(line.startswith("#") for line in ligg.splitlines() if "range" in line)

    edem = _export(capsys, "repose.toml", "--format", "edem", "--condition", "14.1 %")
    assert "\n#   particle.static_friction = 0.470, range 0.443 to 0.496\n" in edem
    assert ("\n# low, high: the range of a calibrated value over its solution set (the comment at the top)\n"
            "Material 1,Material 2,Coefficient of Restitution,Coefficient of Restitution low,") in edem
    table = edem[edem.index("[Interactions]"):edem.index("[Particle")].splitlines()
    header, pp, pw = table[2].split(","), table[3].split(","), table[4].split(",")
    row = dict(zip(header, pp))
    assert (row["Coefficient of Static Friction"], row["Coefficient of Static Friction low"],
            row["Coefficient of Static Friction high"]) == ("0.47", "0.443", "0.496")
    assert (row["Damping Factor"], row["Damping Factor low"], row["Damping Factor high"]) == ("0.1", "0", "0.2")
    assert "Stiffness Factor low" not in header  # not calibrated: no range beside it
    wall = dict(zip(header, pw))
    assert wall["Material 2"] == "steel" and wall["Coefficient of Static Friction low"] == ""
    # the materials table holds no calibrated value: no range columns
    assert "Material,Poisson's Ratio,Solid Density (kg/m3),Shear Modulus (Pa),Yield Strength (Pa)\n" in edem


@pytest.mark.parametrize("edit, reason", [
    ({"factor_ranges": {}, "on_path": ON_PATH},
     "it was verified at a point on the path of steepest ascent, with no design around it, so the card "
     "gives one point and no ranges."),
    ({"factor_ranges": {}, "on_path": {**ON_PATH, "way": "descent", "limit": True}},
     "it was verified at the end of the path of steepest descent, with no design around it, so the card "
     "gives one point and no ranges."),
    ({"factor_ranges": {}},
     "no setting of its last design box meets every target on the model (desirability >= 0.99), so the card "
     "gives the box's best point and no ranges."),
    ({"factor_ranges": None},
     "calibration.json records no factor_ranges for it (written by an older demcal or by hand); calibrate "
     "again for the ranges."),
])
def test_a_condition_without_a_set_says_so_in_every_format(example, capsys, edit, reason):
    data = json.loads(json.dumps(REPOSE_CALIBRATION))
    data["conditions"][1].update(edit)
    if edit["factor_ranges"] is None:
        del data["conditions"][1]["factor_ranges"]
    _calibrate(example, "repose", data)
    said = f"condition '14.1 %' has no solution set: {reason}"
    card = _card(capsys, "repose.toml")
    assert card["conditions"][1]["solution_set"] is None
    assert card["conditions"][0]["solution_set"]["particle.static_friction"] == {"low": 0.298, "high": 0.335,
                                                                                 "unit": "-"}
    assert said in card["warnings"]
    assert main(["export", "repose.toml", "--format", "edem", "--condition", "14.1 %"]) == 0
    captured = capsys.readouterr()
    assert f"demcal: warning: {said}" in captured.err.splitlines()
    assert said in _flat(captured.out) and "solution set: none" in _flat(captured.out)
    assert "Coefficient of Restitution low" not in captured.out
    ligg = _export(capsys, "repose.toml", "--format", "liggghts", "--condition", "14.1 %")
    assert "solution set: none" in _flat(ligg) and said in _flat(ligg)
    # only the exported conditions are judged
    assert not any("no solution set" in w for w in _card(capsys, "repose.toml", "--condition", "6.26 %")["warnings"])
