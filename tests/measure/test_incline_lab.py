"""Inclined-plane readings and lab records."""

import numpy as np
import pytest

from demcal.errors import ConfigError, DataError
from demcal.measure.incline import measure_incline, sliding_angle
from demcal.measure.lab import LabRecord, SieveTable, paper_records, resolve_targets
from demcal.measure.summary import summarize


def test_sliding_angle_is_arcsin_h_over_l():
    # theta = arcsin(H/L), IJABE 2020 Eq. 5; H = 150 mm on L = 300 mm is 30 deg exactly
    assert sliding_angle([150.0], 300.0)[0] == pytest.approx(30.0, abs=1e-12)
    assert sliding_angle(300.0 * np.sin(np.radians(25.42)))[0] == pytest.approx(25.42)


def test_a_level_height_h0_is_taken_off_each_reading():
    # a point L from the spindle stands H0 + L sin(theta) above the base: 171.2 mm with
    # H0 = 21.2 mm on L = 300 mm is 30 deg exactly, where Eq. 5 alone reads 34.79 deg
    assert sliding_angle([171.2], 300.0, 21.2)[0] == pytest.approx(30.0, abs=1e-12)
    assert sliding_angle([171.2], 300.0)[0] == pytest.approx(np.degrees(np.arcsin(171.2 / 300.0)))
    m = measure_incline([171.2, 171.2], 300.0, H0_mm=21.2)
    assert m.mean_deg == pytest.approx(30.0) and m.to_dict()["H0_mm"] == 21.2
    assert measure_incline([150.0]).to_dict()["H0_mm"] == 0.0


@pytest.mark.parametrize("H, H0, match", [([20.0], 21.2, "between H0 and H0 \\+ L \\(21.2 and 321.2 mm\\)"),
                                          ([322.0], 21.2, "between H0 and H0"),
                                          ([100.0], -1.0, "H0 = -1.0 mm must be 0 or more")])
def test_readings_outside_the_level_height_and_arm_are_data_errors(H, H0, match):
    with pytest.raises(DataError, match=match):
        sliding_angle(H, 300.0, H0)


def test_groups_of_repeats_summarise_group_means():
    H = 300 * np.sin(np.radians([24, 25, 26, 27, 28, 29]))
    m = measure_incline(H, 300.0, repeats=3)
    assert m.n == 2
    np.testing.assert_allclose(m.group_means_deg, [25.0, 28.0], atol=1e-9)
    assert m.mean_deg == pytest.approx(26.5)
    assert m.sd_deg == pytest.approx(np.std([25.0, 28.0], ddof=1))
    flat = measure_incline(H)
    assert flat.n == 6 and flat.group_means_deg is None


@pytest.mark.parametrize("H", [[301.0], [-1.0], [np.nan]])
def test_impossible_readings_are_data_errors(H):
    with pytest.raises(DataError, match="between 0 and L"):
        sliding_angle(H, 300.0)


def test_readings_not_splitting_into_groups():
    with pytest.raises(DataError, match="groups of 3"):
        measure_incline([100, 110, 120, 130], repeats=3)


def test_summary_confidence_interval():
    # scipy reference: stats.t.ppf(0.975, 4) = 2.7764451051977987
    s = summarize([1.0, 2.0, 3.0, 4.0, 5.0])
    half = 2.7764451051977987 * np.std([1, 2, 3, 4, 5], ddof=1) / np.sqrt(5)
    assert (s.mean, s.n) == (3.0, 5)
    assert s.ci_low == pytest.approx(3 - half) and s.ci_high == pytest.approx(3 + half)


def test_paper_records_sieve_tables_sum_to_100():
    rec = paper_records()
    assert rec["L"].repose.mean_deg == 31.07 and rec["I"].sliding.mean_deg == 30.46
    for r in rec.values():
        assert r.sieve.fractions.sum() == pytest.approx(1.0)
        assert r.sieve.edges_mm[-1] == np.inf and r.sieve.lower_mm[0] == 0.0


def test_sieve_table_validation():
    with pytest.raises(DataError, match="sum to 90.00"):
        SieveTable([0, 1, 2], [40, 50])
    with pytest.raises(DataError, match="one more class bound"):
        SieveTable([0, 1], [40, 60])
    with pytest.raises(DataError, match="increasing"):
        SieveTable([0, 2, 1], [40, 60])


def test_record_from_dict_and_targets(tmp_path):
    d = {"name": "L", "moisture_percent": 6.26, "bulk_density": 1697.95,
         "sieve": {"edges_mm": [0, 0.25, 5, float("inf")], "mass_percent": [20, 70, 10]},
         "repose": {"mean_deg": 31.07, "sd_deg": 2.1, "n": 20},
         "sliding": {"H_mm": [128.0, 131.0, 127.0], "L_mm": 300}}
    rec = LabRecord.from_dict(d)
    assert rec.sieve.fractions.tolist() == [0.2, 0.7, 0.1]
    targets = resolve_targets(rec)
    assert targets["repose_angle_deg"].mean_deg == 31.07
    assert targets["sliding_angle_deg"].mean_deg == pytest.approx(
        np.degrees(np.arcsin(np.array([128, 131, 127]) / 300)).mean())
    level = resolve_targets(LabRecord.from_dict({**d, "sliding": {**d["sliding"], "H0_mm": 20.0}}))
    assert level["sliding_angle_deg"].mean_deg == pytest.approx(
        np.degrees(np.arcsin((np.array([128, 131, 127]) - 20.0) / 300)).mean())
    assert (targets["sliding_angle_deg"].source, level["sliding_angle_deg"].source) == (
        "incline readings", "incline readings, H0 20 mm")


@pytest.mark.parametrize("d, key", [
    ({"moisture_percent": 5}, "name"),
    ({"name": "x", "moisture": 5}, "moisture"),
    ({"name": "x", "bulk_density": -3}, "bulk_density"),
    ({"name": "x", "bulk_density": "heavy"}, "bulk_density"),
    ({"name": "x", "sieve": {"edges_mm": [0, 1]}}, "sieve.mass_percent"),
    ({"name": "x", "sieve": {"edges_mm": [0, 1, 2], "mass_percent": [10, 10]}}, "sieve"),
    ({"name": "x", "repose": {"sd_deg": 2}}, "mean_deg"),
    ({"name": "x", "repose": {"mean_deg": 30, "photos": ["a.png"]}}, "photos"),
    ({"name": "x", "sliding": {"mean_deg": 95}}, "mean_deg"),
    ({"name": "x", "sliding": {"H_mm": [1, "a"]}}, "H_mm"),
    ({"name": "x", "sliding": {"H_mm": [100], "H0_mm": -2}}, "H0_mm"),
])
def test_record_errors_name_the_key(d, key):
    with pytest.raises(ConfigError, match=key):
        LabRecord.from_dict(d, where="[lab.x]")
