"""Templates and size distributions refuse bad input in one sentence naming the culprit."""

import numpy as np
import pytest

from demcal.errors import ConfigError
from demcal.particles.sizes import Fixed, Normal, SieveTable, Uniform, size_distribution
from demcal.particles.templates import ParticleTemplate, sphere, two_sphere_paper

from sentences import one_sentence


def test_template_with_no_spheres_is_refused_by_its_constructor():
    msg = one_sentence(lambda: ParticleTemplate(np.zeros(0), np.zeros((0, 3)), 0.0, np.zeros(3)))
    assert "sphere" in msg


@pytest.mark.parametrize(
    "args, word",
    [
        ((np.array([0.001, 0.001]), np.zeros((1, 3)), 1e-9, np.ones(3)), "centers"),
        ((np.array([-0.001]), np.zeros((1, 3)), 1e-9, np.ones(3)), "radi"),
        ((np.array([np.nan]), np.zeros((1, 3)), 1e-9, np.ones(3)), "radi"),
        ((np.array([0.001]), np.full((1, 3), np.inf), 1e-9, np.ones(3)), "centers"),
        ((np.array([0.001]), np.zeros((1, 3)), 0.0, np.ones(3)), "volume"),
        ((np.array([0.001]), np.zeros((1, 3)), float("nan"), np.ones(3)), "volume"),
        ((np.array([0.001]), np.zeros((1, 3)), 1e-9, np.ones(2)), "inertia"),
        ((np.array([0.001]), np.zeros((1, 3)), 1e-9, -np.ones(3)), "inertia"),
    ],
)
def test_template_constructor_checks_its_arrays(args, word):
    assert word in one_sentence(lambda: ParticleTemplate(*args))


def test_template_constructor_still_takes_good_arrays():
    t = sphere(0.002)
    again = ParticleTemplate(t.radii, t.centers, t.volume, t.inertia_per_density, name="again")
    assert again.bounding_radius == pytest.approx(0.002)
    assert ParticleTemplate([0.002], [[0.0, 0.0, 0.0]], t.volume, list(t.inertia_per_density)).n_spheres == 1


@pytest.mark.parametrize("radii", [(-0.004, 0.005), (0.004, 0.0), (float("nan"), 0.005)])
def test_two_sphere_bad_radius_is_reported_as_a_radius(radii):
    msg = one_sentence(lambda: two_sphere_paper(radii=radii))
    assert "radi" in msg and "offset" not in msg


@pytest.mark.parametrize("radii", [(0.004,), (0.004, 0.005, 0.006), "ab", 0.004])
def test_two_sphere_needs_two_radii(radii):
    assert "radii" in one_sentence(lambda: two_sphere_paper(radii=radii))


def test_two_sphere_offset_message_prints_a_short_bound():
    msg = one_sentence(lambda: two_sphere_paper(offset=0.01))
    assert "0.009000000000000001" not in msg
    assert "[0, 0.009) m" in msg and "got 0.01" in msg
    assert "offset" in one_sentence(lambda: two_sphere_paper(offset="x"))
    assert "offset" in one_sentence(lambda: two_sphere_paper(offset=float("nan")))


@pytest.mark.parametrize(
    "call, word",
    [
        (lambda: Fixed("a"), "fixed scale factor"),
        (lambda: Fixed(None), "fixed scale factor"),
        (lambda: Uniform("a", 1.0), "uniform size low"),
        (lambda: Uniform(0.5, [1]), "uniform size high"),
        (lambda: Normal("a"), "normal size mean"),
        (lambda: Normal(1.0, "b"), "normal size std"),
        (lambda: Normal(1.0, 0.1, low="x"), "normal size low"),
        (lambda: Normal(1.0, 0.1, high=float("nan")), "normal size high"),
        (lambda: SieveTable((1e-3, "a"), (1.0,), 1e-3), "sieve"),
        (lambda: SieveTable((1e-3, 2e-3), (1.0,), "ref"), "reference_size"),
        (lambda: size_distribution({"kind": "fixed", "value": "big"}), "fixed scale factor"),
    ],
)
def test_non_numeric_size_parameters_are_one_sentence(call, word):
    assert word in one_sentence(call)
