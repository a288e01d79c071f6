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


def test_a_box_moves_only_when_it_misses_the_middle_half_of_the_lab_window():
    from demcal.campaign.loop import out_of_box

    assert not out_of_box(25.42, 2.6, 18.0, 24.2)  # reaches 24.2 >= 25.42 - 1.3
    assert out_of_box(25.42, 2.6, 18.0, 24.0)  # 24.0 < 24.12
    assert out_of_box(30.46, 3.2, 18.0, 26.35)
    assert not out_of_box(20.0, 2.0, 20.9, 30.0) and out_of_box(20.0, 2.0, 21.1, 30.0)  # from above
    assert out_of_box(25.0, None, 10.0, 24.99) and not out_of_box(25.0, None, 10.0, 25.0)  # no sd: the mean
