"""Equations, aliasing, fit summary, reduction and the ``demcal analyze`` command."""

import importlib.resources
import json

import numpy as np
import pandas as pd
import pytest

from demcal.cli import main
from demcal.doe import Factor, box_behnken
from demcal.errors import DataError
from demcal.rsm import backward_elimination, fit_response_surface, fit_summary
from demcal.rsm.terms import parse_term

DATA = importlib.resources.files("demcal") / "data"
TABLE4 = str(DATA / "paper_table4_repose_bbd.csv")
TABLE8 = str(DATA / "paper_table8_sliding_bbd.csv")
# Table 3 of the reference paper: factor levels of e, mu, gamma, zeta
LEVELS4 = ["--factor", "A=0.5:0.7", "--factor", "B=0.3:0.5", "--factor", "C=0.1:0.3",
           "--factor", "D=0.0:0.2"]


@pytest.fixture(scope="module")
def repose():
    df = pd.read_csv(TABLE4)
    factors = [Factor("A", 0.5, 0.7), Factor("B", 0.3, 0.5), Factor("C", 0.1, 0.3), Factor("D", 0.0, 0.2)]
    return fit_response_surface(df[list("ABCD")].to_numpy(), df["repose_angle_deg"], factors,
                                "quadratic", "beta")


def test_actual_equation_predicts_like_coded(repose):
    rng = np.random.default_rng(0)
    coded = rng.uniform(-1, 1, (20, 4))
    actual = repose.to_actual(coded)
    coefs = repose.actual_coefficients()
    names = repose.names
    pred = np.zeros(20)
    for name, b in coefs.items():
        t = parse_term(name, names)
        pred += b * np.prod(actual ** np.array(t), axis=1)
    assert pred == pytest.approx(repose.predict(coded))
    assert repose.predict_actual(actual) == pytest.approx(repose.predict(coded))
    assert "beta = " in repose.equation("actual") and "A²" in repose.equation("coded")


def test_cubic_on_box_behnken_reports_aliases():
    df = pd.read_csv(TABLE4)
    m = fit_response_surface(df[list("ABCD")].to_numpy(), df["repose_angle_deg"], list("ABCD"), "cubic")
    assert m.aliased["A^3"] == "A"
    assert m.aliased["A*B*C"] == "0"
    assert "aliased" in m.notes[0]
    assert m.df_residual > 0


def test_fit_summary_sequence(repose):
    s = fit_summary(repose.x, repose.y, repose.factors)
    seq = s.sequential
    assert list(seq.index) == ["Mean vs Total", "Linear vs Mean", "2FI vs Linear", "Quadratic vs 2FI",
                               "Cubic vs Quadratic", "Residual", "Total"]
    # sequential sums add up to the total sum of squares
    assert seq["sum_sq"].iloc[:-1].sum() == pytest.approx(seq.loc["Total", "sum_sq"])
    assert seq.loc["Quadratic vs 2FI", "df"] == 4
    assert s.lack_of_fit.loc["Quadratic", "F"] == pytest.approx(5.46, abs=0.005)
    assert s.model_stats.loc["Quadratic", "pred_r2"] == pytest.approx(0.7755, abs=5e-5)
    assert s.aliased == ("cubic",) and s.suggested in ("2FI", "Quadratic")


def test_backward_elimination_keeps_hierarchy(repose):
    red = backward_elimination(repose, 0.05)
    m = red.model
    assert red.removed and red.removed[0][0] == "D^2"
    for parent in m.terms:  # every divisor of a kept term is kept
        for j, e in enumerate(parent):
            if e:
                child = list(parent)
                child[j] -= 1
                assert tuple(child) in m.terms
    kept = set(m.term_names)
    assert {"B*C", "C*D", "A*D", "C^2"} <= kept
    assert all(p > 0.05 for _, p in red.removed)


def test_analyze_json_format(capsys):
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"anova", "fit", "coefficients"}
    sources = [r["source"] for r in out["anova"]]
    assert sources[0] == "Model" and sources[-4:] == ["Residual", "Lack of Fit", "Pure Error", "Cor Total"]
    assert "A*B" in sources and "A^2" in sources
    assert set(out["anova"][0]) == {"source", "sum_sq", "df", "mean_sq", "F", "p"}
    assert set(out["fit"]) == {"std_dev", "mean", "cv_percent", "press", "r2", "adj_r2", "pred_r2",
                               "adeq_precision"}
    assert round(out["anova"][0]["F"], 2) == 23.38
    assert round(out["coefficients"]["Intercept"], 2) == 40.03
    assert list(out["coefficients"])[:2] == ["Intercept", "A"]


def test_analyze_text_with_levels_and_reduction(capsys):
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", *LEVELS4, "--reduce", "0.05"]) == 0
    cap = capsys.readouterr()
    assert "Equation in actual factors" in cap.out and "Lack of Fit" in cap.out
    assert "backward elimination removed" in cap.err


def test_analyze_factor_columns_default_and_explicit(tmp_path, capsys):
    assert main(["analyze", TABLE8, "--response", "sliding_angle_deg", "--factors", "E,F,G",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert round(out["anova"][0]["F"], 2) == 363.67


def _err(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("demcal: error:")]
    assert len(lines) == 1
    return lines[0]


def test_analyze_bad_inputs(tmp_path, capsys):
    assert main(["analyze", TABLE4, "--response", "nope"]) == 2
    assert "no column 'nope'" in _err(capsys)

    bad = tmp_path / "bad.csv"
    df = pd.read_csv(TABLE4)
    df["B"] = df["B"].astype(object)
    df.loc[3, "B"] = "high"
    df.to_csv(bad, index=False)
    assert main(["analyze", str(bad), "--response", "repose_angle_deg"]) == 2
    assert "'B'" in _err(capsys)

    few = tmp_path / "few.csv"
    pd.read_csv(TABLE4).head(12).to_csv(few, index=False)
    assert main(["analyze", str(few), "--response", "repose_angle_deg"]) == 2
    assert "15 coefficients" in _err(capsys)

    assert main(["analyze", str(tmp_path / "missing.csv"), "--response", "y"]) == 2
    assert "cannot find" in _err(capsys)

    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--model", "quartic"]) == 2
    assert "unknown model" in _err(capsys)


def test_analyze_without_replicates_says_so_and_carries_on(tmp_path, capsys):
    norep = tmp_path / "norep.csv"
    pd.read_csv(TABLE4).head(25).to_csv(norep, index=False)  # one centre run only
    assert main(["analyze", str(norep), "--response", "repose_angle_deg", "--json"]) == 0
    cap = capsys.readouterr()
    assert "lack of fit cannot be tested" in cap.err
    sources = [r["source"] for r in json.loads(cap.out)["anova"]]
    assert "Lack of Fit" not in sources and "Cor Total" in sources


def test_fit_rejects_mismatched_input():
    with pytest.raises(DataError):
        fit_response_surface(box_behnken(3, 1), np.ones(5))
    with pytest.raises(DataError):
        fit_response_surface(box_behnken(3, 3), np.r_[np.ones(14), np.nan])
