"""A lab record of rotating-drum readings (dynamic angle per speed) and a drum campaign's
target taken from it at the campaign's drum.rpm."""

import math

import pytest

from demcal.campaign.config import load_campaign
from demcal.errors import ConfigError, DataError
from demcal.measure.lab import LabRecord, drum_reading, resolve_targets

DRUM = {"rpm": [2, 5, 10], "mean_deg": [33.0, 35.5, 38.0], "sd_deg": [1.2, 1.4, 1.5], "n": 5}


def test_drum_readings_are_read_and_written_back():
    record = LabRecord.from_dict({"name": "S", "drum": DRUM})
    assert [r.rpm for r in record.drum] == [2.0, 5.0, 10.0]
    five = drum_reading(record, 5)
    assert (five.angle.mean_deg, five.angle.sd_deg, five.angle.n) == (35.5, 1.4, 5)
    assert record.to_dict()["drum"][2] == {"rpm": 10.0, "mean_deg": 38.0, "sd_deg": 1.5, "n": 5, "source": "given"}
    assert resolve_targets(record, drum_rpm=10)["dynamic_angle_deg"].mean_deg == 38.0
    one = LabRecord.from_dict({"name": "S", "drum": {"rpm": [4], "mean_deg": [36.0]}})
    assert resolve_targets(one)["dynamic_angle_deg"].mean_deg == 36.0
    assert math.isnan(one.drum[0].angle.sd_deg)


@pytest.mark.parametrize("drum, words", [
    ({**DRUM, "mean_deg": [33.0, 35.5]}, "one entry per speed"),
    ({**DRUM, "rpm": [2, 2, 10]}, "each given once"),
    ({**DRUM, "rpm": [0, 5, 10]}, "must be > 0"),
    ({**DRUM, "mean_deg": [33.0, 95.0, 38.0]}, "outside its allowed range"),
    ({**DRUM, "speed": 3}, "unknown key 'speed'"),
    ({"mean_deg": [33.0]}, "'rpm' is missing"),
])
def test_bad_drum_records_are_one_sentence(drum, words):
    with pytest.raises(ConfigError) as err:
        LabRecord.from_dict({"name": "S", "drum": drum}, "[S]")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_speed_the_lab_did_not_measure_is_one_sentence():
    record = LabRecord.from_dict({"name": "S", "drum": DRUM})
    with pytest.raises(DataError, match="no drum reading at 7 rpm, only at 2, 5, 10 rpm"):
        drum_reading(record, 7)
    with pytest.raises(DataError, match="set drum.rpm"):
        drum_reading(record, None)


CAMPAIGN = """
[campaign]
name = "drum"
lab = "lab.toml"
[experiment]
test = "drum"
profile = "tiny"
[experiment.settings]
"drum.rpm" = 5
[[factors]]
parameter = "particle.static_friction"
low = 0.3
high = 0.7
[[factors]]
parameter = "particle.rolling_friction"
low = 0.05
high = 0.3
[design]
type = "full-factorial"
[[responses]]
name = "dynamic_angle_deg"
[[conditions]]
name = "S"
sample = "S"
"""

LAB = """
[S]
name = "S"
[S.drum]
rpm = [2, 5, 10]
mean_deg = [33.0, 35.5, 38.0]
sd_deg = [1.2, 1.4, 1.5]
n = 5
"""


def test_a_drum_campaign_takes_the_reading_at_its_speed(tmp_path):
    (tmp_path / "lab.toml").write_text(LAB)
    path = tmp_path / "drum.toml"
    path.write_text(CAMPAIGN)
    (target,) = load_campaign(path).conditions[0].targets
    assert (target.response, target.mean, target.sd) == ("dynamic_angle_deg", 35.5, 1.4)
    path.write_text(CAMPAIGN.replace('"drum.rpm" = 5', '"drum.rpm" = 7'))
    with pytest.raises(DataError, match="no drum reading at 7 rpm"):
        load_campaign(path)
