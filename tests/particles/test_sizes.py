"""Size (scale-factor) distributions: ranges, moments, determinism, sieve mass fractions."""

import re

import numpy as np
import pytest

from demcal.errors import ConfigError
from demcal.particles.sizes import Fixed, Normal, SieveTable, Uniform, paper_sizes, size_distribution

from sentences import one_sentence


def test_fixed_and_uniform():
    assert np.all(Fixed(1.2).sample(5, 0) == 1.2)
    s = paper_sizes().sample(100_000, seed=42)
    assert s.min() >= 0.5 and s.max() <= 1.5
    assert s.mean() == pytest.approx(1.0, abs=0.005)
    assert s.var() == pytest.approx(1.0 / 12.0, rel=0.02)  # (b - a)^2 / 12
    assert np.mean(s**3) == pytest.approx(paper_sizes().mean_cube(), rel=0.01)
    assert paper_sizes().mean_cube() == pytest.approx((1.5**4 - 0.5**4) / 4.0)


def test_same_seed_same_sizes():
    for dist in (Uniform(0.5, 1.5), Normal(1.0, 0.2), SieveTable((1e-3, 2e-3, 4e-3), (0.3, 0.7), 2e-3)):
        assert np.array_equal(dist.sample(100, 7), dist.sample(100, 7))
        assert not np.array_equal(dist.sample(100, 7), dist.sample(100, 8))


def test_truncated_normal():
    d = Normal(mean=1.0, std=0.3, low=0.8, high=1.5)
    s = d.sample(50_000, 1)
    assert s.min() >= 0.8 and s.max() <= 1.5 and d.max_scale == 1.5
    from scipy.stats import truncnorm

    ref = truncnorm((0.8 - 1.0) / 0.3, (1.5 - 1.0) / 0.3, loc=1.0, scale=0.3)
    assert s.mean() == pytest.approx(ref.mean(), abs=0.005)
    assert Normal(1.0, 0.1).min_scale == pytest.approx(0.7)


def test_sieve_table_reproduces_mass_fractions():
    apertures = np.array([0.25, 0.5, 1.0, 2.0, 5.0]) * 1e-3
    mass = np.array([0.1, 0.2, 0.3, 0.4])
    d = SieveTable(apertures, mass, reference_size=1e-3)
    s = d.sample(2_000_000, 3)  # the coarse class holds few particles: needs many
    size = s * 1e-3
    cls = np.searchsorted(apertures, size, side="right") - 1
    m = np.bincount(cls, weights=size**3, minlength=4)
    assert m / m.sum() == pytest.approx(mass, abs=0.01)
    assert s.min() >= 0.25 and s.max() <= 5.0 and d.max_scale == pytest.approx(5.0)


def test_size_distribution_from_table():
    assert size_distribution(1.0) == Fixed(1.0)
    assert size_distribution({"kind": "uniform", "low": 0.5, "high": 1.5}) == Uniform(0.5, 1.5)
    assert one_sentence(lambda: size_distribution({"kind": "lognormal"})) == (
        "unknown size distribution kind 'lognormal': use one of fixed, uniform, normal, sieve.")
    # the rest of this sentence is Python's own TypeError text
    assert re.fullmatch(r"bad keys for a uniform size distribution: .*unexpected keyword argument 'lo'\.",
                        one_sentence(lambda: size_distribution({"kind": "uniform", "lo": 0.5})))
    assert one_sentence(lambda: Uniform(1.5, 0.5)) == "uniform size high (0.5) must be >= low (1.5)."
    assert one_sentence(lambda: SieveTable((1e-3, 2e-3), (0.5, 0.5), 1e-3)) == (
        "a sieve table needs k+1 increasing apertures [m] and k mass fractions, "
        "got 2 apertures and 2 fractions.")
