"""Figures of response-surface results (matplotlib, Agg; PNG and SVG).

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot, so no
global state or display is involved; :func:`save_figure` writes it. The figures follow
the reference paper: predicted vs actual (its Fig. 6), response surface with contour of
two factors with the others held (Figs. 5 and 9), perturbation plot, and the
solution-set plot with the factor ranges of all settings that reach the targets.
"""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg", force=False)

import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

__all__ = [
    "predicted_vs_actual_figure", "surface_figure", "perturbation_figure",
    "solution_set_figure", "save_figure", "save_figure_formats", "figure_png_bytes",
]


def _factor_label(f) -> str:
    return getattr(f, "label", f.name)


def response_label(name: str, label: str | None = None, unit: str | None = None) -> str:
    """Axis label of a response: ``label [unit]``; without them, read from the name:
    ``repose_angle_deg`` -> ``Repose angle [°]`` (:func:`demcal.campaign.wording.response_words`)."""
    from demcal.campaign.wording import response_words

    label, unit = response_words(name, label, unit)
    return f"{label} [{unit}]" if unit else label


def _short_ticks(ax, axes=("x", "y")) -> None:
    """At most 5 ticks per axis, printed with 3 significant digits (no "0.5000.525")."""
    from matplotlib.ticker import MaxNLocator

    for which in axes:
        axis = getattr(ax, f"{which}axis")
        axis.set_major_locator(MaxNLocator(nbins=4, min_n_ticks=3))  # one locator per axis
        axis.set_major_formatter(_make_short())


def _short(v, _pos=None) -> str:
    return f"{v:.3g}" if v != 0 else "0"


def _with_label(text: str, label: str | None) -> str:
    return f"{text} ({label})" if label else text


def predicted_vs_actual_figure(model, title: str | None = None, label: str | None = None) -> Figure:
    """Predicted against actual response with the 1:1 line (paper Fig. 6).

    Parameters
    ----------
    model : ResponseSurface
    title : str, optional
    label : str, optional
        Which model this is (e.g. "reduced model"), added to the default title.
    """
    fig = Figure(figsize=(4.6, 4.2))
    fig.subplots_adjust(left=0.16, right=0.96, bottom=0.13, top=0.92)
    ax = fig.add_subplot()
    y, yhat = model.y, model.diagnostics["predicted"].to_numpy()
    lo, hi = float(min(y.min(), yhat.min())), float(max(y.max(), yhat.max()))
    pad = 0.05 * (hi - lo or 1.0)
    ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], color="0.4", lw=1)
    ax.scatter(y, yhat, s=24, color="tab:blue", edgecolor="k", linewidth=0.4, zorder=3)
    ax.set_xlim(lo - pad, hi + pad)
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_aspect("equal")
    ax.set_xlabel(f"Actual {response_label(model.response)}")
    ax.set_ylabel(f"Predicted {response_label(model.response)}")
    ax.set_title(title or _with_label(f"Predicted vs actual, R² = {model.fit.r2:.3f}", label), fontsize=10)
    return fig


def surface_figure(model, i: int, j: int, hold=None, actual: bool = True, n: int = 41,
                   title: str | None = None, label: str | None = None, points: bool = True,
                   response: str | None = None) -> Figure:
    """Response surface (3-D) and contour of factors ``i`` and ``j`` (paper Figs. 5, 9).

    Parameters
    ----------
    model : ResponseSurface
    i, j : int
        Indices of the two factors on the axes.
    hold : sequence of float, optional
        Coded levels of all factors; entries i and j are ignored. Default: centre (0).
    actual : bool
        Label the axes in actual units.
    n : int
        Grid points per axis.
    label : str, optional
        Which model this is (e.g. "reduced model"), added to the default title.
    points : bool
        Draw the design points on the contour (filled: in the plane of the held levels;
        open: elsewhere, projected onto it) and on the 3-D surface (measured responses).
    response : str, optional
        Axis label of the response (default: :func:`response_label` of its name).
    """
    k = len(model.factors)
    zlabel = response or response_label(model.response)
    hold = np.zeros(k) if hold is None else np.asarray(hold, dtype=float)
    g = np.linspace(-1, 1, n)
    gi, gj = np.meshgrid(g, g, indexing="xy")
    pts = np.tile(hold, (gi.size, 1))
    pts[:, i] = gi.ravel()
    pts[:, j] = gj.ravel()
    z = model.predict(pts).reshape(gi.shape)
    fi, fj = model.factors[i], model.factors[j]
    xi = fi.to_actual(gi) if actual else gi
    xj = fj.to_actual(gj) if actual else gj

    fig = Figure(figsize=(10.0, 4.2))
    fig.subplots_adjust(left=0.02, right=0.97, bottom=0.13, top=0.9, wspace=0.25)
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    stride = max(1, n // 20)  # a coarser mesh for the 3-D view keeps SVG files small
    ax3.plot_surface(xi, xj, z, cmap="viridis", linewidth=0, antialiased=False,
                     rstride=stride, cstride=stride)
    ax3.set_xlabel(_factor_label(fi), fontsize=7)
    ax3.set_ylabel(_factor_label(fj), fontsize=7)
    ax3.set_zlabel(zlabel, fontsize=7)
    ax3.tick_params(labelsize=6)
    _short_ticks(ax3, ("x", "y", "z"))
    ax = fig.add_subplot(1, 2, 2)
    cs = ax.contourf(xi, xj, z, levels=14, cmap="viridis")
    cl = ax.contour(xi, xj, z, levels=cs.levels[::2], colors="k", linewidths=0.5)
    ax.clabel(cl, fontsize=7, fmt=_short)
    bar = fig.colorbar(cs, ax=ax, label=zlabel)
    bar.locator = _locator()
    bar.formatter = _make_short()
    bar.update_ticks()
    if points:
        x = np.asarray(model.x, dtype=float)
        others = [m for m in range(k) if m not in (i, j)]
        inside = np.all(np.abs(x[:, others] - hold[others]) < 1e-9, axis=1) if others else np.ones(len(x), bool)
        px = fi.to_actual(x[:, i]) if actual else x[:, i]
        py = fj.to_actual(x[:, j]) if actual else x[:, j]
        ax.scatter(px[~inside], py[~inside], s=18, facecolor="none", edgecolor="r", linewidth=0.8,
                   zorder=4, label="design point (other levels)")
        ax.scatter(px[inside], py[inside], s=22, color="r", edgecolor="k", linewidth=0.4, zorder=5,
                   label="design point (in this plane)")
        ax3.scatter(px[inside], py[inside], np.asarray(model.y, dtype=float)[inside], color="r", s=10,
                    depthshade=False)
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(0, -0.12), ncol=2, frameon=False)
    ax.set_xlabel(_factor_label(fi))
    ax.set_ylabel(_factor_label(fj))
    _short_ticks(ax)
    others = [f"{f.name} = {f.to_actual(hold[m]) if actual else hold[m]:.3g}"
              for m, f in enumerate(model.factors) if m not in (i, j)]
    fig.suptitle(title or (f"{zlabel}: {fi.name} × {fj.name}"
                           + (f" ({', '.join(others)})" if others else "") + (f", {label}" if label else "")),
                 fontsize=10)
    return fig


def perturbation_figure(model, reference=None, title: str | None = None, label: str | None = None) -> Figure:
    """Response as each factor moves from -1 to +1 through ``reference`` (coded, default 0);
    ``label`` (which model) is added to the default title."""
    k = len(model.factors)
    ref = np.zeros(k) if reference is None else np.asarray(reference, dtype=float)
    fig = Figure(figsize=(5.0, 4.0))
    fig.subplots_adjust(left=0.14, right=0.96, bottom=0.13, top=0.92)
    ax = fig.add_subplot()
    g = np.linspace(-1, 1, 81)
    for m, f in enumerate(model.factors):
        pts = np.tile(ref, (g.size, 1))
        pts[:, m] = g
        ax.plot(g, model.predict(pts), label=f.name)
    ax.axvline(0, color="0.6", lw=0.6)
    ax.set_xlabel("Deviation from reference point (coded units)")
    ax.set_ylabel(response_label(model.response))
    ax.legend(fontsize=8)
    ax.set_title(title or _with_label(f"Perturbation of {model.response}", label), fontsize=10)
    return fig


def solution_set_figure(result, title: str | None = None) -> Figure:
    """Factor ranges of the solution set (D >= threshold) inside the design ranges.

    One row per factor, actual units: the design range as a grey bar, the solution set
    range as a coloured bar, the distinct solutions as dots and the best one as a star.

    Parameters
    ----------
    result : demcal.optimize.Optimization
    """
    factors = result.factors
    k = len(factors)
    height = 0.75 * k + 1.3
    fig = Figure(figsize=(6.4, height))
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.75 / height, top=1 - 0.45 / height, hspace=0.45)
    axes = fig.subplots(k, 1, squeeze=False)[:, 0]
    sol = result.solutions
    good = sol[sol["desirability"] >= result.threshold]
    rng = np.random.default_rng(0)
    for ax, f in zip(axes, factors):
        lo_d, hi_d = f.low, f.high
        ax.barh(0, hi_d - lo_d, left=lo_d, height=0.5, color="0.88")
        if f.name in result.factor_ranges:
            lo, hi = result.factor_ranges[f.name]
            ax.barh(0, max(hi - lo, 1e-12 * (hi_d - lo_d)), left=lo, height=0.5,
                    color="tab:orange", alpha=0.55)
        if len(result.set_points):
            pts = result.set_points
            if len(pts) > 400:
                pts = pts[rng.choice(len(pts), 400, replace=False)]
            xs = f.to_actual(pts[:, factors.index(f)])
            ax.scatter(xs, rng.uniform(-0.18, 0.18, xs.size), s=2, color="tab:orange", alpha=0.35,
                       linewidths=0)
        if len(good):
            xs = good[f"actual:{f.name}"].to_numpy()
            ax.scatter(xs, rng.uniform(-0.12, 0.12, xs.size), s=12, color="tab:blue", zorder=3)
        best = sol.iloc[0][f"actual:{f.name}"]
        ax.scatter([best], [0], marker="*", s=110, color="tab:red", edgecolor="k", linewidth=0.4,
                   zorder=4)
        pad = 0.03 * (hi_d - lo_d)
        ax.set_xlim(lo_d - pad, hi_d + pad)
        ax.set_ylim(-0.45, 0.45)
        ax.set_yticks([0])
        ax.set_yticklabels([f.name])
        ax.tick_params(labelsize=8)
    goals = "; ".join(
        f"{g.response} = {g.target:g}" if g.kind == "target" else f"{g.response} {g.kind}"
        for g in result.goals)
    axes[0].set_title(title or f"Solution set, D ≥ {result.threshold:g} ({goals})", fontsize=10)
    axes[-1].set_xlabel("actual level (grey: design range, orange: solution set, "
                        "blue: solutions, star: best)", fontsize=8)
    return fig


def _locator():
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(nbins=5)


def _make_short():
    from matplotlib.ticker import FuncFormatter

    return FuncFormatter(_short)




def save_figure(fig: Figure, path, dpi: int = 150) -> Path:
    """Write ``fig`` to ``path``; the suffix (.png or .svg) picks the format."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".") or "png"
    if fmt not in ("png", "svg", "pdf"):
        from demcal.errors import ConfigError
        raise ConfigError(f"cannot write a figure as {path.suffix!r}; use .png or .svg.")
    path.parent.mkdir(parents=True, exist_ok=True)
    from demcal._files import save_figure as save_whole

    return save_whole(fig, path, fmt, dpi)


def save_figure_formats(fig: Figure, stem, formats=("png", "svg"), dpi: int = 150) -> list[Path]:
    """Write ``fig`` as ``stem.png`` and ``stem.svg`` (or the given formats)."""
    stem = Path(stem)
    return [save_figure(fig, stem.parent / f"{stem.name}.{f}", dpi) for f in formats]


def figure_png_bytes(fig: Figure, dpi: int = 110) -> bytes:
    """PNG bytes of ``fig`` (for embedding in HTML)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()
