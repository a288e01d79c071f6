"""The stored bias between profiles as the loop's discrepancy before production runs."""

from pathlib import Path

import numpy as np
import pytest

from demcal.bench import profiles
from demcal.campaign.config import load_campaign
from demcal.campaign.loop import Discrepancy, stored_priors

SLIDING = Path(__file__).resolve().parents[2] / "examples" / "residual-film-soil" / "sliding.toml"


def _bias(**kw):
    base = dict(test="incline", response="sliding_angle_deg", cheap="quick", production="paper",
                bias=-2.0, se=0.3, sd_points=0.4, points=({}, {}), measured="today")
    return profiles.ProfileBias(**{**base, **kw})


def test_a_stored_bias_is_the_discrepancy_until_production_runs_exist():
    d = Discrepancy([], _bias())
    assert d.kind == "stored"
    mean, sd = d(np.zeros(3))
    assert mean == -2.0 and sd == pytest.approx(0.5)  # hypot(0.3, 0.4)
    assert "stored quick → paper bias -2.00" in d.describe()
    own = Discrepancy([(np.zeros(3), -5.0), (np.ones(3), -4.0)], _bias())
    assert own.kind == "additive" and own.bias == -4.5  # the campaign's own runs replace it
    assert Discrepancy([]).describe().startswith("no production run yet (discrepancy 0)")


def test_a_stored_bias_knows_the_range_it_was_measured_over():
    stored = profiles.stored("incline", "sliding_angle_deg", "quick", "paper")
    mus = [pt["settings"]["film.static_friction"] for pt in stored.points]
    lo, hi = min(mus), max(mus)
    assert stored.outside({"film.static_friction": hi}) == []
    assert stored.outside({"film.static_friction": hi + 0.146, "particle.count": 9}) == [
        f"film.static_friction {hi + 0.146:g} (measured {lo:g} to {hi:g})"]
    assert _bias().outside({"film.static_friction": 5.0}) == []  # points without settings


def test_stored_priors_apply_to_the_material_settings_only():
    campaign = load_campaign(SLIDING)
    stored = profiles.stored("incline", "sliding_angle_deg", "quick", "paper")
    assert stored is not None, "the incline's quick -> paper bias is stored"
    assert stored_priors(campaign, "quick", "paper") == {"sliding_angle_deg": stored}
    assert stored_priors(campaign, "quick", "quick") == {}
    assert stored_priors(campaign, "tiny", "paper") == {}  # none measured
    import dataclasses

    counted = dataclasses.replace(campaign, settings={**campaign.settings, "particles.count": 500})
    assert stored_priors(counted, "quick", "paper") == {}


def test_replicates_needed_is_the_whole_batch_by_student_t():
    from scipy import stats

    from demcal.campaign.loop import replicates_needed

    m = replicates_needed(sd=2.5, df=2, n=3, lab_sd=2.1, cap=30)
    assert stats.t.ppf(0.975, 2 + m - 3) * 2.5 / m ** 0.5 < 2.1  # enough ...
    assert stats.t.ppf(0.975, 2 + m - 4) * 2.5 / (m - 1) ** 0.5 >= 2.1  # ... and no more
    assert replicates_needed(sd=10.0, df=2, n=3, lab_sd=0.1, cap=12) == 12


def test_a_new_point_adds_one_degree_of_freedom_less_than_its_runs():
    from demcal.campaign.loop import replicates_needed

    # pooled sd 1 with 2 df; a new point (n = 0) of m runs adds m - 1 df:
    # m = 1: t(0.975, 2) = 4.30; m = 2: t(3) / sqrt 2 = 2.25; m = 3: t(4) / sqrt 3 = 1.61
    assert replicates_needed(sd=1.0, df=2, n=0, lab_sd=5.0, cap=10) == 1
    assert replicates_needed(sd=1.0, df=2, n=0, lab_sd=2.5, cap=10) == 2
    assert replicates_needed(sd=1.0, df=2, n=0, lab_sd=2.0, cap=10) == 3
    # at a point that has runs, each new run adds one df (as before)
    assert replicates_needed(sd=1.0, df=2, n=1, lab_sd=2.5, cap=10) == 2


def test_batches_are_rounded_up_to_the_replicate_batch():
    """[calibration] replicate_batch: the new runs of a batch come in multiples of it
    (two workers: three runs take as long as four), never beyond max_replicates; 1 keeps
    what the noise asks for."""
    from demcal.campaign.loop import batched

    assert batched(3, 0, 2, 16) == 4  # a first batch of three on two workers
    assert batched(1, 0, 2, 16) == 2  # a probe
    assert batched(11, 10, 2, 16) == 12  # one more at a point of ten: two
    assert batched(14, 10, 2, 16) == 14  # four more: already a multiple
    assert batched(15, 11, 3, 16) == 16  # six more would pass the cap
    assert batched(16, 13, 2, 16) == 16  # four more would pass it
    assert batched(16, 16, 2, 16) == 16
    assert [batched(n, 4, 1, 10) for n in (5, 7, 12)] == [5, 7, 10]  # 1: as asked, capped
    # the rounding never asks for fewer than the noise did
    assert all(batched(n, d, k, 40) >= n and (batched(n, d, k, 40) - d) % k == 0
               for n in range(1, 30) for d in range(n) for k in (1, 2, 3, 4))


def test_the_first_batch_at_a_new_point_follows_the_pooled_noise():
    from demcal.campaign.config import Target
    from demcal.campaign.loop import first_batch

    lab = [Target("angle", 30.0, 2.5)]
    assert first_batch({}, lab, 3, 1) == 3  # nothing known: [calibration] replicates
    assert first_batch({"angle": (float("nan"), 0)}, lab, 3, 1) == 3
    assert first_batch({"angle": (1.0, 2)}, lab, 3, 1) == 2
    assert first_batch({"angle": (0.2, 2)}, lab, 3, 1) == 1
    assert first_batch({"angle": (0.2, 2)}, lab, 3, 2) == 2  # min_replicates
    assert first_batch({"angle": (9.0, 2)}, lab, 3, 1) == 3  # never more than replicates
    assert first_batch({"angle": (0.2, 2)}, lab, 0, 1) == 0  # no verification asked for
    # every target must be met; one without a lab sd asks for nothing
    two = lab + [Target("other", 10.0, 0.5), Target("free", 1.0, None)]
    assert first_batch({"angle": (0.2, 2), "other": (0.2, 2), "free": (5.0, 2)}, two, 3, 1) == 2
    assert first_batch({"free": (0.2, 2)}, [Target("free", 1.0, None)], 3, 1) == 3  # nothing to size by
    # min_replicates raises the fewest, it does not count as runs already there: pooled sd 1
    # with 1 df, lab sd 1.45: m = 3 gives t(3) / sqrt 3 = 1.84, m = 4 t(4) / 2 = 1.39
    assert first_batch({"angle": (1.0, 1)}, [Target("angle", 30.0, 1.45)], 6, 3) == 4


def test_a_reach_into_the_lab_window_is_told_from_one_that_misses_it():
    from demcal.campaign.config import Target
    from demcal.campaign.loop import in_window

    t = Target("angle", 30.46, 3.2)
    assert in_window(t, 23.46, 28.27)  # up to 28.27 >= 27.26
    assert not in_window(t, 20.0, 27.0)
    assert in_window(t, 33.0, 40.0) and not in_window(t, 34.0, 40.0)
    assert not in_window(Target("angle", 30.0, None), 29.0, 31.0)


def test_a_box_moves_only_when_it_misses_the_middle_half_of_the_lab_window():
    from demcal.campaign.loop import out_of_box

    assert not out_of_box(25.42, 2.6, 18.0, 24.2)  # reaches 24.2 >= 25.42 - 1.3
    assert out_of_box(25.42, 2.6, 18.0, 24.0)  # 24.0 < 24.12
    assert out_of_box(30.46, 3.2, 18.0, 26.35)
    assert not out_of_box(20.0, 2.0, 20.9, 30.0) and out_of_box(20.0, 2.0, 21.1, 30.0)  # from above
    assert out_of_box(25.0, None, 10.0, 24.99) and not out_of_box(25.0, None, 10.0, 25.0)  # no sd: the mean


def _linear_bias():
    """-2 deg at gamma 0.2, -100 deg per unit of gamma, exact (no covariance, no scatter)."""
    return _bias(test="repose-funnel", response="repose_angle_deg", bias=-2.0, se=0.0, sd_points=5.0,
                 terms=("particle.rolling_friction",), reference={"particle.rolling_friction": 0.2},
                 slopes=(-100.0,), covariance=((0.0, 0.0), (0.0, 0.0)), sd_resid=0.0)


def _on_box(bias):
    """Box 0: factor 0 is gamma from 0.1 to 0.3 (coded -1..1), factor 1 something else."""
    from demcal.campaign.loop import StoredPrior

    def to_settings(x0):
        return {"particle.rolling_friction": 0.2 + 0.1 * float(x0[0]), "particle.static_friction": 0.4}

    return StoredPrior(bias, to_settings, 2)


def test_a_linear_stored_bias_is_a_slope_in_the_coded_factor_and_keeps_it():
    from demcal.campaign.loop import CorrectedSurface

    prior = _on_box(_linear_bias())
    assert prior.offset == pytest.approx(-2.0) and prior.slope == pytest.approx([-10.0, 0.0])
    d = Discrepancy([], prior)
    assert d.kind == "stored" and d(np.array([1.0, 0.0]))[0] == pytest.approx(-12.0)
    # production runs set the level; the slope stays: residuals 1 deg above the line
    own = Discrepancy([(np.array([-1.0, 0.0]), 8.0 + 1.0), (np.array([1.0, 0.5]), -12.0 + 1.0)], prior)
    assert own.kind == "additive" and own.bias == pytest.approx(-1.0)
    assert own(np.array([0.0, 0.0]))[0] == pytest.approx(-1.0)
    assert own(np.array([0.5, 0.0]))[0] == pytest.approx(-6.0)
    assert "about the stored slope" in own.describe()

    class Flat:  # a cheap model of 30 deg everywhere
        factors, response, y = ("a", "b"), "repose_angle_deg", np.array([30.0])

        def predict(self, x):
            x = np.asarray(x, float)
            return 30.0 if x.ndim == 1 else np.full(len(x), 30.0)

        def gradient(self, x):
            return np.zeros_like(np.asarray(x, float))

    surface = CorrectedSurface(Flat(), own)
    assert surface.predict(np.array([1.0, 0.0])) == pytest.approx(30.0 - 1.0 - 10.0)
    assert surface.predict(np.array([[1.0, 0.0], [-1.0, 0.0]])) == pytest.approx([19.0, 39.0])
    assert surface.gradient(np.array([0.3, 0.3])) == pytest.approx([-10.0, 0.0])


def test_a_constant_stored_bias_gives_the_additive_bias_as_before():
    """With a constant prior the production runs' mean residual is the bias, bit for bit."""
    res = [(np.zeros(3), -5.0), (np.ones(3), -4.0), (np.full(3, 0.5), -4.3)]
    assert Discrepancy(res, _bias()).bias == Discrepancy(res).bias


def test_a_constant_stored_bias_on_a_box_of_several_factors():
    """prior_on_box with a constant bias: read at the box centre, no slope (the loop's
    usual case for the incline: three factors, a constant bias)."""
    from demcal.campaign.loop import Box, prior_on_box

    campaign = load_campaign(SLIDING)
    box0 = Box(0, tuple(f.low for f in campaign.factors), tuple(f.high for f in campaign.factors))
    from types import SimpleNamespace

    prior = prior_on_box(_bias(), campaign, SimpleNamespace(fixed={}), box0, "quick")
    d = Discrepancy([], prior)
    assert d.kind == "stored" and d.slope is None
    assert d(np.zeros(3)) == pytest.approx((-2.0, 0.5)) and d.bias == -2.0


def test_the_corrected_surfaces_observed_range_includes_the_stored_slope():
    from demcal.campaign.loop import CorrectedSurface

    class Flat:
        factors, response = ("a", "b"), "y"
        x, y = np.array([[-1.0, 0.0], [1.0, 0.0]]), np.array([30.0, 30.0])

        def predict(self, x):
            return 30.0

    surface = CorrectedSurface(Flat(), Discrepancy([], _on_box(_linear_bias())))
    assert surface.y == pytest.approx([30.0 - 2.0 + 10.0, 30.0 - 2.0 - 10.0])
