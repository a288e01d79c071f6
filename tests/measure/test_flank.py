"""Flank fitting: exact lines, outliers, the band, bad outlines."""

import numpy as np
import pytest

from demcal.errors import DataError
from demcal.measure.flank import fit_line, fit_outline


def test_exact_line_gives_exact_angle():
    x = np.linspace(0, 10, 50)
    fit = fit_line(x, 2.0 + np.tan(np.radians(33.0)) * x, "left")
    assert fit.angle_deg == pytest.approx(33.0, abs=1e-9)
    assert fit.r2 == pytest.approx(1.0)
    assert fit.n_inliers == 50


def test_right_flank_angle_is_positive():
    x = np.linspace(0, 10, 50)
    fit = fit_line(x, 9.0 - np.tan(np.radians(41.0)) * x, "right")
    assert fit.angle_deg == pytest.approx(41.0, abs=1e-9)


def test_gross_outliers_are_rejected():
    rng = np.random.default_rng(3)
    x = np.linspace(0, 100, 400)
    z = np.tan(np.radians(28.0)) * x + rng.normal(0, 0.3, x.size)
    bad = rng.choice(x.size, 80, replace=False)  # 20 % fines and shadow points
    z[bad] += rng.uniform(5, 20, bad.size)
    fit = fit_line(x, z, "left")
    assert fit.angle_deg == pytest.approx(28.0, abs=0.05)
    assert not fit.inlier[bad].any()
    # plain least squares would be biased by the outliers
    plain = np.degrees(np.arctan(np.polyfit(x, z, 1)[0]))
    assert abs(plain - 28.0) > 0.1


def test_same_outline_same_angle_to_the_last_digit():
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 50, 300)
    z = 0.7 * x + rng.normal(0, 1, 300)
    assert fit_line(x, z).angle_deg == fit_line(x.copy(), z.copy()).angle_deg


def test_outline_band_drops_rounded_top_and_spread_foot():
    angle = 36.0
    half_width = 100.0
    x = np.linspace(-150, 150, 1201)
    height = half_width * np.tan(np.radians(angle))
    z = np.clip(height - np.abs(x) * np.tan(np.radians(angle)), 0, None)
    z = np.minimum(z, 0.95 * height + 0.02 * (height - z))  # flattened top
    z = np.maximum(z, 3.0 * np.exp(-((np.abs(x) - half_width) / 8.0) ** 2))  # a toe of fines
    fit = fit_outline(x, z, band=(0.1, 0.9))
    assert fit.left.angle_deg == pytest.approx(angle, abs=1e-6)
    assert fit.right.angle_deg == pytest.approx(angle, abs=1e-6)
    assert fit.apex_x == pytest.approx(0.0, abs=1.0)


def test_too_few_points_is_a_data_error():
    with pytest.raises(DataError, match="left flank has only 3"):
        fit_line([0, 1, 2], [0, 1, 2], "left")


def test_bad_band_is_a_data_error():
    with pytest.raises(DataError, match="band"):
        fit_outline([0, 1, 2], [0, 1, 0], band=(0.9, 0.1))


def test_outline_without_height_is_a_data_error():
    with pytest.raises(DataError, match="no point above the base"):
        fit_outline(np.arange(10.0), np.zeros(10))
