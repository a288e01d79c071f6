"""Residual diagnostics of a least-squares response surface, as Design-Expert shows them.

Formulas (Montgomery, *Design and Analysis of Experiments*, 8th ed., 2013, Sec. 10.7;
Myers, Montgomery & Anderson-Cook, *Response Surface Methodology*, 4th ed., 2016,
Sec. 2.7; Belsley, Kuh & Welsch, *Regression Diagnostics*, 1980), with X the n x p
model matrix, e = y - yhat and MSE = e'e / (n - p):

* leverage h_ii: the diagonal of the hat matrix H = X (X'X)^-1 X' (= row sums of Q^2
  for X = QR);
* internally studentized residual r_i = e_i / sqrt(MSE (1 - h_ii));
* externally studentized residual t_i = r_i sqrt((n - p - 1) / (n - p - r_i^2)), the
  residual scaled by the MSE of the fit without run i; t_i ~ t(n - p - 1);
* Cook's distance D_i = r_i^2 h_ii / (p (1 - h_ii));
* DFFITS_i = t_i sqrt(h_ii / (1 - h_ii)).

Limit lines of the plots:

* externally studentized residuals: the Bonferroni outlier test,
  +/- t(1 - alpha / (2n), n - p - 1) (Weisberg, *Applied Linear Regression*, 4th ed.,
  2014, Sec. 9.4.2; Design-Expert draws its red limits on the same t basis);
* Cook's distance: the median of F(p, n - p) (Kutner, Nachtsheim, Neter & Li, *Applied
  Linear Statistical Models*, 5th ed., 2005, Sec. 10.4, p. 403: a run beyond it has a
  major influence on the fit).

Box-Cox (Box & Cox 1964, J. R. Stat. Soc. B 26, 211-252; Montgomery 2013, Sec. 15.1.1):
the residual sum of squares of the model fitted to the standardized power transform
y^(lambda) = (y^lambda - 1) / (lambda g^(lambda - 1)) (g the geometric mean of y;
g ln y at lambda = 0), whose minimum is the maximum-likelihood lambda; the
100(1 - alpha) % confidence interval holds the lambdas whose SS lies below
SS* = SS_min (1 + t^2(alpha/2, nu) / nu), nu the residual degrees of freedom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize as sopt
from scipy import special, stats

from demcal.errors import DataError
from demcal.rsm.terms import model_matrix

#: The lambdas Design-Expert's Box-Cox plot spans.
BOX_COX_RANGE = (-3.0, 3.0)

#: Standard power transforms, by lambda (Stat-Ease help, "Box-Cox plot").
STANDARD_TRANSFORMS = {1.0: "none", 0.5: "square root", 0.0: "natural log",
                       -0.5: "inverse square root", -1.0: "inverse"}


# --------------------------------------------------------------------------- influence


def leverage(X) -> np.ndarray:
    """Diagonal of the hat matrix X (X'X)^-1 X' (through QR: the row sums of Q^2)."""
    Q, _ = np.linalg.qr(np.asarray(X, dtype=float))
    return np.sum(Q**2, axis=1)


def influence_table(y, fitted, leverage, p: int) -> pd.DataFrame:
    """One row per run: ``actual, predicted, residual, leverage, studentized,
    externally_studentized, cooks_distance, dffits`` (formulas in the module docstring).

    Parameters
    ----------
    y, fitted : array_like, shape (n,)
        Responses and the model's predictions at the runs.
    leverage : array_like, shape (n,)
        Diagonal of the hat matrix.
    p : int
        Number of model coefficients (intercept included).
    """
    y = np.asarray(y, dtype=float)
    fitted = np.asarray(fitted, dtype=float)
    h = np.asarray(leverage, dtype=float)
    n = y.size
    resid = y - fitted
    df_res = n - p
    sd = np.sqrt(float(resid @ resid) / df_res) if df_res > 0 else np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        stud = resid / (sd * np.sqrt(1.0 - h))
        ext = (stud * np.sqrt((df_res - 1) / np.maximum(df_res - stud**2, 1e-300)) if df_res > 1
               else np.full(n, np.nan))
        cooks = stud**2 * h / (p * (1.0 - h))
        dffits = ext * np.sqrt(h / (1.0 - h))
    return pd.DataFrame(
        {"actual": y, "predicted": fitted, "residual": resid, "leverage": h,
         "studentized": stud, "externally_studentized": ext, "cooks_distance": cooks,
         "dffits": dffits},
        index=pd.RangeIndex(1, n + 1, name="run"),
    )


def outlier_limit(n: int, p: int, alpha: float = 0.05) -> float:
    """Bonferroni limit of the externally studentized residuals,
    t(1 - alpha / (2n), n - p - 1); NaN without the degrees of freedom."""
    df = n - p - 1
    return float(stats.t.ppf(1.0 - alpha / (2.0 * n), df)) if df > 0 else float("nan")


def cooks_limit(n: int, p: int) -> float:
    """Median of F(p, n - p): Cook's distance beyond it marks a major influence
    (Kutner et al. 2005, p. 403); NaN without residual degrees of freedom."""
    return float(stats.f.ppf(0.5, p, n - p)) if n > p else float("nan")


# --------------------------------------------------------------------------- normal plot


@dataclass(frozen=True)
class NormalPlot:
    """Points and reference line of a normal probability plot.

    ``values`` sorted ascending; ``probability`` the plotting positions (i - 0.5) / n
    (Montgomery 2013, Sec. 2.4.1); ``z`` their standard normal quantiles; the
    reference line ``value = intercept + slope * z`` passes through the first and
    third quartiles of the values at z = -/+ 0.6745 (Chambers, Cleveland, Kleiner &
    Tukey, *Graphical Methods for Data Analysis*, 1983, Sec. 6.7; R's ``qqline``).
    """

    values: np.ndarray
    probability: np.ndarray
    z: np.ndarray
    intercept: float
    slope: float


def normal_plot(values) -> NormalPlot:
    """The normal probability plot of ``values`` (NaNs left out)."""
    v = np.sort(np.asarray(values, dtype=float))
    v = v[np.isfinite(v)]
    n = v.size
    prob = (np.arange(1, n + 1) - 0.5) / n
    z = stats.norm.ppf(prob)
    q1, q3 = np.percentile(v, [25, 75]) if n else (np.nan, np.nan)
    zq = stats.norm.ppf(0.75)
    slope = (q3 - q1) / (2.0 * zq)
    return NormalPlot(v, prob, z, float((q1 + q3) / 2.0), float(slope))


# --------------------------------------------------------------------------- Box-Cox


@dataclass(frozen=True)
class BoxCox:
    """Box-Cox analysis of one model: ln(residual SS) against lambda.

    Attributes
    ----------
    lambdas, ln_ss : numpy.ndarray
        The curve over :data:`BOX_COX_RANGE`.
    best : float
        Lambda of the smallest residual SS (maximum likelihood).
    ci : (float, float)
        The confidence interval of lambda, clipped to the plotted range.
    ci_open : (bool, bool)
        The interval runs past the low / high end of the range.
    ln_ss_limit : float
        ln SS*, the level that bounds the interval.
    level : float
    current : float
        The lambda of the model as fitted (1: no transform).
    """

    lambdas: np.ndarray
    ln_ss: np.ndarray
    best: float
    ci: tuple[float, float]
    ci_open: tuple[bool, bool]
    ln_ss_limit: float
    level: float = 0.95
    current: float = 1.0

    def contains(self, lam: float) -> bool:
        lo, hi = self.ci
        return (lo <= lam or self.ci_open[0]) and (lam <= hi or self.ci_open[1])

    @property
    def recommended(self) -> float | None:
        """Design-Expert's choice: None (no transform) when the current lambda lies
        inside the interval, else the standard transform nearest the best lambda inside
        it, else the best lambda itself (a power transform)."""
        if self.contains(self.current):
            return None
        inside = [lam for lam in STANDARD_TRANSFORMS if self.contains(lam)]
        return min(inside, key=lambda lam: abs(lam - self.best)) if inside else float(self.best)

    def recommendation(self) -> str:
        """The recommendation in words."""
        pct = f"{100 * self.level:g} %"
        lo = f"below {self.lambdas[0]:g}" if self.ci_open[0] else f"{self.ci[0]:.2f}"
        hi = f"above {self.lambdas[-1]:g}" if self.ci_open[1] else f"{self.ci[1]:.2f}"
        where = f"best lambda {self.best:.2f}, {pct} CI {lo} to {hi}"
        rec = self.recommended
        if rec is None:
            return f"lambda = {self.current:g} lies inside the {pct} CI ({where}): no transform recommended."
        name = STANDARD_TRANSFORMS.get(rec)
        what = f"{name} (lambda = {rec:g})" if name else f"power transform with lambda = {rec:.2f}"
        return f"lambda = {self.current:g} lies outside the {pct} CI ({where}): recommended transform: {what}."


def box_cox_ss(X, y, lambdas) -> np.ndarray:
    """Residual SS of the model matrix ``X`` fitted to the standardized Box-Cox
    transform of ``y`` (all positive) at each lambda."""
    y = np.asarray(y, dtype=float)
    if np.any(y <= 0) or not np.all(np.isfinite(y)):
        raise DataError("a Box-Cox transform needs positive responses; add a constant to make them all "
                        "positive first.")
    Q, _ = np.linalg.qr(np.asarray(X, dtype=float))
    log_g = float(np.mean(np.log(y)))
    out = []
    for lam in np.atleast_1d(np.asarray(lambdas, dtype=float)):
        # (y^lam - 1) / lam through scipy (exact at and near lam = 0), scaled by g^(lam - 1)
        z = special.boxcox(y, lam) / np.exp((lam - 1.0) * log_g)
        r = z - Q @ (Q.T @ z)
        out.append(float(r @ r))
    return np.array(out)


def box_cox(X, y, level: float = 0.95, lambdas=None, current: float = 1.0) -> BoxCox:
    """Box-Cox analysis of the model with matrix ``X`` on responses ``y``.

    The best lambda minimises the residual SS (searched over :data:`BOX_COX_RANGE`);
    the interval ends are where ln SS crosses ln SS* (module docstring), found by root
    bracketing.

    Raises
    ------
    DataError
        A response not positive, or no residual degrees of freedom.
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float).ravel()
    n, p = X.shape
    nu = n - p
    if nu <= 0:
        raise DataError("a Box-Cox analysis needs residual degrees of freedom: more runs than model terms.")
    lo_end, hi_end = BOX_COX_RANGE
    grid = np.linspace(lo_end, hi_end, 121) if lambdas is None else np.asarray(lambdas, dtype=float)
    ss = box_cox_ss(X, y, grid)
    if np.min(ss) <= 0:
        raise DataError("the model fits the responses exactly, so a Box-Cox analysis has nothing to compare.")

    def ln_ss(lam: float) -> float:
        return float(np.log(box_cox_ss(X, y, [lam])[0]))

    k = int(np.argmin(ss))
    left, right = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    best = float(sopt.minimize_scalar(ln_ss, bounds=(left, right), method="bounded",
                                      options={"xatol": 1e-8}).x) if right > left else float(grid[k])
    t = stats.t.ppf(0.5 + level / 2.0, nu)
    limit = ln_ss(best) + float(np.log1p(t * t / nu))

    def crossing(a: float, b: float) -> float:
        return float(sopt.brentq(lambda lam: ln_ss(lam) - limit, a, b, xtol=1e-10))

    # the last grid point above the limit on each side of the best lambda brackets a crossing
    ln_grid = np.log(ss)
    outside = ln_grid > limit
    low = np.flatnonzero(outside & (grid < best))
    high = np.flatnonzero(outside & (grid > best))
    ci_low = crossing(grid[low[-1]], min(grid[low[-1] + 1], best)) if low.size else float(grid[0])
    ci_high = crossing(max(grid[high[0] - 1], best), grid[high[0]]) if high.size else float(grid[-1])
    return BoxCox(grid, ln_grid, best, (ci_low, ci_high), (not low.size, not high.size), limit, level,
                  current)


def model_box_cox(model, level: float = 0.95) -> BoxCox:
    """:func:`box_cox` of a fitted :class:`~demcal.rsm.ResponseSurface` (its own terms)."""
    return box_cox(model_matrix(model.x, model.terms), model.y, level)


# --------------------------------------------------------------------------- interactions


def significant_interactions(model, alpha: float = 0.05) -> list[tuple[int, int, float]]:
    """Two-factor interaction terms (A*B) of ``model`` with ANOVA p < ``alpha``, as
    ``(i, j, p)`` factor indices, strongest first."""
    out = []
    for term, name in zip(model.terms, model.term_names):
        if sorted(term) != [0] * (len(term) - 2) + [1, 1] or name not in model.anova.index:
            continue
        p = float(model.anova.loc[name, "p"])
        if np.isfinite(p) and p < alpha:
            i, j = (m for m, e in enumerate(term) if e)
            out.append((i, j, p))
    return sorted(out, key=lambda r: r[2])


def confidence_band(model, coded, level: float = 0.95) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prediction and the ``level`` confidence interval of the mean response at coded
    points: yhat -/+ t(1/2 + level/2, n - p) se(yhat)."""
    coded = np.atleast_2d(np.asarray(coded, dtype=float))
    yhat = np.asarray(model.predict(coded), dtype=float)
    half = float(stats.t.ppf(0.5 + level / 2.0, model.df_residual)) * model.prediction_se(coded)
    return yhat, yhat - half, yhat + half
