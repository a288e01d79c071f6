"""The run control: one loop that advances a simulation between its reporters' requests.

:meth:`demcal.dem.Simulation.run` is this loop. Each pass asks every reporter how many
steps until it next wants data, lets a gravity schedule cut the stretch to its window
(:mod:`demcal.dem.gravity`), advances that far in the compiled step loop
(:mod:`demcal.dem.stepping`), and reports to the reporters that are due, in the order
given; one of them may end the run with :class:`~demcal.dem.reporters.StopRun`. A run
by duration whose automatic step shrinks (particles added by a reporter) counts its
remaining steps again. However it ends, the reporters' ``finish`` are called; the
engine's arrays keep their order (users read them through ``sim.state``).
"""

from __future__ import annotations

import time as _time

from demcal.errors import ConfigError

from . import checks as _checks
from . import stepping as _stepping
from .reporters import StopRun
from .summary import RunSummary


def run(sim, duration=None, steps=None, reporters=()) -> RunSummary:
    """Advance ``sim`` by ``duration`` [s] or ``steps`` (see :meth:`Simulation.run`)."""
    _checks.run_length(duration, steps)
    _checks.finite_gravity(sim._gravity)
    dt = sim.dt if sim.n_spheres else sim.description.dt
    end = None   # the time a run by duration ends at [s]
    if steps is None:
        if dt is None:
            raise ConfigError("add particles (or give dt) before running by duration.")
        steps = int(round(duration / dt))
        end = sim.time + float(duration)
    steps = int(steps)
    reporters = list(reporters)
    for r in reporters:
        if hasattr(r, "start"):
            r.start(sim, steps)
    done = particle_steps = 0
    stopped = None
    t_start, clock = sim.time, _time.perf_counter()
    try:
        while done < steps:
            want = [max(1, int(r.next_report(sim))) for r in reporters]
            nxt = sim._clock.apply(sim._gravity, sim.time, sim.step_count,
                                   sim.dt if sim.n_spheres else None,
                                   min([steps - done] + want))
            _checks.finite_gravity(sim._gravity)
            particle_steps += sim.n_particles * nxt
            _stepping.advance(sim, nxt)
            done += nxt
            sim._snapshot, sim._reporting = None, True  # one snapshot for this pass
            for r, k in zip(reporters, want):
                if k == nxt:
                    r.report(sim)
            sim._snapshot, sim._reporting = None, False
            if end is not None and done < steps and sim._dt is None \
                    and sim.n_spheres and sim.dt != dt:
                # particles were added: the automatic step shrank
                dt = sim.dt
                steps = done + max(0, int(round((end - sim.time) / dt)))
    except StopRun as stop:
        stopped = stop.reason
    finally:
        sim._snapshot, sim._reporting = None, False
        for r in reporters:
            if hasattr(r, "finish"):
                r.finish(sim)
    return RunSummary(steps=done, simulated_time=sim.time - t_start,
                      wall_time=_time.perf_counter() - clock,
                      particles=sim.n_particles, particle_steps=particle_steps,
                      simulation=sim, stopped=stopped)
