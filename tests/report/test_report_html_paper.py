"""HTML builder, figures and the paper re-analysis report."""

import json

import numpy as np
import pandas as pd
import pytest

from demcal.report.figures import (
    perturbation_figure, predicted_vs_actual_figure, save_figure, surface_figure,
)
from demcal.optimize import Goal, optimize
from demcal.report.html import HtmlReport, format_number
from demcal.report.paper import REPOSE, SLIDING, evaluate_points, fit_study, write_paper_report


def test_format_number():
    assert format_number(0.00002, column="p") == "< 0.0001"
    assert format_number(0.05813, column="p") == "0.0581"
    assert format_number(23.378378) == "23.38"
    assert format_number(2.9554e-4) == "0.0002955"
    assert format_number(3.096e4) == "30960" and format_number(2.9554e-6) == "2.955e-06"
    assert format_number(np.nan) == ""
    assert format_number(14) == "14"


def test_html_report_writes_tables_and_figures(tmp_path):
    rep = HtmlReport("Test <report>", tmp_path, figure_formats=("png", "svg"))
    rep.section("Numbers")
    rep.paragraph("a & b")
    df = pd.DataFrame({"F": [23.378, 2.1], "p": [1e-7, 0.1696]}, index=pd.Index(["Model", "A"], name="source"))
    name = rep.table(df, "anova", caption="ANOVA")
    m = fit_study(SLIDING)
    rep.figure(perturbation_figure(m), "pert", caption="perturbation")
    path = rep.write()
    text = path.read_text()
    assert "Test &lt;report&gt;" in text and "a &amp; b" in text and "< 0.0001" not in text
    assert "&lt; 0.0001" in text and "23.38" in text and "data:image/png;base64," in text
    assert (tmp_path / "tables" / f"{name}.csv").exists()
    rows = json.loads((tmp_path / "tables" / f"{name}.json").read_text())
    assert rows[0]["source"] == "Model" and rows[1]["p"] == pytest.approx(0.1696)
    assert (tmp_path / "figures" / "pert.png").stat().st_size > 1000
    assert (tmp_path / "figures" / "pert.svg").read_text().lstrip().startswith("<?xml")


def test_figures_png_and_svg(tmp_path):
    m = fit_study(REPOSE)
    f1 = save_figure(predicted_vs_actual_figure(m), tmp_path / "pva.svg")
    f2 = save_figure(surface_figure(m, 1, 2, hold=[0.5, 0, 0, -0.5]), tmp_path / "bc.png")
    assert f1.stat().st_size > 1000 and f2.read_bytes()[:4] == b"\x89PNG"


def test_paper_points_tables_6_and_10():
    # printed Eq. (4)/(6) give 31.03, 39.95, 25.21, 30.24; the unrounded fit 31.02,
    # 39.94, 25.21, 30.23
    rep = evaluate_points(REPOSE, fit_study(REPOSE))
    sl = evaluate_points(SLIDING, fit_study(SLIDING))
    printed = list(rep["predicted (printed equation)"]) + list(sl["predicted (printed equation)"])
    fitted = list(rep["predicted (fitted model)"]) + list(sl["predicted (fitted model)"])
    assert np.round(printed, 2) == pytest.approx([31.03, 39.95, 25.21, 30.24])
    assert np.round(fitted, 2) == pytest.approx([31.02, 39.94, 25.21, 30.23])
    assert rep.loc["6.26±1.5 %", "A coded"] == pytest.approx(-0.2)


def test_write_paper_report(tmp_path):
    path = write_paper_report(tmp_path, n_starts=6, figure_formats=(), dpi=40)
    text = path.read_text()
    for needle in ("Table 5 re-analysed", "Table 9 re-analysed", "23.38", "363.67", "3197",
                   "Solving for 31.07", "Solving for 30.46", "Reduced model", "Fit summary",
                   "equation in coded factors", "Table 6", "Table 10"):
        assert needle in text, needle
    ranges = pd.read_csv(tmp_path / "tables" / "repose_target_31p07_factor_ranges.csv", index_col=0)
    assert list(ranges.index) == ["A", "B", "C", "D"]
    sols = pd.read_csv(tmp_path / "tables" / "sliding_target_25p42_solutions.csv")
    assert (sols["predicted:sliding_angle_deg"] - 25.42).abs().max() < 0.01
    assert text.count("data:image/png;base64,") >= 10

    # the reduced-model ANOVA is the reduced model's: backward elimination at 0.05 first
    # removes the highest-order term with the largest p, D² of Table 5 (p = 0.9956) and
    # FG of Table 9 (p = 0.664); the full-model ANOVA still has them
    tables = tmp_path / "tables"
    for study, term in (("repose", "D²"), ("sliding", "FG")):
        full = pd.read_csv(tables / f"{study}_anova.csv", index_col=0)
        reduced = pd.read_csv(tables / f"{study}_reduced_anova.csv", index_col=0)
        assert term in full.index and term not in reduced.index, study
        assert set(reduced.index) < set(full.index)

    # solution-set ranges: low <= high inside the design levels (Tables 3 and 7), and the
    # very ranges optimize() finds with the report's settings (6 starts, seed 0)
    for study in (REPOSE, SLIDING):
        model = fit_study(study)
        for _, target in study.targets:
            name = f"{study.key}_target_{target:g}".replace(".", "p")
            df = pd.read_csv(tables / f"{name}_factor_ranges.csv", index_col=0)
            res = optimize({study.response: model}, [Goal(study.response, "target", target)],
                           n_starts=6, seed=0)
            assert list(df.index) == [f.name for f in study.factors]
            for f in study.factors:
                row = df.loc[f.name]
                lo, hi = row["solution set low"], row["solution set high"]
                assert (row["design low"], row["design high"]) == (f.low, f.high)
                assert f.low - 1e-9 <= lo <= hi <= f.high + 1e-9, (name, f.name)
                assert (lo, hi) == pytest.approx(res.factor_ranges[f.name], rel=1e-12, abs=1e-15)
    design_levels = {"A": (0.5, 0.7), "B": (0.3, 0.5), "C": (0.1, 0.3), "D": (0.0, 0.2)}
    assert {f.name: (f.low, f.high) for f in REPOSE.factors} == design_levels  # Table 3


def test_figure_files_at_300_dpi_and_labelled(tmp_path):
    """Issue 19: figure files at 300 dpi (the embedded PNG stays at 110 dpi), the response
    axis named with its unit, the design points on the contour."""
    import base64
    import io

    from PIL import Image

    from demcal.report.figures import response_label, surface_figure

    m = fit_study(REPOSE)
    fig = surface_figure(m, 1, 2)
    contour = fig.axes[1]
    assert len(contour.collections) >= 2 and any(len(c.get_offsets()) for c in contour.collections[-2:])
    assert response_label("repose_angle_deg") == "Repose angle [°]"
    assert "Repose angle [°]" in [a.get_ylabel() for a in fig.axes]
    rep = HtmlReport("t", tmp_path)
    rep.figure(fig, "surf")
    with Image.open(tmp_path / "figures" / "surf.png") as im:
        assert round(im.info["dpi"][0]) == 300
        file_width = im.size[0]
    embedded = base64.b64decode(rep.blocks[-1]["src"].split("base64,")[1])
    with Image.open(io.BytesIO(embedded)) as im:
        assert im.size[0] * 300 == pytest.approx(file_width * 110, rel=0.01)
    assert (tmp_path / "figures" / "surf.svg").exists()
