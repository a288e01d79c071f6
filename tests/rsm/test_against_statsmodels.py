"""Independent check of the ANOVA, coefficients and diagnostics against statsmodels.

Reference values are computed live with statsmodels (``ols`` + ``anova_lm(typ=3)``,
``OLSInfluence``); the lack-of-fit F test is checked as the extra-sum-of-squares test of
the model against the cell-means (one mean per distinct point) model, which is its
textbook definition (Montgomery 2013, Sec. 10.7 / Draper & Smith 1998, Ch. 2).
"""

import importlib.resources

import numpy as np
import pandas as pd
import pytest

sm = pytest.importorskip("statsmodels.api")
smf = pytest.importorskip("statsmodels.formula.api")
from statsmodels.stats.anova import anova_lm  # noqa: E402
from statsmodels.stats.outliers_influence import OLSInfluence  # noqa: E402

from demcal.doe import central_composite  # noqa: E402
from demcal.rsm import fit_response_surface  # noqa: E402

DATA = importlib.resources.files("demcal") / "data"


def _datasets():
    t4 = pd.read_csv(DATA / "paper_table4_repose_bbd.csv")
    yield "table4", t4[list("ABCD")], t4["repose_angle_deg"].to_numpy()
    rng = np.random.default_rng(42)
    x = central_composite(3, alpha="rotatable", center=4)
    y = 10 + x @ [1.0, -2.0, 0.5] + 0.8 * x[:, 0] * x[:, 1] - 1.5 * x[:, 2] ** 2 + rng.normal(0, 0.4, len(x))
    yield "ccd3", pd.DataFrame(x, columns=list("ABC")), y


@pytest.mark.parametrize("name, X, y", list(_datasets()), ids=lambda v: v if isinstance(v, str) else "")
def test_quadratic_anova_matches_statsmodels(name, X, y):
    names = list(X.columns)
    df = X.assign(y=y)
    pairs = " + ".join(f"{a}:{b}" for i, a in enumerate(names) for b in names[i + 1:])
    squares = " + ".join(f"I({a}**2)" for a in names)
    formula = f"y ~ {' + '.join(names)} + {pairs} + {squares}"
    ref = smf.ols(formula, df).fit()
    ref_anova = anova_lm(ref, typ=3)

    ours = fit_response_surface(X.to_numpy(), y, names, "quadratic", "y")
    a = ours.anova

    def ref_name(term):
        if term.endswith("^2"):
            return f"I({term[:-2]} ** 2)"
        return term.replace("*", ":")

    for term in ours.term_names[1:]:
        r = ref_anova.loc[ref_name(term)]
        assert a.loc[term, "sum_sq"] == pytest.approx(r["sum_sq"], rel=1e-9, abs=1e-12)
        assert a.loc[term, "F"] == pytest.approx(r["F"], rel=1e-9, abs=1e-12)
        assert a.loc[term, "p"] == pytest.approx(r["PR(>F)"], rel=1e-7)
        assert ours.coefficients[term] == pytest.approx(ref.params[ref_name(term)], abs=1e-10)
        assert ours.coefficient_table.loc[term, "std_error"] == pytest.approx(ref.bse[ref_name(term)])
        lo, hi = ref.conf_int().loc[ref_name(term)]
        assert ours.coefficient_table.loc[term, "ci_low"] == pytest.approx(lo)
        assert ours.coefficient_table.loc[term, "ci_high"] == pytest.approx(hi)
    assert a.loc["Model", "F"] == pytest.approx(ref.fvalue)
    assert a.loc["Model", "p"] == pytest.approx(ref.f_pvalue, rel=1e-6)
    assert a.loc["Residual", "sum_sq"] == pytest.approx(ref.ssr)
    assert ours.fit.r2 == pytest.approx(ref.rsquared)
    assert ours.fit.adj_r2 == pytest.approx(ref.rsquared_adj)

    infl = OLSInfluence(ref)
    d = ours.diagnostics
    assert d["leverage"].to_numpy() == pytest.approx(infl.hat_matrix_diag)
    assert d["studentized"].to_numpy() == pytest.approx(infl.resid_studentized_internal)
    assert d["externally_studentized"].to_numpy() == pytest.approx(infl.resid_studentized_external)
    assert d["cooks_distance"].to_numpy() == pytest.approx(infl.cooks_distance[0])
    assert d["dffits"].to_numpy() == pytest.approx(infl.dffits[0])
    assert ours.fit.press == pytest.approx(infl.ess_press)

    # VIF = 1 / (1 - R_j^2) of each term regressed on the other terms
    from statsmodels.stats.outliers_influence import variance_inflation_factor
    exog = ref.model.exog
    for j, term in enumerate(ref.model.exog_names):
        if term == "Intercept":
            continue
        ours_term = next(t for t in ours.term_names if ref_name(t) == term)
        assert ours.coefficient_table.loc[ours_term, "vif"] == pytest.approx(
            variance_inflation_factor(exog, j), rel=1e-8)

    # lack of fit = extra-SS test of the model against the cell-means model; both data
    # sets have replicated centre runs, so the row must be there
    assert "Lack of Fit" in a.index and "Pure Error" in a.index
    cells = df.assign(cell=df[names].round(9).astype(str).agg("|".join, axis=1))
    full = smf.ols("y ~ cell", cells).fit()  # string column: categorical
    lof = anova_lm(smf.ols(formula, cells).fit(), full)
    assert a.loc["Lack of Fit", "df"] == lof["df_diff"].iloc[1]
    assert a.loc["Pure Error", "df"] == lof["df_resid"].iloc[1]
    assert a.loc["Lack of Fit", "F"] == pytest.approx(lof["F"].iloc[1])
    assert a.loc["Lack of Fit", "p"] == pytest.approx(lof["Pr(>F)"].iloc[1])
