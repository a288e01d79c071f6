"""JKR cohesion against its closed forms.

Johnson, Kendall & Roberts 1971 (Proc. R. Soc. Lond. A 324, 301-313) and Johnson 1985
(Contact Mechanics, section 5.5), written with gamma the surface energy as EDEM names it
(the work of adhesion per unit area; EDEM's pull-off force is 1.5 pi gamma R*):

* overlap and force as functions of the contact radius a:
  ``delta = a^2/R* - sqrt(2 pi gamma a / E*)``,
  ``F = 4 E* a^3 / (3 R*) - sqrt(8 pi gamma E* a^3)``;
* pull-off force (the least force on the stable branch, reached under force control):
  ``F_c = -3/2 pi gamma R*``;
* at zero overlap ``F = -4/3 pi gamma R*`` (= 8/9 F_c), the jump-in on approach;
* separation under displacement control where d delta / d a = 0:
  ``a_s = (pi gamma R*^2 / (8 E*))^(1/3)``, ``delta_s = -3 a_s^2 / R*``,
  ``F_s = -5/6 pi gamma R*`` (= 5/9 F_c).

Friction against a JKR contact is capped at ``mu_s (F + 2 |F_c|)`` (Thornton & Yin 1991,
Powder Technol. 65, 153-166; LAMMPS ``pair granular`` jkr).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from demcal.dem import GravityRamp, Simulation
from demcal.dem.contact.kernel import HIST_WIDTH, contact
from demcal.dem.contact.registry import DAMPING, NORMAL, ROLLING, TANGENTIAL, ContactModel
from demcal.dem.contact.table import pair_table
from demcal.errors import ConfigError
from demcal.geometry import Plane, WallSet
from demcal.geometry.motion import Translation
from demcal.particles.materials import Interaction, MaterialTable
from demcal.particles.templates import sphere

from dem_helpers import SOFT, Trace, sphere_mass

R = 0.005                 # sphere radius [m]
GAMMA = 1.0               # surface energy [J/m2]
ESTAR = SOFT.youngs_modulus / (2.0 * (1.0 - SOFT.poisson_ratio ** 2))   # like spheres
RS = R / 2.0              # R* of two like spheres


def delta_of(a, r=RS, gamma=GAMMA):
    return a * a / r - math.sqrt(2.0 * math.pi * gamma * a / ESTAR)


def force_of(a, r=RS, gamma=GAMMA):
    return 4.0 * ESTAR * a ** 3 / (3.0 * r) - math.sqrt(8.0 * math.pi * gamma * ESTAR * a ** 3)


def a_s(r=RS, gamma=GAMMA):
    return (math.pi * gamma * r * r / (8.0 * ESTAR)) ** (1.0 / 3.0)


def kernel_force(delta, gamma=GAMMA, mu_s=0.0, slip=None, r=RS):
    it = Interaction(restitution=0.5, static_friction=mu_s, rolling_friction=0.0,
                     surface_energy=gamma)
    hist = np.zeros((1, HIST_WIDTH))
    if slip is not None:
        hist[0, 0:3] = slip
    out = contact(NORMAL["jkr"], DAMPING["tsuji"], TANGENTIAL["mindlin"], ROLLING["none"],
                  pair_table(MaterialTable([SOFT], it)), 0, 0, hist, 0, delta,
                  0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                  r, r, r, 1e-3, 0.0, 0.0, 0.0, 1e-7)
    return np.array(out[:3])


def test_force_follows_the_jkr_curve_on_the_stable_branch():
    for a in np.geomspace(a_s() * 1.0001, 50 * a_s(), 40):
        f = kernel_force(delta_of(a))
        assert f[2] == pytest.approx(force_of(a), rel=1e-9, abs=1e-12 * math.pi * GAMMA * RS)
        assert f[0] == 0.0 and f[1] == 0.0


def test_pull_off_force_jump_in_and_separation_force():
    fc = 1.5 * math.pi * GAMMA * RS
    # the least force over the stable branch, found by a library minimiser of the
    # kernel's own curve (through its overlap), is the pull-off force
    deltas = np.linspace(-0.9999 * 3 * a_s() ** 2 / RS, 3 * a_s() ** 2 / RS, 4001)
    forces = np.array([kernel_force(d)[2] for d in deltas])
    assert forces.min() == pytest.approx(-fc, rel=1e-5)
    assert kernel_force(0.0)[2] == pytest.approx(-8.0 / 9.0 * fc, rel=1e-9)
    d_s = -3.0 * a_s() ** 2 / RS
    assert delta_of(a_s()) == pytest.approx(d_s, rel=1e-12)
    assert kernel_force(d_s * (1 - 1e-9))[2] == pytest.approx(-5.0 / 9.0 * fc, rel=1e-3)


def test_reach_is_the_separation_distance():
    from demcal.dem.contact.normal import reach
    tab = pair_table(MaterialTable([SOFT], Interaction(surface_energy=GAMMA)))
    assert reach(NORMAL["jkr"], tab, 0, 0, RS) == pytest.approx(3 * a_s() ** 2 / RS, rel=1e-12)
    # brentq on d delta / d a = 0 finds the same end of the stable branch
    a_end = brentq(lambda a: 2 * a / RS - 0.5 * math.sqrt(2 * math.pi * GAMMA / (ESTAR * a)),
                   1e-9, 1e-2, xtol=1e-16)
    assert a_end == pytest.approx(a_s(), rel=1e-9)
    assert reach(NORMAL["hertz"], tab, 0, 0, RS) == 0.0


def test_zero_surface_energy_is_hertz_exactly():
    for delta in (1e-6, 1e-5, 1e-4):
        hertz = 4.0 / 3.0 * ESTAR * math.sqrt(RS) * delta ** 1.5
        assert kernel_force(delta, gamma=0.0)[2] == pytest.approx(hertz, rel=1e-12)


def test_friction_is_capped_from_the_pull_off_state():
    fc = 1.5 * math.pi * GAMMA * RS
    a = 2.0 * a_s()
    d = delta_of(a)
    f = kernel_force(d, mu_s=0.3, slip=(1.0, 0.0, 0.0))    # a slip far past the cap
    assert abs(f[0]) == pytest.approx(0.3 * (force_of(a) + 2.0 * fc), rel=1e-9)
    assert force_of(a) < 0.0      # in tension, and still friction


def _pair(gap, touched, gamma=GAMMA):
    """Two like spheres (one fixed) whose surfaces are ``gap`` apart, at rest, no
    gravity; ``touched``: they were pressed together one step before. Restitution 1: no
    dashpot, so the force is JKR's alone."""
    sim = Simulation([SOFT], Interaction(restitution=1.0, static_friction=0.3,
                                         rolling_friction=0.0, surface_energy=gamma),
                     contact_model="hertz_mindlin_jkr", gravity=(0, 0, 0))
    z = 2 * R - 1e-6 if touched else 2 * R + gap
    sim.add_particles(sphere(R), [[0, 0, 0], [0, 0, z]], fixed=[True, False])
    if touched:
        sim.run(steps=1)
        st = sim.state
        st.positions[1, 2] = 2 * R + gap
        st.velocities[1] = 0.0
    return sim


def test_approach_and_separation_differ_hysteresis():
    gap = 0.5 * 3 * a_s() ** 2 / RS        # half the separation distance
    approaching = _pair(gap, touched=False)
    approaching.run(steps=20)
    assert np.all(approaching.state.velocities[1] == 0.0)    # no force before touching
    separating = _pair(gap, touched=True)
    separating.run(steps=1)
    i, j, f = separating.contacts()
    # the gap the force was taken at (the step drifted the sphere on its last
    # acceleration, so not exactly the gap it was put at)
    now = separating.state.positions[1, 2] - 2 * R
    assert 0.0 < now < 3 * a_s() ** 2 / RS
    a = brentq(lambda x: delta_of(x) + now, a_s(), 10 * a_s(), xtol=1e-18)
    # held, and pulling: n points from j (sphere 1, above) to i (sphere 0), so the
    # attractive force on i points up
    assert (i[0], j[0]) == (0, 1)
    assert f[0][2] == pytest.approx(-force_of(a), rel=1e-6)
    separating.run(steps=1)
    assert separating.state.velocities[1, 2] < 0.0


def test_a_pulled_contact_opens_at_the_separation_distance():
    # displacement control: a fixed sphere on a floor that moves away at a constant
    # slow speed; the floor feels the pull until the gap reaches delta_s (R* = R)
    v = 1e-4                                         # [m/s]
    it = Interaction(restitution=0.5, static_friction=0.3, rolling_friction=0.0,
                     surface_energy=GAMMA)
    floor = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), name="floor",
                           motion=Translation(velocity=(0.0, 0.0, -v)))])
    sim = Simulation([SOFT], it, walls=floor, contact_model="hertz_mindlin_jkr",
                     gravity=(0, 0, 0))
    sim.add_particles(sphere(R), [[0, 0, R - 1e-7]], fixed=True)
    d_s = 3 * a_s(r=R) ** 2 / R
    pull = Trace(lambda s: (R - s.state.positions[0, 2] + 0 * s.time,
                            s.wall_forces()["floor"][0][2], s.time))
    sim.run(duration=2 * d_s / v, reporters=[pull])
    rows = np.array(pull.rows)
    gap = v * rows[:, 2] - (1e-7 + 0 * rows[:, 0])     # the floor's distance below touching
    held = rows[:, 1] != 0.0
    assert held[0] and not held[-1] and np.all(np.diff(held.astype(int)) <= 0)
    assert gap[held].max() == pytest.approx(d_s, abs=2 * v * sim.dt)
    # the pull on the floor (up) just before it let go: the JKR force at that gap (the
    # dashpot adds about 0.5 %), close to -5/6 pi gamma R at delta_s itself
    last = gap[held].max()
    a = brentq(lambda x: delta_of(x, r=R) + last, a_s(r=R), 10 * a_s(r=R), xtol=1e-18)
    assert rows[held][-1, 1] == pytest.approx(-force_of(a, r=R), rel=1e-2)
    assert rows[held][-1, 1] == pytest.approx(5.0 / 6.0 * math.pi * GAMMA * R, rel=5e-2)


def test_a_hanging_sphere_falls_when_its_weight_passes_the_pull_off_force():
    fc = 1.5 * math.pi * GAMMA * RS
    m = sphere_mass(R, SOFT.density)
    sim = Simulation([SOFT], Interaction(restitution=0.3, static_friction=0.3,
                                         rolling_friction=0.0, surface_energy=GAMMA),
                     contact_model="hertz_mindlin_jkr", gravity=(0, 0, 0))
    sim.add_particles(sphere(R), [[0, 0, 0], [0, 0, -(2 * R - 1e-6)]], fixed=[True, False])
    sim.run(duration=0.05)                       # settle at the zero-load contact
    rate = 20.0                                  # [m/s3]
    sim.gravity_schedule = GravityRamp((0, 0, 0), (0, 0, -rate), start=sim.time,
                                       tolerance=1e-4)
    t0 = sim.time
    held = Trace(lambda s: (s.time, len(s.contacts()[0])), interval=10)
    sim.run(duration=1.5 * fc / m / rate, reporters=[held])
    t_off = next(t for t, n in held.rows if n == 0)
    # the weight when the contact let go, against F_c: quasi-static ramp, 10-step reads
    assert m * rate * (t_off - t0) == pytest.approx(fc, rel=0.03)


def test_negative_surface_energy_and_a_misfit_are_one_sentence():
    with pytest.raises(ConfigError, match=r"^surface_energy must be in \[0, inf\) J/m2, got -1\.$"):
        Simulation([SOFT], Interaction(surface_energy=-1.0), contact_model="hertz_mindlin_jkr")
    with pytest.raises(ConfigError, match=r"the jkr normal model does not fit with the "
                                          r"hysteretic damping model"):
        Simulation([SOFT], Interaction(), contact_model=ContactModel("jkr", "hysteretic", "mindlin"))


def test_skin_covers_the_reach_and_a_smaller_one_is_refused():
    it = Interaction(surface_energy=50.0)
    sim = Simulation([SOFT], it, contact_model="hertz_mindlin_jkr")
    sim.add_particles(sphere(R), [[0, 0, 0]])
    tab = pair_table(MaterialTable([SOFT], it))
    from demcal.dem.contact.normal import reach
    far = reach(NORMAL["jkr"], tab, 0, 0, R)      # the wall case, R* = R: the largest
    assert sim.skin >= 2 * far and sim.skin >= 0.5 * R
    tight = Simulation([SOFT], it, contact_model="hertz_mindlin_jkr", skin=far / 2)
    tight.add_particles(sphere(R), [[0, 0, 0]])
    with pytest.raises(ConfigError, match="skin"):
        tight.run(steps=1)


def test_surface_energy_is_a_bench_setting():
    from demcal.bench.registry import get_experiment
    keys = get_experiment("repose-funnel").settings("quick")
    assert "particle.surface_energy" in keys and "wall.surface_energy" in keys
    assert "hertz_mindlin_jkr" in keys["contact.model"].choices


def test_the_critical_force_offset_is_jkr_s_alone():
    # chosen-only pair constant: 3 pi gamma in a JKR pair table, 0 in any other, so the
    # kernel adds it without a branch on the sub-model
    from demcal.dem.contact.normal import P_PULL
    it = Interaction(surface_energy=GAMMA)
    jkr = pair_table(MaterialTable([SOFT], it), ContactModel.preset("hertz_mindlin_jkr"))
    hertz = pair_table(MaterialTable([SOFT], it), ContactModel.preset("hertz_mindlin"))
    assert jkr[0, 0, P_PULL] == pytest.approx(3 * math.pi * GAMMA, rel=1e-15)
    assert hertz[0, 0, P_PULL] == 0.0
    sim = Simulation([SOFT], it, contact_model="hertz_mindlin")
    assert sim.description.table[0, 0, P_PULL] == 0.0
