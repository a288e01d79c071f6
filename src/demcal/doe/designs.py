"""Experimental designs as pure functions returning coded matrices.

Every generator returns a ``numpy`` array of shape ``(runs, k)`` in coded units, rows
in standard order (the order the source tabulates them), centre points last. Run-order
randomisation, factor names and actual levels are added by :class:`demcal.doe.Design`.

Sources
-------
* Box, G.E.P. & Behnken, D.W. (1960). Some new three level designs for the study of
  quantitative variables. *Technometrics* 2(4), 455-475. (Box-Behnken designs)
* Box, G.E.P. & Wilson, K.B. (1951). On the experimental attainment of optimum
  conditions. *J. R. Stat. Soc. B* 13, 1-45. (central composite designs, steepest ascent)
* Plackett, R.L. & Burman, J.P. (1946). The design of optimum multifactorial
  experiments. *Biometrika* 33(4), 305-325. (screening designs)
* Montgomery, D.C. *Design and Analysis of Experiments*, 8th ed., Wiley 2013:
  Sec. 8.2-8.7 (fractional factorials, Table 8.14 generators), Sec. 11.2 (steepest
  ascent), Sec. 11.4 (CCD alpha for rotatability and orthogonal blocking).

pyDOE3
------
The matrices come from pyDOE3 wherever it builds the published design: ``fullfact``
(full factorials), ``ff2n`` (two-level factorials), ``fracfact`` (fractional
factorials), ``bbdesign`` (Box-Behnken, k = 3..5) and ``star`` (the axial runs of a
central composite design). Its rows are put into the standard order above, which is
part of a campaign's run keys (a stored campaign stays valid only while every design
is identical run for run; ``tests/doe`` checks that against the matrices demcal
produced before pyDOE3 was used). demcal's own construction is kept where pyDOE3 gives
another design: Box-Behnken at k = 6 and 7, Plackett-Burman, and the orthogonal CCD
alpha (reasons at each).
"""

from __future__ import annotations

import math
import numbers
import string

import numpy as np

from demcal.errors import ConfigError

#: Most runs a design may have: every run is a DEM simulation, so a larger design is a
#: mistake (too many levels or factors), and building it could exhaust the memory.
MAX_RUNS = 100_000


def format_count(n: int) -> str:
    """``n`` with thousands separators, or ``more than 10^d`` for astronomically large ones."""
    n = int(n)
    if n < 10**15:
        return f"{n:,}"
    return f"more than 10^{int(math.log10(n))}"


def check_run_count(runs: int, what: str, advice: str) -> None:
    """Refuse a design of more than :data:`MAX_RUNS` runs, before it is built.

    Parameters
    ----------
    runs : int
        Run count of the design, centre points included.
    what : str
        The design, e.g. ``"a full factorial of 2 factors at 400 levels"``.
    advice : str
        How to make it smaller, e.g. ``"use fewer levels or factors"``.
    """
    if runs > MAX_RUNS:
        raise ConfigError(
            f"{what} has {format_count(runs)} runs, more than the {MAX_RUNS:,} a design may have "
            f"(every run is a DEM simulation); {advice}."
        )


def check_count(value, what: str, minimum: int = 0) -> int:
    """``value`` as an int, refused unless it is a whole number of at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ConfigError(f"the {what} must be a whole number, not {value!r}.")
    if value < minimum:
        raise ConfigError(f"the {what} must be at least {minimum}, not {value}.")
    return int(value)


def check_center(center) -> int:
    """A number of centre points: a whole number, 0 or more (callers check the run total)."""
    return check_count(center, "number of centre points", 0)

# ---------------------------------------------------------------------------------------
# Box-Behnken
# ---------------------------------------------------------------------------------------

#: Factor groups varied together in a Box-Behnken design, 1-based factor numbers.
#: k = 3..5: every pair once (2^2 factorial per pair). The k = 3 and k = 4 orders are
#: Design-Expert's standard order, as printed in the reference paper's Tables 8 and 4.
#: k = 6: the partially balanced incomplete block design of Box & Behnken (1960)
#: (blocks of three, each factor in three blocks; 2^3 factorial per block, 48 runs).
#: k = 7: the balanced incomplete block design (7, 3, 1) of Box & Behnken (1960)
#: (every pair of factors together in exactly one block; 56 runs).
BOX_BEHNKEN_BLOCKS: dict[int, tuple[tuple[int, ...], ...]] = {
    3: ((1, 2), (1, 3), (2, 3)),
    4: ((1, 2), (3, 4), (1, 4), (2, 3), (1, 3), (2, 4)),
    5: ((1, 2), (3, 4), (2, 5), (1, 3), (4, 5), (2, 3), (1, 4), (3, 5), (1, 5), (2, 4)),
    6: ((1, 2, 4), (2, 3, 5), (3, 4, 6), (1, 4, 5), (2, 5, 6), (1, 3, 6)),
    7: ((4, 5, 6), (1, 6, 7), (2, 5, 7), (1, 2, 4), (3, 4, 7), (1, 3, 5), (2, 3, 6)),
}

#: Runs without centre points, as published (Box & Behnken 1960).
BOX_BEHNKEN_RUNS = {3: 12, 4: 24, 5: 40, 6: 48, 7: 56}


def _pydoe3():
    """The pyDOE3 package, imported on first use (it loads scipy.stats, about 0.5 s that
    commands which build no design need not pay)."""
    import pyDOE3

    return pyDOE3


def _two_level_full(m: int) -> np.ndarray:
    """2^m factorial in Yates standard order (first column changes fastest): pyDOE3's
    ``ff2n`` (whose last column changes fastest in pyDOE3 1.6) with its rows sorted."""
    design = np.asarray(_pydoe3().ff2n(m), dtype=float)
    return np.ascontiguousarray(design[np.argsort(_yates_index(design), kind="stable")])


def _yates_index(signs: np.ndarray) -> np.ndarray:
    """Position of each row of a +-1 matrix in Yates order (first column fastest)."""
    return ((signs > 0) * (1 << np.arange(signs.shape[1]))).sum(axis=1)


def _in_block_order(matrix: np.ndarray, blocks) -> np.ndarray:
    """Box-Behnken rows sorted into the order of ``blocks`` (1-based factors varied
    together), Yates order within a block, centre runs last."""
    rank = {tuple(sorted(b)): i for i, b in enumerate(blocks)}

    def key(row):
        varied = np.flatnonzero(row)
        if not varied.size:
            return (len(blocks), 0)
        return (rank[tuple(varied + 1)], int(_yates_index(row[None, varied])[0]))

    return matrix[sorted(range(len(matrix)), key=lambda i: key(matrix[i]))]


def box_behnken(k: int, center: int = 5) -> np.ndarray:
    """Box-Behnken design for ``k`` = 3..7 factors plus ``center`` centre points.

    Parameters
    ----------
    k : int
        Number of factors, 3 to 7.
    center : int
        Number of centre runs appended at the end (Design-Expert's default is 5 for
        k = 3 and 4).

    Returns
    -------
    numpy.ndarray
        ``(BOX_BEHNKEN_RUNS[k] + center, k)`` coded matrix with levels -1, 0, +1.

    Notes
    -----
    k = 3..5: pyDOE3's ``bbdesign`` (every pair of factors once), its rows put into the
    block order of :data:`BOX_BEHNKEN_BLOCKS` (Design-Expert's standard order).
    k = 6, 7: demcal's own construction from the published blocks. pyDOE3's
    ``bbdesign`` pairs every two factors for any k, which gives 60 runs at k = 6 and 84
    at k = 7 instead of the published 48 and 56 (Box & Behnken 1960 use blocks of three
    factors there); it is not the Box-Behnken design at those k.
    """
    if k not in BOX_BEHNKEN_BLOCKS:
        raise ConfigError(f"Box-Behnken designs exist for 3 to 7 factors, not {k}.")
    center = check_center(center)
    check_run_count(BOX_BEHNKEN_RUNS[k] + center,
                    f"a Box-Behnken design of {k} factors with {center:,} centre points",
                    "use fewer centre points")
    if k <= 5:
        design = _pydoe3().bbdesign(k, center=center).astype(float)
        return np.ascontiguousarray(_in_block_order(design, BOX_BEHNKEN_BLOCKS[k]))
    # k = 6, 7: pyDOE3 gives the all-pairs design (60, 84 runs), not the published one
    rows = []
    for block in BOX_BEHNKEN_BLOCKS[k]:
        sub = _two_level_full(len(block))
        for s in sub:
            row = np.zeros(k)
            row[[i - 1 for i in block]] = s
            rows.append(row)
    rows.extend(np.zeros(k) for _ in range(center))
    return np.array(rows, dtype=float)


# ---------------------------------------------------------------------------------------
# Factorials
# ---------------------------------------------------------------------------------------


def full_factorial(levels) -> np.ndarray:
    """Full factorial in coded units.

    Parameters
    ----------
    levels : int or sequence of int
        Number of levels of each factor, or ``k`` for a 2-level 2^k design. Levels are
        spread evenly over -1 .. +1 (3 levels: -1, 0, +1).

    Returns
    -------
    numpy.ndarray
        Rows in standard order, first factor changing fastest.
    """
    if isinstance(levels, (int, np.integer)):
        levels = [2] * check_count(levels, "number of factors of a factorial", 1)
    levels = [int(n) for n in levels]
    if not levels or min(levels) < 2:
        raise ConfigError("a factorial needs at least one factor with at least two levels.")
    runs = math.prod(levels)
    if len(set(levels)) == 1:
        what = (f"a full factorial of {len(levels)} factor{'s' if len(levels) > 1 else ''} "
                f"at {levels[0]:,} levels")
    else:
        what = f"a full factorial at {' x '.join(map(str, levels))} levels"
    check_run_count(runs, what, "use fewer levels or factors, or a fractional design")
    # pyDOE3's fullfact: level indices 0..n-1, first factor fastest (the standard order)
    index = _pydoe3().fullfact(levels).astype(np.intp)
    grids = [np.linspace(-1.0, 1.0, n) for n in levels]
    return np.column_stack([grid[index[:, j]] for j, grid in enumerate(grids)])


#: Standard generators of 2^(k-p) fractions (Montgomery 2013, Table 8.14), letters
#: A, B, C, ... name the factors in order.
FRACTION_GENERATORS: dict[tuple[int, int], tuple[str, ...]] = {
    (3, 1): ("C=AB",),
    (4, 1): ("D=ABC",),
    (5, 1): ("E=ABCD",),
    (5, 2): ("D=AB", "E=AC"),
    (6, 1): ("F=ABCDE",),
    (6, 2): ("E=ABC", "F=BCD"),
    (6, 3): ("D=AB", "E=AC", "F=BC"),
    (7, 1): ("G=ABCDEF",),
    (7, 2): ("F=ABCD", "G=ABDE"),
    (7, 3): ("E=ABC", "F=BCD", "G=ACD"),
    (7, 4): ("D=AB", "E=AC", "F=BC", "G=ABC"),
    (8, 2): ("G=ABCD", "H=ABEF"),
    (8, 3): ("F=ABC", "G=ABD", "H=BCDE"),
    (8, 4): ("E=BCD", "F=ACD", "G=ABC", "H=ABD"),
}

_LETTERS = "ABCDEFGHJKLMNOPQRSTUVWXYZ"


def fractional_factorial(k: int, p: int | None = None, generators=None) -> np.ndarray:
    """Two-level fractional factorial 2^(k-p).

    Parameters
    ----------
    k : int
        Number of factors.
    p : int, optional
        Number of generators; with ``generators`` omitted the standard ones of
        :data:`FRACTION_GENERATORS` are used.
    generators : sequence of str, optional
        Generators such as ``("D=ABC",)`` or ``("D=-ABC",)``; factor letters follow
        Design-Expert (A, B, C, ..., skipping I). Each generated factor must be one of
        the last ``p`` letters.

    Returns
    -------
    numpy.ndarray
        ``(2^(k-p), k)`` coded matrix; the base factors in standard order.
    """
    if p is not None:
        p = check_count(p, "number of generators p of a 2^(k-p) fraction", 1)
    if generators is None:
        if p is None:
            raise ConfigError("give either the number of generators p or the generators.")
        if (k, p) not in FRACTION_GENERATORS:
            raise ConfigError(
                f"no standard generators stored for a 2^({k}-{p}) design; pass them, "
                "e.g. --generators D=ABC."
            )
        generators = FRACTION_GENERATORS[(k, p)]
    generators = [g.replace(" ", "").upper() for g in generators]
    if p is not None and p != len(generators):
        raise ConfigError(
            f"p = {p} disagrees with the {len(generators)} generators given "
            f"({', '.join(generators)}); give one generator per generated factor."
        )
    p = len(generators)
    if not 1 <= k <= len(_LETTERS):
        raise ConfigError(f"fractional factorials are named for 1 to {len(_LETTERS)} factors, not {k}.")
    base = k - p
    if base < 1:
        raise ConfigError(f"a 2^({k}-{p}) fraction has no base factors left.")
    letters = _LETTERS[:k]
    check_run_count(2**base, f"a 2^({k}-{p}) fractional factorial",
                    "use fewer factors or more generators")
    parsed, words = {}, {}
    for g in generators:
        try:
            lhs, rhs = g.split("=")
        except ValueError:
            raise ConfigError(f"cannot read generator {g!r}; write it like D=ABC.") from None
        sign = -1.0 if rhs.startswith("-") else 1.0
        rhs = rhs[1:] if rhs[:1] in "+-" else rhs
        if len(lhs) != 1 or lhs not in letters[base:]:
            raise ConfigError(
                f"generator {g!r} must define one of the factors {', '.join(letters[base:])}."
            )
        if lhs in parsed:
            raise ConfigError(
                f"factor {lhs} is defined by two generators ({parsed[lhs][2]} and {g}); define "
                f"each of {', '.join(letters[base:])} once."
            )
        if not rhs or any(c not in letters[:base] for c in rhs):
            raise ConfigError(
                f"generator {g!r} may only use the base factors {', '.join(letters[:base])}."
            )
        if len(set(rhs)) != len(rhs):
            raise ConfigError(
                f"generator {g!r} repeats a base factor, which cancels out; write it as a product "
                "of distinct base factors, e.g. D=ABC."
            )
        if len(rhs) < 2:
            raise ConfigError(
                f"generator {g!r} would alias {lhs} with the base factor {rhs} (identical columns); "
                "use a product of two or more distinct base factors, e.g. D=AB."
            )
        word = frozenset(rhs)
        if word in words:
            raise ConfigError(
                f"generators {words[word]!r} and {g!r} give the same column up to sign; use a "
                "different product of base factors for each generated factor."
            )
        words[word] = g
        parsed[lhs] = (sign, rhs, g)
    # pyDOE3's fracfact names the base factors a, b, c, ... (our letters skip I) and lists
    # its base runs with the last base factor fastest: put them into Yates order
    name = {letter: string.ascii_lowercase[i] for i, letter in enumerate(letters)}
    spec = [name[c] for c in letters[:base]]
    for lhs in letters[base:]:
        sign, rhs, _ = parsed[lhs]
        spec.append(("-" if sign < 0 else "") + "".join(name[c] for c in rhs))
    design = _pydoe3().fracfact(" ".join(spec)).astype(float)
    return np.ascontiguousarray(design[np.argsort(_yates_index(design[:, :base]), kind="stable")])


# ---------------------------------------------------------------------------------------
# Plackett-Burman
# ---------------------------------------------------------------------------------------

#: First rows of the cyclic Plackett-Burman designs (Plackett & Burman 1946, as
#: tabulated in Montgomery 2013, Table 8.23). Runs 2..N-1 are cyclic shifts of the
#: first row; run N is all minus.
#:
#: demcal's own construction: pyDOE3's ``pbdesign`` builds other Hadamard matrices
#: (Paley and Sylvester constructions, not these cyclic tables: not one of its 8- to
#: 24-run designs has the published rows, in any order), always takes the smallest run
#: count (no 16 runs for 5 factors) and gives 4 runs for 3 factors.
PLACKETT_BURMAN_GENERATORS: dict[int, str] = {
    8: "+++-+--",
    12: "++-+++---+-",
    16: "++++-+-++--+---",
    20: "++--++++-+-+----++-",
    24: "+++++-+-++--++--+-+----",
}


def plackett_burman(n_factors: int, runs: int | None = None) -> np.ndarray:
    """Plackett-Burman screening design.

    Parameters
    ----------
    n_factors : int
        Number of factors (at most ``runs - 1``).
    runs : int, optional
        Run count, one of 8, 12, 16, 20, 24; by default the smallest that fits.

    Returns
    -------
    numpy.ndarray
        ``(runs, n_factors)`` matrix of -1/+1; column j is the generator shifted so
        that row i holds ``generator[(j - i) mod (N-1)]`` (the cyclic construction).
    """
    if runs is None:
        fitting = [n for n in sorted(PLACKETT_BURMAN_GENERATORS) if n - 1 >= n_factors]
        if not fitting:
            raise ConfigError(
                f"Plackett-Burman designs are stored for up to 23 factors, not {n_factors}."
            )
        runs = fitting[0]
    if runs not in PLACKETT_BURMAN_GENERATORS:
        raise ConfigError(f"Plackett-Burman run counts available: 8, 12, 16, 20, 24 (not {runs}).")
    if not 1 <= n_factors <= runs - 1:
        raise ConfigError(f"a {runs}-run Plackett-Burman design takes 1 to {runs - 1} factors.")
    gen = np.array([1.0 if c == "+" else -1.0 for c in PLACKETT_BURMAN_GENERATORS[runs]])
    m = runs - 1
    full = np.empty((runs, m))
    for i in range(m):
        full[i] = np.roll(gen, i)
    full[m] = -1.0
    return full[:, :n_factors]


# ---------------------------------------------------------------------------------------
# Central composite
# ---------------------------------------------------------------------------------------


def ccd_alpha(k: int, kind: str = "rotatable", center: int = 0, fraction_p: int = 0) -> float:
    """Axial distance of a central composite design [coded units].

    * ``"rotatable"``: alpha = F^(1/4), F = 2^(k-p) factorial runs (Box & Hunter 1957;
      Montgomery 2013 Eq. 11.21).
    * ``"orthogonal"``: alpha = [F (sqrt(N) - sqrt(F))^2 / 4]^(1/4), N the total run count,
      which makes the quadratic terms uncorrelated (Montgomery 2013, Sec. 11.4.2).
    * ``"face"``: alpha = 1.

    demcal's own formulas: pyDOE3's ``star`` has the same rotatable alpha for a full
    factorial but none for a fractional one, and its ``"orthogonal"`` alpha,
    sqrt(k (1 + n_a0 / 2k) / (1 + n_c0 / F)), is the one for orthogonal blocking
    (centre runs split between the factorial and axial blocks), not this one.
    """
    f = 2 ** (k - fraction_p)
    if kind == "rotatable":
        return f**0.25
    if kind == "orthogonal":
        n = f + 2 * k + center
        return (f * (np.sqrt(n) - np.sqrt(f)) ** 2 / 4.0) ** 0.25
    if kind in ("face", "face-centred", "face-centered"):
        return 1.0
    raise ConfigError(f"unknown CCD alpha {kind!r}; use rotatable, orthogonal or face.")


def central_composite(
    k: int,
    kind: str = "circumscribed",
    alpha: str | float = "rotatable",
    center: int = 6,
    fraction_p: int = 0,
) -> np.ndarray:
    """Central composite design: 2^(k-p) factorial + 2k axial + centre runs.

    Parameters
    ----------
    k : int
        Number of factors (2 or more).
    kind : {"circumscribed", "inscribed", "face-centred"}
        Circumscribed: factorial at +-1, axial at +-alpha. Inscribed: the same design
        scaled by 1/alpha so the axial points sit at +-1. Face-centred: alpha = 1.
    alpha : {"rotatable", "orthogonal"} or float
        How alpha is chosen (see :func:`ccd_alpha`); ignored for face-centred designs.
    center : int
        Centre runs.
    fraction_p : int
        Use a 2^(k-p) fraction (standard generators) for the factorial part.

    Returns
    -------
    numpy.ndarray
        Factorial rows, then axial rows (-alpha, +alpha for each factor in turn), then
        centre rows.

    Notes
    -----
    Built from pyDOE3's parts, with the alpha of :func:`ccd_alpha`: the two-level
    factorial (``ff2n``, or ``fracfact`` through :func:`fractional_factorial`) and the
    axial runs of ``star`` at alpha 1, scaled. For a full factorial part with a
    rotatable or face-centred alpha this is pyDOE3's ``ccdesign(k, center=(0, c))``
    with the factorial rows in Yates order; ``ccdesign`` itself has no fractional part,
    no numeric alpha and another "orthogonal" alpha.
    """
    if k < 2:
        raise ConfigError("a central composite design needs at least two factors.")
    center = check_center(center)
    fraction_p = check_count(fraction_p, "number of generators p of the factorial part", 0)
    if fraction_p >= k:
        raise ConfigError(
            f"the factorial part of a {k}-factor central composite design takes p = 0 to {k - 1} "
            f"generators, not {fraction_p}."
        )
    check_run_count(2 ** (k - fraction_p) + 2 * k + center,
                    f"a central composite design of {k} factors with {center:,} centre points",
                    "use fewer factors or centre points, or a fractional factorial part")
    kind = {"ccc": "circumscribed", "cci": "inscribed", "ccf": "face-centred",
            "face": "face-centred", "face-centered": "face-centred"}.get(kind, kind)
    if kind not in ("circumscribed", "inscribed", "face-centred"):
        raise ConfigError(
            f"unknown CCD type {kind!r}; use circumscribed, inscribed or face-centred."
        )
    if kind == "face-centred":
        a = 1.0
    elif isinstance(alpha, str):
        a = ccd_alpha(k, alpha, center, fraction_p)
    else:
        try:
            a = float(alpha)
        except (TypeError, ValueError):
            raise ConfigError(
                f"the CCD axial distance alpha must be rotatable, orthogonal or a number, not {alpha!r}."
            ) from None
        if not (math.isfinite(a) and a > 0):
            raise ConfigError(f"the CCD axial distance alpha must be a positive number, not {alpha!r}.")
    fact = fractional_factorial(k, fraction_p) if fraction_p else _two_level_full(k)
    axial = _pydoe3().doe_star.star(k, alpha="faced")[0] * a  # -1, +1 per factor in turn
    design = np.vstack([fact, axial, np.zeros((center, k))])
    if kind == "inscribed":
        design = design / a
    return design


# ---------------------------------------------------------------------------------------
# Steepest ascent
# ---------------------------------------------------------------------------------------


def steepest_ascent(
    coefficients, step: float = 1.0, n_steps: int = 5, base: int | None = None,
    descent: bool = False,
) -> np.ndarray:
    """Points along the path of steepest ascent of a first-order model.

    From y = b0 + sum b_i x_i (coded), the path moves in proportion to the b_i
    (Montgomery 2013, Sec. 11.2): the ``base`` factor (by default the one with the
    largest |b_i|) moves ``step`` coded units per step and every other factor moves
    ``step * b_j / |b_base|``.

    Parameters
    ----------
    coefficients : sequence of float
        First-order coefficients b_1 .. b_k (no intercept), coded units.
    step : float
        Step of the base factor [coded units].
    n_steps : int
        Number of steps after the origin.
    base : int, optional
        Index of the base factor.
    descent : bool
        Follow steepest descent instead.

    Returns
    -------
    numpy.ndarray
        ``(n_steps + 1, k)`` coded points, the origin first.
    """
    try:
        step = float(step)
    except (TypeError, ValueError):
        raise ConfigError(f"the step of the ascent path must be a number, not {step!r}.") from None
    if not (math.isfinite(step) and step > 0):
        raise ConfigError(
            f"the step of the ascent path must be a positive number of coded units, not {step:g} "
            "(follow steepest descent to go downhill)."
        )
    n_steps = check_count(n_steps, "number of steps along the ascent path", 1)
    check_run_count(n_steps + 1, f"a path of {n_steps:,} steps", "use fewer steps")
    b = np.asarray(coefficients, dtype=float)
    if b.ndim != 1 or not np.any(b):
        raise ConfigError("the first-order model has no slope, so there is no ascent path.")
    if base is None:
        base = int(np.argmax(np.abs(b)))
    if b[base] == 0:
        raise ConfigError("the base factor of the ascent path has a zero coefficient.")
    delta = step * b / abs(b[base])
    if descent:
        delta = -delta
    return np.arange(n_steps + 1)[:, None] * delta[None, :]
