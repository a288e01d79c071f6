"""Materials given by Young's modulus, and the defaults an ``Interaction()`` takes.

G = E / (2 (1 + nu)) for an isotropic elastic solid (Timoshenko & Goodier, Theory of
Elasticity, 3rd ed., 1970, section 4). Reference values by hand: steel E = 200 GPa,
nu = 0.3 gives G = 200e9 / 2.6 = 76.923... GPa.
"""

import pytest

from demcal.errors import ConfigError
from demcal.particles.materials import (SOIL_YIELD_STRENGTH, Interaction, Material,
                                        soil_interaction)


def test_from_youngs_modulus():
    m = Material.from_youngs_modulus(200e9, 0.3, 7800.0, yield_strength=2.5e8, name="steel")
    assert m.shear_modulus == pytest.approx(76.92307692307692e9, rel=1e-15)
    assert m.youngs_modulus == pytest.approx(200e9, rel=1e-15)
    assert (m.density, m.poisson_ratio, m.yield_strength, m.name) == (7800.0, 0.3, 2.5e8,
                                                                      "steel")
    assert Material.from_youngs_modulus(2.6e6, 0.3, 1500.0).yield_strength == \
        SOIL_YIELD_STRENGTH


@pytest.mark.parametrize("args, match", [
    ((-1.0, 0.3, 1000.0), "glass.youngs_modulus must be > 0 Pa"),
    (("stiff", 0.3, 1000.0), "glass.youngs_modulus must be a number"),
    ((1e7, 0.5, 1000.0), r"glass.poisson_ratio must be in \[0, 0.5\)"),
    ((1e7, 0.3, 0.0), "glass.density must be > 0"),
])
def test_from_youngs_modulus_refuses_bad_values(args, match):
    with pytest.raises(ConfigError, match=match):
        Material.from_youngs_modulus(*args, name="glass")


def test_interaction_defaults_are_the_papers_soil_but_damping():
    # docs/dem.md ("Defaults") and the Interaction docstring name these
    it = Interaction()
    soil = soil_interaction()
    assert (it.restitution, it.static_friction, it.rolling_friction, it.stiffness_factor) \
        == (soil.restitution, soil.static_friction, soil.rolling_friction,
            soil.stiffness_factor) == (0.6, 0.4, 0.2, 0.95)
    assert (it.damping_factor, soil.damping_factor) == (0.0, 0.1)
    assert it.rolling_damping == 0.3
