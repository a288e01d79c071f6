"""The Python API refuses bad input with one sentence and never runs on silently.

Each error is a single :class:`ConfigError` (or :class:`SimulationError`) sentence naming
the parameter, what is wrong and the fix; valid input (numpy scalars included) is
accepted, and a run by duration ends at the requested time even when particles added
during the run shrink the automatic time step.
"""

import math

import numpy as np
import pytest

from demcal.dem import ContactModel, Simulation
from demcal.dem.reporters import Callback
from demcal.errors import ConfigError
from demcal.geometry import Box, WallSet
from demcal.particles.materials import Interaction, soil, soil_interaction

from dem_helpers import GLASS, RADIUS


def one_sentence(info):
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message, message
    assert message.endswith("."), message
    return message


def make(**kw):
    args = dict(materials=[GLASS], interactions=Interaction(), gravity=(0, 0, 0))
    args.update(kw)
    return Simulation(**args)


def soil_sim(**kw):
    return Simulation([soil()], soil_interaction(), **kw)


class Pair:
    """A duck-typed two-sphere template (overlapping spheres of one body)."""

    name = "pair"

    def __init__(self, r=0.002):
        self.radii = np.array([r, r])
        self.centers = np.array([[-0.5 * r, 0, 0], [0.5 * r, 0, 0]])
        self.volume = 2 * 4.0 / 3.0 * math.pi * r ** 3
        self.inertia_per_density = np.array([0.4, 0.5, 0.5]) * r ** 2 * self.volume


# -------------------------------------------------------------- 1. run(duration) --
def test_duration_run_ends_at_requested_time_when_dt_shrinks():
    sim = soil_sim()
    sim.add_particles(0.004, [[0, 0, 0]])
    dt0 = sim.dt

    def add_small(s):
        if s.n_particles == 1 and s.time >= 0.02:
            s.add_particles(0.001, [[0.05, 0, 0]])

    sim.run(duration=0.1, reporters=[Callback(10, add_small)])
    assert sim.n_particles == 2
    assert sim.dt < dt0 / 2
    assert abs(sim.time - 0.1) <= 0.5 * sim.dt + 1e-12


def test_duration_run_with_fixed_dt_keeps_exact_step_count():
    sim = soil_sim(dt=1e-5)
    sim.add_particles(0.004, [[0, 0, 0]])

    def add_small(s):
        if s.n_particles == 1:
            s.add_particles(0.001, [[0.05, 0, 0]])

    sim.run(duration=0.01, reporters=[Callback(100, add_small)])
    assert sim.step_count == 1000
    assert sim.n_particles == 2


# -------------------------------------------------------------- 2. user dt re-checked --
def test_user_dt_rechecked_when_smaller_particles_are_added():
    first = soil_sim(dt=9e-5)
    first.add_particles(0.0004, [[0.05, 0, 0]])
    with pytest.raises(ConfigError) as expected:
        first.run(steps=1)
    sim = soil_sim(dt=9e-5)
    sim.add_particles(0.004, [[0, 0, 0]])
    sim.run(steps=1)
    sim.add_particles(0.0004, [[0.05, 0, 0]])
    with pytest.raises(ConfigError) as info:
        sim.run(steps=1)
    assert one_sentence(info) == str(expected.value)
    assert "is above the stable limit" in str(info.value)


def test_user_dt_rechecked_when_particles_added_during_a_run():
    sim = soil_sim(dt=9e-5)
    sim.add_particles(0.004, [[0, 0, 0]])

    def add_small(s):
        if s.n_particles == 1:
            s.add_particles(0.0004, [[0.05, 0, 0]])

    with pytest.raises(ConfigError, match="is above the stable limit"):
        sim.run(steps=20, reporters=[Callback(5, add_small)])
    assert sim.step_count == 5


# -------------------------------------------------------------- 3. bad particles --
def test_overlapping_new_particles_refused():
    sim = make()
    with pytest.raises(ConfigError) as info:
        sim.add_particles(0.004, [[0, 0, 0], [0.0008, 0, 0]])
    msg = one_sentence(info)
    assert "particles 0 and 1 overlap by 0.0072 m" in msg, msg
    assert sim.n_particles == 0


def test_particle_overlapping_an_existing_one_refused():
    sim = make()
    sim.add_particles(0.004, [[0, 0, 0], [0.02, 0, 0]])
    with pytest.raises(ConfigError) as info:
        sim.add_particles(0.004, [[0.026, 0, 0]])
    assert "particles 1 and 2 overlap" in one_sentence(info)
    assert sim.n_particles == 2 and sim.n_spheres == 2


def test_slight_overlaps_of_a_settled_bed_and_clumps_accepted():
    sim = make()
    # 1 % of the radius, as in a bed copied from a checkpoint
    sim.add_particles(0.004, [[0, 0, 0], [0.008 - 0.00004, 0, 0]])
    # the spheres of one clump overlap each other by design
    sim.add_particles(Pair(), [[0.05, 0, 0], [0.06, 0, 0]])
    # fixed obstacles may overlap each other (a rough wall of spheres)
    sim.add_particles(0.004, [[0, 0.05, 0], [0.004, 0.05, 0]], fixed=True)
    sim.run(steps=2)
    assert sim.n_particles == 6


@pytest.mark.parametrize("radius", [math.inf, math.nan])
def test_non_finite_radius_refused(radius):
    with pytest.raises(ConfigError) as info:
        make().add_particles(radius, [[0, 0, 0]])
    assert "radius" in one_sentence(info)


@pytest.mark.parametrize("scale", [math.inf, math.nan, 0.0])
def test_non_finite_scale_refused(scale):
    with pytest.raises(ConfigError) as info:
        make().add_particles(RADIUS, [[0, 0, 0]], scales=scale)
    assert "scales" in one_sentence(info)


@pytest.mark.parametrize("name", ["velocities", "angular_velocities"])
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_velocities_refused(name, bad):
    sim = make()
    with pytest.raises(ConfigError) as info:
        sim.add_particles(RADIUS, [[0, 0, 0]], **{name: [0.0, bad, 0.0]})
    assert name in one_sentence(info)
    assert sim.n_particles == 0


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_positions_refused(bad):
    with pytest.raises(ConfigError) as info:
        make().add_particles(RADIUS, [[0, bad, 0]])
    assert "positions" in one_sentence(info)


def test_gravity_of_wrong_shape_at_construction():
    with pytest.raises(ConfigError) as info:
        make(gravity=(0, -9.81))
    assert "gravity" in one_sentence(info)


@pytest.mark.parametrize("value", [(0, 0, math.nan), (0, math.inf, 0)])
def test_gravity_set_non_finite_after_construction(value):
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0]])
    sim.gravity[:] = value
    with pytest.raises(ConfigError) as info:
        sim.run(steps=1)
    assert "gravity" in one_sentence(info)
    assert sim.step_count == 0


def test_gravity_assigned_wrong_shape_after_construction():
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0]])
    with pytest.raises(ConfigError) as info:
        sim.gravity = (0, -9.81)
        sim.run(steps=1)
    assert "gravity" in one_sentence(info)


def test_gravity_assigned_as_tuple_is_used():
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0]])
    sim.gravity = (0, 0, -9.81)
    sim.run(steps=10)
    assert sim.state.velocities[0, 2] < 0


# -------------------------------------------------------------- 4. rolling_model --
def test_rolling_model_conflicting_with_contact_model_refused():
    with pytest.raises(ConfigError) as info:
        make(contact_model=ContactModel(), rolling_model="type_c")
    msg = one_sentence(info)
    assert "rolling_model 'type_c'" in msg and "'type_a'" in msg, msg


def test_rolling_model_agreeing_with_contact_model_accepted():
    sim = make(contact_model=ContactModel(rolling="type_c"), rolling_model="epsd")
    assert sim.contact_model.rolling == "type_c"
    sim = make(contact_model=ContactModel(rolling="cdt"))
    assert sim.contact_model.rolling == "cdt"
    assert make().contact_model.rolling == "type_a"


# -------------------------------------------------------------- 5. shapes and types --
@pytest.mark.parametrize("kw, name", [
    (dict(scales=[1.0, 1.0, 1.0]), "scales"),
    (dict(velocities=[[0, 0, 1], [0, 0, 1], [0, 0, 1]]), "velocities"),
    (dict(velocities=[1.0, 2.0]), "velocities"),
    (dict(angular_velocities=np.zeros((2, 2))), "angular_velocities"),
    (dict(orientations=[[1, 0, 0, 0]] * 3), "orientations"),
    (dict(orientations=np.ones((4, 2))), "orientations"),
])
def test_wrong_shapes_in_add_particles(kw, name):
    sim = make()
    with pytest.raises(ConfigError) as info:
        sim.add_particles(RADIUS, [[0, 0, 0], [0.05, 0, 0]], **kw)
    assert name in one_sentence(info)
    assert sim.n_particles == 0


@pytest.mark.parametrize("duration", [math.inf, math.nan, -1.0, "1"])
def test_bad_duration(duration):
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0]])
    with pytest.raises(ConfigError) as info:
        sim.run(duration=duration)
    assert "duration" in one_sentence(info)


@pytest.mark.parametrize("steps", [1.5, math.inf, math.nan, -1, True, "2"])
def test_bad_steps(steps):
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0]])
    with pytest.raises(ConfigError) as info:
        sim.run(steps=steps)
    assert "steps" in one_sentence(info)
    assert sim.step_count == 0


def test_whole_steps_of_any_number_type():
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0]])
    sim.run(steps=np.int64(2))
    sim.run(steps=3.0)
    assert sim.step_count == 5


@pytest.mark.parametrize("which", [[5], [-4], np.ones(4, bool), [0.5]])
def test_bad_remove_particles(which):
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0], [0.05, 0, 0], [0.1, 0, 0]])
    with pytest.raises(ConfigError) as info:
        sim.remove_particles(which)
    assert "remove_particles" in one_sentence(info)
    assert sim.n_particles == 3


def test_remove_particles_valid_forms():
    sim = make()
    sim.add_particles(RADIUS, [[0, 0, 0], [0.05, 0, 0], [0.1, 0, 0], [0.15, 0, 0]])
    sim.remove_particles([])
    sim.remove_particles(np.array([False, True, False, False]))
    sim.remove_particles(np.int64(-1))
    assert sim.n_particles == 2
    assert np.allclose(sim.state.positions[:, 0], [0.0, 0.1])


def test_numpy_scalars_accepted():
    sim = make(threads=np.int64(2), dt=np.float32(1e-6))
    assert sim.threads == 2 and isinstance(sim.threads, int)
    sim.add_particles(RADIUS, [[0, 0, 0]])
    assert sim.dt == pytest.approx(1e-6)
    sim.run(steps=2)


@pytest.mark.parametrize("kw, name", [
    (dict(dt="1e-6"), "dt"), (dict(dt=True), "dt"), (dict(threads=2.0), "threads"),
    (dict(dt_fraction="x"), "dt_fraction"), (dict(impact_speed=math.nan), "impact_speed"),
    (dict(skin=math.inf), "skin"),
])
def test_bad_scalars_at_construction(kw, name):
    with pytest.raises(ConfigError) as info:
        make(**kw)
    assert name in one_sentence(info)


# -------------------------------------------------------------- 6. particle vs Box --
def box_sim(**box):
    walls = WallSet([Box(lower=(0, 0, 0), upper=(0.01, 0.01, 0.01), name="cup", **box)])
    return Simulation([GLASS], Interaction(), walls=walls)


def test_particle_larger_than_closed_box_refused():
    sim = box_sim()
    with pytest.raises(ConfigError) as info:
        sim.add_particles(0.01, [[0.005, 0.005, 0.005]])
    msg = one_sentence(info)
    assert "0.02 m" in msg and "'cup'" in msg and "0.01 m" in msg, msg
    assert sim.n_particles == 0


def test_clump_larger_than_open_box_refused_and_small_one_accepted():
    sim = box_sim(open_top=True)
    with pytest.raises(ConfigError, match="'cup'"):
        sim.add_particles(Pair(0.004), [[0.005, 0.005, 0.005]])
    sim.add_particles(0.004, [[0.005, 0.005, 0.005]])
    # outside the box a large particle is no concern of the box
    sim.add_particles(0.01, [[0.05, 0.05, 0.05]])
    assert sim.n_particles == 2
