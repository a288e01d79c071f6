"""The design catalogue: every design kind by name, the options each takes, and
:func:`design_matrix`, which builds any of them.

One table of names (:data:`DESIGN_NAMES`, each kind with the other spellings it
accepts) and one table of options (:data:`DESIGN_OPTIONS`) serve ``demcal design`` and
the ``[design]`` table of a campaign file alike, so that both accept the same
spellings and options and build the same matrices. The generators themselves are the
pure functions of :mod:`demcal.doe.designs`.

This module imports nothing heavy at its top: the command line reads its tables to
build ``demcal design --help``.
"""

from __future__ import annotations

import numbers
from typing import TYPE_CHECKING, Any

from demcal._checks import and_list
from demcal.errors import ConfigError

if TYPE_CHECKING:
    import numpy as np

#: Every design kind, by its name, with the other spellings it accepts (``demcal design``
#: and a campaign's ``[design] type`` take any of them).
DESIGN_NAMES: dict[str, tuple[str, ...]] = {
    "box-behnken": ("bbd",),
    "central-composite": ("ccd",),
    "full-factorial": ("factorial",),
    "fractional-factorial": ("fractional",),
    "plackett-burman": (),
}

#: Every spelling -> the kind's name.
DESIGN_KINDS: dict[str, str] = {
    spelling: name for name, others in DESIGN_NAMES.items() for spelling in (name, *others)
}

#: The options each kind takes (``None`` or absent: the default). ``center``: centre
#: points (default 5 for Box-Behnken, 6 for a central composite, 0 otherwise);
#: ``variant``: circumscribed (default), inscribed or face-centred; ``alpha``: the CCD
#: axial distance, rotatable (default), orthogonal or a number; ``fraction``: p of the
#: 2^(k-p) factorial part (default 0 for a central composite; 1, or one per generator,
#: for a fractional factorial); ``generators``: e.g. ``"D=ABC,E=ABD"`` or a list of them
#: (standard ones by default); ``levels``: per factor (default 2); ``runs``: of a
#: Plackett-Burman design (default: the smallest that fits).
DESIGN_OPTIONS: dict[str, tuple[str, ...]] = {
    "box-behnken": ("center",),
    "central-composite": ("center", "variant", "alpha", "fraction"),
    "full-factorial": ("center", "levels"),
    "fractional-factorial": ("center", "fraction", "generators"),
    "plackett-burman": ("center", "runs"),
}

#: Every option of any kind, in the order of :data:`DESIGN_OPTIONS`.
OPTION_NAMES: tuple[str, ...] = tuple(dict.fromkeys(o for opts in DESIGN_OPTIONS.values() for o in opts))


def kind_label(name: str) -> str:
    """A kind's name with its other spellings, e.g. ``central-composite (ccd)``."""
    others = DESIGN_NAMES[name]
    return f"{name} ({', '.join(others)})" if others else name


def design_kind(kind: str, also: tuple[str, ...] = ()) -> str:
    """The name of the design kind spelled ``kind`` (any spelling of :data:`DESIGN_NAMES`);
    ``also``: further kinds the caller takes, named in the message that refuses ``kind``."""
    name = DESIGN_KINDS.get(kind) if isinstance(kind, str) else None
    if name is not None:
        return name
    import difflib

    near = difflib.get_close_matches(str(kind), [*DESIGN_KINDS, *also], n=1, cutoff=0.5)
    hint = (f"did you mean '{near[0]}'?" if near else
            f"choose one of: {', '.join([*(kind_label(n) for n in DESIGN_NAMES), *also])}.")
    raise ConfigError(f"unknown design type '{kind}'; {hint}")


def takers(option: str) -> tuple[str, ...]:
    """The kinds that take ``option``."""
    return tuple(name for name, options in DESIGN_OPTIONS.items() if option in options)


def check_options(name: str, options: dict[str, Any]) -> None:
    """Refuse an option that kind ``name`` does not take, or that no kind knows."""
    for option in options:
        if option in DESIGN_OPTIONS[name]:
            continue
        if option not in OPTION_NAMES:
            raise ConfigError(f"unknown design option '{option}'; the options are "
                              f"{', '.join(OPTION_NAMES)}.")
        raise ConfigError(f"option '{option}' does not apply to a {name} design; only "
                          f"{and_list(kind_label(n) for n in takers(option))} designs take it, so remove it or "
                          "choose one of those.")


def _whole(options: dict, key: str, default: int, minimum: int) -> int:
    """An option that counts something: a whole number >= ``minimum``."""
    value = options.get(key, default)
    ok = (isinstance(value, numbers.Real) and not isinstance(value, bool)
          and float(value).is_integer() and value >= minimum)
    if not ok:
        raise ConfigError(f"design option '{key}' must be a whole number of at least "
                          f"{minimum}, got {value!r}; give e.g. {key} = {max(default, minimum)}.")
    return int(value)


def _generators(value) -> list[str]:
    """``"D=ABC,E=ABD"`` or ``["D=ABC", "E=ABD"]`` as a list of generators."""
    if isinstance(value, str):
        return [g for g in value.split(",") if g.strip()]
    if isinstance(value, (list, tuple)) and all(isinstance(g, str) for g in value):
        return [g for g in value if g.strip()]
    raise ConfigError(f"design option 'generators' must be text such as \"D=ABC,E=ABD\" or a list "
                      f"of such generators, got {value!r}.")


def _alpha(value):
    """The CCD axial distance: a number, or the name of a rule (a number written as text
    is read as that number)."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _with_center(coded, center, what: str):
    """``coded`` with ``center`` centre rows appended, checked against the run cap."""
    import numpy as np

    from demcal.doe.designs import check_center, check_run_count

    center = check_center(center or 0)
    check_run_count(coded.shape[0] + center, f"{what} with {center:,} centre points",
                    "use fewer centre points")
    return np.vstack([coded, np.zeros((center, coded.shape[1]))])


def design_matrix(kind: str, factors, **options) -> np.ndarray:
    """The coded matrix of a design, in standard order, centre points last.

    Parameters
    ----------
    kind : str
        Any spelling of :data:`DESIGN_NAMES`: ``box-behnken`` (``bbd``),
        ``central-composite`` (``ccd``), ``full-factorial`` (``factorial``),
        ``fractional-factorial`` (``fractional``), ``plackett-burman``.
    factors : int or sequence
        The number of factors, or the factors themselves (only their count is used).
    **options
        The options of :data:`DESIGN_OPTIONS` that this kind takes; ``None`` means the
        default.

    Returns
    -------
    numpy.ndarray
        ``(runs, k)`` coded levels.

    Raises
    ------
    demcal.errors.ConfigError
        An unknown kind, an option the kind does not take, or a bad value.
    """
    import numpy as np

    from demcal.doe import designs

    name = design_kind(kind)
    k = int(factors) if isinstance(factors, numbers.Integral) else len(factors)
    options = {key: value for key, value in options.items() if value is not None}
    check_options(name, options)
    center = options.get("center")
    if name == "box-behnken":
        matrix = designs.box_behnken(k, 5 if center is None else center)
    elif name == "central-composite":
        matrix = designs.central_composite(k, options.get("variant", "circumscribed"),
                                           _alpha(options.get("alpha", "rotatable")),
                                           6 if center is None else center,
                                           _whole(options, "fraction", 0, 0))
    elif name == "full-factorial":
        levels = _whole(options, "levels", 2, 2)
        matrix = _with_center(designs.full_factorial([levels] * k), center,
                              f"a full factorial of {k} factors at {levels:,} levels")
    elif name == "fractional-factorial":
        generators = _generators(options.get("generators", [])) or None  # none given: the standard ones
        fraction = (_whole(options, "fraction", 1, 1)
                    if "fraction" in options or generators is None else None)
        matrix = designs.fractional_factorial(k, fraction, generators)
        matrix = _with_center(matrix, center, f"a {matrix.shape[0]}-run fractional factorial")
    else:  # plackett-burman
        matrix = designs.plackett_burman(k, options.get("runs"))
        matrix = _with_center(matrix, center, f"a {matrix.shape[0]}-run Plackett-Burman design")
    return np.asarray(matrix, dtype=float)
