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
    rows = [_row("quick", 0.4, 20.0), _row("quick", 0.4, 22.0, 2), _row("paper", 0.4, 18.0),   # -3
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


def test_the_same_run_in_two_files_counts_once():
    rows = [_row("quick", 0.4, 20.0), _row("quick", 0.4, 22.0, 2), _row("paper", 0.4, 18.0),
            _row("quick", 0.6, 30.0), _row("paper", 0.6, 29.0)]
    again = rows + [_row("quick", 0.4, 20.0), _row("paper", 0.6, 29.0)]
    one = profiles.measure("incline", "sliding_angle_deg", "quick", "paper", rows)
    two = profiles.measure("incline", "sliding_angle_deg", "quick", "paper", again)
    assert one == two and one.points[0]["cheap_n"] == 2


def _funnel(profile, gamma, mu, value, seed=1):
    return {"test": "repose-funnel", "profile": profile, "seed": seed,
            "set": {"particle.rolling_friction": gamma, "particle.static_friction": mu},
            "responses": {"repose_angle_deg": value}}


def test_a_difference_that_follows_a_setting_is_stored_as_a_slope_in_it():
    """paper - quick = 10 - 100 (gamma - 0.2) exactly plus a scatter of +-0.5 that does not
    follow mu: the F-test takes gamma, not mu, and the model gives the bias back."""
    pts = [(0.1, 0.4, +0.5), (0.1, 0.5, -0.5), (0.2, 0.4, -0.5), (0.2, 0.5, +0.5), (0.3, 0.4, +0.5),
           (0.3, 0.5, -0.5)]
    rows = []
    for gamma, mu, noise in pts:
        rows += [_funnel("quick", gamma, mu, 30.0), _funnel("paper", gamma, mu, 30.0 + 10 - 100 * (gamma - 0.2) + noise)]
    b = profiles.measure("repose-funnel", "repose_angle_deg", "quick", "paper", rows)
    assert b.terms == ("particle.rolling_friction",)
    assert b.reference == {"particle.rolling_friction": pytest.approx(0.2)}
    assert b.bias == pytest.approx(10.0) and b.slopes[0] == pytest.approx(-100.0)
    assert b.sd_resid == pytest.approx((6 * 0.25 / 4) ** 0.5)  # six residuals of 0.5, 4 dof
    mean, sd = b.at({"particle.rolling_friction": 0.3, "particle.static_friction": 0.5})
    assert mean == pytest.approx(0.0)
    # at the reference the sd is the intercept's se and the scatter combined
    assert b.at({})[1] == pytest.approx((b.se ** 2 + b.sd_resid ** 2) ** 0.5)
    assert sd > b.at({})[1]  # further from the points' centre, less sure
    assert "-10.0° per 0.1 of particle.rolling_friction" in b.describe()


def test_a_slope_the_points_do_not_resolve_stays_a_constant():
    rows = []
    for i, (gamma, d) in enumerate([(0.1, -1.0), (0.2, 1.0), (0.3, -1.2), (0.1, 0.9), (0.3, 1.1)]):
        rows += [_funnel("quick", gamma, 0.4 + 0.01 * i, 30.0), _funnel("paper", gamma, 0.4 + 0.01 * i, 30.0 + d)]
    b = profiles.measure("repose-funnel", "repose_angle_deg", "quick", "paper", rows)
    assert b.terms == () and b.at({"particle.rolling_friction": 0.3})[0] == pytest.approx(b.bias)


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


def test_the_funnel_bias_is_stored_as_a_slope_in_the_rolling_friction():
    """With type A rolling the paper-profile heap falls where the quick heap rises with
    gamma (docs/validation.md): the stored funnel bias says so, and at gamma 0.1 and 0.3
    it has opposite signs."""
    b = profiles.stored("repose-funnel", "repose_angle_deg", "quick", "paper")
    assert b is not None and b.terms == ("particle.rolling_friction",) and len(b.points) >= 5
    assert b.slopes[0] < -50  # degrees per unit of gamma: about -13 deg per 0.1
    assert b.at({"particle.rolling_friction": 0.1})[0] > 5 > -5 > b.at({"particle.rolling_friction": 0.3})[0]


def test_the_cylinder_bias_is_stored_and_changes_sign_with_the_rolling_friction():
    """The lifted cylinder shares the funnel's reversal at the paper profile
    (docs/validation-repose.md, "The lifted cylinder"): paper - quick is negative at gamma
    0.2 and positive at gamma 0.1, five quick seeds against one paper run a point."""
    b = profiles.stored("repose-cylinder", "repose_angle_deg", "quick", "paper")
    assert b is not None and len(b.points) >= 3
    assert all(p["cheap_n"] == 5 and p["production_n"] == 1 for p in b.points)
    by_gamma = {}
    for p in b.points:
        by_gamma.setdefault(p["settings"].get("particle.rolling_friction", 0.2), []).append(
            p["production_mean"] - p["cheap_mean"])
    assert max(by_gamma[0.2]) < 0 < min(by_gamma[0.1])
    assert b.sd_points > 3  # the report and the loop carry that spread as the bias's uncertainty


def test_the_stored_studies_measure_the_paper_incline_noise_once_per_point():
    """The paper-profile incline's seeds in the stored studies: 0.74 deg pooled over 22 df
    (eleven points of three seeds). quick -> paper and medium -> paper share their paper
    points; each counts once."""
    import math

    sd, df, runs = profiles.stored_noise("incline", "sliding_angle_deg", "paper")
    assert df == 22 and runs == 33 and sd == pytest.approx(0.738, abs=0.005)
    one = profiles.stored("incline", "sliding_angle_deg", "quick", "paper")
    pts = [p for p in one.points if (p["production_n"] or 0) > 1]
    assert df == sum(p["production_n"] - 1 for p in pts)
    assert sd == pytest.approx(math.sqrt(sum((p["production_n"] - 1) * p["production_sd"] ** 2 for p in pts) / df))
    assert math.isnan(profiles.stored_noise("repose-funnel", "repose_angle_deg", "paper")[0])  # one seed a point
    assert profiles.stored_noise("incline", "sliding_angle_deg", "quick")[1] == 0  # no study's production


@pytest.mark.slow
@pytest.mark.parametrize("test, response, cheap, first", [("incline", "sliding_angle_deg", "quick", None),
                                                          ("repose-funnel", "repose_angle_deg", "quick", None),
                                                          ("repose-cylinder", "repose_angle_deg", "quick", None),
                                                          ("incline", "sliding_angle_deg", "medium", 3)])
def test_the_cheap_profile_still_gives_the_stored_points(test, response, cheap, first):
    """A stored quick (or medium) -> paper bias holds while that profile gives what it
    gave when the bias was measured: at each stored point, the seeds it was measured with.

    An engine change that only reorders sums (docs/validation.md, "Seed-to-seed spread")
    gives each seed a new realisation of the same flow, so the new mean is compared with
    the stored one as two independent means of n seeds: each point's difference within
    two standard errors of the difference (at least 1 deg), and the mean difference
    over all points, which a systematic shift of the profile would move, within two
    standard errors of that mean (about 0.6 deg for the incline's seven points)."""
    from statistics import mean, stdev

    from demcal.bench.registry import get_experiment

    bias = profiles.stored(test, response, cheap, "paper")
    bench = get_experiment(test)
    diffs, variances = [], []
    for point in bias.points[:first]:  # (the medium profile: its first three points, 15 runs of 20-40 s)
        n = point["cheap_n"]
        values = [bench.run(point["settings"], seed=s, profile=cheap).responses[response]
                  for s in range(1, 1 + n)]
        diff = mean(values) - point["cheap_mean"]
        var = (point["cheap_sd"] ** 2 + stdev(values) ** 2) / n
        print(f"{point['settings']}: {mean(values):.2f} (sd {stdev(values):.2f}) now, "
              f"{point['cheap_mean']:.2f} (sd {point['cheap_sd']:.2f}) stored")
        diffs.append(diff)
        variances.append(var)
    for diff, var in zip(diffs, variances):
        assert abs(diff) < max(1.0, 2 * var ** 0.5)
    k = len(diffs)
    shift, se = sum(diffs) / k, sum(variances) ** 0.5 / k
    print(f"mean difference over {k} points: {shift:+.2f} deg (standard error {se:.2f})")
    assert abs(shift) < 2 * se


def test_settings_that_move_together_are_not_fitted_twice():
    """mu = 0.8 - gamma at every point: once gamma is in, mu adds nothing (no singular fit)."""
    rows = []
    for i, (gamma, d) in enumerate([(0.1, 10.0), (0.2, 0.5), (0.3, -10.0), (0.15, 4.0), (0.25, -4.5), (0.12, 8.5)]):
        pt = {"particle.rolling_friction": gamma, "particle.static_friction": 0.8 - gamma}
        rows += [{"test": "repose-funnel", "profile": p, "seed": i, "set": pt,
                  "responses": {"repose_angle_deg": v}} for p, v in (("quick", 30.0), ("paper", 30.0 + d))]
    b = profiles.measure("repose-funnel", "repose_angle_deg", "quick", "paper", rows)
    assert len(b.terms) == 1


def test_the_incline_medium_profile_is_the_quick_one_with_a_bed_of_1000():
    """benchmarks/profile_bias.py reads the study's ``--profile quick --set
    particles.count=1000`` runs as medium-profile runs: that holds only while medium differs
    from quick in the particle count alone (both bits were checked equal when the profile
    was added: seed 2 at Table 7's centre gives 20.258497375305364 either way)."""
    from demcal.bench.registry import get_experiment

    incline = get_experiment("incline")
    assert "medium" in incline.profiles
    quick = {k: s.default for k, s in incline.settings("quick").items()}
    medium = {k: s.default for k, s in incline.settings("medium").items()}
    assert {k for k in quick if quick[k] != medium[k]} == {"particles.count"}
    assert (quick["particles.count"], medium["particles.count"]) == (250, 1000)


def test_a_test_without_a_medium_profile_refuses_it_in_one_sentence():
    from demcal.bench.registry import get_experiment
    from demcal.errors import ConfigError

    with pytest.raises(ConfigError, match="unknown profile 'medium' for repose-funnel; choose one of: "
                                          "tiny, quick, paper"):
        get_experiment("repose-funnel").settings("medium")
