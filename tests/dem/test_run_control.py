"""One run control: reporters that share a snapshot and can end a run (issue 18, item 5)."""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.dem.reporters import BlowUpDetector, RestDetector, Reporter, StopRun, TimeLimit
from demcal.errors import SimulationError
from demcal.particles.materials import Interaction

from dem_helpers import GLASS, RADIUS, WALL, floor


def _drop(n=3, height=0.05):
    sim = Simulation([GLASS, WALL], Interaction(restitution=0.3, static_friction=0.5, rolling_friction=0.1),
                     walls=floor())
    sim.add_particles(RADIUS, [[3 * RADIUS * i, 0.0, height] for i in range(n)])
    return sim


class _Count(Reporter):
    """Counts reports and the snapshots it saw."""

    def __init__(self, interval):
        super().__init__(interval)
        self.snaps = []

    def report(self, sim):
        self.snaps.append(sim.snapshot())


def test_a_reporter_ends_the_run_with_stoprun_and_the_summary_says_why():
    class StopAt(Reporter):
        def report(self, sim):
            if sim.step_count >= 30:
                raise StopRun("enough")

    sim = _drop()
    summary = sim.run(steps=1000, reporters=[StopAt(10)])
    assert summary.stopped == "enough" and summary.steps == 30 and sim.step_count == 30
    assert sim.run(steps=5).stopped is None  # a run that ran its length


def test_reporters_due_at_one_step_share_one_snapshot_computed_once():
    sim = _drop()
    a, b = _Count(5), _Count(10)
    sim.run(steps=20, reporters=[a, b])
    assert [s.step for s in a.snaps] == [5, 10, 15, 20] and [s.step for s in b.snaps] == [10, 20]
    assert a.snaps[1] is b.snaps[0] and a.snaps[3] is b.snaps[1]  # the same object
    snap = sim.snapshot()
    st = snap.state
    assert snap.kinetic_energy == sim.kinetic_energy() > 0
    m = float(st.masses.sum())
    assert snap.rms_speed == pytest.approx(math.sqrt(2 * snap.kinetic_energy / m))
    assert snap.finite
    sim.add_particles(RADIUS, [[0.0, 0.05, 0.05]])  # new particles: a new snapshot
    assert sim.snapshot() is not snap and sim.snapshot().state.n == 4


def test_the_rest_detector_ends_a_settling_run_at_two_checks_below_the_limit():
    sim = _drop()
    rest = RestDetector(200, limit=1e-3)
    summary = sim.run(duration=2.0, reporters=[rest])
    assert summary.stopped == "at rest" and summary.simulated_time < 2.0
    assert sim.snapshot().rms_speed < 1e-3 and rest.hits == 2
    # "not yet" (None) leaves the count alone; False counts as a miss
    gate = RestDetector(10, limit=1.0, ready=lambda s: None)
    assert sim.run(steps=100, reporters=[gate]).stopped is None and gate.hits == 0
    miss = RestDetector(10, limit=1.0, ready=lambda s: False)
    assert sim.run(steps=100, reporters=[miss]).stopped is None and miss.hits == 0


def test_the_time_limit_ends_a_run_at_the_first_report_past_it():
    sim = _drop()
    dt = sim.dt
    summary = sim.run(steps=10 ** 9, reporters=[TimeLimit(7, 100.5 * dt)])
    assert summary.stopped == "time limit" and summary.steps == 105  # 15 reports of 7 steps


def test_a_blow_up_names_the_simulation_and_the_fix():
    sim = _drop()
    sim.run(steps=1)
    sim.state.velocities[0, 0] = 1000.0  # a particle flung out: faster than max_speed
    with pytest.raises(SimulationError, match="the heap simulation blew up .*; lower time.step_fraction"):
        sim.run(steps=10, reporters=[BlowUpDetector(1, what="heap simulation", fix="lower time.step_fraction")])


def test_outside_a_run_a_snapshot_sees_values_written_in_place():
    sim = _drop()
    assert sim.snapshot().rms_speed == 0.0
    sim.state.velocities[:] = 1.0
    assert sim.snapshot().rms_speed > 0.5  # a new snapshot, not the cached one
    sim.run(steps=3)
    assert sim.snapshot() is not sim.snapshot()  # nothing kept from the run's reporter passes
