"""The bench tests' step is the engine's time-step policy (dem/timestep.choose_dt)."""

import pytest

from demcal.bench import common as C
from demcal.bench.registry import get_experiment
from demcal.dem import Simulation
from demcal.dem.timestep import choose_dt
from demcal.errors import ConfigError
from demcal.geometry import Plane, WallSet
from demcal.particles.materials import soil, soil_interaction


def test_the_policy_is_the_smaller_of_its_two_shares():
    assert choose_dt(0, 1.0, 2.0, 0.2) == min(0.2, 2.0 / 10.0)  # the engine's: t_c / 10
    assert choose_dt(0, 1.0, 2.0, 0.2, contact_fraction=0.05) == 0.1
    assert choose_dt(0, 1.0, 0.5, 0.2, contact_fraction=0.2) == 0.1
    with pytest.raises(ConfigError, match="dt_fraction must be in"):
        choose_dt(0, 1.0, 2.0, 0.0)


def test_a_bench_step_is_the_policy_for_its_smallest_particle():
    """The funnel's step: 0.2 Rayleigh times or time.step_fraction of the shortest contact of
    the smallest particle, whichever is smaller, a hair below it; the engine accepts it."""
    s = get_experiment("repose-funnel").resolve({}, "tiny")
    tpl, sizes = C.template_for(s), C.sizes_for(s)
    mats = [soil(), soil()]
    walls = WallSet([Plane(material=1, name="plate")])
    inter = soil_interaction()
    dt = C.time_step(s, mats, inter, walls, tpl, sizes.min_scale)
    probe = Simulation(mats, inter, walls=walls, contact_model=s["contact.model"], rolling_model=s["rolling.model"])
    probe.add_particles(tpl, [[0.0, 0.0, 0.0]], scales=[sizes.min_scale])
    t_r, t_c = probe.time_scales()
    assert dt == min(0.2 * t_r, float(s["time.step_fraction"]) * t_c) * (1.0 - 1e-9)
    sim = Simulation(mats, inter, walls=walls, dt=dt, contact_model=s["contact.model"],
                     rolling_model=s["rolling.model"])
    sim.add_particles(tpl, [[0.0, 0.0, 0.1]], scales=[sizes.min_scale])
    sim.run(steps=1)  # a given step is checked against the stable limit here
