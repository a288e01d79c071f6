"""Main effects of a replicated two-level screening design, and what they say about
identifiability: which factors the responses move beyond their seed noise, and which
combinations of factors they cannot tell apart.

The design is ``points`` rows of coded levels -1 / +1 (a Plackett-Burman design or a
two-level fraction), each run with ``replicates`` seeds. For factor ``j`` and response
``i``:

* the **main effect** is half the difference of the mean response at the high and at
  the low level, ``b_ij = (ybar+ - ybar-) / 2`` [response unit per coded unit]: the
  regression coefficient of the factor in coded units (Montgomery, *Design and Analysis
  of Experiments*, 8th ed., Wiley 2013, §6.2; the effect there is ``ybar+ - ybar-``);
* its **standard error** comes from the replicates' pure error alone,
  ``se = s sqrt(1/n+ + 1/n-) / 2`` with ``s`` the seed-to-seed sd pooled over the points
  (``points (replicates - 1)`` degrees of freedom) and ``n+``, ``n-`` the runs at each
  level; ``t = b / se``, and the effect moves the response *beyond its seed noise* when
  ``|t|`` exceeds Student's two-sided quantile at ``level`` (95 %);
* the **scaled sensitivity** ``S_ij = 2 b_ij / s_i`` is the change of the response over
  the factor's whole range (low to high) in seed sds: each column scaled by the factor's
  range, each row by the response's noise (Brun, Reichert & Künsch 2001, "Practical
  identifiability analysis of large environmental simulation models", *Water Resources
  Research* 37(4), 1015-1030, doi:10.1029/2000WR900350, §2.3, where the scales are the
  parameters' ranges of interest and the measurements' errors).

A direction ``v`` (unit length, range-scaled factors) moves the responses by ``|S v|``
seed sds over the range; the screen detects a move of ``tau = 2 t_crit se_1`` or more
(``se_1 = sqrt(1/n+ + 1/n-) / 2``; the same test as for one effect). The singular values
of ``S`` are the moves of its principal directions, so the responses pin as many
directions as ``S`` has singular values of at least ``tau`` -- one response pins at most
one direction -- and the condition number ``s_max / s_k`` (``k`` factors; infinite when
there are fewer responses than factors) says how unevenly. Factors that no response
moves are *not pinned*; among the others, the right singular vectors of the informative
part of ``S`` whose singular values lie below ``tau`` (zero-padded to the number of
factors) span the combinations the responses cannot see: a factor with a share of at
least :data:`SHARE` of that null space (the root of its diagonal entry of the projector)
is *not separately identifiable*, together with the factors its null directions couple it
to (Brun et al.'s collinearity, read from the singular vectors).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from demcal.errors import DataError

#: Smallest share of the null space (root of the projector's diagonal entry) that makes a
#: factor take part in a combination the responses cannot see.
SHARE = 0.2
#: Two-sided confidence level of "beyond the seed noise".
LEVEL = 0.95


@dataclass(frozen=True)
class Screen:
    """The main effects of a replicated two-level design (``m`` responses, ``k`` factors)."""

    effects: np.ndarray  #: (m, k) half the high-minus-low difference [response unit]
    se: np.ndarray  #: (m, k) their standard errors from the replicates [response unit]
    noise: np.ndarray  #: (m,) seed-to-seed sd pooled over the points [response unit]
    dof: int  #: degrees of freedom of the noise: points x (replicates - 1)
    se_unit: float  #: max over factors of sqrt(1/n+ + 1/n-) / 2: se = noise * se_unit

    @property
    def t(self) -> np.ndarray:
        """(m, k) t-ratios ``effect / se``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.effects / self.se

    @property
    def sensitivity(self) -> np.ndarray:
        """(m, k) scaled sensitivity: the response's change over the factor's range in seed sds."""
        return 2.0 * self.effects / self.noise[:, None]


def main_effects(coded: np.ndarray, values: np.ndarray) -> Screen:
    """Main effects of a replicated two-level design.

    Parameters
    ----------
    coded : (points, k) levels -1 / +1; at least ``k + 1`` points, the factors' columns
        and a column of ones independent.
    values : (points, replicates, m) responses, replicates >= 2, all finite.

    Raises
    ------
    DataError
        A design that is not two-level, has too few points or confounds factors; fewer
        than two replicates; a response with no seed noise at all.
    """
    coded = np.asarray(coded, dtype=float)
    values = np.asarray(values, dtype=float)
    points, k = coded.shape
    check_design(coded)
    if values.ndim != 3 or values.shape[0] != points:
        raise DataError(f"the screen needs one row of responses per design point ({points}), got {values.shape}.")
    if values.shape[1] < 2:
        raise DataError("the screen needs at least 2 seeds per point to measure the seed noise; give 2 or more "
                        "replicates.")
    if not np.all(np.isfinite(values)):
        raise DataError("a screening run returned a response that is not a finite number; rerun it or "
                        "check the bench.")
    replicates = values.shape[1]
    means = values.mean(axis=1)  # (points, m)
    dof = points * (replicates - 1)
    noise = np.sqrt(((values - means[:, None, :]) ** 2).sum(axis=(0, 1)) / dof)
    high = coded > 0
    n_high = high.sum(axis=0) * replicates
    n_low = (~high).sum(axis=0) * replicates
    # (m, k): mean of the point means at +1 minus at -1, halved
    effects = 0.5 * (means.T @ high / high.sum(axis=0) - means.T @ ~high / (~high).sum(axis=0))
    unit = 0.5 * np.sqrt(1.0 / n_high + 1.0 / n_low)  # (k,)
    se = noise[:, None] * unit[None, :]
    return Screen(effects=effects, se=se, noise=noise, dof=int(dof), se_unit=float(unit.max()))


def check_design(coded: np.ndarray) -> None:
    """One :class:`DataError` sentence when ``coded`` cannot give every main effect."""
    points, k = coded.shape
    if points < k + 1:
        raise DataError(f"a screen of {points} runs cannot estimate {k} main effects and the mean; it needs at "
                        f"least {k + 1} design points.")
    if not np.all(np.isin(coded, (-1.0, 1.0))):
        raise DataError("a screening design must be two-level: every coded level -1 or +1.")
    for j in range(k):
        if np.all(coded[:, j] == coded[0, j]):
            raise DataError(f"column {j + 1} of the screening design holds one level only; each factor needs "
                            "runs at both its low and its high level.")
    if np.linalg.matrix_rank(np.column_stack([np.ones(points), coded])) < k + 1:
        raise DataError("the screening design confounds some factors (its columns are not independent); use a "
                        "Plackett-Burman design or a fraction of resolution III or more.")


def t_quantile(dof: int, level: float = LEVEL) -> float:
    """Student's two-sided ``level`` quantile with ``dof`` degrees of freedom."""
    from scipy import stats

    return float(stats.t.ppf(0.5 + level / 2.0, dof))


@dataclass(frozen=True)
class Combination:
    """Factors the responses cannot tell apart: they pin fewer directions among them
    than there are factors."""

    factors: tuple[int, ...]  #: indices of the factors
    free: int  #: directions among them the responses leave free
    pinned: tuple[tuple[float, ...], ...]  #: the combinations they do pin (unit, range-scaled), one per row


@dataclass(frozen=True)
class Identifiability:
    """What a screen says about ``k`` factors and ``m`` responses."""

    screen: Screen
    t_crit: float  #: |t| beyond this: the effect moves the response beyond its noise
    threshold: float  #: tau: the smallest move of a direction the screen detects [seed sds over the range]
    singular_values: np.ndarray  #: of the scaled sensitivity, largest first, zero-padded to k
    condition_number: float  #: s_max / s_k (inf: fewer pinned directions than factors at all)
    informative: np.ndarray  #: (m, k) bool: |t| > t_crit
    unpinned: tuple[int, ...]  #: factors no response moves beyond its noise
    combinations: tuple[Combination, ...]

    @property
    def rank(self) -> int:
        """How many directions the responses pin (singular values of at least ``threshold``)."""
        return int(np.sum(self.singular_values >= self.threshold))

    @property
    def pinned(self) -> tuple[int, ...]:
        """Factors moved beyond the noise and in no combination."""
        tied = {j for c in self.combinations for j in c.factors}
        k = self.informative.shape[1]
        return tuple(j for j in range(k) if j not in tied and j not in self.unpinned)


def identifiability(screen: Screen, level: float = LEVEL) -> Identifiability:
    """Which factors the responses of ``screen`` pin, and which combinations they cannot see."""
    t_crit = t_quantile(screen.dof, level)
    tau = 2.0 * t_crit * screen.se_unit
    s_matrix = screen.sensitivity
    m, k = s_matrix.shape
    informative = np.abs(screen.t) > t_crit
    singular = padded_singular_values(s_matrix, k)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
    unpinned = tuple(j for j in range(k) if not informative[:, j].any())
    cols = [j for j in range(k) if j not in unpinned]
    rows = [i for i in range(m) if informative[i].any()]
    combos = null_combinations(s_matrix[np.ix_(rows, cols)], tau) if cols else []
    combinations = tuple(Combination(tuple(cols[j] for j in members), free, pinned)
                         for members, free, pinned in combos)
    return Identifiability(screen=screen, t_crit=t_crit, threshold=float(tau), singular_values=singular,
                           condition_number=condition, informative=informative, unpinned=unpinned,
                           combinations=combinations)


def padded_singular_values(matrix: np.ndarray, k: int) -> np.ndarray:
    """The singular values of ``matrix``, largest first, with zeros up to ``k``."""
    singular = np.linalg.svd(matrix, compute_uv=False) if matrix.size else np.zeros(0)
    return np.concatenate([singular, np.zeros(max(k - singular.size, 0))])[:k]


def null_space(matrix: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``(null, row)``: orthonormal columns spanning the directions ``matrix`` moves by less
    than ``tau`` (its right singular vectors of singular value below ``tau``, the zero ones
    included), and those spanning the rest."""
    k = matrix.shape[1]
    _, singular, vt = np.linalg.svd(matrix, full_matrices=True)
    singular = np.concatenate([singular, np.zeros(k - singular.size)])[:k]
    small = singular < tau
    return vt[small].T, vt[~small].T


def null_combinations(matrix: np.ndarray, tau: float) -> list[tuple[tuple[int, ...], int, tuple]]:
    """Groups of columns of ``matrix`` tied together by its null space (see the module's
    docstring): ``(columns, free directions, pinned combinations)`` per group."""
    null, row = null_space(matrix, tau)
    if null.shape[1] == 0:
        return []
    projector = null @ null.T
    share = np.sqrt(np.clip(np.diag(projector), 0.0, None))
    tied = [j for j in range(matrix.shape[1]) if share[j] >= SHARE]
    groups: list[list[int]] = []
    for j in tied:  # connected components: i ~ j when the null space couples them
        linked = [g for g in groups if any(abs(projector[i, j]) >= SHARE**2 for i in g)]
        merged = [j] + [i for g in linked for i in g]
        groups = [g for g in groups if g not in linked] + [sorted(merged)]
    out = []
    for members in sorted(groups):
        sub = projector[np.ix_(members, members)]
        free = int(np.sum(np.linalg.eigvalsh(sub) > 0.5))  # eigenvalues of a projector's block: ~0 or ~1
        free = max(free, 1)
        pinned = _pinned_within(row[members], len(members) - free)
        out.append((tuple(members), free, pinned))
    return out


def _pinned_within(row: np.ndarray, count: int) -> tuple[tuple[float, ...], ...]:
    """The ``count`` combinations of a group's factors that the responses pin: the
    principal directions of the row space restricted to the group, unit length, the
    largest component positive."""
    if count <= 0 or row.size == 0:
        return ()
    u, _, _ = np.linalg.svd(row, full_matrices=False)
    out = []
    for c in range(min(count, u.shape[1])):
        v = u[:, c] / np.linalg.norm(u[:, c])
        v = v if v[np.argmax(np.abs(v))] > 0 else -v
        out.append(tuple(float(x) for x in v))
    return tuple(out)


def pinned_count(matrix: np.ndarray, tau: float) -> int:
    """How many directions the rows of ``matrix`` (scaled sensitivities) move by ``tau`` or more."""
    if matrix.size == 0:
        return 0
    return int(np.sum(np.linalg.svd(matrix, compute_uv=False) >= tau))


def pins_more(matrix: np.ndarray, row: np.ndarray, tau: float) -> bool:
    """Whether adding the response ``row`` to the responses ``matrix`` (both scaled
    sensitivities over the same factors) pins a direction they leave free."""
    return pinned_count(np.vstack([matrix, row]), tau) > pinned_count(matrix, tau)


def describe_combination(weights: Sequence[float], names: Sequence[str], digits: int = 2) -> str:
    """``0.71 A + 0.71 B`` (range-scaled weights), signs spelled out."""
    parts = []
    for w, name in zip(weights, names):
        if round(abs(w), digits) == 0:
            continue
        sign = "-" if w < 0 else "+"
        parts.append(f"{sign} {abs(w):.{digits}f} {name}")
    text = " ".join(parts)
    return text[2:] if text.startswith("+ ") else text
