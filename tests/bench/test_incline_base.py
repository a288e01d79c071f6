"""The incline's base kinematics: how the bed moves at the detection of sliding."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from demcal.bench.incline import base_kinematics


def _state(v, omega_y, z_top=None):
    """Spheres of radius 5 mm on the film (z = 5 mm), one per body, plus one body on top."""
    r = 0.005
    pos = np.array([[0.0, 0.0, r], [0.02, 0.0, r]] + ([[0.01, 0.0, z_top]] if z_top else []))
    n = len(pos)
    vel = np.zeros((n, 3))
    vel[:2, 0] = v
    if z_top:
        vel[2, 0] = 2 * v
    om = np.zeros((n, 3))
    om[:2, 1] = omega_y
    return SimpleNamespace(positions=pos, velocities=vel, omegas=om, masses=np.ones(n),
                           sphere_positions=pos.copy(), radii=np.full(n, r), sphere_body=np.arange(n))


def test_sliding_without_rotation_is_all_slip():
    out = base_kinematics(_state(0.01, 0.0))
    assert out["base_slip_ratio"] == pytest.approx(1.0)
    assert out["base_velocity_ratio"] == pytest.approx(1.0) and out["base_mass_fraction"] == 1.0


def test_rolling_without_slip_is_no_slip():
    # v = omega_y R rolls along +x without slipping (contact point at rest): v + omega_y (-R) = 0
    out = base_kinematics(_state(0.01, 0.01 / 0.005))
    assert out["base_slip_ratio"] == pytest.approx(0.0, abs=1e-12)


def test_a_bed_that_shears_above_its_base():
    # the top body moves twice as fast as the two basal ones: the base carries 2/3 of the mass
    out = base_kinematics(_state(0.01, 0.0, z_top=0.02))
    assert out["base_mass_fraction"] == pytest.approx(2 / 3)
    assert out["base_velocity_ratio"] == pytest.approx(0.01 / (0.04 / 3))


def test_rigid_container_holds_within_its_rim_friction_and_yields_beyond():
    import math

    from demcal.bench.incline import RigidContainer

    w = 10.0  # the material's weight [N]
    rim = RigidContainer(weight_c=5.0, mu=0.4, v_ref=0.2, weight=w)
    th = math.radians(20.0)
    hold = 0.4 * 5.0 * math.cos(th)  # 1.879 N of static rim friction
    own = 5.0 * math.sin(th)  # 1.710 N of its own weight along the slope
    assert rim.velocity(0.0, th) == 0.0  # its own weight alone is held
    assert rim.velocity(hold - own - 1e-6, th) == 0.0
    assert rim.velocity(hold - own + 1.0, th) == pytest.approx(0.2 * 1.0 / w)  # pushed 1 N past the limit
    assert rim.velocity(-(hold + own) - 2.0, th) == pytest.approx(-0.2 * 2.0 / w)  # pulled uphill
    massless = RigidContainer(0.0, 0.0, 0.2, w)
    assert massless.velocity(0.5, th) == pytest.approx(0.01)  # any push moves it
    assert massless.velocity(1e6, th) == 0.5  # capped


def test_the_load_a_rough_wall_carries_adds_to_the_rim_friction():
    import math

    from demcal.bench.incline import RigidContainer

    w = 10.0
    th = math.radians(25.0)
    massless = RigidContainer(weight_c=0.0, mu=0.5, v_ref=0.2, weight=w)
    # the wall carries 3 N of the material's weight onto the rim: 1.5 N of rim friction
    assert massless.velocity(1.5 - 1e-6, th, load=3.0) == 0.0
    assert massless.velocity(2.5, th, load=3.0) == pytest.approx(0.2 * 1.0 / w)
    # a wall that pulls the container up unloads its rim, never below zero
    heavy = RigidContainer(weight_c=2.0, mu=0.5, v_ref=0.2, weight=w)
    own = 2.0 * math.sin(th)
    assert heavy.velocity(1.0, th, load=-5.0) == pytest.approx(0.2 * (1.0 + own) / w)
    hold = 0.5 * (2.0 * math.cos(th) + 1.0)
    assert heavy.velocity(hold - own - 1e-6, th, load=1.0) == 0.0


def test_a_free_container_sticks_then_accelerates_then_sticks_again():
    import math

    from demcal.bench.incline import FreeContainer
    from demcal.errors import ConfigError

    g = 9.81
    box = FreeContainer(weight_c=2.0 * g, mu=0.5)  # a 2 kg ring
    th = math.radians(20.0)
    hold = 0.5 * (2.0 * g * math.cos(th) + 4.0)  # rim friction with 4 N carried by the wall
    own = 2.0 * g * math.sin(th)
    assert box.velocity(hold - own - 1e-6, th, 4.0, 1e-3) == 0.0  # held
    # pushed 2 N past its rim friction: a = 2 N / 2 kg for 1 ms
    v1 = box.velocity(hold - own + 2.0, th, 4.0, 1e-3)
    assert v1 == pytest.approx(1e-3)
    # moving, kinetic friction acts against the velocity: net 2 N again, it keeps accelerating
    assert box.velocity(hold - own + 2.0, th, 4.0, 1e-3) == pytest.approx(2e-3)
    # no push: its weight's slope component is within the rim's hold, friction brakes it
    assert box.velocity(0.0, th, 4.0, 5e-4) == pytest.approx(2e-3 + (own - hold) * 5e-4 / 2.0)
    # held back by a pull that cancels its weight: friction stops it within the step, and at
    # the turn the rim holds it instead of letting it swing back
    assert box.velocity(-own, th, 4.0, 1e-2) == 0.0
    assert box.velocity(-own, th, 4.0, 1e-2) == 0.0
    with pytest.raises(ConfigError, match="container_mass above 0"):
        FreeContainer(0.0, 0.5)


def test_a_free_container_slides_uphill_against_its_rim_and_turns_when_it_cannot_hold():
    from demcal.bench.incline import FreeContainer

    g = 9.81
    box = FreeContainer(weight_c=1.0 * g, mu=0.4)  # 1 kg, flat plate: its weight does not drive it
    hold = 0.4 * g
    # pulled uphill 3 N past the hold: friction points downhill, a = -3 m/s2
    assert box.velocity(-(hold + 3.0), 0.0, 0.0, 1e-3) == pytest.approx(-3e-3)
    # moving uphill with no pull, friction decelerates it (0.4 g for 0.5 ms), then, in a
    # longer step that would turn it, the rim holds it where it stops
    assert box.velocity(0.0, 0.0, 0.0, 5e-4) == pytest.approx(-3e-3 + hold * 5e-4)
    assert box.velocity(0.0, 0.0, 0.0, 1e-2) == 0.0
    # moving uphill, then pushed downhill past the hold: it turns and breaks away downhill
    box.velocity(-(hold + 3.0), 0.0, 0.0, 1e-3)
    assert box.velocity(hold + 50.0, 0.0, 0.0, 1e-3) == pytest.approx(50.0 * 1e-3)


def test_the_rim_reporter_passes_the_wall_load_and_steps_a_free_body_symplectically():
    """_Rim: the load is minus the wall force's normal component (a force on the wall,
    as for the film), and a free body moves by its new velocity, a rigid one by its old."""
    import math
    from types import SimpleNamespace

    import numpy as np

    from demcal.bench.common import DrivenTranslation
    from demcal.bench.incline import FreeContainer, RigidContainer, _Rim

    g = 9.81
    seen = {}

    class Body(FreeContainer):
        def velocity(self, fx, theta, load, dt):
            seen.update(fx=fx, load=load, dt=dt)
            return super().velocity(fx, theta, load, dt)

    def sim_with(force):
        return SimpleNamespace(step_count=10, dt=1e-4,
                               wall_forces=lambda: {"container": (np.array(force), np.zeros(3))})

    for body, moves_with_new in ((Body(1.0 * g, 0.0), True), (RigidContainer(0.0, 0.0, 0.05, g), False)):
        motion = DrivenTranslation()
        motion.place((0.01, 0.0, 0.0), (0.002, 0.0, 0.0))
        tilt = SimpleNamespace(_origin=0, interval=50, theta=0.0, motion=motion)
        rim = _Rim(tilt, body, 5)
        rim.report(sim_with([3.0, 0.0, -2.5]))  # pushed 3 N downhill, pressed 2.5 N onto the film
        v_new = motion.velocity[0]
        step = (v_new if moves_with_new else 0.002) * 5 * 1e-4
        assert motion.offset[0] == pytest.approx(0.01 + step)
        if moves_with_new:
            assert seen == {"fx": 3.0, "load": 2.5, "dt": pytest.approx(5e-4)}
            assert v_new == pytest.approx(3.0 * 5e-4)  # from rest, 3 N on 1 kg for 0.5 ms
    assert math.isfinite(v_new)
