"""The stored bias between bench profiles (demcal.bench.profiles)."""

import subprocess
import sys
from pathlib import Path

import pytest

from demcal.bench import profiles

ROOT = Path(__file__).resolve().parents[2]


def _row(profile, mu, value, seed=1):
    return {"test": "incline", "profile": profile, "seed": seed, "set": {"film.static_friction": mu},
            "responses": {"sliding_angle_deg": value}}


def test_bias_is_the_mean_difference_of_the_points_means():
    rows = [_row("quick", 0.4, 20.0), _row("quick", 0.4, 22.0), _row("paper", 0.4, 18.0),   # -3
            _row("quick", 0.6, 30.0, 1), _row("quick", 0.6, 30.0, 2), _row("paper", 0.6, 29.0),  # -1
            _row("quick", 0.5, 25.0)]  # no paper run: not a point
    b = profiles.measure("incline", "sliding_angle_deg", "quick", "paper", rows)
    assert b.bias == pytest.approx(-2.0)
    assert b.sd_points == pytest.approx(2 ** 0.5)  # sd of (-3, -1)
    assert b.se == pytest.approx(1.0)  # sqrt(2) / sqrt(2)
    assert len(b.points) == 2
    first = next(p for p in b.points if p["settings"] == {"film.static_friction": 0.4})
    assert (first["cheap_mean"], first["cheap_n"], first["production_n"]) == (21.0, 2, 1)
    assert first["production_sd"] is None


def test_one_point_is_not_a_bias():
    rows = [_row("quick", 0.4, 20.0), _row("paper", 0.4, 18.0), _row("quick", 0.6, 30.0)]
    with pytest.raises(ValueError, match="1 point"):
        profiles.measure("incline", "sliding_angle_deg", "quick", "paper", rows)


def test_a_bias_applies_only_to_material_settings():
    assert profiles.applies({}) == []
    assert profiles.applies({"particle.restitution": 0.6, "film.static_friction": 0.5}) == []
    assert profiles.applies({"particles.count": 3000, "film.restitution": 0.5}) == ["particles.count"]


def test_the_stored_file_is_what_the_studies_give():
    """benchmarks/profile_bias.py --check: the package's numbers come from the committed runs."""
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "profile_bias.py"), "--check"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_stored_lookup():
    b = profiles.stored("incline", "sliding_angle_deg", "quick", "paper")
    assert b.production == "paper" and len(b.points) >= 2 and b.bias < 0
    assert "stored quick → paper bias" in b.describe()
    assert profiles.stored("incline", "sliding_angle_deg", "paper", "quick") is None


@pytest.mark.slow
def test_the_quick_incline_still_gives_the_stored_points():
    """The stored quick -> paper bias holds while the quick profile gives what it gave
    when the bias was measured: five seeds at each stored point, mean within 1 deg
    (or two standard errors of the stored mean, if larger)."""
    from demcal.bench.registry import get_experiment

    bias = profiles.stored("incline", "sliding_angle_deg", "quick", "paper")
    incline = get_experiment("incline")
    for point in bias.points:
        values = [incline.run(point["settings"], seed=s, profile="quick").responses["sliding_angle_deg"]
                  for s in range(1, 1 + point["cheap_n"])]
        mean = sum(values) / len(values)
        tolerance = max(1.0, 2 * point["cheap_sd"] / point["cheap_n"] ** 0.5)
        print(f"{point['settings']}: {mean:.2f} now, {point['cheap_mean']:.2f} stored")
        assert abs(mean - point["cheap_mean"]) < tolerance
