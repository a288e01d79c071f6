"""Response surfaces with Design-Expert's conventions.

:func:`fit_response_surface` fits a linear, 2FI, quadratic or cubic polynomial in coded
factors and returns a :class:`ResponseSurface` holding the ANOVA (partial sums of
squares, lack of fit vs pure error), fit statistics, coefficient table and diagnostics.
:func:`fit_summary` compares the orders; :func:`backward_elimination` reduces a model
while keeping it hierarchical; :func:`read_runs` loads and codes a run table.
"""

from demcal.rsm.data import Runs, read_runs, runs_from_frame
from demcal.rsm.fit import FitStatistics, ResponseSurface, fit_response_surface
from demcal.rsm.reduce import Reduction, backward_elimination
from demcal.rsm.summary import FitSummary, fit_summary
from demcal.rsm.terms import display_name, model_terms, term_name

__all__ = [
    "fit_response_surface", "ResponseSurface", "FitStatistics", "fit_summary", "FitSummary",
    "backward_elimination", "Reduction", "read_runs", "runs_from_frame", "Runs",
    "model_terms", "term_name", "display_name",
]
