"""Design-Expert's "Fit Summary": which polynomial order do the data support?

Three tables (Design-Expert 13 help, "Fit Summary"; Myers, Montgomery & Anderson-Cook
2016, Sec. 3.3 on extra sums of squares):

``sequential``
    Sequential (Type I) model sums of squares: Mean vs Total, Linear vs Mean, 2FI vs
    Linear, Quadratic vs 2FI, Cubic vs Quadratic, Residual, Total. Each F divides the
    added mean square by the residual mean square of the larger model.
``lack_of_fit``
    Lack-of-fit test of each order against pure error.
``model_stats``
    Std. Dev., R², adjusted R², predicted R² and PRESS of each order.

The suggested model is the highest order that adds significantly (p < alpha), is not
aliased and leaves residual degrees of freedom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

from demcal.errors import DataError
from demcal.rsm.fit import fit_response_surface, pure_error

_LABELS = {"linear": "Linear", "2fi": "2FI", "quadratic": "Quadratic", "cubic": "Cubic"}


@dataclass(frozen=True)
class FitSummary:
    """Result of :func:`fit_summary`; tables indexed by source / model."""

    sequential: pd.DataFrame
    lack_of_fit: pd.DataFrame
    model_stats: pd.DataFrame
    suggested: str | None
    aliased: tuple[str, ...]


def fit_summary(x_coded, y, factors=None, alpha: float = 0.05) -> FitSummary:
    """Compare linear, 2FI, quadratic and cubic models on the same runs."""
    x = np.atleast_2d(np.asarray(x_coded, dtype=float))
    y = np.asarray(y, dtype=float)
    n = y.size
    fits = {}
    for order in ("linear", "2fi", "quadratic", "cubic"):
        try:
            fits[order] = fit_response_surface(x, y, factors, order)
        except DataError:
            break
    if not fits:
        raise DataError(f"{n} runs are too few to fit even a linear model in {x.shape[1]} factors.")
    ss_pe, df_pe, n_distinct = pure_error(x, y)

    seq_rows = {"Mean vs Total": [n * y.mean() ** 2, 1, n * y.mean() ** 2, np.nan, np.nan]}
    prev_sse, prev_p = float(np.sum((y - y.mean()) ** 2)), 1
    prev_label = "Mean"
    aliased = []
    for order, m in fits.items():
        sse = float(m.anova.loc["Residual", "sum_sq"])
        df = m.p - prev_p
        ss = prev_sse - sse
        ms = ss / df if df > 0 else np.nan
        F = ms / m.mse if df > 0 and m.mse > 0 else np.nan
        pv = stats.f.sf(F, df, m.df_residual) if np.isfinite(F) else np.nan
        seq_rows[f"{_LABELS[order]} vs {prev_label}"] = [ss, df, ms, F, pv]
        if m.aliased:
            aliased.append(order)
        prev_sse, prev_p, prev_label = sse, m.p, _LABELS[order]
    last = list(fits.values())[-1]
    seq_rows["Residual"] = [prev_sse, last.df_residual, last.mse, np.nan, np.nan]
    seq_rows["Total"] = [float(y @ y), n, float(y @ y) / n, np.nan, np.nan]
    cols = ["sum_sq", "df", "mean_sq", "F", "p"]
    sequential = pd.DataFrame.from_dict(seq_rows, orient="index", columns=cols)
    sequential["df"] = sequential["df"].astype(int)
    sequential.index.name = "source"

    lof_rows = {}
    if df_pe > 0:
        ms_pe = ss_pe / df_pe
        for order, m in fits.items():
            df = n_distinct - m.p
            ss = float(m.anova.loc["Residual", "sum_sq"]) - ss_pe
            if df > 0:
                # replicates that agree exactly (a deterministic response) leave no pure error to test against
                F = (ss / df) / ms_pe if ms_pe > 0 else np.nan
                lof_rows[_LABELS[order]] = [ss, df, ss / df, F, stats.f.sf(F, df, df_pe) if ms_pe > 0 else np.nan]
            else:
                lof_rows[_LABELS[order]] = [max(ss, 0.0), df, np.nan, np.nan, np.nan]
        lof_rows["Pure Error"] = [ss_pe, df_pe, ms_pe, np.nan, np.nan]
    lack_of_fit = pd.DataFrame.from_dict(lof_rows, orient="index", columns=cols)
    lack_of_fit.index.name = "source"

    stat_rows = {}
    for order, m in fits.items():
        f = m.fit
        stat_rows[_LABELS[order]] = [f.std_dev, f.r2, f.adj_r2, f.pred_r2, f.press,
                                     "aliased" if m.aliased else ""]
    model_stats = pd.DataFrame.from_dict(
        stat_rows, orient="index",
        columns=["std_dev", "r2", "adj_r2", "pred_r2", "press", "note"])
    model_stats.index.name = "model"

    suggested = None
    for order, key in zip(fits, list(seq_rows)[1:]):
        pv = sequential.loc[key, "p"]
        if order not in aliased and np.isfinite(pv) and pv < alpha:
            suggested = _LABELS[order]
    return FitSummary(sequential, lack_of_fit, model_stats, suggested, tuple(aliased))
