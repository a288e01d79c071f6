"""The campaign report says what it shows: the goal actually solved, the model each
table and figure uses, extrapolated published values, and what to run next.

The campaign is the test double of tests/campaign (``test-heap``) with its design
results written straight into the store (nothing is simulated): a surface that does
not depend on D, so the reduced model (``reduce_alpha = 0.05``) drops D; a condition
whose target lies below what the box reaches; and published values with a
restitution outside the factor box.
"""

from __future__ import annotations

import html
import importlib.util
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

CAMPAIGN_TESTS = Path(__file__).resolve().parents[1] / "campaign"
if str(CAMPAIGN_TESTS) not in sys.path:  # the test double's plugin, campaign_testbench
    sys.path.insert(0, str(CAMPAIGN_TESTS))
_spec = importlib.util.spec_from_file_location("_campaign_fixtures", CAMPAIGN_TESTS / "conftest.py")
_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_fixtures)
CAMPAIGN = _fixtures.CAMPAIGN

RESPONSE = "repose_angle_deg"


def _angle(p: dict, seed: int) -> float:
    """A known surface without D, plus seeded noise of sd 0.2."""
    a = (p["particle.restitution"] - 0.6) / 0.1
    b = (p["particle.static_friction"] - 0.4) / 0.1
    c = (p["particle.rolling_friction"] - 0.2) / 0.1
    noise = np.random.default_rng(seed + 7).normal(0.0, 0.2)
    return float(40.0 - 0.5 * a + 3.0 * b + 6.0 * c + 1.9 * b * c - 1.5 * c * c + noise)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    import campaign_testbench  # noqa: F401  registers test-heap

    from demcal.campaign.calibrate import calibrate
    from demcal.campaign.config import parse_campaign
    from demcal.campaign.runner import open_store, plan_design
    from demcal.report.campaign_report import write_report

    folder = tmp_path_factory.mktemp("honest")
    text = CAMPAIGN.format(sleep=0.0).replace('order = "quadratic"\n', 'order = "quadratic"\nreduce_alpha = 0.05\n')
    text += ('\n[[conditions]]\nname = "too low"\ntargets = { repose_angle_deg = { mean = 25.0, sd = 1.0 } }\n'
             '[conditions.reference]\n"particle.restitution" = 0.95\n"particle.static_friction" = 0.30\n'
             '"particle.rolling_friction" = 0.10\n"particle.damping_factor" = 0.12\n')
    path = folder / "campaign.toml"
    path.write_text(text)
    campaign = parse_campaign(text, path)
    specs = {s.key: s for s in plan_design(campaign).specs}
    with open_store(campaign) as store:
        store.add(specs.values())
        while (record := store.claim(list(specs))) is not None:
            spec = specs[record.key]
            store.finish(record.id, {"responses": {RESPONSE: _angle(spec.parameters, spec.seed)},
                                     "wall_s": 0.1}, None, "test")
    cal = calibrate(campaign, simulate=False, progress=False)
    report = write_report(campaign, folder / "report", [cal], figure_files=False)
    return campaign, cal, report, report.read_text()


def _text(page: str) -> str:
    """The page as plain text (tags dropped, entities decoded)."""
    return html.unescape(re.sub(r"<[^>]+>", " ", page))


def test_fixture_is_what_the_tests_assume(built):
    campaign, cal, _, _ = built
    removed = [t for t, _ in cal.removed[RESPONSE]]
    assert removed and not [t for t in cal.models[RESPONSE].term_names if "D" in t]
    result = cal.conditions[2]
    assert result.condition.name == "too low" and not result.verdicts[0].target_reachable
    assert result.desirability >= 0.99  # of the substituted goal, not of the lab target


def test_unreachable_target_shows_the_goal_solved_and_its_real_desirability(built):
    campaign, cal, report, page = built
    table = pd.read_csv(report.parent / "tables" / "model_predictions.csv", index_col=0)
    low = table.loc["too low"]
    edge = cal.conditions[2].optimization.goals[0].target
    text = _text(page)
    assert f"solved for {edge:.2f}, the nearest the box reaches" in text
    assert "unreachable" in str(low.to_dict())
    assert float(low["desirability"]) < 0.99  # the real target is not met
    for name in ("6.26 %", "14.1 %"):
        assert float(table.loc[name, "desirability"]) >= 0.99


def test_reduced_model_equation_in_actual_factors_is_shown_and_labelled(built):
    campaign, cal, report, page = built
    text = _text(page)
    reduced = cal.models[RESPONSE].equation("actual", digits=5)
    full = cal.full[RESPONSE].equation("actual", digits=5)
    assert reduced != full
    assert reduced in text and full in text
    assert "Final equation in actual factors, reduced model (the one calibration uses)" in text
    assert "Final equation in actual factors, full quadratic model" in text
    assert text.index("reduced model (the one calibration uses)") < text.index(reduced)


def test_diagnostics_and_figures_use_and_name_the_reduced_model(built):
    campaign, cal, report, page = built
    diag = pd.read_csv(report.parent / "tables" / f"{RESPONSE}_diagnostics.csv")
    np.testing.assert_allclose(diag["predicted"], cal.models[RESPONSE].diagnostics["predicted"], rtol=1e-9)
    text = _text(page)
    assert "Residuals, leverage, studentized residuals and Cook's distance of the reduced model" in text
    assert f"Predicted vs actual {RESPONSE}, reduced model" in text
    captions = re.findall(r"<figcaption>([^<]*)</figcaption>", page)
    surfaces = [c for c in captions if c.startswith("Response surface")]
    assert surfaces and all("reduced model" in c for c in surfaces), surfaces
    # D is not in the reduced model: no surface of D
    assert not re.search(rf'alt="{RESPONSE}_surface_.?D', page)
    assert not [c for c in surfaces if " D " in f" {c.replace(',', ' ')} "], surfaces


def test_full_model_figures_say_so_when_nothing_is_reduced(tmp_path):
    from demcal.report.html import HtmlReport
    from demcal.report.paper import REPOSE, add_model_sections, fit_study

    report = HtmlReport("t", tmp_path, figure_formats=())
    add_model_sections(report, fit_study(REPOSE), "r", surfaces=((1, 2),), reduce_alpha=None)
    text = _text(report.to_html())
    assert "Residuals, leverage, studentized residuals and Cook's distance of the full quadratic model" in text
    assert "Response surface and contour of B and C, full quadratic model" in text
    assert "Final equation in actual factors, full quadratic model" in text


def test_published_values_outside_the_box_are_flagged(built):
    campaign, cal, report, page = built
    table = pd.read_csv(report.parent / "tables" / "model_predictions.csv", index_col=0)
    assert "outside the design box: extrapolated" in str(table.loc["too low"].to_dict())
    assert "outside the design box" not in str(table.loc["6.26 %"].to_dict())
    params = pd.read_csv(report.parent / "tables" / "calibrated_parameters.csv")
    flagged = params[params["reference value"].fillna("").str.contains("outside the design box: extrapolated")]
    assert list(flagged["condition"]) == ["too low"] and list(flagged["factor"]) == ["A"]
    assert flagged.iloc[0]["reference"] == pytest.approx(0.95)
    assert "A = 0.95 outside 0.5 to 0.7" in str(table.loc["too low"].to_dict())


def test_unfinished_verification_says_what_to_run(built):
    campaign, cal, report, page = built
    text = _text(page)
    assert "0/2" in text
    assert f"demcal calibrate {campaign.path} --profile tiny" in text


def test_stale_calibration_json_says_what_to_run(built, tmp_path):
    import json

    from demcal.report.campaign_report import write_report

    campaign, cal, _, _ = built
    saved = campaign.workdir / "calibration.json"
    old = {**cal.conditions[0].chosen, "particle.restitution": 0.55}
    saved.write_text(json.dumps({"profile": campaign.profile,
                                 "conditions": [{"name": cal.conditions[0].condition.name, "chosen": old}]}))
    try:
        text = _text(write_report(campaign, tmp_path / "report", [cal], figure_files=False).read_text())
    finally:
        saved.unlink()
    assert "calibration.json is out of date" in text and "6.26 %" in text
    assert f"Run `demcal calibrate {campaign.path} --profile tiny` to solve and verify them again" in text


def test_the_plugins_a_campaign_names_are_in_the_report(built):
    """Issue 20: plugins run code, so the report names them (and imports none itself)."""
    text = _text(built[3])
    assert "Plugins named by the campaign file: campaign_testbench" in text
    assert "`demcal report` imports none" in text


def test_a_reference_table_is_read_and_re_analysed(built, tmp_path):
    """Issue 20: `[report] reference_table` was checked for existence and never read; a
    campaign that is not one of the paper's studies gets its table fitted with its own
    model, and a table that does not fit it is one sentence before anything is written."""
    import dataclasses
    import shutil

    from demcal.errors import DataError
    from demcal.report.campaign_report import write_report

    campaign, cal, _, _ = built
    table = tmp_path / "published.csv"
    shutil.copy(Path(__file__).resolve().parents[2] / "examples" / "residual-film-soil" /
                "paper_table4_repose_bbd.csv", table)
    with_table = dataclasses.replace(campaign, reference_table=table)
    page = write_report(with_table, tmp_path / "report", [cal], figure_files=False).read_text()
    assert "Reference table re-analysed: published.csv" in _text(page)
    anova = pd.read_csv(tmp_path / "report" / "tables" / f"reference_{RESPONSE}_anova.csv", index_col=0)
    assert anova.loc["Cor Total", "df"] == 28  # the table's 29 runs
    table.write_text("user:x:0:0:root:/root:/bin/bash\nbin:x:1:1::/:\n")
    with pytest.raises(DataError, match=r"^\[report\] reference_table of campaign.toml: .*published.csv has no "
                                         r"column 'repose_angle_deg'"):
        write_report(with_table, tmp_path / "again", [cal], figure_files=False)
    assert not (tmp_path / "again").exists()


def test_each_condition_has_ramps_and_an_overlay_of_the_lab_window(built):
    """Issue 19: Design-Expert's desirability ramps and overlay plot per condition. The
    overlay spans the two factors that move the angle most (B and C: 3 and 6 deg per
    coded unit, A 0.5, D none), and its yellow region is where the calibration's model
    predicts the lab mean ± sd; the unreachable target has none, and says so."""
    from demcal.report.diagnostics import overlay_grid
    from demcal.report.html import _slug

    campaign, cal, _, page = built
    captions = dict(re.findall(r'<figure><img alt="([^"]+)"[^>]*><figcaption>([^<]*)</figcaption>', page))
    for result in cal.conditions:
        name = f"solve_{result.condition.name}"
        assert "desirability ramps of solution 1" in captions[_slug(f"{name}_ramps")]
        overlay = captions[_slug(f"{name}_overlay")]
        assert "overlay plot over B and C" in overlay
        target = result.condition.targets[0]
        window = f"within {target.mean - target.sd:.4g} to {target.mean + target.sd:.4g} (lab mean ± sd)"
        assert window in html.unescape(overlay)
        assert ("no setting in this plane meets every window" in overlay) == (result.condition.name == "too low")

    result = cal.conditions[0]
    target = result.condition.targets[0]
    window = {RESPONSE: (target.mean - target.sd, target.mean + target.sd, "lab mean ± sd")}
    best = result.optimization.solutions.iloc[0]
    point = np.array([best[f"coded:{f.name}"] for f in result.optimization.factors])
    grid = overlay_grid(cal.models, window, point, 1, 2, n=21)
    pts = np.tile(point, (grid["gi"].size, 1))
    pts[:, 1], pts[:, 2] = grid["gi"].ravel(), grid["gj"].ravel()
    y = cal.models[RESPONSE].predict(pts).reshape(grid["gi"].shape)
    np.testing.assert_array_equal(grid["feasible"], (y >= window[RESPONSE][0]) & (y <= window[RESPONSE][1]))
    assert 0 < grid["feasible"].mean() < 1
