"""Which contact parameters each virtual bench's response passes through: a declared table.

``demcal identify`` names, for a parameter the campaign's responses cannot pin, the other
benches whose response depends on it. That is read from this table, not measured: a bench
*reads* an interaction's parameters when the contacts its response is measured from pass
through that interaction (the heap's particles touch one another and the steel plate; the
incline's bed slides on the film), as each bench's module describes its set-up. How
strongly a response depends on a parameter is for a screen of that bench to show
(``demcal identify`` on a campaign of it).

A plug-in bench declares its own: an attribute ``reads`` (setting keys) and, optionally,
``measures`` (a few words) on the registered experiment.
"""

from __future__ import annotations

from typing import Mapping

#: The contact parameters of one interaction that a bulk response passes through.
_BULK = ("restitution", "static_friction", "rolling_friction", "damping_factor", "rolling_damping",
         "surface_energy")
#: Those of a single normal impact: no sliding or rolling, no cohesion at 1 m/s.
_IMPACT = ("restitution", "damping_factor")


def _keys(interaction: str, names: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(f"{interaction}.{name}" for name in names)


#: bench -> (what it measures, the setting keys its response reads)
DECLARED: Mapping[str, tuple[str, tuple[str, ...]]] = {
    "repose-funnel": ("a static heap poured from a funnel onto a steel plate",
                      _keys("particle", _BULK) + _keys("wall", _BULK)),
    "repose-cylinder": ("a static heap left by a lifted steel cylinder",
                        _keys("particle", _BULK) + _keys("wall", _BULK)),
    "drum": ("the dynamic angle of a bed flowing in a turning steel drum",
             _keys("particle", _BULK) + _keys("wall", _BULK)),
    "incline": ("the angle at which a bed slides on the film",
                _keys("film", _BULK) + _keys("particle", _BULK)),
    "impact": ("the restitution of one normal impact on a particle, the steel or the film",
               _keys("particle", _IMPACT) + _keys("wall", _IMPACT) + _keys("film", _IMPACT)),
}


def declared(experiment) -> tuple[str, tuple[str, ...]] | None:
    """``(measures, reads)`` of a registered experiment: its own ``reads`` attribute, else
    :data:`DECLARED`; None when neither declares it."""
    own = getattr(experiment, "reads", None)
    if own is not None:
        return str(getattr(experiment, "measures", experiment.description)), tuple(own)
    return DECLARED.get(experiment.name)


def benches_reading(parameter: str, exclude: tuple[str, ...] = ()) -> list[tuple[str, str]]:
    """``(bench, what it measures)`` of every registered bench, but ``exclude``, declared to
    read ``parameter``, by name."""
    from demcal.bench.registry import get_experiment, names

    out = []
    for name in names():
        if name in exclude:
            continue
        found = declared(get_experiment(name))
        if found is not None and parameter in found[1]:
            out.append((name, found[0]))
    return out
