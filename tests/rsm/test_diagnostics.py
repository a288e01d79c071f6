"""Residual diagnostics, Box-Cox and interaction selection (demcal.rsm.diagnostics)
against their definitions, closed forms, scipy and the paper's printed ANOVA.

Each statistic is checked against an independent route to the same number: leverage
against the explicit hat matrix; externally studentized residuals and Cook's distance
against refits with each run left out (their definitions: Belsley, Kuh & Welsch 1980,
Eq. 2.26; Cook 1977, Technometrics 19, 15-18, Eq. 5); the limits against distributions
with closed-form quantiles; Box-Cox against ``scipy.stats.boxcox_llf`` (the same
likelihood for the intercept-only model) and against data generated with a known lambda.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from demcal.doe import central_composite
from demcal.errors import DataError
from demcal.report.paper import REPOSE, SLIDING, fit_study
from demcal.rsm import fit_response_surface
from demcal.rsm.diagnostics import (
    box_cox, box_cox_ss, confidence_band, cooks_limit, influence_table, leverage, model_box_cox,
    normal_plot, outlier_limit, significant_interactions,
)
from demcal.rsm.terms import model_matrix

# A tiny straight-line data set (x, y); run 5 sits off the line.
X_TINY = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
Y_TINY = np.array([1.1, 2.9, 5.2, 6.8, 11.5, 11.2])


def _line(x, y):
    X = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return X, coef


def test_leverage_is_the_diagonal_of_the_hat_matrix():
    rng = np.random.default_rng(3)
    X = np.column_stack([np.ones(12), rng.normal(size=(12, 3))])
    hat = X @ np.linalg.inv(X.T @ X) @ X.T
    h = leverage(X)
    np.testing.assert_allclose(h, np.diag(hat), rtol=1e-12)
    assert h.sum() == pytest.approx(4.0)  # trace H = p
    # the straight line's closed form: h_ii = 1/n + (x_i - xbar)^2 / Sxx
    x = X_TINY
    closed = 1 / x.size + (x - x.mean()) ** 2 / np.sum((x - x.mean()) ** 2)
    np.testing.assert_allclose(leverage(_line(x, Y_TINY)[0]), closed, rtol=1e-12)


def test_studentized_residuals_and_cooks_distance_by_leaving_each_run_out():
    x, y = X_TINY, Y_TINY
    X, coef = _line(x, y)
    n, p = X.shape
    fitted = X @ coef
    h = leverage(X)
    table = influence_table(y, fitted, h, p)
    e = y - fitted
    mse = e @ e / (n - p)
    for i in range(n):
        keep = np.arange(n) != i
        Xi, ci = _line(x[keep], y[keep])
        s_i = np.sqrt(np.sum((y[keep] - Xi @ ci) ** 2) / (n - 1 - p))  # MSE without run i
        internal = e[i] / np.sqrt(mse * (1 - h[i]))
        external = e[i] / (s_i * np.sqrt(1 - h[i]))
        cook = np.sum((fitted - X @ ci) ** 2) / (p * mse)  # shift of all fitted values
        row = table.iloc[i]
        assert row["studentized"] == pytest.approx(internal, rel=1e-10)
        assert row["externally_studentized"] == pytest.approx(external, rel=1e-10)
        assert row["cooks_distance"] == pytest.approx(cook, rel=1e-10)
        # the identity D_i = r_i^2 h_ii / (p (1 - h_ii))
        assert cook == pytest.approx(internal**2 * h[i] / (p * (1 - h[i])), rel=1e-10)
    # run 5 (x = 4) is the one off the line
    assert int(np.argmax(np.abs(table["externally_studentized"]))) == 4


def test_fit_diagnostics_are_the_influence_table():
    model = fit_study(REPOSE)
    again = influence_table(model.y, model.diagnostics["predicted"], leverage(model_matrix(model.x, model.terms)),
                            model.p)
    np.testing.assert_allclose(model.diagnostics.to_numpy(), again.to_numpy(), rtol=1e-9, atol=1e-12)


def test_limits_against_closed_form_quantiles():
    # n - p - 1 = 1: t(1) is the Cauchy distribution, t_q = tan(pi (q - 1/2))
    n, p = 10, 8
    assert outlier_limit(n, p) == pytest.approx(np.tan(np.pi * (0.5 - 0.05 / (2 * n))), rel=1e-9)
    # F(2, 2) has CDF x / (1 + x): its median is 1
    assert cooks_limit(4, 2) == pytest.approx(1.0, rel=1e-12)
    # F(2, 4): CDF 1 - (1 + x/2)^-2, median 2 (sqrt 2 - 1)
    assert cooks_limit(6, 2) == pytest.approx(2 * (np.sqrt(2) - 1), rel=1e-9)
    assert np.isnan(outlier_limit(5, 4)) and np.isnan(cooks_limit(4, 4))


def test_normal_plot_positions_and_quartile_line():
    z = stats.norm.ppf((np.arange(1, 202) - 0.5) / 201)
    plot = normal_plot(3.0 + 2.0 * z[::-1])
    np.testing.assert_allclose(plot.probability, (np.arange(1, 202) - 0.5) / 201)
    np.testing.assert_allclose(plot.z, z)
    assert plot.slope == pytest.approx(2.0, rel=0.01) and plot.intercept == pytest.approx(3.0, abs=1e-9)


def test_box_cox_of_the_mean_model_is_scipys_likelihood():
    """For the intercept-only model, ln SS(lambda) of the standardized transform is
    ln n - 2 llf(lambda) / n with scipy's Box-Cox log-likelihood, and the best lambda
    is scipy's maximum-likelihood lambda."""
    y = np.random.default_rng(5).lognormal(1.0, 0.5, 40)
    X = np.ones((y.size, 1))
    lams = np.array([-2.0, -0.5, 0.0, 0.7, 2.5])
    llf = np.array([stats.boxcox_llf(lam, y) for lam in lams])
    np.testing.assert_allclose(np.log(box_cox_ss(X, y, lams)), np.log(y.size) - 2 * llf / y.size, rtol=1e-10)
    bc = box_cox(X, y)
    assert bc.best == pytest.approx(stats.boxcox_normmax(y, method="mle"), abs=1e-5)


@pytest.mark.parametrize("true_lambda, recommended", [(0.5, 0.5), (0.0, 0.0), (1.0, None)])
def test_box_cox_interval_covers_the_lambda_the_data_were_made_with(true_lambda, recommended):
    """y^lambda (log y at 0) is a quadratic in three factors plus normal noise: the
    interval holds that lambda, and the recommendation is its transform."""
    rng = np.random.default_rng(11)
    x = np.vstack([central_composite(3, alpha="rotatable", center=6)] * 2)
    eta = 6.0 + x @ [1.2, -0.9, 0.6] + 0.4 * x[:, 0] * x[:, 1] + rng.normal(0.0, 0.08, len(x))
    if true_lambda == 0:
        y = np.exp(eta / 3.0)
    elif true_lambda == 1:
        y = 20.0 + eta
    else:
        y = eta ** (1.0 / true_lambda)
    model = fit_response_surface(x, y, None, "quadratic", "y")
    bc = model_box_cox(model)
    assert bc.contains(true_lambda), (bc.best, bc.ci)
    assert bc.recommended == recommended, bc.recommendation()
    # the interval's ends lie on the limit line ln SS* = ln SS_min + ln(1 + t^2 / nu)
    X = model_matrix(model.x, model.terms)
    nu = model.df_residual
    t = stats.t.ppf(0.975, nu)
    ln_min = np.log(box_cox_ss(X, y, [bc.best])[0])
    assert bc.ln_ss_limit == pytest.approx(ln_min + np.log1p(t * t / nu), rel=1e-12)
    for end, is_open in zip(bc.ci, bc.ci_open):
        if not is_open:
            assert np.log(box_cox_ss(X, y, [end])[0]) == pytest.approx(bc.ln_ss_limit, abs=1e-8)
    words = bc.recommendation()
    assert ("no transform recommended" in words) == (recommended is None)


def test_box_cox_interval_holds_the_true_lambda_95_times_in_100():
    """Coverage of the 95 % interval over 100 data sets made with lambda = 0.5 (three
    standard deviations of a binomial count either side of 95)."""
    x = np.vstack([central_composite(3, alpha="rotatable", center=6)] * 2)
    X = model_matrix(x, fit_response_surface(x, x[:, 0], None, "quadratic").terms)
    covered = 0
    for seed in range(100):
        eta = 6.0 + x @ [1.2, -0.9, 0.6] + np.random.default_rng(seed).normal(0.0, 0.08, len(x))
        covered += box_cox(X, eta**2).contains(0.5)
    assert 88 <= covered <= 100


def test_box_cox_refuses_non_positive_responses():
    with pytest.raises(DataError, match="positive"):
        box_cox(np.ones((4, 1)), [1.0, 2.0, 0.0, 3.0])


def test_significant_interactions_are_the_papers():
    """Table 5 of the paper (Design-Expert output) prints p = 0.0155 for BC, 0.0224 for
    AD and 0.0354 for CD, the only two-factor terms below 0.05; Table 9 none."""
    pairs = significant_interactions(fit_study(REPOSE))
    assert [(i, j) for i, j, _ in pairs] == [(1, 2), (0, 3), (2, 3)]
    assert [round(p, 4) for *_, p in pairs] == [0.0155, 0.0224, 0.0354]
    assert significant_interactions(fit_study(SLIDING)) == []


def test_confidence_band_is_the_mean_interval():
    model = fit_study(REPOSE)
    point = np.array([[0.3, -0.5, 1.0, 0.0]])
    yhat, lo, hi = confidence_band(model, point)
    x0 = model_matrix(point, model.terms)[0]
    se = np.sqrt(x0 @ model.xtx_inv @ x0 * model.mse)
    half = stats.t.ppf(0.975, model.df_residual) * se
    assert hi[0] - yhat[0] == pytest.approx(half, rel=1e-10)
    assert yhat[0] - lo[0] == pytest.approx(half, rel=1e-10)
