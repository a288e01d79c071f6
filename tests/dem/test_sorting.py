"""The engine's spatial sort (particles reordered in memory by cell, as LIGGGHTS'
``atom_modify sort``) is invisible to users: particles keep their indices, reading the
state never reorders the engine, what is written into it reaches the right particle,
contacts keep their history, and results do not depend on how a run is split,
on the thread count, or on a checkpoint restart."""

import numpy as np
import pytest

from demcal.dem.reporters import EnergyReporter
from demcal.particles.templates import two_sphere_paper

from dem_helpers import Trace
from test_pour import pour


def _sorting(sim, interval=40):
    """Sort this small system often (the defaults only sort large ones)."""
    sim.sort_threshold = 0
    sim.sort_interval = interval
    return sim


def test_particles_keep_their_index_and_reading_never_reorders(backend):
    width, read_every = 0.03, 10
    sim = _sorting(pour(backend, 300, width))
    st = sim.state
    first = st.positions.copy()
    scales = st.scales.copy()
    # while the particles mostly fall freely (11 contacts by 0.05 s) the sorted run stays
    # with an unsorted one to rounding (measured: 4e-13 m), particle by particle
    sim.run(duration=0.05)
    assert sim.sorts >= 10                       # the engine did reorder, many times
    assert not np.array_equal(sim.engine_order, np.arange(300))
    plain = pour(backend, 300, width)
    plain.run(duration=0.05)
    assert plain.sorts == 0
    assert np.abs(sim.state.positions - plain.state.positions).max() < 1e-9
    # the state read before the run is a record of its step, and read-only from then on
    assert st.step == 0 and np.array_equal(st.positions, first)
    with pytest.raises(ValueError):
        st.velocities[0] = 0.0
    # then they pile up and the two runs part (chaos; 8 mm by 0.25 s): each particle
    # must still move continuously between reads of the state. No particle is
    # faster than a fall from the top of the box, sqrt(2 g 4 width) = 1.5 m/s, i.e.
    # 0.25 mm between reads; two touching spheres are >= 3 mm apart, so a particle
    # read at another's place jumps far more than the bound (twice that move).
    sorts = sim.sorts
    trace = Trace(lambda s: s.state.positions.copy(), read_every)
    prev = sim.state.positions.copy()
    sim.run(duration=0.2, reporters=[trace])
    assert sim.sorts >= sorts + 10 and len(trace.rows) > 1000
    now = sim.state
    assert now is sim.state                      # one object until the next step
    track = np.array([prev] + trace.rows + [now.positions])
    step = np.linalg.norm(np.diff(track, axis=0), axis=2).max()
    assert step < 2.0 * np.sqrt(2 * 9.81 * 4 * width) * read_every * sim.dt
    assert np.array_equal(now.scales, scales)    # particle k is still particle k
    i, j, _ = sim.contacts()
    gap = (np.linalg.norm(now.sphere_positions[i] - now.sphere_positions[j], axis=1)
           - now.radii[i] - now.radii[j])
    assert len(i) > 300 and np.all(gap < 0)      # user indices of touching spheres


def test_reading_the_state_costs_no_reordering(backend, monkeypatch):
    # Issue 18: 20 x (run(50) + state) used to put the arrays in user order and back
    # each time (41 permutations on 5,202 spheres). Reading now gathers copies: the
    # only reorderings are the engine's own sorts. (A roundtrip leaves no trace in the
    # public API, so this counts the storage's permutations.)
    from demcal.dem.storage import Store

    sim = _sorting(pour(backend, 300, 0.03), interval=200)
    sim.run(steps=100)
    calls = []
    permute = Store.permute
    monkeypatch.setattr(Store, "permute", lambda self, order: calls.append(1) or permute(self, order))
    sorts = sim.sorts
    for _ in range(20):
        sim.run(steps=50)
        sim.state.positions.sum()
    assert sim.sorts > sorts and len(calls) == sim.sorts - sorts


def test_what_is_written_into_the_state_moves_that_particle(backend):
    # in a sorted system, a velocity written at user index k moves particle k
    sim = _sorting(pour(backend, 300, 0.03))
    sim.run(duration=0.05)
    assert not np.array_equal(sim.engine_order, np.arange(300))
    k = int(np.argmax(sim.state.positions[:, 2]))   # the highest one: free in the air
    before = sim.state.positions[k].copy()
    sim.state.velocities[k] = (0.5, 0.0, 0.0)
    sim.state.omegas[k] = 0.0
    assert sim.state.velocities[k, 0] == 0.5         # the same object until the run
    sim.run(steps=1)
    assert sim.state.positions[k, 0] - before[0] == pytest.approx(0.5 * sim.dt, rel=1e-6)
    with pytest.raises(ValueError):
        sim.state.masses[k] = 1.0                    # set by add_particles only


def test_results_do_not_depend_on_how_a_run_is_split(backend):
    a = _sorting(pour(backend, 200, 0.03))
    a.run(steps=6000)
    assert a.sorts >= 3
    b = _sorting(pour(backend, 200, 0.03))
    energy = EnergyReporter(137)   # reporters read the state in between
    for _ in range(6):
        b.run(steps=1000, reporters=[energy])
        b.state.positions.sum()
    assert np.array_equal(a.state.positions, b.state.positions)
    assert np.array_equal(a.state.angular_momenta, b.state.angular_momenta)


def test_sorted_results_do_not_depend_on_threads(backend):
    runs = []
    for threads in (1, 2, 3):
        sim = _sorting(pour(backend, 200, 0.03, threads=threads, fill=1.0))
        sim.parallel_threshold = 0
        sim.gravity[:] = (0.0, 0.0, -80.0)   # a heap within 4,000 steps
        sim.run(steps=4000)
        assert sim.sorts >= 3
        assert len(sim.contacts()[0]) > 250
        runs.append([sim.state.positions.copy(), sim.state.angular_momenta.copy()])
    for other in runs[1:]:
        for a, b in zip(runs[0], other):
            assert np.array_equal(a, b)


def test_sorted_checkpoint_restart_is_bit_identical(backend, tmp_path):
    tpl = two_sphere_paper(resolution=64).scaled(0.3)
    a = _sorting(pour(backend, 200, 0.03, template=tpl), interval=25)
    a.run(steps=3000)
    a.save_checkpoint(tmp_path / "chk.npz")
    a.run(steps=3000)
    assert a.sorts >= 3
    b = _sorting(pour(backend, 200, 0.03, template=tpl), interval=25)
    b.load_checkpoint(tmp_path / "chk.npz")
    b.run(steps=3000)
    for name in ("positions", "velocities", "quaternions", "angular_momenta"):
        assert np.array_equal(getattr(a.state, name), getattr(b.state, name)), name


@pytest.mark.parametrize("rolling", ["cdt", "type_c"])
def test_contact_history_survives_reordering(backend, rolling, tmp_path):
    # A settled bed held by static friction (and type C rolling springs): if a sort lost
    # the tangential displacement or the rolling spring, or kept it with the wrong sign
    # after swapping the two sides of a contact, the bed would jump. Sorted and unsorted
    # runs from the same settled state, with the same forced rebuilds, stay together to
    # rounding (measured: 1e-17 m; 3e-6 m with the sign flip left out).
    base = pour(backend, 250, 0.025, rolling=rolling)
    base.run(duration=0.5)
    base.save_checkpoint(tmp_path / "bed.npz")
    ends = []
    for sort in (False, True):
        sim = pour(backend, 250, 0.025, rolling=rolling)
        sim.load_checkpoint(tmp_path / "bed.npz")
        if sort:
            _sorting(sim, interval=1)
        for _ in range(10):
            sim.rebuild_neighbours()
            sim.run(steps=50)
        if sort:
            assert sim.sorts >= 1
        ends.append(sim.state.positions.copy())
    assert np.abs(ends[0] - ends[1]).max() < 1e-12   # a wrong sign: ~3e-6 m


def test_a_refused_add_keeps_the_state_and_names_user_indices(backend):
    from demcal.errors import ConfigError

    sim = _sorting(pour(backend, 300, 0.03))
    sim.run(duration=0.05)
    assert not np.array_equal(sim.engine_order, np.arange(300))
    st = sim.state
    st.velocities[3] = (0.1, 0.0, 0.0)   # a write still pending
    k = 7
    with pytest.raises(ConfigError, match=f"particles {k} and 300 overlap"):
        sim.add_particles(radii=float(st.radii[k]), positions=[st.positions[k]])
    assert sim.state is st and st.velocities.flags.writeable   # nothing changed: the same state
    sim.run(steps=1)
    assert sim.state.velocities[3, 0] == pytest.approx(0.1, abs=0.01)   # the write was taken


@pytest.mark.parametrize("change", ["remove", "add"])
def test_contacts_right_after_a_change_of_the_particles_name_user_indices(backend, change):
    # the lists are rebuilt at the next step; until then contacts() renumbers them
    sim = _sorting(pour(backend, 300, 0.03))
    sim.run(duration=0.25)
    assert not np.array_equal(sim.engine_order, np.arange(300))
    before = len(sim.contacts()[0])
    if change == "remove":
        sim.remove_particles([0, 5, 17])
    else:
        top = sim.state.positions[:, 2].max() + 0.02
        sim.add_particles(radii=0.002, positions=[[0.0, 0.0, top]])
    st = sim.state
    i, j, _ = sim.contacts()
    gap = (np.linalg.norm(st.sphere_positions[i] - st.sphere_positions[j], axis=1)
           - st.radii[i] - st.radii[j])
    assert len(i) > 0.9 * before and np.all(gap < 0)   # the same touching pairs, user indices
    sim.run(steps=1)
    assert abs(len(sim.contacts()[0]) - len(i)) <= 0.1 * len(i)
