"""The step loop: velocity-Verlet steps of a simulation's store, with neighbour rebuilds
and moving walls.

:func:`advance` takes exactly ``n`` steps. Most run inside one compiled call per
neighbour-list period (:meth:`~demcal.dem.backend.CpuBackend.steps`), which places the
walls that translate at constant velocity or turn at a constant rate itself
(:func:`demcal.geometry.placement.place_moving`); a wall moved by a function of time is
placed from Python before each step. A rebuild
(:func:`rebuild`) first stops on NaN positions, drops particles that left the domain and
re-sorts the particles in space when due (:mod:`demcal.dem.ordering`).
"""

from __future__ import annotations

import numpy as np

from demcal.errors import SimulationError

from .stepper import StepParams


def rebuild(sim) -> None:
    """New contact lists for ``sim`` (a :class:`~demcal.dem.Simulation`)."""
    store = sim._store
    s = store.spheres
    if s.n and not np.all(np.isfinite(s.pos)):
        raise SimulationError(
            f"particle positions became NaN or infinite at t = {sim.time:.6g} s: the "
            f"time step {sim.dt:.3g} s is too large for these stiffnesses or speeds; "
            "reduce dt.")
    domain = sim.description.domain
    if domain is not None and s.n:
        lo, hi = domain
        out_s = np.any((s.pos < lo) | (s.pos > hi), axis=1)
        if np.any(out_s):
            gone = np.zeros(store.bodies.n, bool)
            gone[np.unique(s.body[out_s])] = True
            sim.escaped += int(gone.sum())
            sim._keep(~gone)
            s = store.spheres
    skin = sim.skin
    if sim._ordering.sort_due(s.n, sim.step_count, sim.sort_threshold, sim.sort_interval):
        sim._ordering.sort(store, 2.0 * float(s.radius.max()) + skin, sim.step_count)
    sim._lists.rebuild(store, skin, sim._walls.rows, sim._ordering.old_of_new)
    sim._wall_travel = 0.0
    sim._ordering.rebuilt()
    sim._needs_rebuild = False
    sim.rebuilds += 1


def forces(sim, kick: bool) -> None:
    """Evaluate the forces (and, with ``kick``, the closing half kick)."""
    d = sim.description
    sim._backend.forces(d.chosen, d.table, sim.dt, sim.gravity, sim._store,
                        sim._walls.rows, kick)
    sim._forces_valid = True


def prepare(sim) -> None:
    """Resolve the step, rebuild stale lists and evaluate stale forces."""
    sim.dt  # noqa: B018  (resolve and check)
    if sim._needs_rebuild:
        rebuild(sim)
    if not sim._forces_valid:
        forces(sim, False)


def sync_walls(sim) -> None:
    """Pick up a wall set changed since the last run: copy its rows into the engine,
    rebuild the lists (a wall may have jumped) and re-evaluate the forces."""
    if not sim._walls.changed():
        return
    sim._walls.sync(sim._store.walls, sim.time)
    sim._needs_rebuild = True
    sim._forces_valid = False


def advance(sim, nsteps: int) -> None:
    """Advance ``sim`` by exactly ``nsteps`` steps."""
    if nsteps <= 0:
        return
    sim._view.close(sim._store)   # what the user wrote into sim.state
    store, walls = sim._store, sim._walls
    sim._ordering.to_engine(store)
    if store.spheres.n == 0:
        dt = sim.description.dt or 0.0
        for _ in range(nsteps):
            sim.step_count += 1
            sim.time += dt
            if walls.moving:
                walls.walls.update(sim.time)
        return
    sync_walls(sim)
    prepare(sim)
    # a backend that can rebuild the lists itself (cuda) may do so inside ``steps`` when
    # a rebuild here would do nothing else: no sphere out of the domain (the backend
    # checks), no spatial sort due (from step ``host_rebuild_at`` on, set below)
    sim._backend.domain = sim.description.domain
    dt = sim.dt
    half_skin = 0.5 * sim.skin
    done = 0
    per_step = None  # wall travel per step [m]; the bound moves with the spheres
    while done < nsteps:
        moves = walls.compiled_motions()
        if moves is None:
            # a moving wall: one step at a time, the walls placed before each force
            disp = sim._backend.drift(dt, store)
            sim.time += dt
            sim.step_count += 1
            done += 1
            walls.place(sim.time)
            sim._wall_travel += walls.speed(store.spheres.pos, sim.skin) * dt
            if disp + sim._wall_travel > half_skin or sim._needs_rebuild:
                rebuild(sim)
            forces(sim, True)
            per_step = None
            continue
        if per_step is None:
            per_step = walls.speed(store.spheres.pos, sim.skin, moves) * dt
        d = sim.description
        sim._backend.host_rebuild_at = sim._ordering.sort_step(
            store.spheres.n, sim.step_count, sim.sort_threshold, sim.sort_interval)
        sim._backend.step_count = sim.step_count
        params = StepParams(dt, sim.time, sim.gravity, d.chosen, d.table, half_skin,
                            sim._wall_travel, per_step)
        k, again, sim.time, sim._wall_travel = sim._backend.steps(
            nsteps - done, params, store, walls.rows, moves)
        sim.rebuilds += sim._backend.pop_rebuilds()
        if moves[0].any():
            walls.place(sim.time)  # the WallSet (and the bounding boxes) catch up
        sim.step_count += k
        done += k
        if again or sim._needs_rebuild:
            rebuild(sim)
            forces(sim, True)
            per_step = None
