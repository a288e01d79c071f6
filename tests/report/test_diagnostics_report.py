"""Design-Expert's diagnostic graphs in the report (demcal.report.diagnostics): each
figure is there with a caption that names its limit lines and their values, the run
order is the one given, and flagged runs and a missing Box-Cox plot are said in words."""

from __future__ import annotations

import html
import re

import numpy as np
import pytest

from demcal.report.diagnostics import residuals_vs_run_figure
from demcal.report.html import HtmlReport
from demcal.report.paper import REPOSE, SLIDING, add_model_sections, fit_study
from demcal.rsm import fit_response_surface
from demcal.rsm.diagnostics import cooks_limit, outlier_limit


def _captions(report: HtmlReport) -> dict[str, str]:
    """``{figure name: caption}`` of the report's figures."""
    page = report.to_html()
    found = re.findall(r'<figure><img alt="([^"]+)"[^>]*><figcaption>([^<]*)</figcaption>', page)
    return {name: html.unescape(caption) for name, caption in found}


def _text(report: HtmlReport) -> str:
    return html.unescape(re.sub(r"<[^>]+>", " ", report.to_html()))


def test_model_sections_show_every_diagnostic_graph_with_its_limits(tmp_path):
    model = fit_study(REPOSE)  # 29 runs, 15 terms
    report = HtmlReport("t", tmp_path, figure_formats=())
    add_model_sections(report, model, "r", surfaces=(), reduce_alpha=None)
    captions = _captions(report)
    limit = outlier_limit(29, 15)
    assert limit == pytest.approx(3.93, abs=0.01)
    assert "Normal probability plot of the externally studentized residuals" in captions["r_normal_plot"]
    for name in ("r_residuals_vs_predicted", "r_residuals_vs_run"):
        assert f"±{limit:.2f}, the Bonferroni outlier limits t(1 - 0.05/(2·29), 13)" in captions[name]
    assert "design run order" in captions["r_residuals_vs_run"]
    assert f"red line: {cooks_limit(29, 15):.3g}, the median of F(15, 14)" in captions["r_cooks_distance"]
    assert "lambda = 1 lies inside the 95 % CI" in captions["r_box_cox"]
    assert "no transform recommended" in captions["r_box_cox"]
    # Table 5's significant interactions: BC (p 0.0155), AD (0.0224), CD (0.0354)
    interactions = {k: v for k, v in captions.items() if "_interaction_" in k}
    assert list(interactions) == ["r_interaction_BC", "r_interaction_AD", "r_interaction_CD"]
    assert "(p = 0.0155)" in interactions["r_interaction_BC"]
    held = "A, D at their centre levels; bands: 95 % confidence interval of the mean"
    assert held in interactions["r_interaction_BC"]
    assert not any("paper" in c or "Table" in c for c in captions.values())


def test_no_significant_interaction_is_said(tmp_path):
    report = HtmlReport("t", tmp_path, figure_formats=())
    add_model_sections(report, fit_study(SLIDING), "s", surfaces=(), reduce_alpha=None)
    assert not [k for k in _captions(report) if "_interaction_" in k]
    assert "No two-factor interaction of sliding_angle_deg is significant (p < 0.05)" in _text(report)


def test_residuals_against_run_follow_the_given_run_order():
    model = fit_study(SLIDING)
    order = np.random.default_rng(1).permutation(model.n) + 1
    fig = residuals_vs_run_figure(model, order)
    ax = fig.axes[0]
    points = ax.collections[-1].get_offsets()
    np.testing.assert_array_equal(points[:, 0], order)
    np.testing.assert_allclose(points[:, 1], model.diagnostics["externally_studentized"])
    line = ax.lines[-1].get_xydata()
    assert np.all(np.diff(line[:, 0]) > 0)  # joined in run order
    with pytest.raises(Exception, match="run numbers"):
        residuals_vs_run_figure(model, order[:-1])


def test_an_outlier_and_an_influential_run_are_named(tmp_path):
    x = np.linspace(-1, 1, 15)[:, None]
    y = 5.0 + 2.0 * x[:, 0] + np.random.default_rng(2).normal(0, 0.05, 15)
    y[14] += 1.0  # the last run, at the end of the range: an outlier with leverage
    model = fit_response_surface(x, y, None, "linear", "y")
    report = HtmlReport("t", tmp_path, figure_formats=())
    add_model_sections(report, model, "o", surfaces=(), reduce_alpha=None)
    text = _text(report)
    assert re.search(r"externally studentized residuals beyond ±3\.65: run 15 \(16\.\d\d\);", text)
    assert re.search(r"Cook's distance above 0\.731: run 15 \(1\.9\d\)\.", text)


def test_a_response_not_positive_has_no_box_cox_plot_and_says_why(tmp_path):
    x = np.linspace(-1, 1, 9)[:, None]
    y = np.sin(3 * x[:, 0]) + np.random.default_rng(0).normal(0, 0.1, 9)  # negative values
    report = HtmlReport("t", tmp_path, figure_formats=())
    add_model_sections(report, fit_response_surface(x, y, None, "quadratic", "y"), "n", surfaces=(),
                       reduce_alpha=None)
    assert "n_box_cox" not in _captions(report)
    assert "No Box-Cox plot of y: a Box-Cox transform needs positive responses" in _text(report)
