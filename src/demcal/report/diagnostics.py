"""Design-Expert's diagnostic and optimisation graphs for the HTML report.

For each response model (:func:`add_residual_sections`, :func:`add_interaction_sections`):
the normal probability plot of the externally studentized residuals, those residuals
against the predicted response and against run order, Cook's distance per run, the
Box-Cox plot with its recommendation in words, and an interaction plot for each
significant two-factor term. For each solved condition (:func:`add_desirability_sections`):
the desirability ramps and the overlay plot of the window every response must meet.

The statistics come from :mod:`demcal.rsm.diagnostics`; the figures follow
:mod:`demcal.report.figures` (no pyplot, axis labels with units, at most five ticks).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from demcal.errors import DataError
from demcal.report.figures import _factor_label, _short_ticks, _with_label, response_label
from demcal.rsm.diagnostics import (
    confidence_band, cooks_limit, model_box_cox, normal_plot, outlier_limit, significant_interactions,
)

__all__ = [
    "normal_plot_figure", "residuals_vs_predicted_figure", "residuals_vs_run_figure",
    "cooks_distance_figure", "box_cox_figure", "interaction_figure", "ramps_figure", "overlay_figure",
    "overlay_grid", "tests_figure", "important_factors", "solved_models",
    "add_residual_sections", "add_interaction_sections", "add_desirability_sections",
]

#: Probabilities [%] marked on the normal plot's axis (Design-Expert's scale).
_PROBABILITIES = (1, 5, 10, 20, 30, 50, 70, 80, 90, 95, 99)
_LIMIT = dict(color="tab:red", lw=1.0)
_POINT = dict(s=24, color="tab:blue", edgecolor="k", linewidth=0.4, zorder=3)
STUDENTIZED = "Externally studentized residual [-]"


def _axes(size=(4.6, 3.8)):
    fig = Figure(figsize=size)
    fig.subplots_adjust(left=0.16, right=0.96, bottom=0.14, top=0.9)
    return fig, fig.add_subplot()


def _runs(model, run_order) -> np.ndarray:
    runs = np.asarray(model.diagnostics.index if run_order is None else run_order, dtype=float)
    if runs.size != model.n:
        raise DataError(f"{runs.size} run numbers were given for the {model.n} runs of the model.")
    return runs


def _limit_lines(ax, limit: float) -> None:
    if np.isfinite(limit):
        for v in (-limit, limit):
            ax.axhline(v, **_LIMIT)
    ax.axhline(0.0, color="0.6", lw=0.6)


def _residual_span(ax, values, limit: float) -> None:
    top = np.nanmax(np.abs(values)) if np.any(np.isfinite(values)) else 1.0
    top = max(top, limit if np.isfinite(limit) else 0.0, 1.0) * 1.12
    ax.set_ylim(-top, top)


def normal_plot_figure(model, label: str | None = None) -> Figure:
    """Normal % probability against the externally studentized residuals, with the
    reference line through their quartiles (:func:`demcal.rsm.diagnostics.normal_plot`)."""
    from scipy import stats

    plot = normal_plot(model.diagnostics["externally_studentized"])
    fig, ax = _axes()
    ax.scatter(plot.values, plot.z, **_POINT)
    z = np.array([min(plot.z.min(), -2.4), max(plot.z.max(), 2.4)]) if plot.z.size else np.array([-2.4, 2.4])
    ax.plot(plot.intercept + plot.slope * z, z, color="tab:red", lw=1.0)
    ax.set_yticks(stats.norm.ppf(np.array(_PROBABILITIES) / 100.0))
    ax.set_yticklabels([f"{p:g}" for p in _PROBABILITIES])
    ax.set_ylim(z[0] - 0.1, z[1] + 0.1)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=5))
    ax.set_xlabel(STUDENTIZED)
    ax.set_ylabel("Normal probability [%]")
    ax.set_title(_with_label("Normal plot of residuals", label), fontsize=10)
    return fig


def residuals_vs_predicted_figure(model, label: str | None = None) -> Figure:
    """Externally studentized residuals against the predicted response, with the
    Bonferroni outlier limits (:func:`demcal.rsm.diagnostics.outlier_limit`)."""
    d = model.diagnostics
    limit = outlier_limit(model.n, model.p)
    fig, ax = _axes()
    _limit_lines(ax, limit)
    ax.scatter(d["predicted"], d["externally_studentized"], **_POINT)
    _residual_span(ax, d["externally_studentized"].to_numpy(), limit)
    _short_ticks(ax, ("x",))
    ax.set_xlabel(f"Predicted {response_label(model.response)}")
    ax.set_ylabel(STUDENTIZED)
    ax.set_title(_with_label("Residuals vs predicted", label), fontsize=10)
    return fig


def residuals_vs_run_figure(model, run_order=None, label: str | None = None) -> Figure:
    """Externally studentized residuals in run order, with the Bonferroni outlier limits."""
    d = model.diagnostics
    runs = _runs(model, run_order)
    order = np.argsort(runs, kind="stable")
    limit = outlier_limit(model.n, model.p)
    fig, ax = _axes()
    _limit_lines(ax, limit)
    ext = d["externally_studentized"].to_numpy()
    ax.plot(runs[order], ext[order], color="0.5", lw=0.6)
    ax.scatter(runs, ext, **_POINT)
    _residual_span(ax, ext, limit)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=6, integer=True))
    ax.set_xlabel("Run number (design order) [-]")
    ax.set_ylabel(STUDENTIZED)
    ax.set_title(_with_label("Residuals vs run", label), fontsize=10)
    return fig


def cooks_distance_figure(model, run_order=None, label: str | None = None) -> Figure:
    """Cook's distance of each run, with the median of F(p, n - p) as the limit
    (:func:`demcal.rsm.diagnostics.cooks_limit`)."""
    cooks = model.diagnostics["cooks_distance"].to_numpy()
    runs = _runs(model, run_order)
    limit = cooks_limit(model.n, model.p)
    fig, ax = _axes()
    ax.vlines(runs, 0.0, cooks, color="0.5", lw=0.8)
    ax.scatter(runs, cooks, **_POINT)
    if np.isfinite(limit):
        ax.axhline(limit, **_LIMIT)
    top = max(np.nanmax(cooks) if np.any(np.isfinite(cooks)) else 0.0, limit if np.isfinite(limit) else 0.0)
    ax.set_ylim(0.0, 1.12 * top or 1.0)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=6, integer=True))
    _short_ticks(ax, ("y",))
    ax.set_xlabel("Run number (design order) [-]")
    ax.set_ylabel("Cook's distance [-]")
    ax.set_title(_with_label("Cook's distance", label), fontsize=10)
    return fig


def box_cox_figure(model, result=None, label: str | None = None) -> Figure:
    """ln(residual SS) against lambda: the curve, the level ln SS* that bounds the
    confidence interval, the interval, the best lambda and the current one (1)."""
    bc = model_box_cox(model) if result is None else result
    fig, ax = _axes((5.0, 4.4))
    fig.subplots_adjust(bottom=0.3)
    ax.plot(bc.lambdas, bc.ln_ss, color="tab:blue", lw=1.4, label="ln(residual SS)")
    ax.axhline(bc.ln_ss_limit, color="0.5", lw=0.8, ls=":", label=f"{100 * bc.level:g} % limit (ln SS*)")
    for lam, is_open in zip(bc.ci, bc.ci_open):
        if not is_open:
            ax.axvline(lam, **_LIMIT)
    ax.axvspan(bc.ci[0], bc.ci[1], color="tab:red", alpha=0.08, lw=0,
               label=f"{100 * bc.level:g} % CI of lambda")
    ax.axvline(bc.best, color="tab:green", lw=1.2, label=f"best lambda = {bc.best:.2f}")
    ax.axvline(bc.current, color="tab:blue", lw=1.0, ls="--", label=f"current lambda = {bc.current:g}")
    span = np.ptp(bc.ln_ss)
    ax.set_ylim(bc.ln_ss.min() - 0.05 * span, bc.ln_ss.max() + 0.05 * span)
    ax.set_xlim(bc.lambdas[0], bc.lambdas[-1])
    _short_ticks(ax, ("y",))
    ax.set_xlabel("Lambda [-]")
    ax.set_ylabel("ln(residual SS) [-]")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0, -0.14), ncol=2, frameon=False)
    rec = bc.recommended
    ax.set_title(_with_label("Box-Cox: " + ("no transform recommended" if rec is None else
                                           f"transform recommended (lambda = {rec:.2g})"), label), fontsize=10)
    return fig


def interaction_figure(model, i: int, j: int, hold=None, label: str | None = None, n: int = 41) -> Figure:
    """Response against factor ``i`` with factor ``j`` at its low and high level (other
    factors at ``hold``, coded, default the centre), with 95 % confidence bands of the
    mean (:func:`demcal.rsm.diagnostics.confidence_band`)."""
    k = len(model.factors)
    hold = np.zeros(k) if hold is None else np.asarray(hold, dtype=float)
    fi, fj = model.factors[i], model.factors[j]
    g = np.linspace(-1.0, 1.0, n)
    fig, ax = _axes((5.0, 3.9))
    for level, colour in ((-1.0, "tab:blue"), (1.0, "tab:red")):
        pts = np.tile(hold, (n, 1))
        pts[:, i] = g
        pts[:, j] = level
        yhat, lo, hi = confidence_band(model, pts)
        x = fi.to_actual(g)
        ax.fill_between(x, lo, hi, color=colour, alpha=0.15, lw=0)
        ax.plot(x, yhat, color=colour, lw=1.4, label=f"{fj.name} = {float(fj.to_actual(level)):.3g} ({level:+g})")
    _short_ticks(ax)
    ax.set_xlabel(_factor_label(fi))
    ax.set_ylabel(response_label(model.response))
    ax.legend(fontsize=7, frameon=False, title=_factor_label(fj), title_fontsize=7)
    ax.set_title(_with_label(f"Interaction {fi.name}{fj.name}", label), fontsize=10)
    return fig


# --------------------------------------------------------------------------- report blocks


def _outside(values, runs, limit: float, fmt: str) -> str:
    """"run 7 (3.9), run 12 (-4.1)" for the values beyond +/- ``limit``."""
    values = np.asarray(values, dtype=float)
    hit = np.isfinite(values) & (np.abs(values) > limit)
    return ", ".join(f"run {int(r)} ({v:{fmt}})" for r, v in zip(np.asarray(runs)[hit], values[hit]))


def add_residual_sections(report, model, name: str, of: str, label: str | None = None, run_order=None) -> None:
    """Normal plot, residuals vs predicted and vs run, Cook's distance and Box-Cox of
    ``model`` (described as ``of`` in captions), appended to ``report``."""
    n, p = model.n, model.p
    runs = _runs(model, run_order)
    limit = outlier_limit(n, p)
    limit_text = (f"red lines: ±{limit:.2f}, the Bonferroni outlier limits t(1 - 0.05/(2·{n}), {n - p - 1})"
                  if np.isfinite(limit) else "no outlier limits: too few residual degrees of freedom")
    report.figure(normal_plot_figure(model, label), f"{name}_normal_plot",
                  caption=f"Normal probability plot of the externally studentized residuals of {model.response}, "
                          f"{of}; red line: through their quartiles; points along it mean normally distributed errors")
    report.figure(residuals_vs_predicted_figure(model, label), f"{name}_residuals_vs_predicted",
                  caption=f"Externally studentized residuals against predicted {model.response}, {of}; "
                          f"{limit_text}; a funnel or curve means the variance or the model is wrong")
    report.figure(residuals_vs_run_figure(model, runs, label), f"{name}_residuals_vs_run",
                  caption=f"Externally studentized residuals of {model.response} in design run order, {of}; "
                          f"{limit_text}; a trend means something drifted from run to run")
    flagged = _outside(model.diagnostics["externally_studentized"], runs, limit, ".2f") if np.isfinite(limit) else ""
    if flagged:
        report.note(f"{model.response}: externally studentized residuals beyond ±{limit:.2f}: {flagged}; "
                    "check those runs (a failed or unsettled simulation, a wrong entry) before trusting the model.")
    climit = cooks_limit(n, p)
    report.figure(cooks_distance_figure(model, runs, label), f"{name}_cooks_distance",
                  caption=f"Cook's distance of each run of {model.response}, {of}; red line: {climit:.3g}, "
                          f"the median of F({p}, {n - p}) (Kutner et al. 2005): a run above it moves the fit "
                          "strongly" if np.isfinite(climit) else
                          f"Cook's distance of each run of {model.response}, {of}")
    influential = _outside(model.diagnostics["cooks_distance"], runs, climit, ".3g") if np.isfinite(climit) else ""
    if influential:
        report.note(f"{model.response}: Cook's distance above {climit:.3g}: {influential}.")
    try:
        bc = model_box_cox(model)
    except DataError as exc:
        report.note(f"No Box-Cox plot of {model.response}: {exc}")
        return
    report.figure(box_cox_figure(model, bc, label), f"{name}_box_cox",
                  caption=f"Box-Cox plot of {model.response}, {of}: ln(residual SS) of the standardized power "
                          f"transform against lambda; {bc.recommendation()}")


def add_interaction_sections(report, model, name: str, of: str, label: str | None = None,
                             alpha: float = 0.05) -> None:
    """One interaction plot per two-factor term of ``model`` with p < ``alpha``."""
    pairs = significant_interactions(model, alpha)
    if not pairs:
        report.paragraph(f"No two-factor interaction of {model.response} is significant (p < {alpha:g}) in the "
                         f"{of}, so there is no interaction plot.")
        return
    for i, j, p in pairs:
        fi, fj = model.factors[i], model.factors[j]
        others = [f.name for m, f in enumerate(model.factors) if m not in (i, j)]
        held = f", {', '.join(others)} at their centre levels" if others else ""
        report.figure(interaction_figure(model, i, j, label=label), f"{name}_interaction_{fi.name}{fj.name}",
                      caption=f"Interaction {fi.name}{fj.name} (p = {p:.3g}) of {model.response}, {of}: "
                              f"{model.response} against {fi.name} with {fj.name} at its low and high level"
                              f"{held}; bands: 95 % confidence interval of the mean")


# --------------------------------------------------------------------------- desirability


def _parts(test: str, windows: dict) -> dict:
    """``{response: test}`` of a joint test's responses (the one test's name otherwise)."""
    from demcal.bench.registry import get_experiment

    experiment = get_experiment(test)
    part_of = getattr(experiment, "part_of", None)
    return {r: (part_of(r) if part_of else test) for r in windows}


def solved_models(cal, result) -> dict:
    """``{response: surface}`` the condition's search solved: the final box's model
    plus the production discrepancy (as :mod:`demcal.campaign.loop` builds it), or
    the models of the condition's design when it ran no loop."""
    loop = result.loop
    if loop is None or not loop.models:
        name = result.condition.name
        designs = getattr(cal, "designs", None) or []
        return dict(next((d.models for d in designs if name in {c.name for c in d.conditions}), cal.models))
    return {**loop.models, **loop.corrected()}


def _windows(result, optimization) -> dict:
    """``{response: (low, high, how)}``: the lab mean ± sd, or the goal's D >= threshold band."""
    out = {}
    goals = {g.response: g for g in optimization.goals}
    for t in result.condition.targets:
        if t.sd is not None and t.sd > 0:
            out[t.response] = (t.mean - t.sd, t.mean + t.sd, "lab mean ± sd")
        elif t.response in goals:
            lo, hi = goals[t.response].band(optimization.threshold)
            out[t.response] = (lo, hi, f"desirability ≥ {optimization.threshold:g}")
    return out


def _solution(optimization) -> tuple[np.ndarray, dict]:
    """Coded point and predictions of solution 1 (the one simulated)."""
    best = optimization.solutions.iloc[0]
    point = np.array([float(best[f"coded:{f.name}"]) for f in optimization.factors])
    predicted = {g.response: float(best[f"predicted:{g.response}"]) for g in optimization.goals}
    return point, predicted


def important_factors(models: dict, windows: dict, point, k: int) -> list[int]:
    """Factor indices, most important first: how far each response moves as the factor
    runs over the box (others at ``point``), relative to its window's width, summed."""
    g = np.linspace(-1.0, 1.0, 21)
    score = np.zeros(k)
    for response, (lo, hi, _) in windows.items():
        width = hi - lo if np.isfinite(hi - lo) and hi > lo else 1.0
        for m in range(k):
            pts = np.tile(point, (g.size, 1))
            pts[:, m] = g
            y = np.asarray(models[response].predict(pts), dtype=float)
            score[m] += np.ptp(y) / width
    return [int(m) for m in np.argsort(-score, kind="stable")]


def ramps_figure(optimization, windows: dict | None = None) -> Figure:
    """Design-Expert's ramps: one panel per factor (its range, the solution's level) and
    per response (the goal's desirability ramp, the solution's prediction, the window)."""
    factors, goals = list(optimization.factors), list(optimization.goals)
    best = optimization.solutions.iloc[0]
    panels = len(factors) + len(goals)
    cols = min(panels, 5)
    rows = -(-panels // cols)
    fig = Figure(figsize=(2.5 * cols, 2.0 * rows + 0.5))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.16 / rows + 0.06, top=1 - 0.5 / (2.0 * rows + 0.5),
                        wspace=0.35, hspace=0.9)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, f in zip(axes, factors):
        x = float(best[f"actual:{f.name}"])
        ax.plot([f.low, f.high], [1.0, 1.0], color="tab:green", lw=2.0)
        ax.scatter([x], [1.0], marker="o", s=40, color="tab:red", edgecolor="k", linewidth=0.4, zorder=3)
        ax.set_xlim(f.low - 0.05 * (f.high - f.low), f.high + 0.05 * (f.high - f.low))
        ax.set_title(f"{f.name} = {x:.4g}", fontsize=8)
        ax.set_xlabel(_factor_label(f), fontsize=7)
    for ax, g in zip(axes[len(factors):], goals):
        y = float(best[f"predicted:{g.response}"])
        lo, hi = g.low, g.high
        pad = 0.1 * (hi - lo or 1.0)
        grid = np.linspace(lo - pad, hi + pad, 201)
        ax.plot(grid, g.desirability(grid), color="tab:green", lw=1.5)
        if windows and g.response in windows:
            wl, wh, _ = windows[g.response]
            ax.axvspan(wl, wh, color="gold", alpha=0.3, lw=0)
        ax.scatter([y], [float(g.desirability(y))], marker="o", s=40, color="tab:red", edgecolor="k",
                   linewidth=0.4, zorder=3)
        ax.set_xlim(grid[0], grid[-1])
        ax.set_title(f"{g.response} = {y:.4g}, d = {float(g.desirability(y)):.3f}", fontsize=8)
        ax.set_xlabel(response_label(g.response), fontsize=7)
    for ax in axes[:panels]:
        ax.set_ylim(-0.08, 1.12)
        ax.set_yticks([0, 0.5, 1])
        ax.tick_params(labelsize=7)
        _short_ticks(ax, ("x",))
    axes[0].set_ylabel("Desirability [-]", fontsize=7)
    for ax in axes[panels:]:
        ax.set_visible(False)
    fig.suptitle(f"Desirability ramps, solution 1: D = {float(best['desirability']):.3f}", fontsize=10)
    return fig


def overlay_grid(models: dict, windows: dict, point, i: int, j: int, n: int = 81,
                 level: float | None = None) -> dict:
    """Coded grid over factors ``i`` and ``j`` (others at ``point``): ``{"gi", "gj",
    "z": {response: predictions}, "inside": {response: inside its window}, "feasible":
    every response inside its window}``. With ``level``, a response counts as inside where
    its ``level`` confidence interval of the mean reaches into the window
    (:func:`demcal.optimize.overlay.interval_half_width`, as the compatible ranges)."""
    from demcal.optimize.overlay import interval_half_width, reaches

    g = np.linspace(-1.0, 1.0, n)
    gi, gj = np.meshgrid(g, g, indexing="xy")
    pts = np.tile(np.asarray(point, dtype=float), (gi.size, 1))
    pts[:, i] = gi.ravel()
    pts[:, j] = gj.ravel()
    z = {r: np.asarray(models[r].predict(pts), dtype=float) for r in windows}
    inside = {r: reaches(z[r], 0.0 if level is None else interval_half_width(models[r], pts, level), lo,
                         hi).reshape(gi.shape)
              for r, (lo, hi, _) in windows.items()}
    feasible = np.logical_and.reduce([inside[r] for r in windows]) if windows else np.ones(gi.shape, bool)
    return {"gi": gi, "gj": gj, "z": {r: y.reshape(gi.shape) for r, y in z.items()}, "inside": inside,
            "feasible": feasible}


def overlay_figure(models: dict, optimization, windows: dict, i: int, j: int, point=None, n: int = 81,
                   grid: dict | None = None) -> Figure:
    """Overlay plot over factors ``i`` and ``j`` (actual units), others at ``point``
    (coded, default solution 1): yellow where every predicted response lies inside its
    window (:func:`overlay_grid`), grey elsewhere; each window's limits as contours;
    solution 1 flagged with its predictions."""
    factors = list(optimization.factors)
    sol, predicted = _solution(optimization)
    point = sol if point is None else np.asarray(point, dtype=float)
    grid = overlay_grid(models, windows, point, i, j, n) if grid is None else grid
    fi, fj = factors[i], factors[j]
    xi, xj = fi.to_actual(grid["gi"]), fj.to_actual(grid["gj"])
    fig, ax = _axes((5.4, 4.4))
    fig.subplots_adjust(bottom=0.2)
    colours = ("tab:red", "tab:blue", "tab:purple", "tab:brown")
    handles = []
    ax.contourf(xi, xj, grid["feasible"].astype(float), levels=[-0.5, 0.5, 1.5], colors=["0.8", "gold"],
                zorder=1)
    for m, (response, (lo, hi, how)) in enumerate(windows.items()):
        z = grid["z"][response]
        colour = colours[m % len(colours)]
        levels = [v for v in (lo, hi) if np.isfinite(v) and z.min() < v < z.max()]
        if levels:
            cs = ax.contour(xi, xj, z, levels=levels, colors=colour, linewidths=1.0, zorder=3)
            ax.clabel(cs, fontsize=6, fmt=lambda v: f"{v:.3g}")
        handles.append(Line2D([], [], color=colour, label=f"{response}: {lo:.3g} to {hi:.3g} ({how})"))
    x0, y0 = float(fi.to_actual(point[i])), float(fj.to_actual(point[j]))
    ax.scatter([x0], [y0], marker="*", s=140, color="tab:red", edgecolor="k", linewidth=0.4, zorder=5,
               clip_on=False)
    # the label on the side of the star that faces the plot's middle, so it is never cut off
    (xl, xh), (yl, yh) = ax.get_xlim(), ax.get_ylim()
    right, up = x0 < 0.5 * (xl + xh), y0 < 0.5 * (yl + yh)
    ax.annotate(", ".join(f"{r} {v:.3g}" for r, v in predicted.items()), (x0, y0), textcoords="offset points",
                xytext=(6 if right else -6, 6 if up else -6), ha="left" if right else "right",
                va="bottom" if up else "top", fontsize=7, zorder=6, bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.5",
                                                                lw=0.5))
    _short_ticks(ax)
    ax.set_xlabel(_factor_label(fi))
    ax.set_ylabel(_factor_label(fj))
    ax.legend(handles=handles, fontsize=6, loc="upper left", bbox_to_anchor=(0, -0.13), frameon=False)
    others = [f"{f.name} = {f.to_actual(point[m]):.3g}" for m, f in enumerate(factors) if m not in (i, j)]
    what = "Overlay: yellow meets every window" if grid["feasible"].any() else "Overlay: no setting meets every window"
    ax.set_title(what + (f" ({', '.join(others)})" if others else ""), fontsize=9)
    return fig


def tests_figure(models: dict, optimization, windows: dict, parts: dict, i: int, j: int, point,
                 reference: dict | None = None, n: int = 81) -> Figure:
    """How much each test of a joint campaign pins, over factors ``i`` and ``j`` (others
    at the coded ``point``): each test's own region (every one of its responses inside its
    window, within the fit's 95 % interval of the mean as the compatible ranges:
    :data:`demcal.campaign.calibrate.COMPATIBLE_LEVEL`) outlined and lightly filled in its
    colour, the region of all together in gold,
    solution 1 as a red star and ``reference`` (parameter: value, e.g. the values the
    targets were simulated at) as a black cross where it names both factors. ``parts``
    maps each response to its test."""
    from demcal.campaign.calibrate import COMPATIBLE_LEVEL

    factors = list(optimization.factors)
    grid = overlay_grid(models, windows, point, i, j, n, level=COMPATIBLE_LEVEL)
    fi, fj = factors[i], factors[j]
    xi, xj = fi.to_actual(grid["gi"]), fj.to_actual(grid["gj"])
    fig, ax = _axes((5.4, 4.6))
    fig.subplots_adjust(bottom=0.26)
    colours = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:brown")
    handles = []
    for m, test in enumerate(dict.fromkeys(parts[r] for r in windows)):
        alone = np.logical_and.reduce([grid["inside"][r] for r in windows if parts[r] == test])
        colour = colours[m % len(colours)]
        if alone.any():
            ax.contourf(xi, xj, alone.astype(float), levels=[0.5, 1.5], colors=[colour], alpha=0.18, zorder=1)
            ax.contour(xi, xj, alone.astype(float), levels=[0.5], colors=[colour], linewidths=1.2, zorder=3)
        handles.append(Patch(facecolor=colour, alpha=0.35, edgecolor=colour,
                             label=f"{test} alone: {100.0 * alone.mean():.0f} % of the plane"))
    if grid["feasible"].any():
        ax.contourf(xi, xj, grid["feasible"].astype(float), levels=[0.5, 1.5], colors=["gold"], zorder=2)
    handles.append(Patch(facecolor="gold", label=f"all together: {100.0 * grid['feasible'].mean():.0f} % of the plane"))
    sol, _ = _solution(optimization)
    ax.scatter([float(fi.to_actual(sol[i]))], [float(fj.to_actual(sol[j]))], marker="*", s=140, color="tab:red",
               edgecolor="k", linewidth=0.4, zorder=5, clip_on=False)
    handles.append(Line2D([], [], marker="*", color="tab:red", markeredgecolor="k", linestyle="", label="solution 1"))
    reference = reference or {}
    if fi.parameter in reference and fj.parameter in reference:
        ax.scatter([reference[fi.parameter]], [reference[fj.parameter]], marker="x", s=70, color="k", zorder=6,
                   clip_on=False)
        handles.append(Line2D([], [], marker="x", color="k", linestyle="", label="reference values"))
    _short_ticks(ax)
    ax.set_xlabel(_factor_label(fi))
    ax.set_ylabel(_factor_label(fj))
    ax.legend(handles=handles, fontsize=6, loc="upper left", bbox_to_anchor=(0, -0.13), frameon=False, ncol=2)
    others = [f"{f.name} = {f.to_actual(point[m]):.3g}" for m, f in enumerate(factors) if m not in (i, j)]
    ax.set_title("Each test alone and all together" + (f" ({', '.join(others)})" if others else ""), fontsize=9)
    return fig


def add_desirability_sections(report, cal, result, name: str) -> None:
    """Ramps and overlay plot of one solved condition (``cal``: its
    :class:`~demcal.campaign.calibrate.Calibration`, ``result``: the condition's result)."""
    optimization = result.optimization
    condition = result.condition.name
    windows = _windows(result, optimization)
    report.figure(ramps_figure(optimization, windows), f"{name}_ramps",
                  caption=f"{condition}: desirability ramps of solution 1 (the one simulated): each factor over "
                          "its box range with the solution's level (red dot), each response's desirability "
                          "against its value with the prediction there (red dot) and the target window (yellow)")
    models = solved_models(cal, result)
    k = len(optimization.factors)
    windows = {r: w for r, w in windows.items() if r in models}
    if k < 2 or not windows:
        return
    point, _ = _solution(optimization)
    i, j = sorted(important_factors(models, windows, point, k)[:2])
    fi, fj = optimization.factors[i], optimization.factors[j]
    how = "; ".join(f"{r} within {lo:.4g} to {hi:.4g} ({what})" for r, (lo, hi, what) in windows.items())
    grid = overlay_grid(models, windows, point, i, j)
    none = "" if grid["feasible"].any() else "; no setting in this plane meets every window"
    report.figure(overlay_figure(models, optimization, windows, i, j, point, grid=grid), f"{name}_overlay",
                  caption=f"{condition}: overlay plot over {fi.name} and {fj.name} (the two factors that move the "
                          f"responses most against their windows), other factors at solution 1; yellow: every "
                          f"predicted response meets its window ({how}); grey: at least one does not{none}")
    parts = _parts(cal.campaign.test, windows)
    if len(set(parts.values())) >= 2:
        report.figure(tests_figure(models, optimization, windows, parts, i, j, point, result.condition.reference),
                      f"{name}_tests",
                      caption=f"{condition}: how much each test pins, over {fi.name} and {fj.name} (other factors at "
                              "solution 1): each test's own region, where its responses are predicted inside their "
                              "windows within the fit's 95 % interval of the mean (the compatible ranges' rule), "
                              "outlined and lightly filled in its colour; gold where every response is; the "
                              "black cross marks the condition's reference values where it gives both")
