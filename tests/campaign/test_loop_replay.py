"""Stored demo campaigns replayed through the calibration loop decide exactly what they
decided when their fixture was made (``loop_replay.py``; ``tests/campaign/data/``).

``demo-repose-interrupted``: the repose demo stopped while the 14.1 % condition's
production runs were under way (6.26 % verified after three production points; 14.1 %
ran its path and waits for its production runs). The digest compares status, reason,
chosen values, verdict numbers, boxes, history, notes and every run the loop asked for,
floats to the bit: the same code on the same stored numbers.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from loop_replay import replay, same

DATA = Path(__file__).parent / "data"
FIXTURES = sorted(p.name for p in DATA.iterdir() if (p / "expected.json").is_file())


@pytest.mark.parametrize("name", FIXTURES)
def test_a_stored_campaign_replays_to_the_same_decisions(name, tmp_path, monkeypatch):
    fixture = DATA / name
    expected = json.loads((fixture / "expected.json").read_text())
    found = replay(fixture, tmp_path, monkeypatch)
    for want, got in zip(expected["conditions"], found["conditions"]):
        # the first difference, readably, before the whole digest's
        for key in want:
            assert json.dumps(got.get(key), sort_keys=True) == json.dumps(want[key], sort_keys=True), \
                (want["condition"], key)
    assert same(found, expected)
