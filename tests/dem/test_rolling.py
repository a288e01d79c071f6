"""Rolling resistance on a flat floor and on a slope.

Closed forms:

* Type A (EDEM constant directional torque, tau = -mu_r Fn R w/|w|): a solid sphere
  rolling without slip on a horizontal plane loses kinetic energy
  (1/2)(m + I/R^2) v^2 = (7/10) m v^2 at the rate mu_r m g R w = mu_r m g v, hence
  a = -(5/7) mu_r g (energy balance as in Ai et al. 2011, Powder Technol. 206, 269,
  section 3.1, their Eq. 20 for model A with I = 2/5 m R^2).
* The same holds for the relative-velocity model (cdt) against a fixed floor (R* = R).
* Relative-velocity model (cdt, LIGGGHTS 3.8.0 ``rolling_friction cdt``; Ai et al. 2011
  model A with the relative angular velocity): between two spheres the torque is
  tau_i = -mu_r k_n delta R* w_t/|w_r| with w_r = w_i - w_j, w_t its part normal to the
  contact normal, k_n delta the elastic normal force and R* = R_i R_j/(R_i + R_j), and
  tau_j = -tau_i (test_rolling_torque.py checks each term on one contact). Two equal
  spheres stacked on a frictionless floor, counter-rotating about a horizontal axis
  (w_i = -w_j, pure rolling at their contact, so no tangential force and w_t = w_r) with
  k_n delta = Fn = m g at rest (the weight of the top one) and R* = R/2 each spin down at
  |dw/dt| = mu_r m g (R/2) / (2/5 m R^2) = (5/4) mu_r g / R. Type A uses each body's
  own lever (about R) instead, twice the torque.
* Type C (elastic-plastic spring-dashpot, Ai et al. 2011 model C) holds a sphere at rest
  on a slope while tan(theta) < mu_r (the limiting moment M_m = mu_r R Fn, their
  Eq. 12, balances m g sin(theta) R with Fn = m g cos(theta)); above it the sphere
  rolls away with the constant moment M_m, so rolling without slip (I = 2/5 m R^2)
  gives a = (5/7) g (sin(theta) - mu_r cos(theta)). The slope is bracketed at
  tan(theta) = 0.9 mu_r and 1.1 mu_r, so a limiting moment off by 10 % fails.
* Type A with a moment limiter (``type_a_limited``: EDEM's standard rolling friction
  capped as Simcenter STAR-CCM+'s Constant Torque method caps its moment, "Rolling
  Resistance", Moment Limiter Factor f = 0.08: at most f times the moment that negates
  the spin in the next time step, |tau| <= f I |w| / dt). Velocity Verlet evaluates the
  contact with the half-step spin and applies its torque over a whole step, so a spin
  below the cap's threshold mu_r Fn R dt / (f I) is multiplied by exactly (1 - f) per
  step: it decays to 0 without reversing, where type A's constant torque, larger than
  I |w| / dt, flips the spin's sign every step (chatter). A rolling sphere (v = w R)
  spins far above the threshold until the last few steps before it stops, so the
  rolling phase is type A's, a = -(5/7) mu_r g, bit for bit.
"""

import json
import math

import numpy as np
import pytest

from demcal.bench.registry import get_experiment, resolve_settings
from demcal.cli import main
from demcal.dem import Simulation
from demcal.dem.contact.registry import ROLLING
from demcal.dem.contact.rolling import MOMENT_LIMITER
from demcal.particles.materials import Interaction

from dem_helpers import RADIUS, SOFT, SOFT_WALL, Trace, floor, tilted_gravity

G = 9.81


def settled(backend, rolling_model, mu_r, gravity=(0, 0, -G), mu_s=0.8):
    sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, static_friction=mu_s,
                                                    rolling_friction=mu_r),
                     walls=floor(), gravity=gravity, rolling_model=rolling_model,
                     backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS]])
    sim.run(duration=0.05)
    return sim


@pytest.mark.parametrize("rolling_model", ["type_a", "cdt", "rvd"])
def test_rolling_deceleration(backend, rolling_model):
    mu_r = 0.1
    sim = settled(backend, rolling_model, mu_r)
    v0 = 0.5
    sim.state.velocities[0] = [v0, 0, 0]
    r_roll = RADIUS - (RADIUS - sim.state.positions[0, 2])  # centre height
    sim.state.angular_momenta[0] = [0, v0 / r_roll * sim.state.inertias[0, 0], 0]
    sim.state.omegas[0] = [0, v0 / r_roll, 0]
    ts, vs = [], []
    for _ in range(20):
        sim.run(duration=0.01)
        ts.append(sim.time)
        vs.append(sim.state.velocities[0, 0])
    a = np.polyfit(ts, vs, 1)[0]
    assert a == pytest.approx(-5.0 / 7.0 * mu_r * G, rel=0.02)


@pytest.mark.parametrize("rolling_model", ["cdt", "type_a", "type_a_limited"])
def test_rolling_torque_between_counter_rotating_spheres(backend, rolling_model):
    """Sphere on sphere, where cdt (R*, w_i - w_j) and type_a (own lever, own w) differ:
    the closed-form torque on both bodies and the spin decay of both (see the module
    docstring; Ai et al. 2011, Powder Technol. 206, 269, model A, Eq. 4-5). The spins
    stay above type_a_limited's threshold (0.3 rad/s here), so it is type A's."""
    mu_r = 0.1
    w0 = 20.0
    # rolling resistance only between the spheres; the floor is frictionless, so the
    # bottom sphere spins freely on it and the stack stays exactly vertical
    inter = {(0, 0): Interaction(restitution=0.3, static_friction=0.8, rolling_friction=mu_r),
             "default": Interaction(restitution=0.3, static_friction=0.0,
                                    rolling_friction=0.0)}
    sim = Simulation([SOFT, SOFT_WALL], inter, walls=floor(), gravity=(0, 0, -G),
                     rolling_model=rolling_model, backend=backend)
    sim.add_particles(RADIUS, [[0, 0, RADIUS], [0, 0, 3 * RADIUS]])
    sim.run(duration=0.05)
    st = sim.state
    sign = np.array([-1.0, 1.0])          # bottom spins -w0, top +w0 about y
    for k in range(2):
        st.omegas[k] = [0, sign[k] * w0, 0]
        st.angular_momenta[k] = [0, sign[k] * w0 * st.inertias[k, 0], 0]
    delta = 2 * RADIUS - (st.positions[1, 2] - st.positions[0, 2])
    lever = {"cdt": RADIUS / 2, "type_a": RADIUS - delta / 2,
             "type_a_limited": RADIUS - delta / 2}[rolling_model]
    m = st.masses[1]
    torque = mu_r * m * G * lever                       # Fn = m g
    decel = torque / st.inertias[1, 0]
    ts, ws = [], []
    for _ in range(12):
        sim.run(duration=0.0025)
        st = sim.state
        ts.append(sim.time)
        ws.append(st.omegas[:, 1].copy())
        # torque opposes each body's spin: -sign * torque on both
        assert st.torques[:, 1] == pytest.approx(-sign * torque, rel=1e-3)
    ws = np.array(ws)
    assert np.all(ws * sign > 0), "spins must not reach zero in the window"
    slopes = np.polyfit(ts, ws, 1)[0]
    assert slopes == pytest.approx(-sign * decel, rel=1e-3)
    if rolling_model == "cdt":
        assert decel == pytest.approx(1.25 * mu_r * G / RADIUS, rel=1e-9)
    # the stack neither slides nor tips
    assert np.abs(st.positions[:, :2]).max() < 1e-9


def test_type_c_rests_below_rolling_limit(backend):
    mu_r = 0.2
    theta = math.atan(0.9 * mu_r)
    sim = settled(backend, "type_c", mu_r, gravity=tilted_gravity(theta))
    sim.state.velocities[0] = [0.01, 0, 0]     # a downhill nudge
    sim.run(duration=0.3)
    assert abs(sim.state.velocities[0, 0]) < 1e-4
    assert abs(sim.state.omegas[0, 1]) * RADIUS < 1e-4


def test_type_c_rolls_above_rolling_limit(backend):
    """Above the limit the full moment mu_r R Fn resists: a = (5/7) g (sin - mu_r cos)."""
    mu_r = 0.2
    theta = math.atan(1.1 * mu_r)
    sim = settled(backend, "type_c", mu_r, gravity=tilted_gravity(theta))
    ts, vs = [], []
    for _ in range(30):
        sim.run(duration=0.01)
        ts.append(sim.time)
        vs.append(sim.state.velocities[0, 0])
    a = np.polyfit(ts[10:], vs[10:], 1)[0]
    assert vs[-1] > 0.03
    assert a == pytest.approx(5.0 / 7.0 * G * (math.sin(theta) - mu_r * math.cos(theta)),
                              rel=0.03)


# ------------------------------------------------- type A with the moment limiter --

def spin_trace(backend, rolling_model, w0, steps):
    """A sphere at rest on a frictionless floor (the rolling torque is then the only
    torque on it) set spinning at w0 about y; per step: its spin (the full-step value
    the state holds), the spin the next force evaluation sees (the half-step value
    w + T dt / 2I) and the torque about y."""
    sim = settled(backend, rolling_model, 0.1, mu_s=0.0)
    st = sim.state
    i0 = st.inertias[0, 0]
    st.omegas[0] = [0, w0, 0]
    st.angular_momenta[0] = [0, w0 * i0, 0]
    dt = sim.dt
    trace = Trace(lambda s: (s.state.omegas[0, 1],
                             s.state.omegas[0, 1] + s.state.torques[0, 1] * dt / (2 * i0),
                             s.state.torques[0, 1]))
    sim.run(steps=steps, reporters=[trace])
    return np.array(trace.rows).T, sim


def test_type_a_limited_stops_a_slow_spin_where_type_a_chatters(backend):
    """Module docstring: below mu_r Fn R dt / (f I) (0.33 rad/s here) type A's torque,
    larger than I |w| / dt, reverses the spin every step (EDEM standard rolling
    friction); STAR-CCM+'s moment limiter makes it -f I w / dt, and the spin decays by
    exactly (1 - f) per step, never changing sign."""
    w0 = 1e-3
    (w, w_half, torque), sim = spin_trace(backend, "type_a", w0, 200)
    i0 = sim.state.inertias[0, 0]
    # type A: the spin the contact sees and the torque flip sign every step
    assert np.all(np.sign(w_half[1:]) == -np.sign(w_half[:-1]))
    assert np.all(np.sign(torque[1:]) == -np.sign(torque[:-1]))
    assert np.abs(w_half).max() > 10 * w0                 # and the chatter is no small one
    (w, w_half, torque), sim = spin_trace(backend, "type_a_limited", w0, 200)
    assert np.all(w > 0) and np.all(w_half > 0) and np.all(torque < 0)
    assert np.all(np.diff(w) < 0) and np.all(np.diff(w_half) < 0)
    # the limiter binds all along: T = -f I w_half(previous step) / dt, the spin shrinks
    # by (1 - f) per step (by 1 - f/2 in the first, whose first half kick had no torque)
    assert w[0] == pytest.approx(w0 * (1 - MOMENT_LIMITER / 2), rel=1e-12)
    assert w[1:] / w[:-1] == pytest.approx(1 - MOMENT_LIMITER, rel=1e-9)
    assert torque[1:] == pytest.approx(-MOMENT_LIMITER * i0 / sim.dt * w_half[:-1], rel=1e-9)
    assert w[-1] < 1e-6 * w0


def test_type_a_limited_rolls_as_type_a_and_comes_to_rest(backend):
    """A sphere set rolling (v = w R) on the floor: a = -(5/7) mu_r g under type A (Ai et
    al. 2011, model A, energy balance; module docstring) and under type_a_limited the
    same to the bit, since its spin stays above the limiter's threshold (0.33 rad/s,
    v = 1.6 mm/s) until the last steps; then type_a_limited comes to rest, where type A
    is left creeping (its chatter; measured 2.2e-5 m/s)."""
    mu_r = 0.1
    v0 = 0.1
    t_stop = v0 / (5.0 / 7.0 * mu_r * G)          # 0.143 s
    runs = {}
    for model in ("type_a", "type_a_limited"):
        sim = settled(backend, model, mu_r)
        st = sim.state
        h = st.positions[0, 2]
        st.velocities[0] = [v0, 0, 0]
        st.angular_momenta[0] = [0, v0 / h * st.inertias[0, 0], 0]
        st.omegas[0] = [0, v0 / h, 0]
        t_start = sim.time
        ts, vs, ws = [], [], []
        for _ in range(20):
            sim.run(duration=0.01)
            ts.append(sim.time - t_start)
            vs.append(sim.state.velocities[0, 0])
            ws.append(sim.state.omegas[0, 1])
        runs[model] = np.array(ts), np.array(vs), np.array(ws)
    ts, va, _ = runs["type_a"]
    _, vl, wl = runs["type_a_limited"]
    rolling = ts < t_stop - 0.005
    assert rolling.sum() >= 13
    assert vl[rolling] == pytest.approx(va[rolling], rel=1e-12, abs=1e-15)
    a = np.polyfit(ts[rolling], vl[rolling], 1)[0]
    assert a == pytest.approx(-5.0 / 7.0 * mu_r * G, rel=0.01)
    # at rest 0.05 s after the stop (type A is not: the test means something)
    assert abs(vl[-1]) < 1e-9 and abs(wl[-1]) * RADIUS < 1e-9
    assert abs(va[-1]) > 1e-6


def test_type_a_limited_names():
    """The sub-model's name and alias reach the engine and the bench settings."""
    assert ROLLING["type_a_limited"] == ROLLING["constant_limited"] == 4
    for name in ("type_a_limited", "constant_limited"):
        sim = Simulation([SOFT, SOFT_WALL], Interaction(restitution=0.3, rolling_friction=0.1),
                         rolling_model=name)
        assert sim.contact_model.rolling == name            # kept as given, like "constant"
        assert sim.description.models[3] == ROLLING["type_a_limited"]
    funnel = get_experiment("repose-funnel")
    s = resolve_settings(funnel, {"rolling.model": "type_a_limited"}, "tiny")
    assert s["rolling.model"] == "type_a_limited"


def test_type_a_limited_bench_setting_runs(capsys):
    """``demcal bench repose-funnel --profile tiny --set rolling.model=type_a_limited``
    (150 particles, about 3 s) gives a heap."""
    assert main(["bench", "repose-funnel", "--profile", "tiny", "--json",
                 "--set", "rolling.model=type_a_limited"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert 5.0 < data["responses"]["repose_angle_deg"] < 60.0
