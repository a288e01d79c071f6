"""Particle size distributions, as scale factors applied to a template.

Every distribution draws ``n`` scale factors from a :class:`numpy.random.Generator`
(:meth:`SizeDistribution.sample`), so the same seed gives the same sizes. A scale
factor ``s`` multiplies all lengths of a :class:`~demcal.particles.templates.ParticleTemplate`
(mass ~ s^3, inertia ~ s^5). The paper draws ``s`` uniformly in 0.5-1.5
(:func:`paper_sizes`).

* :class:`Fixed` -- every particle the same;
* :class:`Uniform` -- ``s ~ U(low, high)``;
* :class:`Normal` -- normal, truncated to ``[low, high]`` (rejection sampling);
* :class:`SieveTable` -- mass fractions retained between sieve apertures; particles are
  drawn per class in proportion to number (mass fraction / mean particle mass of the
  class), sizes uniform within a class, and divided by a reference size;
* :func:`scaled_sieve` -- a lab sieve table (bounds [mm], mass [%]) as simulated sizes:
  cut to a window of lab sizes and coarse-grained by a factor.

:func:`size_distribution` builds one from a plain mapping (a campaign file's table).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from demcal._checks import as_float
from demcal.errors import ConfigError

__all__ = [
    "SizeDistribution",
    "Fixed",
    "Uniform",
    "Normal",
    "SieveTable",
    "paper_sizes",
    "ScaledSieve",
    "scaled_sieve",
    "size_distribution",
    "as_generator",
]


def as_generator(seed) -> np.random.Generator:
    """A Generator from a seed (int, SeedSequence, None) or a Generator itself."""
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(seed)


def _finite_positive(value, name: str) -> float:
    v = as_float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ConfigError(f"{name} must be a number > 0, got {value!r}.")
    return v


def _finite(value, name: str) -> float:
    v = as_float(value)
    if not math.isfinite(v):
        raise ConfigError(f"{name} must be a finite number, got {value!r}.")
    return v


class SizeDistribution:
    """Base class: scale factors > 0."""

    def sample(self, n: int, seed=None) -> np.ndarray:
        """``n`` scale factors (float64) drawn with ``seed`` (int or Generator)."""
        raise NotImplementedError

    @property
    def max_scale(self) -> float:
        """Largest scale factor this distribution can return."""
        raise NotImplementedError

    @property
    def min_scale(self) -> float:
        """Smallest scale factor this distribution can return."""
        raise NotImplementedError

    def mean_cube(self, n: int = 200_000, seed: int = 0) -> float:
        """E[s^3] (mean volume factor); Monte Carlo unless overridden."""
        return float(np.mean(self.sample(n, seed) ** 3))


class _Interval(SizeDistribution):
    """A distribution on ``[low, high]``: the bounds are its extreme scale factors."""

    @property
    def max_scale(self):
        return float(self.high)

    @property
    def min_scale(self):
        return float(self.low)


@dataclass(frozen=True)
class Fixed(_Interval):
    """Every particle at scale ``value``."""

    value: float = 1.0

    #: Both bounds are the fixed scale factor.
    low = high = property(lambda self: self.value)

    def __post_init__(self):
        _finite_positive(self.value, "fixed scale factor")

    def sample(self, n, seed=None):
        return np.full(int(n), float(self.value))

    def mean_cube(self, n=0, seed=0):
        return float(self.value) ** 3


@dataclass(frozen=True)
class Uniform(_Interval):
    """Scale factor uniform in ``[low, high]``."""

    low: float = 0.5
    high: float = 1.5

    def __post_init__(self):
        _finite_positive(self.low, "uniform size low")
        _finite_positive(self.high, "uniform size high")
        if self.high < self.low:
            raise ConfigError(f"uniform size high ({self.high}) must be >= low ({self.low}).")

    def sample(self, n, seed=None):
        return as_generator(seed).uniform(self.low, self.high, int(n))

    def mean_cube(self, n=0, seed=0):
        a, b = float(self.low), float(self.high)
        return a**3 if a == b else (b**4 - a**4) / (4.0 * (b - a))


@dataclass(frozen=True)
class Normal(_Interval):
    """Normal scale factor with ``mean`` and ``std``, truncated to ``[low, high]``
    (defaults: mean -/+ 3 std, and never below 1 % of the mean)."""

    mean: float = 1.0
    std: float = 0.1
    low: float | None = None
    high: float | None = None

    def __post_init__(self):
        _finite_positive(self.mean, "normal size mean")
        std = as_float(self.std)
        if not (math.isfinite(std) and std >= 0.0):
            raise ConfigError(f"normal size std must be a number >= 0, got {self.std!r}.")
        lo = self.mean - 3.0 * self.std if self.low is None else _finite(self.low, "normal size low")
        hi = self.mean + 3.0 * self.std if self.high is None else _finite(self.high, "normal size high")
        lo = max(lo, 0.01 * self.mean)
        if hi < lo:
            raise ConfigError(f"normal size bounds [{lo}, {hi}] are empty: widen them.")
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "high", hi)

    def sample(self, n, seed=None):
        rng = as_generator(seed)
        n = int(n)
        if self.std == 0.0:
            return np.full(n, float(np.clip(self.mean, self.low, self.high)))
        out = np.empty(0)
        for _ in range(1000):
            need = n - len(out)
            if need <= 0:
                break
            draw = rng.normal(self.mean, self.std, max(2 * need, 64))
            draw = draw[(draw >= self.low) & (draw <= self.high)]
            out = np.concatenate([out, draw[:need]])
        if len(out) < n:
            raise ConfigError(
                f"normal size window [{self.low}, {self.high}] is too far in the tail of "
                f"N({self.mean}, {self.std}): widen it."
            )
        return out


@dataclass(frozen=True)
class SieveTable(SizeDistribution):
    """A sieve analysis: mass fractions retained between consecutive apertures.

    Parameters
    ----------
    apertures : sequence of float
        Increasing sieve apertures [m] (class ``i`` is ``apertures[i]..apertures[i+1]``),
        ``len(mass_fractions) + 1`` values.
    mass_fractions : sequence of float
        Mass fraction of each class (normalised to sum 1).
    reference_size : float
        The particle size [m] that corresponds to scale 1 (e.g. the template's
        equivalent diameter); a particle of size ``D`` gets scale ``D / reference_size``.

    Sizes are uniform within a class. A class is drawn with probability proportional
    to its number fraction ``w_i / E[D^3 | class i]`` (equal density and shape in every
    class), so the sampled *mass* fractions converge to ``mass_fractions``.
    """

    apertures: tuple = ()
    mass_fractions: tuple = ()
    reference_size: float = 1.0

    def __post_init__(self):
        try:
            edges = np.asarray(self.apertures, dtype=float)
            w = np.asarray(self.mass_fractions, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(
                "sieve apertures [m] and mass fractions must be lists of numbers, got "
                f"{self.apertures!r} and {self.mass_fractions!r}."
            ) from None
        if edges.ndim != 1 or len(edges) < 2 or len(w) != len(edges) - 1:
            raise ConfigError(
                "a sieve table needs k+1 increasing apertures [m] and k mass fractions, "
                f"got {len(edges)} apertures and {len(w)} fractions."
            )
        if np.any(edges <= 0) or np.any(np.diff(edges) <= 0) or not np.all(np.isfinite(edges)):
            raise ConfigError("sieve apertures must be positive and strictly increasing [m].")
        if np.any(w < 0) or not np.all(np.isfinite(w)) or w.sum() <= 0:
            raise ConfigError("sieve mass fractions must be >= 0 with a positive sum.")
        _finite_positive(self.reference_size, "sieve reference_size")
        object.__setattr__(self, "apertures", tuple(edges.tolist()))
        object.__setattr__(self, "mass_fractions", tuple((w / w.sum()).tolist()))

    def number_fractions(self) -> np.ndarray:
        """Probability of each class by number."""
        a = np.asarray(self.apertures[:-1])
        b = np.asarray(self.apertures[1:])
        mean_cube = (b**4 - a**4) / (4.0 * (b - a))
        p = np.asarray(self.mass_fractions) / mean_cube
        return p / p.sum()

    def sample(self, n, seed=None):
        rng = as_generator(seed)
        n = int(n)
        cls = rng.choice(len(self.mass_fractions), size=n, p=self.number_fractions())
        a = np.asarray(self.apertures[:-1])[cls]
        b = np.asarray(self.apertures[1:])[cls]
        return (a + (b - a) * rng.random(n)) / self.reference_size

    def mean_cube(self, n=0, seed=0):
        """E[s^3] over the number distribution, exactly."""
        a = np.asarray(self.apertures[:-1])
        b = np.asarray(self.apertures[1:])
        cube = (b**4 - a**4) / (4.0 * (b - a))
        return float(np.dot(self.number_fractions(), cube)) / float(self.reference_size) ** 3

    @property
    def max_scale(self):
        w = np.asarray(self.mass_fractions)
        top = np.nonzero(w > 0)[0].max()
        return self.apertures[top + 1] / self.reference_size

    @property
    def min_scale(self):
        w = np.asarray(self.mass_fractions)
        bottom = np.nonzero(w > 0)[0].min()
        return self.apertures[bottom] / self.reference_size


@dataclass(frozen=True)
class ScaledSieve:
    """A lab sieve table as the simulation draws it (:func:`scaled_sieve`).

    Attributes
    ----------
    distribution : the simulated sizes, as scale factors on the template.
    window_mm : (low, high) the lab sizes simulated [mm]; the sample's mass outside them
        is left out.
    left_out_percent : the lab mass outside the window [%].
    coarse_grain : a lab particle of size D is simulated at ``coarse_grain * D``.
    """

    distribution: SieveTable
    window_mm: tuple
    left_out_percent: float
    coarse_grain: float


def scaled_sieve(edges_mm, mass_percent, reference_size: float, coarse_grain: float = 1.0,
                 size_min_mm: float = 0.0, size_max_mm: float = 0.0) -> ScaledSieve:
    """The simulated size distribution of a lab sieve table.

    Parameters
    ----------
    edges_mm, mass_percent : a checked lab table (:class:`demcal.measure.lab.SieveTable`):
        increasing class bounds [mm], the first may be 0 and the last ``inf``; mass of each
        class [%].
    reference_size : the template's size [m] at scale 1 (its volume-equivalent diameter).
    coarse_grain : every lab size D is simulated at ``coarse_grain * D``.
    size_min_mm, size_max_mm : the window of lab sizes simulated [mm]. 0 takes the
        defaults: from the first bound above 0 (a class from 0 has no smallest particle)
        to the top bound; an open top class (``>= d``) is taken as d to 2 d (demcal's
        choice: the sieve says nothing above d).

    A class the window cuts keeps the part of its mass inside the window, sizes being
    uniform within a class (as :class:`SieveTable` draws them); the mass outside is left
    out and the rest normalised, so the simulated classes keep their mass ratios.
    """
    a = np.asarray(edges_mm, dtype=float)[:-1]
    b = np.asarray(edges_mm, dtype=float)[1:].copy()
    mass = np.asarray(mass_percent, dtype=float)
    if not np.isfinite(b[-1]):  # the open top class ">= d" taken as d to 2 d
        b[-1] = 2.0 * a[-1]
    positive = np.concatenate([a, b])
    positive = positive[positive > 0]
    lo = float(size_min_mm) if size_min_mm else (float(positive.min()) if positive.size else 0.0)
    hi = float(size_max_mm) if size_max_mm else float(b.max())
    if not (0.0 < lo < hi):
        raise ConfigError(f"the window of simulated sizes {lo:g} to {hi:g} mm is empty: give "
                          "particles.size_min_mm below particles.size_max_mm, both above 0.")
    c = _finite_positive(coarse_grain, "the coarse-graining factor")
    a_in, b_in = np.clip(a, lo, hi), np.clip(b, lo, hi)
    width = np.where(b > a, b - a, 1.0)
    kept = mass * np.clip((b_in - a_in) / width, 0.0, 1.0)
    if kept.sum() <= 0.0:
        raise ConfigError(f"no sieve class holds mass between {lo:g} and {hi:g} mm: widen "
                          "particles.size_min_mm .. particles.size_max_mm.")
    inside = b_in > a_in  # the classes the window keeps: contiguous, as the window is
    bounds = np.append(a_in[inside], b_in[inside][-1])
    table = SieveTable(apertures=tuple(c * bounds * 1e-3), mass_fractions=tuple(kept[inside]),
                       reference_size=reference_size)
    return ScaledSieve(table, (lo, hi), float(100.0 * (1.0 - kept.sum() / mass.sum())), c)


def paper_sizes() -> Uniform:
    """The paper's scale factors: uniform in 0.5-1.5 times the basic unit."""
    return Uniform(0.5, 1.5)


def size_distribution(spec) -> SizeDistribution:
    """A size distribution from a number (fixed scale) or a mapping with ``kind``:

    ``{"kind": "fixed", "value": 1}``, ``{"kind": "uniform", "low": 0.5, "high": 1.5}``,
    ``{"kind": "normal", "mean": 1, "std": 0.1, "low": .., "high": ..}``,
    ``{"kind": "sieve", "apertures": [...], "mass_fractions": [...], "reference_size": ..}``.
    """
    if isinstance(spec, SizeDistribution):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        return Fixed(float(spec))
    if not isinstance(spec, Mapping):
        raise ConfigError(f"a size distribution must be a number or a table with 'kind', got {spec!r}.")
    spec = dict(spec)
    kind = spec.pop("kind", None)
    classes = {"fixed": Fixed, "uniform": Uniform, "normal": Normal, "sieve": SieveTable}
    if kind not in classes:
        raise ConfigError(
            f"unknown size distribution kind {kind!r}: use one of {', '.join(classes)}."
        )
    try:
        return classes[kind](**spec)
    except TypeError as exc:
        raise ConfigError(f"bad keys for a {kind} size distribution: {exc}.") from None
