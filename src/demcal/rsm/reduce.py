"""Backward elimination of insignificant terms, keeping the model hierarchical.

At each step the term with the largest p-value above ``alpha`` is removed, among the
terms that no remaining higher-order term contains (A stays while AB or A² stays), so
the reduced model is always hierarchical (Montgomery 2013, Sec. 10.4; Design-Expert's
"Backward" selection with hierarchy maintained).
"""

from __future__ import annotations

from dataclasses import dataclass

from demcal.rsm.fit import ResponseSurface, fit_response_surface
from demcal.rsm.terms import contains, degree, term_name


@dataclass(frozen=True)
class Reduction:
    """A reduced model and the terms removed, in removal order, with their p-values."""

    model: ResponseSurface
    removed: tuple[tuple[str, float], ...]


def backward_elimination(model: ResponseSurface, alpha: float = 0.05) -> Reduction:
    """Remove terms with p > ``alpha`` one at a time, refitting after each removal."""
    if not 0 < alpha < 1:
        raise ValueError("alpha must lie between 0 and 1")
    current = model
    removed = []
    while True:
        names = current.names
        terms = current.terms
        candidates = []
        for t in terms:
            if degree(t) == 0 or any(contains(o, t) for o in terms):
                continue
            pv = float(current.anova.loc[term_name(t, names), "p"])
            if pv > alpha:
                candidates.append((pv, t))
        if not candidates or len(terms) <= 2:
            break
        pv, worst = max(candidates)
        removed.append((term_name(worst, names), pv))
        current = fit_response_surface(
            current.x, current.y, current.factors, [t for t in terms if t != worst],
            current.response)
    return Reduction(current, tuple(removed))
