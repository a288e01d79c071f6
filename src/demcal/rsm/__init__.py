"""Response surfaces with Design-Expert's conventions.

:func:`fit_response_surface` fits a linear, 2FI, quadratic or cubic polynomial in coded
factors and returns a :class:`ResponseSurface` holding the ANOVA (partial sums of
squares, lack of fit vs pure error), fit statistics, coefficient table and diagnostics.
:func:`fit_summary` compares the orders; :func:`backward_elimination` reduces a model
while keeping it hierarchical; :func:`read_runs` loads and codes a run table.
:mod:`demcal.rsm.diagnostics` holds the residual diagnostics (leverage, studentized
residuals, Cook's distance and their limits), the Box-Cox analysis and the choice of
interaction plots.
"""

from demcal._lazy import lazy_exports

__all__ = [
    "fit_response_surface", "ResponseSurface", "FitStatistics", "fit_summary", "FitSummary",
    "backward_elimination", "Reduction", "read_runs", "runs_from_frame", "Runs",
    "model_terms", "term_name", "display_name",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "data": ["Runs", "read_runs", "runs_from_frame"],
    "fit": ["FitStatistics", "ResponseSurface", "fit_response_surface"],
    "reduce": ["Reduction", "backward_elimination"],
    "summary": ["FitSummary", "fit_summary"],
    "terms": ["display_name", "model_terms", "term_name"],
})
