"""The overlay region (Design-Expert's graphical optimisation in numbers), with and without
the fitted mean's confidence interval, against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from demcal.optimize.overlay import interval_half_width, overlay

SPACING = 2 * 2.0 / 2 ** 14  # one factor: two of the Sobol sample's 2^14 strata (coded units)


class _Line:
    """y = 10 x, with a standard error of the mean of 0.5 everywhere and 5 residual df."""

    df_residual = 5

    def predict(self, x):
        return 10.0 * np.asarray(x, dtype=float)[:, 0]

    def prediction_se(self, x):
        return np.full(len(np.atleast_2d(x)), 0.5)


class _Saturated(_Line):
    df_residual = 0


def test_the_region_is_where_the_prediction_lies_in_the_window():
    region = overlay({"y": _Line()}, {"y": (-1.0, 1.0)}, 1)
    lo, hi = region.ranges[0]
    assert lo == pytest.approx(-0.1, abs=SPACING) and hi == pytest.approx(0.1, abs=SPACING)
    assert region.share == pytest.approx(0.1, abs=SPACING)


def test_with_a_level_the_interval_of_the_mean_only_has_to_reach_the_window():
    """|10 x| <= 1 + t(0.975, 5) 0.5: the settings the fitted mean cannot tell from one inside."""
    edge = (1.0 + stats.t.ppf(0.975, 5) * 0.5) / 10.0
    lo, hi = overlay({"y": _Line()}, {"y": (-1.0, 1.0)}, 1, level=0.95).ranges[0]
    assert lo == pytest.approx(-edge, abs=SPACING) and hi == pytest.approx(edge, abs=SPACING)
    assert edge == pytest.approx(0.2285, abs=1e-4)


def test_a_fit_without_residual_df_is_not_widened():
    assert interval_half_width(_Saturated(), np.zeros((3, 1)), 0.95) == 0.0
    lo, hi = overlay({"y": _Saturated()}, {"y": (-1.0, 1.0)}, 1, level=0.95).ranges[0]
    assert hi == pytest.approx(0.1, abs=SPACING)


def test_a_real_fit_gives_its_confidence_band():
    """The half width is the one of demcal.rsm.diagnostics.confidence_band."""
    from demcal.rsm import fit_response_surface
    from demcal.rsm.diagnostics import confidence_band

    rng = np.random.default_rng(3)
    x = np.repeat(np.linspace(-1.0, 1.0, 5), 2)
    y = 2.0 + 3.0 * x + rng.normal(0.0, 0.4, x.size)
    model = fit_response_surface(x[:, None], y, model="linear")
    pts = np.linspace(-1.0, 1.0, 7)[:, None]
    yhat, low, high = confidence_band(model, pts, 0.95)
    assert interval_half_width(model, pts, 0.95) == pytest.approx(0.5 * (high - low), rel=1e-12)
