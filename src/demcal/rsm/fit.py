"""Least-squares response surfaces with Design-Expert's ANOVA and fit statistics.

Conventions (Design-Expert 13 help, "ANOVA output" and "Fit statistics"; Montgomery
2013, Ch. 10 and 11; Myers, Montgomery & Anderson-Cook, *Response Surface
Methodology*, 4th ed., 2016, Sec. 2.7):

* the model is fitted in coded factors;
* each term's sum of squares is its partial (Type III) sum of squares,
  SS_t = b_t^2 / [(X'X)^-1]_tt (all terms have one degree of freedom);
* Model SS is the regression SS about the mean; F = MS / MS_residual;
* Residual SS splits into Pure Error (replicated points about their means) and Lack of
  Fit (the rest); Lack of Fit F = MS_LoF / MS_PE;
* PRESS = sum (e_i / (1 - h_ii))^2, predicted R^2 = 1 - PRESS / SS_total;
* adequate precision = (max yhat - min yhat) / sqrt(mean V(yhat)), with
  mean V(yhat) = p sigma^2 / n over the design points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import stats

from demcal.doe.factors import Factor
from demcal.errors import DataError
from demcal.rsm.diagnostics import influence_table
from demcal.rsm.equations import actual_coefficients, format_equation
from demcal.rsm.terms import (
    Polynomial, Term, degree, display_name, model_matrix, model_terms, normalise_order, term_name,
)

#: Relative size below which a model column counts as a combination of earlier ones.
ALIAS_TOLERANCE = 1e-8


@dataclass(frozen=True)
class FitStatistics:
    """Design-Expert's fit statistics for one model."""

    std_dev: float
    mean: float
    cv_percent: float
    press: float
    r2: float
    adj_r2: float
    pred_r2: float
    adeq_precision: float

    def to_dict(self) -> dict:
        return {k: _num(v) for k, v in self.__dict__.items()}


def _num(v):
    """JSON-safe float (NaN and inf become None)."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def find_aliases(X: np.ndarray, terms, names) -> tuple[list[int], dict[str, str]]:
    """Columns that are linear combinations of earlier columns.

    Returns the indices of the columns kept and ``{term: "alias expression"}`` for each
    dropped term, e.g. ``{"A^3": "A"}`` in a Box-Behnken design.
    """
    kept: list[int] = []
    aliases: dict[str, str] = {}
    for j in range(X.shape[1]):
        col = X[:, j]
        norm = np.linalg.norm(col)
        if kept:
            B = X[:, kept]
            coef, *_ = np.linalg.lstsq(B, col, rcond=None)
            resid = col - B @ coef
        else:
            coef, resid = np.zeros(0), col
        if norm == 0 or np.linalg.norm(resid) <= ALIAS_TOLERANCE * max(norm, 1.0):
            expr = []
            for c, i in zip(coef, kept):
                if abs(c) > 1e-6:
                    nm = term_name(terms[i], names)
                    if nm == "Intercept":
                        expr.append(f"{c:+.4g}")
                    elif abs(c - 1) < 1e-9 or abs(c + 1) < 1e-9:
                        expr.append(("+" if c > 0 else "-") + nm)
                    else:
                        expr.append(f"{c:+.4g}*{nm}")
            text = " ".join(expr).lstrip("+") or "0"
            aliases[term_name(terms[j], names)] = text
        else:
            kept.append(j)
    return kept, aliases


def replicate_groups(x: np.ndarray) -> np.ndarray:
    """Integer label per row; rows with the same factor settings share a label."""
    keys = np.round(np.asarray(x, dtype=float), 9)
    _, labels = np.unique(keys, axis=0, return_inverse=True)
    return labels.ravel()


def pure_error(x: np.ndarray, y: np.ndarray) -> tuple[float, int, int]:
    """(SS_pure_error, df_pure_error, number of distinct points)."""
    labels = replicate_groups(x)
    ss = 0.0
    for g in np.unique(labels):
        yy = y[labels == g]
        ss += float(np.sum((yy - yy.mean()) ** 2))
    n_distinct = int(np.unique(labels).size)
    return ss, int(len(y) - n_distinct), n_distinct


@dataclass
class ResponseSurface:
    """A fitted response surface: coefficients, ANOVA, fit statistics and diagnostics.

    Build it with :func:`fit_response_surface`. Tables are ``pandas.DataFrame``:

    ``anova``
        index ``source`` (Model, terms, Residual, Lack of Fit, Pure Error, Cor Total);
        columns ``sum_sq, df, mean_sq, F, p``.
    ``coefficient_table``
        index term; columns ``estimate, df, std_error, ci_low, ci_high, vif``.
    ``diagnostics``
        one row per run: ``actual, predicted, residual, leverage, studentized,
        externally_studentized, cooks_distance, dffits``
        (:func:`demcal.rsm.diagnostics.influence_table`).
    """

    response: str
    factors: tuple[Factor, ...]
    terms: list[Term]
    x: np.ndarray
    y: np.ndarray
    coef: np.ndarray
    xtx_inv: np.ndarray
    anova: pd.DataFrame
    fit: FitStatistics
    coefficient_table: pd.DataFrame
    diagnostics: pd.DataFrame
    aliased: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    order: str = "custom"

    # -- basic properties -------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        return [f.name for f in self.factors]

    @property
    def term_names(self) -> list[str]:
        return [term_name(t, self.names) for t in self.terms]

    @property
    def n(self) -> int:
        return int(self.y.size)

    @property
    def p(self) -> int:
        return len(self.terms)

    @property
    def df_residual(self) -> int:
        return self.n - self.p

    @property
    def mse(self) -> float:
        return float(self.anova.loc["Residual", "mean_sq"])

    @property
    def coefficients(self) -> dict[str, float]:
        """``{term name: coefficient}`` in coded units."""
        return {nm: float(b) for nm, b in zip(self.term_names, self.coef)}

    @property
    def has_lack_of_fit(self) -> bool:
        return "Lack of Fit" in self.anova.index

    # -- prediction --------------------------------------------------------------------
    @property
    def polynomial(self) -> Polynomial:
        """The fitted model as a fast :class:`~demcal.rsm.terms.Polynomial` (coded units)."""
        if getattr(self, "_poly", None) is None:
            self._poly = Polynomial(self.terms, self.coef)
        return self._poly

    def predict(self, coded) -> np.ndarray:
        """Predicted response at coded points ``(n, k)`` (or one point ``(k,)``)."""
        coded = np.asarray(coded, dtype=float)
        out = self.polynomial(coded)
        return out[0] if coded.ndim == 1 else out

    def gradient(self, coded) -> np.ndarray:
        """Gradient of the prediction with respect to the coded factors."""
        coded = np.asarray(coded, dtype=float)
        out = self.polynomial.gradient(coded)
        return out[0] if coded.ndim == 1 else out

    def predict_actual(self, actual) -> np.ndarray:
        """Predicted response at actual factor levels."""
        actual = np.atleast_2d(np.asarray(actual, dtype=float))
        coded = np.column_stack([f.to_coded(actual[:, j]) for j, f in enumerate(self.factors)])
        return self.predict(coded)

    def prediction_se(self, coded) -> np.ndarray:
        """Standard error of the mean prediction at coded points."""
        X = model_matrix(np.atleast_2d(np.asarray(coded, dtype=float)), self.terms)
        return np.sqrt(np.einsum("ij,jk,ik->i", X, self.xtx_inv, X) * self.mse)

    def to_coded(self, actual) -> np.ndarray:
        actual = np.atleast_2d(np.asarray(actual, dtype=float))
        return np.column_stack([f.to_coded(actual[:, j]) for j, f in enumerate(self.factors)])

    def to_actual(self, coded) -> np.ndarray:
        coded = np.atleast_2d(np.asarray(coded, dtype=float))
        return np.column_stack([f.to_actual(coded[:, j]) for j, f in enumerate(self.factors)])

    # -- equations ---------------------------------------------------------------------
    def actual_coefficients(self) -> dict[str, float]:
        """``{term name: coefficient}`` of the same model in actual factor units."""
        coded = dict(zip(self.terms, self.coef))
        return {term_name(t, self.names): float(v)
                for t, v in actual_coefficients(coded, self.factors).items()}

    def equation(self, units: str = "coded", digits: int = 4, display: bool = True) -> str:
        """The model as text, ``units`` ``"coded"`` or ``"actual"``."""
        if units == "coded":
            coefs = dict(zip(self.terms, self.coef))
        elif units == "actual":
            coefs = actual_coefficients(dict(zip(self.terms, self.coef)), self.factors)
        else:
            raise ValueError(units)
        return format_equation(self.response, coefs, self.names, digits, display)

    # -- output ------------------------------------------------------------------------
    def anova_records(self) -> list[dict]:
        rows = []
        for src, r in self.anova.iterrows():
            rows.append({"source": src, "sum_sq": _num(r["sum_sq"]),
                         "df": None if pd.isna(r["df"]) else int(r["df"]),
                         "mean_sq": _num(r["mean_sq"]), "F": _num(r["F"]), "p": _num(r["p"])})
        return rows

    def to_dict(self) -> dict:
        """The ``demcal analyze --json`` object: anova, fit, coefficients."""
        return {"anova": self.anova_records(), "fit": self.fit.to_dict(),
                "coefficients": {k: _num(v) for k, v in self.coefficients.items()}}

    def display_anova(self) -> pd.DataFrame:
        """ANOVA with Design-Expert term labels (AB, A²) and a significance column."""
        df = self.anova.copy()
        labels = {term_name(t, self.names): display_name(t, self.names) for t in self.terms}
        df.index = [labels.get(i, i) for i in df.index]
        df.index.name = "Source"
        sig = []
        for src, p in zip(df.index, df["p"]):
            if pd.isna(p):
                sig.append("")
            elif src == "Lack of Fit":
                sig.append("significant" if p < 0.05 else "not significant")
            else:
                sig.append("**" if p <= 0.01 else "*" if p <= 0.05 else "")
        df["significance"] = sig
        return df


# -------------------------------------------------------------------------------------


def _check_runs(n: int, p_full: int, order: str, k: int):
    if n <= p_full:
        raise DataError(
            f"the {order} model in {k} factors has {p_full} coefficients but the data have only "
            f"{n} runs; it needs at least {p_full + 1} runs, or choose a smaller model."
        )


def fit_response_surface(
    x_coded,
    y,
    factors=None,
    model: str | list = "quadratic",
    response: str = "y",
) -> ResponseSurface:
    """Fit a polynomial response surface in coded factors.

    Parameters
    ----------
    x_coded : array_like, shape (n, k)
        Coded factor levels of each run.
    y : array_like, shape (n,)
        Response of each run.
    factors : sequence of Factor or str, optional
        Names and actual levels (a plain name means actual = coded); default A, B, C, ...
    model : str or list of Term
        ``"linear"``, ``"2fi"``, ``"quadratic"``, ``"cubic"`` or an explicit list of terms
        (exponent tuples; the intercept is added if missing).
    response : str
        Response name used in equations and tables.

    Returns
    -------
    ResponseSurface

    Raises
    ------
    DataError
        Too few runs for the model, or non-finite data.
    """
    from demcal.doe.factors import coded_factors, default_names

    x = np.atleast_2d(np.asarray(x_coded, dtype=float))
    y = np.asarray(y, dtype=float).ravel()
    n, k = x.shape
    if y.size != n:
        raise DataError(f"there are {n} runs of factor settings but {y.size} responses.")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise DataError("the data contain empty or non-finite values; fill or remove those runs.")
    if factors is None:
        factors = coded_factors(default_names(k))
    factors = tuple(Factor(f) if isinstance(f, str) else f for f in factors)
    if len(factors) != k:
        raise DataError(f"{len(factors)} factors were named for {k} factor columns.")
    names = [f.name for f in factors]
    if isinstance(model, str):
        order = normalise_order(model)
        terms = model_terms(k, order)
    else:
        order = "custom"
        terms = [tuple(int(e) for e in t) for t in model]
        zero = tuple([0] * k)
        if zero not in terms:
            terms = [zero] + terms
        terms = sorted(dict.fromkeys(terms), key=lambda t: terms.index(t))
    label = order if order != "custom" else "chosen"
    p_full = len(terms)
    # a cubic model is expected to lose aliased terms (Design-Expert fits what is left);
    # any other model needs more runs than coefficients
    if p_full >= n and order != "cubic":
        _check_runs(n, p_full, label, k)

    X_full = model_matrix(x, terms)
    kept, aliases = find_aliases(X_full, terms, names)
    notes = []
    if aliases:
        notes.append(
            "aliased terms left out of the model: "
            + "; ".join(f"{t} = {e}" for t, e in aliases.items()) + "."
        )
    terms = [terms[i] for i in kept]
    X = X_full[:, kept]
    p = len(terms)
    if n <= p:
        _check_runs(n, p, label, k)

    # least squares through QR (numerically stable), (X'X)^-1 = R^-1 R^-T
    Q, R = np.linalg.qr(X)
    coef = np.linalg.solve(R, Q.T @ y)
    R_inv = np.linalg.inv(R)
    xtx_inv = R_inv @ R_inv.T
    fitted = X @ coef
    resid = y - fitted
    leverage = np.sum(Q**2, axis=1)

    sse = float(resid @ resid)
    ybar = float(y.mean())
    sst = float(np.sum((y - ybar) ** 2))
    df_res = n - p
    mse = sse / df_res
    df_model = p - 1
    ss_model = sst - sse

    def f_row(ss, df, denom, df_denom):
        ms = ss / df if df > 0 else np.nan
        F = ms / denom if df > 0 and denom > 0 else np.nan
        pv = stats.f.sf(F, df, df_denom) if np.isfinite(F) else np.nan
        return [ss, df, ms, F, pv]

    rows = {}
    if df_model > 0:
        rows["Model"] = f_row(ss_model, df_model, mse, df_res)
    diag = np.diag(xtx_inv)
    for j, t in enumerate(terms):
        if degree(t) == 0:
            continue
        ss_t = coef[j] ** 2 / diag[j]
        rows[term_name(t, names)] = f_row(ss_t, 1, mse, df_res)
    rows["Residual"] = [sse, df_res, mse, np.nan, np.nan]
    ss_pe, df_pe, n_distinct = pure_error(x, y)
    df_lof = n_distinct - p
    if df_pe > 0 and df_lof > 0:
        ms_pe = ss_pe / df_pe
        rows["Lack of Fit"] = f_row(sse - ss_pe, df_lof, ms_pe, df_pe)
        rows["Pure Error"] = [ss_pe, df_pe, ms_pe, np.nan, np.nan]
    elif df_pe == 0:
        notes.append("no replicated points, so lack of fit cannot be tested; "
                     "add centre points or repeat runs to test it.")
    else:
        notes.append("the model has as many coefficients as there are distinct points, "
                     "so lack of fit cannot be tested.")
    rows["Cor Total"] = [sst, n - 1, np.nan, np.nan, np.nan]
    anova = pd.DataFrame.from_dict(rows, orient="index", columns=["sum_sq", "df", "mean_sq", "F", "p"])
    anova["df"] = anova["df"].astype(int)
    anova.index.name = "source"

    # fit statistics
    sd = math.sqrt(mse)
    with np.errstate(divide="ignore", invalid="ignore"):
        press = float(np.sum((resid / (1.0 - leverage)) ** 2)) if np.all(leverage < 1 - 1e-10) else np.nan
    r2 = 1.0 - sse / sst if sst > 0 else np.nan
    adj_r2 = 1.0 - (sse / df_res) / (sst / (n - 1)) if sst > 0 else np.nan
    pred_r2 = 1.0 - press / sst if sst > 0 else np.nan
    mean_var = p * mse / n
    adeq = (fitted.max() - fitted.min()) / math.sqrt(mean_var) if mean_var > 0 else np.inf
    fit = FitStatistics(sd, ybar, 100.0 * sd / ybar if ybar != 0 else np.nan, press, r2, adj_r2,
                        pred_r2, adeq)

    # coefficient table
    se = np.sqrt(diag * mse)
    tcrit = stats.t.ppf(0.975, df_res)
    vif = np.full(p, np.nan)
    non_int = [j for j, t in enumerate(terms) if degree(t) > 0]
    if len(non_int) >= 1:
        Z = X[:, non_int]
        Zc = Z - Z.mean(axis=0)
        scale = np.sqrt(np.sum(Zc**2, axis=0))
        corr = (Zc / scale).T @ (Zc / scale)
        try:
            vif[non_int] = np.diag(np.linalg.inv(corr))
        except np.linalg.LinAlgError:
            pass
    coef_table = pd.DataFrame(
        {"estimate": coef, "df": 1, "std_error": se, "ci_low": coef - tcrit * se,
         "ci_high": coef + tcrit * se, "vif": vif},
        index=[term_name(t, names) for t in terms],
    )
    coef_table.index.name = "term"

    diagnostics = influence_table(y, fitted, leverage, p)
    return ResponseSurface(response, factors, terms, x, y, coef, xtx_inv, anova, fit,
                           coef_table, diagnostics, aliases, notes, order)
