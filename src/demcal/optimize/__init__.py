"""Desirability optimisation: solve response surfaces for measured targets.

:class:`Goal` describes what one response should do (target, maximise, minimise, stay in
range) with Derringer-Suich weights and importance; :func:`optimize` searches the coded
design box from many starts and returns an :class:`Optimization` with the distinct
solutions and the factor ranges of the solution set (D >= 0.99).
"""

from demcal._lazy import lazy_exports

__all__ = ["Goal", "parse_goal", "overall_desirability", "optimize", "Optimization", "reachable_range"]

__getattr__, __dir__ = lazy_exports(__name__, {
    "desirability": ["Goal", "overall_desirability", "parse_goal"],
    "search": ["Optimization", "optimize", "reachable_range"],
})
