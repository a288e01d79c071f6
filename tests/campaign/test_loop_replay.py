"""Stored demo campaigns replayed through the calibration loop decide exactly what they
decided when their fixture was made (``loop_replay.py``; ``tests/campaign/data/``).

* ``demo-repose-interrupted``: the repose demo stopped while the 14.1 % condition's
  production runs were under way (73 runs, some pending or running): 6.26 % verified
  after three production points; 14.1 % ran its path and stops unfinished.
* ``demo-repose``: the full demo's repose campaign (48 runs): 6.26 % verified after
  three production points; 14.1 %'s path leads nowhere, so box 0 is solved at its edge
  and verified there.
* ``demo-sliding``: the full demo's sliding campaign (49 runs), whose conditions take
  the particle values repose calibrated (its ``calibration.json``): 6.26 % verified;
  14.1 % verified at a point on the path of steepest ascent.

The digest compares status, reason, chosen values, verdict numbers, boxes, history,
notes and every run the loop asked for, floats to the bit: the same code on the same
stored numbers.
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
    expected.pop("campaign", None)  # the campaign file replayed
    found = replay(fixture, tmp_path, monkeypatch)
    for want, got in zip(expected["conditions"], found["conditions"]):
        # the first difference, readably, before the whole digest's
        for key in want:
            assert json.dumps(got.get(key), sort_keys=True) == json.dumps(want[key], sort_keys=True), \
                (want["condition"], key)
    assert same(found, expected)
