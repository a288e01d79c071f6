"""demcal's responses against a published design table, point by point."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from demcal.campaign.config import Factor
from demcal.report.benchmark import compare, figure


def _campaign(tmp_path, rows):
    path = tmp_path / "published.csv"
    path.write_text("run,A,B,y\n" + "".join(f"{i + 1},{a},{b},{y}\n" for i, (a, b, y) in enumerate(rows)))
    factors = (Factor(name="A", low=0.5, high=0.7, parameter="p.a"), Factor(name="B", low=0.3, high=0.5, parameter="p.b"))
    return SimpleNamespace(reference_table=path, factor_names=["A", "B"], factors=factors, settings={"fixed": 1},
                           test="t")


def _record(a, b, y, profile="quick", settings=None):
    params = {"p.a": a, "p.b": b}
    return SimpleNamespace(status="done", test="t", profile=profile, responses={"y": y}, parameters=params,
                           settings={**params, **(settings or {"fixed": 1})})


def test_offset_rms_slope_and_pooled_sd(tmp_path):
    # published: 30 + 10 A + 5 B at the four corners and the centre
    rows = [(-1, -1, 15.0), (1, -1, 35.0), (-1, 1, 25.0), (1, 1, 45.0), (0, 0, 30.0)]
    campaign = _campaign(tmp_path, rows)
    # demcal: 2 deg lower everywhere, and 0.8 x the effects; centre twice (29, 27: sd sqrt 2)
    records = [_record(0.5, 0.3, 30 - 2 + 0.8 * (-15)), _record(0.7, 0.3, 30 - 2 + 0.8 * 5),
               _record(0.5, 0.5, 30 - 2 + 0.8 * (-5)), _record(0.7, 0.5, 30 - 2 + 0.8 * 15),
               _record(0.6, 0.4, 29.0), _record(0.6, 0.4, 27.0),
               _record(0.6, 0.4, 99.0, settings={"fixed": 2}),  # another set-up: left out
               _record(0.6, 0.4, 30.0, profile="paper")]  # one point only at paper: no comparison
    (c,) = compare(campaign, "y", records)
    assert c.profile == "quick" and len(c.points) == 5
    assert c.offset == pytest.approx(-2.0) and c.slope == pytest.approx(0.8)
    assert c.rms == pytest.approx(np.sqrt(np.mean(np.array([1, -3, -1, -5, -2.0]) ** 2)))
    assert c.pooled_sd == pytest.approx(np.sqrt(2.0))
    centre = c.points[c.points["A"] == 0].iloc[0]
    assert centre["n"] == 2 and centre["demcal"] == 28.0
    figure([c], "y", "angle")  # draws


def test_no_reference_or_too_few_points_is_no_comparison(tmp_path):
    campaign = _campaign(tmp_path, [(-1, -1, 15.0), (1, 1, 45.0)])
    assert compare(campaign, "y", [_record(0.5, 0.3, 14.0), _record(0.7, 0.5, 44.0)]) == []
    assert compare(campaign, "missing", [_record(0.5, 0.3, 14.0)]) == []


def test_a_stored_bias_adds_a_shifted_row(tmp_path, monkeypatch):
    from demcal.bench import profiles

    rows = [(-1, -1, 15.0), (1, -1, 35.0), (-1, 1, 25.0), (1, 1, 45.0)]
    campaign = _campaign(tmp_path, rows)
    campaign.settings = {"p.x": 1}  # not a material setting: no stored bias applies
    records = [_record(0.5, 0.3, 14.0, settings={"p.x": 1}), _record(0.7, 0.3, 34.0, settings={"p.x": 1}),
               _record(0.5, 0.5, 24.0, settings={"p.x": 1}), _record(0.7, 0.5, 44.0, settings={"p.x": 1})]
    bias = profiles.ProfileBias("t", "y", "quick", "paper", bias=-3.0, se=0.4, sd_points=1.0, points=({}, {}))
    monkeypatch.setattr(profiles, "stored", lambda test, response, cheap, production:
                        bias if (test, response, cheap, production) == ("t", "y", "quick", "paper") else None)
    assert [c.profile for c in compare(campaign, "y", records)] == ["quick"]
    campaign.settings = {"particle.x": 1}  # a material value: the stored bias applies
    records = [_record(r.parameters["p.a"], r.parameters["p.b"], r.responses["y"], settings={"particle.x": 1})
               for r in records]
    quick, shifted = compare(campaign, "y", records)
    assert shifted.profile == "quick + stored bias to paper (-3.00°)"
    assert quick.offset == pytest.approx(-1.0) and shifted.offset == pytest.approx(-4.0)
    assert shifted.slope == pytest.approx(quick.slope)
    assert shifted.points["sd"].iloc[0] == pytest.approx(0.4)  # no seed sd: the bias's se alone


def test_a_stored_bias_linear_in_a_factor_shifts_each_point_by_its_own_value(tmp_path, monkeypatch):
    """A bias of -1 deg at p.a = 0.6 and -100 deg per unit of p.a (-10 deg per coded unit):
    each point moves by its own amount, and the slope against the paper changes."""
    from demcal.bench import profiles

    rows = [(-1, -1, 15.0), (1, -1, 35.0), (-1, 1, 25.0), (1, 1, 45.0)]
    campaign = _campaign(tmp_path, rows)
    campaign.settings = {"particle.x": 1}
    records = [_record(a, b, y, settings={"particle.x": 1})
               for a, b, y in [(0.5, 0.3, 14.0), (0.7, 0.3, 34.0), (0.5, 0.5, 24.0), (0.7, 0.5, 44.0)]]
    bias = profiles.ProfileBias("t", "y", "quick", "paper", bias=-1.0, se=0.3, sd_points=9.0, points=({}, {}),
                                terms=("p.a",), reference={"p.a": 0.6}, slopes=(-100.0,),
                                covariance=((0.09, 0.0), (0.0, 4.0)), sd_resid=0.5)
    monkeypatch.setattr(profiles, "stored", lambda *a: bias)
    quick, shifted = compare(campaign, "y", records)
    assert shifted.profile == "quick + stored bias to paper (-1.00° at the centre, -10.0° per 0.1 of p.a)"
    low = shifted.points[shifted.points["A"] == -1]["demcal"].tolist()
    high = shifted.points[shifted.points["A"] == 1]["demcal"].tolist()
    assert low == pytest.approx([14.0 - 1 + 10, 24.0 - 1 + 10]) and high == pytest.approx([34.0 - 11, 44.0 - 11])
    # the model's se at p.a = 0.5: sqrt(0.09 + 0.1^2 * 4), without the points' scatter
    assert shifted.points["sd"].iloc[0] == pytest.approx((0.09 + 0.04) ** 0.5)
