"""The :class:`Simulation`: the public face of the engine, and its run loop.

The rooms behind it, one concept each: :mod:`~demcal.dem.description` (what the
simulation is, checked once), :mod:`~demcal.dem.storage` (the arrays, by field),
:mod:`~demcal.dem.ordering` (engine vs user order), :mod:`~demcal.dem.backend` and
:mod:`~demcal.dem.threads` (where the compiled loops run), :mod:`~demcal.dem.lists`
(contact lists), :mod:`~demcal.dem.walltable` (the walls' rows), :mod:`~demcal.dem.stepping`
(the step loop), :mod:`~demcal.dem.insertion` (new particles) and
:mod:`~demcal.dem.checkpoint`. See :mod:`demcal.dem` for an overview and an example.
"""

from __future__ import annotations

import numpy as np

from demcal.errors import ConfigError

from . import checkpoint as _checkpoint
from . import checks as _checks
from . import control as _control
from . import insertion as _insertion
from . import stepping as _stepping
from . import timestep as _ts
from .backend import BACKENDS, make_backend  # noqa: F401  (BACKENDS: public here)
from .description import describe
from .gravity import GravitySchedule, ScheduleClock
from .lists import ListBuilder
from .lists import skin as _lists_skin
from .ordering import Ordering, UserView
from .reporters import Snapshot
from .storage import State, Store
from .summary import RunSummary
from .walltable import WallTable

CHECKPOINT_VERSION = _checkpoint.VERSION

__all__ = ["Simulation", "State", "RunSummary", "BACKENDS", "CHECKPOINT_VERSION"]


class Simulation:
    """A DEM simulation of rigid multi-sphere particles and walls.

    Parameters
    ----------
    materials : Material or list of Material
        Particle and wall materials (EDEM material table).
    interactions : Interaction or dict
        One Interaction for all pairs, or ``{(a, b): Interaction, "default": ...}`` with
        materials by index or name (EDEM interaction table).
    walls : demcal.geometry.WallSet, optional
        Walls (row layouts in :mod:`demcal.geometry.kernels`); their ``material``
        indices refer to ``materials``. :meth:`remove_wall` takes one out, also during
        a run.
    gravity : 3 floats or GravitySchedule
        Gravitational acceleration [m/s2], default (0, 0, -9.81); may be changed
        between runs or from a reporter (``sim.gravity[:] = ...`` or
        ``sim.gravity = (gx, gy, gz)``), e.g. to tilt a plane exactly. It is checked
        (three finite numbers) at every run. A schedule (:mod:`demcal.dem.gravity`: a
        linear ramp or a constant-rate rotation) makes it a function of time, see
        :attr:`gravity_schedule`.
    dt : float, optional
        Time step [s]. Default: ``dt_fraction`` of the Rayleigh time, capped at a tenth
        of the shortest contact duration (:mod:`demcal.dem.timestep`), derived again
        whenever particles are added. A given step is checked against the stable limit
        of the particles present at the first run and again after every
        :meth:`add_particles`; above it the run raises :class:`ConfigError`.
    contact_model : {"hertz_mindlin", "hysteretic_spring", "linear"} or ContactModel
        Default ``"hertz_mindlin"`` (EDEM's Hertz-Mindlin no slip).
    rolling_model : {"type_a", "cdt", "type_c", "type_a_limited", "rvd", "none"}, optional
        Rolling resistance. With a preset name for ``contact_model`` the default is
        ``"type_a"`` (EDEM's standard rolling friction; a constant torque that never
        lets a bed become perfectly static, see docs/dem-contact.md: name ``"type_c"`` where a
        static packing matters, or ``"type_a_limited"``, type A with a moment limiter). A
        :class:`ContactModel` names its own rolling model;
        a different ``rolling_model`` is refused rather than one of the two ignored.
    dt_fraction : float
        Fraction of the Rayleigh time for the automatic step (default 0.2).
    impact_speed : float
        Characteristic impact speed [m/s] for the Hertz contact-time check (default 2).
    skin : float, optional
        Neighbour-list skin [m]; default half the largest sphere radius.
    domain : (lo, hi), optional
        Box [m]; particles are refused if they do not fit, and particles leaving it are
        removed (counted in ``sim.escaped``).
    threads : int, optional
        Worker threads (default: numba's thread count). Results are bitwise identical
        for any thread count.
    backend : {"cpu"}
        Compute backend (see :data:`~demcal.dem.backend.BACKENDS`).
    """

    #: Deepest accepted overlap of a new particle's sphere with a sphere of another
    #: particle, as a fraction of the smaller radius. Beds copied from a settled
    #: checkpoint overlap a few per cent (up to 7 % in the benchmark's beds of the
    #: paper's soft soil); particles placed on top of each other by mistake would be
    #: flung apart. Pairs of fixed particles are not checked.
    overlap_tolerance = 0.25
    #: Particles are reordered in space at a neighbour rebuild at most every
    #: ``sort_interval`` steps when there are at least ``sort_threshold`` spheres
    #: (:mod:`demcal.dem.ordering`; users never see it).
    sort_threshold = 4096
    sort_interval = 1000

    def __init__(self, materials, interactions, walls=None, gravity=(0.0, 0.0, -9.81),
                 dt=None, contact_model="hertz_mindlin", rolling_model=None,
                 dt_fraction=0.2, impact_speed=2.0, skin=None, domain=None,
                 threads=None, backend="cpu"):
        schedule = gravity if isinstance(gravity, GravitySchedule) else None
        self.gravity = gravity.at(0.0) if schedule is not None else gravity
        self.description = describe(materials, interactions, dt, contact_model,
                                    rolling_model, dt_fraction, impact_speed, skin, domain,
                                    threads, backend)
        d = self.description
        self.time = 0.0
        self.step_count = 0
        self._walls = WallTable(walls, self.time, d.material_table)
        self.gravity_schedule = schedule
        self._backend = make_backend(d.backend, d.threads)
        self._store = Store.empty()
        self._ordering = Ordering()
        self._lists = ListBuilder(self._backend)
        self.templates = []
        self.escaped = 0
        self.rebuilds = 0
        self._dt = None
        self._wall_travel = 0.0
        self._needs_rebuild = True
        self._forces_valid = False
        self._generation = 0  # bumped by every change of the particles (see snapshot)
        self._snapshot = None
        self._reporting = False  # inside a reporter pass of a run (see snapshot)
        self._view = UserView(self._ordering)   # the State handed out by `state`

    # -- the description, as attributes ----------------------------------------------
    material_table = property(lambda self: self.description.material_table)
    materials = property(lambda self: self.description.materials)
    contact_model = property(lambda self: self.description.contact_model)
    domain = property(lambda self: self.description.domain)
    dt_fraction = property(lambda self: self.description.dt_fraction)
    impact_speed = property(lambda self: self.description.impact_speed)
    threads = property(lambda self: self.description.threads)
    backend = property(lambda self: self.description.backend)
    walls = property(lambda self: self._walls.walls, doc="The WallSet (or None).")
    wall_names = property(lambda self: self._walls.names)
    sorts = property(lambda self: self._ordering.sorts,
                     doc="Spatial reorderings done (see sort_threshold).")
    nbytes = property(lambda self: self._store.nbytes, doc="Bytes held by the arrays.")

    @property
    def parallel_threshold(self) -> int:
        """Below this many particles the loops run in the calling thread only."""
        return self._backend.workers.parallel_threshold

    @parallel_threshold.setter
    def parallel_threshold(self, value):
        self._backend.workers.parallel_threshold = value

    @property
    def gravity(self) -> np.ndarray:
        """Gravitational acceleration [m/s2], a live (3,) array: change it in place
        (``sim.gravity[:] = ...``) or assign three numbers; checked at every run."""
        return self._gravity

    @gravity.setter
    def gravity(self, value):
        self._gravity = _checks.gravity_array(value)

    @property
    def gravity_schedule(self):
        """Gravity as a function of time (:mod:`demcal.dem.gravity`), or None.

        A :class:`~demcal.dem.gravity.GravityRamp` or
        :class:`~demcal.dem.gravity.GravityRotation` has :meth:`run` set
        :attr:`gravity` once per window of steps (from the step it is set at) to the
        schedule's value at the window's middle: within the schedule's ``tolerance``
        [m/s2] of the exact value at every step, with no Python call per step. Setting
        it sets :attr:`gravity` to its value now. Set None to keep gravity where it is
        from then on. Not stored in checkpoints.
        """
        return self._clock.schedule

    @gravity_schedule.setter
    def gravity_schedule(self, value):
        self._clock = ScheduleClock(value)
        if value is not None:
            self._gravity[:] = value.at(self.time)

    # -- particles ------------------------------------------------------------------
    @property
    def n_particles(self) -> int:
        """Number of particles (rigid bodies)."""
        return self._store.bodies.n

    @property
    def n_spheres(self) -> int:
        """Number of spheres (contact entities)."""
        return self._store.spheres.n

    def add_particles(self, template=None, positions=None, orientations=None, scales=None,
                      velocities=None, angular_velocities=None, material=0, fixed=False,
                      seed=0, radii=None, rotation=True):
        """Add particles made from one template; returns the new particle indices.

        ``template`` is a sphere radius [m] or a multi-sphere template (``radii``,
        ``centers`` in the principal frame, ``volume``, ``inertia_per_density``; see
        :mod:`demcal.particles.templates`); ``radii=`` (one per particle, or one for
        all) adds single spheres instead. ``positions`` (n, 3) are centres of mass [m];
        ``orientations`` quaternions (w, x, y, z), "random" (from ``seed``) or None
        (identity); ``scales`` size factors (radii and offsets x s, mass s^3, inertia
        s^5); ``velocities`` [m/s] and ``angular_velocities`` [rad/s] one row or one per
        particle; ``material`` an index or name; ``fixed`` particles never move;
        ``rotation=False`` locks rotation (principal inertias ``inf``, so 1/I = 0;
        their mean moment, which the rolling models' damping uses, stays the
        template's; ``angular_velocities`` must be 0).

        Everything is checked before anything is added (:mod:`demcal.dem.insertion`):
        finite numbers of the right shapes; no particle outside ``domain`` or larger
        than a :class:`Box` wall it is placed in; no sphere overlapping a sphere of
        another particle by more than :attr:`overlap_tolerance` of the smaller radius. A
        given ``dt`` is checked again against the new particles at the next step.
        """
        mi = self.material_table.index(material)
        self.material_table.check_meets(mi, np.unique(self._store.bodies.mat[:self.n_particles]),
                                        np.unique(self._walls.rows.material))
        b = _insertion.batch(mi, template, positions, orientations, scales, velocities,
                             angular_velocities, fixed, seed, radii, rotation)
        _insertion.check_domain(b, self.domain)
        _insertion.check_boxes(self.walls, self.wall_names, self.time, b.pos, b.diameters)
        nb0 = self.n_particles
        spheres = _insertion.sphere_rows(b, nb0)
        _insertion.check_overlaps(self.state, spheres[0], spheres[2], spheres[3],
                                  np.repeat(b.fixed, b.k), self.overlap_tolerance)
        self._view.close(self._store)
        self._ordering.release(self._store)
        try:
            tid = next(k for k, t in enumerate(self.templates) if t is b.template)
        except StopIteration:
            self.templates.append(b.template)
            tid = len(self.templates) - 1
        bodies, new = _insertion.rows(b, self.materials[mi].density, tid, spheres)
        self._store.append(bodies, new)
        self._ordering.added(new.n)
        self._generation += 1
        self._needs_rebuild = True
        self._forces_valid = False
        # re-derive the automatic step (smaller particles may need a smaller one), or
        # check a given step against the new particles, at the next step
        self._dt = None
        return np.arange(nb0, nb0 + b.n)

    def remove_particles(self, which):
        """Remove particles given by a boolean mask (one entry per particle) or indices
        (negative ones count from the end); the others keep their contact history."""
        keep = _checks.kept_particles(which, self.n_particles)
        if keep is None:
            return
        self._view.close(self._store)
        self._ordering.release(self._store)
        if not keep.all():
            self._keep(keep)

    def _keep(self, keep):
        """Keep the particles where ``keep`` is true (engine order)."""
        skeep = np.repeat(keep, np.diff(self._store.bodies.start))
        old_sphere = self._store.keep(keep)
        self._ordering.kept(keep, skeep, old_sphere)
        self._generation += 1
        self._needs_rebuild = True
        self._forces_valid = False

    def rebuild_neighbours(self) -> None:
        """Rebuild the contact lists before the next step (they are rebuilt anyway when
        a sphere has moved half the skin; contacts keep their history)."""
        self._needs_rebuild = True

    # -- time step --------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """Time step [s] (derived from the particles on first use when not given)."""
        if self._dt is None:
            self._dt = _ts.resolve_dt(self.description, *self.time_scales())
        return self._dt

    def time_scales(self):
        """(Rayleigh time, shortest contact duration) [s] for the current particles."""
        if self.n_spheres == 0:
            raise ConfigError("add particles before asking for the time step.")
        b, s = self._store.bodies, self._store.spheres
        return _ts.time_scales(self.description, b.mat, b.mass, s.radius, s.body,
                               self._walls.rows.material)

    @property
    def skin(self) -> float:
        """Neighbour skin [m] (:func:`demcal.dem.lists.skin`): the one given, or half the
        largest sphere radius; at least twice the gap a cohesive contact holds across."""
        r_max = float(self._store.spheres.radius.max()) if self.n_spheres else None
        return _lists_skin(self.description, r_max)

    # -- walls ------------------------------------------------------------------------
    def remove_wall(self, name: str) -> None:
        """Take the wall called ``name`` (all its rows) out of the simulation, also from
        a reporter during a run: the particles stop feeling it from the next step on,
        its contacts are dropped with their history, :meth:`wall_forces` no longer
        lists it, and the shared wall set loses it too
        (:meth:`~demcal.geometry.WallSet.remove`). ConfigError if no wall has that
        name (the message lists the walls there are)."""
        if self.walls is None or not hasattr(self.walls, "remove"):
            raise ConfigError(f"no wall named {name!r}: this simulation has no walls.")
        self.walls.remove(name)
        _stepping.sync_walls(self)

    # -- running ----------------------------------------------------------------------
    def run(self, duration=None, steps=None, reporters=()):
        """Advance by ``duration`` [s] (rounded to whole steps) or ``steps``.

        Reporters (OpenMM style) are objects with ``next_report(sim) -> int`` (steps until
        they next want data, >= 1) and ``report(sim)``; see :mod:`demcal.dem.reporters`.
        A reporter may add or remove particles, change gravity, or end the run: raising
        :class:`~demcal.dem.reporters.StopRun` ends it normally (the summary's
        ``stopped`` says why), any other exception ends it with that error.

        A run by duration ends at the requested time to within half a step: when
        particles added during the run shrink the automatic time step, the steps left
        are counted again from the time left. A given ``dt`` never changes, so the run
        takes exactly ``round(duration / dt)`` steps (reporters' ``start`` get that
        count). With a :attr:`gravity_schedule`, gravity is set at every window of its
        steps. Returns a :class:`RunSummary` (:mod:`demcal.dem.control`).
        """
        return _control.run(self, duration, steps, reporters)

    def snapshot(self):
        """The simulation now (:class:`~demcal.dem.reporters.Snapshot`). Within one
        reporter pass of a run it is one object, shared by the reporters due at that step
        (a change of the particles makes a new one); outside a run every call makes a new
        one, so values written into ``state`` in place are always seen."""
        key = (self.step_count, self._generation)
        if self._snapshot is None or self._snapshot[0] != key:
            snap = Snapshot(self)
            if not self._reporting:
                return snap
            self._snapshot = (key, snap)
        return self._snapshot[1]

    # -- observables ------------------------------------------------------------------
    @property
    def state(self) -> State:
        """The particles now, in user order (:class:`State`): copies, one object until
        the next step or change of the particles; what is written into its writable
        fields is where the next run starts from."""
        return self._view.state(self._store, self.time, self.step_count,
                                (self.step_count, self._generation))

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy [J] of the free particles."""
        st = self.state   # summed in user order, whatever the engine's order
        free = ~st.fixed
        et = 0.5 * np.sum(st.masses[free] * np.sum(st.velocities[free] ** 2, axis=1))
        er = 0.5 * np.sum(st.omegas[free] * st.angular_momenta[free])
        return float(et + er)

    def wall_forces(self) -> dict:
        """Force [N] and torque [N m] (about each row's origin) on every wall group:
        ``{group name: (force (3,), torque (3,))}``; torques of a group's rows are summed
        about their own origins (identical for rigid groups sharing an origin)."""
        return self._walls.forces(self._store.walls, self._forces_valid)

    def contacts(self):
        """Current particle-particle contacts as (i_sphere, j_sphere, force on i (3,)),
        spheres in user order."""
        return self._view.contacts(self._store.pairs)

    def contact_lists(self):
        """The engine's contact lists ``(pairs, walls)``
        (:class:`~demcal.dem.storage.ContactList`, spheres in engine order: see
        :attr:`engine_order`); read them, do not write (for diagnostics)."""
        return self._store.pairs, self._store.walls

    @property
    def engine_order(self):
        """The user index of each particle in the engine's spatial order (a copy), or
        None while the engine keeps the user's order (:mod:`demcal.dem.ordering`)."""
        perm = self._ordering.perm
        return None if perm is None else perm[0].copy()

    @property
    def engine_backend(self):
        """The backend object doing the work (:mod:`demcal.dem.backend`)."""
        return self._backend

    def contact_histories(self):
        """History rows (``contact.kernel``'s layout) of the touching pair and wall
        contacts, ``(pairs, walls)``, in the lists' order (for diagnostics)."""
        return tuple(c.hist[:c.size][c.act[:c.size]]
                     for c in (self._store.pairs, self._store.walls))

    # -- checkpoints ------------------------------------------------------------------
    def save_checkpoint(self, path):
        """Write the full state (npz, :mod:`demcal.dem.checkpoint`) so that
        :meth:`load_checkpoint` restarts bit-identically."""
        _checkpoint.save_simulation(self, path)

    def load_checkpoint(self, path):
        """Restore a state written by :meth:`save_checkpoint` into this simulation,
        built with the same materials, walls, contact model and particle templates
        (templates are referred to by index)."""
        self._view.close(self._store)
        _checkpoint.restore_simulation(self, path)
        self._generation += 1
        return self
