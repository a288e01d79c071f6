"""Bad input gets one clear ConfigError sentence naming the parameter, what is wrong
and the allowed range (checked word for word where the message is fixed)."""

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.errors import ConfigError
from demcal.particles.materials import Interaction, Material

from dem_helpers import GLASS, RADIUS


def assert_sentence(info, expected):
    """The error is exactly ``expected``: one line, no traceback text."""
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message, message
    assert message == expected


def make(**kw):
    args = dict(materials=[GLASS], interactions=Interaction())
    args.update(kw)
    return Simulation(**args)


def test_unknown_contact_model(backend):
    with pytest.raises(ConfigError, match="contact_model 'hertz_mindlinn'"):
        make(contact_model="hertz_mindlinn", backend=backend)


def test_unknown_rolling_model(backend):
    with pytest.raises(ConfigError, match="rolling_model 'type_b'"):
        make(rolling_model="type_b", backend=backend)


@pytest.mark.parametrize("e, expected", [
    (0.0, "restitution must be in (0, 1], got 0.0."),
    (-0.2, "restitution must be in (0, 1], got -0.2."),
    (1.5, "restitution must be in (0, 1], got 1.5."),
    (float("nan"), "restitution must be a finite number, got nan."),
])
def test_restitution_out_of_range(e, expected):
    with pytest.raises(ConfigError) as info:
        Interaction(restitution=e)
    assert_sentence(info, expected)


@pytest.mark.parametrize("name", ["static_friction", "rolling_friction", "damping_factor"])
def test_negative_friction(name):
    with pytest.raises(ConfigError) as info:
        Interaction(**{name: -0.1})
    assert_sentence(info, f"{name} must be >= 0, got -0.1.")


@pytest.mark.parametrize("field,value,expected", [
    ("density", 0.0, "material.density must be > 0 kg/m3, got 0.0."),
    ("shear_modulus", -1.0, "material.shear_modulus must be > 0 Pa, got -1.0."),
    ("poisson_ratio", 0.5, "material.poisson_ratio must be in [0, 0.5), got 0.5."),
    ("yield_strength", 0.0, "material.yield_strength must be > 0 Pa, got 0.0."),
])
def test_bad_material(field, value, expected):
    args = dict(density=1000.0, shear_modulus=1e7, poisson_ratio=0.3)
    args[field] = value
    with pytest.raises(ConfigError) as info:
        Material(**args)
    assert_sentence(info, expected)


def test_particle_larger_than_domain(backend):
    sim = make(domain=((0, 0, 0), (0.008, 0.1, 0.1)), backend=backend)
    with pytest.raises(ConfigError, match="larger than the domain"):
        sim.add_particles(RADIUS, [[0.004, 0.05, 0.05]])


def test_time_step_above_stable_limit(backend):
    sim = make(dt=1e-3, backend=backend)
    sim.add_particles(RADIUS, [[0, 0, 0]])
    with pytest.raises(ConfigError, match="dt = 0.001 s is above the stable limit"):
        sim.run(steps=1)


def test_unknown_material_and_missing_pair(backend):
    sim = make(backend=backend)
    with pytest.raises(ConfigError, match="unknown material 'steel'"):
        sim.add_particles(RADIUS, [[0, 0, 0]], material="steel")
    steel = Material(7800, 7e10, 0.3, name="steel")
    # pairs that never meet need no interaction: steel is only checked once steel
    # particles (or walls) join the glass ones
    sim = Simulation([GLASS, steel], {(0, 0): Interaction()}, backend=backend)
    sim.add_particles(RADIUS, [[0, 0, 0]])
    with pytest.raises(ConfigError, match="no interaction defined between materials 'steel' "
                                          "and 'glass', and steel particles would meet glass particles"):
        sim.add_particles(RADIUS, [[0.1, 0, 0]], material="steel")
    assert sim.n_particles == 1


def test_walls_take_material_names_and_pairs_that_meet_need_an_interaction(backend):
    """A wall names its material; glass particles on a steel plate need a glass-steel
    interaction, and no steel-steel one (no steel particle)."""
    from demcal.geometry import Disk, WallSet

    steel = Material(7800, 7e10, 0.3, name="steel")
    by_name = Simulation([GLASS, steel], {("glass", "glass"): Interaction(), ("steel", "glass"): Interaction()},
                         walls=WallSet([Disk(radius=0.1, material="steel")]), backend=backend)
    assert list(by_name._walls.rows.material) == [1]
    by_name.add_particles(RADIUS, [[0, 0, 0.01]])
    lone = Simulation([GLASS, steel], {(0, 0): Interaction()}, walls=WallSet([Disk(radius=0.1, material="steel")]),
                      backend=backend)
    with pytest.raises(ConfigError, match="no interaction defined between materials 'glass' and 'steel', "
                                          "and glass particles would meet steel walls"):
        lone.add_particles(RADIUS, [[0, 0, 0.01]])
    with pytest.raises(ConfigError, match="a wall's material: unknown material 'iron'; known materials are"):
        Simulation([GLASS, steel], Interaction(), walls=WallSet([Disk(radius=0.1, material="iron")]),
                   backend=backend)


def test_run_needs_duration_or_steps(backend):
    sim = make(backend=backend)
    with pytest.raises(ConfigError, match="exactly one of duration"):
        sim.run()


def test_unknown_backend():
    with pytest.raises(ConfigError, match=r"unknown backend 'opencl'; available: \['cpu', 'cuda'\]"):
        make(backend="opencl")
