"""The :class:`Simulation`: state, neighbour lists, walls and the run loop.

See :mod:`demcal.dem` for an overview and an example.
"""

from __future__ import annotations

import math
import numbers
import os
import time as _time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numba
import numpy as np

from demcal.errors import ConfigError, SimulationError
from demcal.particles.materials import MaterialTable

from . import forces as _forces
from . import integrator as _integ
from . import neighbours as _nl
from . import stepper as _stepper
from . import timestep as _ts
from .contact.kernel import HIST_WIDTH
from .contact.registry import ContactModel
from .gravity import GravitySchedule, as_schedule

_NO_HALO = np.zeros(1, np.int64)                # an unsplit pair loop's empty halo index
_NO_DEFERRED = np.zeros((0, HIST_WIDTH))

CHECKPOINT_VERSION = 3

#: Compute backends present. The kernels are written so the same source can be compiled
#: with numba.cuda later; only the numba CPU backend exists today.
BACKENDS = ("cpu",)


@dataclass
class State:
    """Live views of the simulation arrays (SI units). Copy what you keep.

    Bodies (one per particle, ``n`` rows): ``positions`` [m] (centre of mass),
    ``velocities`` [m/s], ``omegas`` [rad/s] (world frame), ``quaternions`` (w, x, y, z;
    body principal frame -> world), ``angular_momenta`` [kg m2/s] (world),
    ``forces`` [N] and ``torques`` [N m] of the last evaluation (gravity included),
    ``masses`` [kg], ``inertias`` [kg m2] (principal; ``inf`` for a particle added
    with ``rotation=False``), ``materials`` (index),
    ``templates`` (index into ``Simulation.templates``), ``scales`` (size factor),
    ``fixed`` (bool). Spheres (``ns`` rows): ``sphere_positions`` [m], ``radii`` [m],
    ``sphere_body`` (owning body).
    """

    positions: np.ndarray
    velocities: np.ndarray
    omegas: np.ndarray
    quaternions: np.ndarray
    angular_momenta: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    masses: np.ndarray
    inertias: np.ndarray
    materials: np.ndarray
    templates: np.ndarray
    scales: np.ndarray
    fixed: np.ndarray
    sphere_positions: np.ndarray
    radii: np.ndarray
    sphere_body: np.ndarray
    time: float
    step: int

    @property
    def n(self) -> int:
        """Number of particles (bodies)."""
        return self.positions.shape[0]


@dataclass(frozen=True)
class RunSummary:
    """What one :meth:`Simulation.run` did.

    ``steps`` taken, ``simulated_time`` [s] advanced, ``wall_time`` [s] it took,
    ``particles`` at its end and ``particle_steps`` (particles present times steps,
    summed over the run's stretches between reporters). Before issue 18 ``run()``
    returned the simulation itself: reading one of the simulation's attributes here
    still works, with a DeprecationWarning (use the simulation instead).
    """

    steps: int
    simulated_time: float
    wall_time: float
    particles: int
    particle_steps: int
    simulation: "Simulation" = field(repr=False, compare=False)

    @property
    def particle_steps_per_second(self) -> float:
        """Particle-steps per second of wall time (0 when no time was measured)."""
        return self.particle_steps / self.wall_time if self.wall_time > 0 else 0.0

    def __getattr__(self, name):
        if name.startswith("__") or name == "simulation":
            raise AttributeError(name)
        value = getattr(self.simulation, name)
        warnings.warn(f"run() now returns a RunSummary; read {name!r} from the simulation "
                      f"(sim.{name}) instead.", DeprecationWarning, stacklevel=2)
        return value


class _SphereTemplate:
    """A single sphere of radius ``radius`` (internal; duck-types a template)."""

    def __init__(self, radius: float):
        self.name = f"sphere({radius:g})"
        self.radii = np.array([radius])
        self.centers = np.zeros((1, 3))
        self.volume = 4.0 / 3.0 * math.pi * radius ** 3
        i = 0.4 * radius ** 2 * self.volume
        self.inertia_per_density = np.array([i, i, i])


def _empty_walls():
    return dict(kind=np.zeros(0, np.int32), params=np.zeros((0, 16)),
                velocity=np.zeros((0, 3)), omega=np.zeros((0, 3)),
                origin=np.zeros((0, 3)), aabb=np.zeros((0, 6)),
                material=np.zeros(0, np.int32), group=np.zeros(0, np.int32),
                id=np.zeros(0, np.int64))


def _mean_inertia(inertia):
    """Mean principal moment per body (the rolling inertia of Ai et al. 2011)."""
    return (inertia[:, 0] + inertia[:, 1] + inertia[:, 2]) / 3.0


def _closed_up(perm, kept):
    """``perm`` (engine index -> user index) over the kept entries, with the user indices
    of the kept entries renumbered 0, 1, ... in their order."""
    user_kept = np.zeros(perm.size, bool)
    user_kept[perm[kept]] = True
    rank = np.cumsum(user_kept) - 1
    return rank[perm[kept]]


def _is_real(x) -> bool:
    """A real number (Python or numpy scalar), not a bool."""
    return isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))


def _is_integer(x) -> bool:
    """A whole number (Python or numpy integer), not a bool."""
    return isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_))


def _gravity_array(value):
    """``value`` as a float (3,) array; ConfigError unless three finite numbers."""
    try:
        g = np.array(value, dtype=float)
    except (TypeError, ValueError):
        g = None
    if g is None or g.size != 3 or not np.all(np.isfinite(g)):
        raise ConfigError(f"gravity must be three finite numbers [m/s2], got {value!r}; "
                          "give e.g. gravity=(0, 0, -9.81).")
    return g.reshape(3)


def _floats(value, name, unit):
    """``value`` as a float array; ConfigError naming ``name`` if it is not numbers."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be numbers [{unit}], got {value!r}.") from None


def _rows(value, n, width, name, unit):
    """One row for all ``n`` particles, ``(width,)`` or ``(1, width)``, or one row per
    particle ``(n, width)``, as a new ``(n, width)`` float array of finite numbers."""
    a = _floats(value, name, unit)
    if not (a.shape == (width,) or (a.ndim == 2 and a.shape[1] == width
                                    and a.shape[0] in (1, n))):
        raise ConfigError(f"{name} [{unit}] must be one ({width},) row for all particles "
                          f"or an ({n}, {width}) array (one row per particle), got shape "
                          f"{a.shape}.")
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"{name} must be finite numbers [{unit}], got a NaN or an "
                          "infinite value.")
    return np.broadcast_to(a, (n, width)).copy()


def _flags(value, n, name):
    """``value`` (one bool, or one per particle) as a new (n,) bool array; ConfigError
    naming ``name`` otherwise."""
    a = np.asarray(value)
    if a.ndim == 0 and isinstance(a.item(), (bool, int)):
        return np.full(n, bool(a))
    if a.shape == (n,) and a.dtype == np.bool_:
        return a.copy()
    raise ConfigError(f"{name} must be True, False or one bool per particle (n = {n}), "
                      f"got {value!r}.")


def _random_quaternions(n, rng):
    """Uniform random rotations (Shoemake 1992, Graphics Gems III)."""
    u1, u2, u3 = rng.random((3, n))
    a = np.sqrt(1.0 - u1)
    b = np.sqrt(u1)
    return np.stack([a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2),
                     b * np.sin(2 * np.pi * u3), b * np.cos(2 * np.pi * u3)], axis=1)


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
        Walls (the arrays of :mod:`demcal.geometry.wallset`, row layouts in
        :mod:`demcal.geometry.kernels`); their ``material`` indices refer to
        ``materials``. :meth:`remove_wall` takes one out, also during a run.
    gravity : 3 floats or GravitySchedule
        Gravitational acceleration [m/s2], default (0, 0, -9.81); may be changed
        between runs or from a reporter (``sim.gravity[:] = ...`` or
        ``sim.gravity = (gx, gy, gz)``), e.g. to tilt a plane exactly. It is checked
        (three finite numbers) at every run. A schedule
        (:mod:`demcal.dem.gravity`: a linear ramp or a constant-rate rotation) makes
        it a function of time, see :attr:`gravity_schedule`.
    dt : float, optional
        Time step [s]. Default: ``dt_fraction`` of the Rayleigh time, capped at a tenth
        of the shortest contact duration (:mod:`demcal.dem.timestep`), derived again
        whenever particles are added. A given step is checked against the stable limit
        of the particles present at the first run and again after every
        :meth:`add_particles`; above it the run raises :class:`ConfigError`.
    contact_model : {"hertz_mindlin", "hysteretic_spring", "linear"} or ContactModel
        Default ``"hertz_mindlin"`` (EDEM's Hertz-Mindlin no slip).
    rolling_model : {"type_a", "cdt", "type_c", "none"}, optional
        Rolling resistance. With a preset name for ``contact_model`` the default is
        ``"type_a"`` (EDEM's standard rolling friction, the model the paper used in
        EDEM; a constant torque that never lets a bed become perfectly static, see
        docs/dem.md: name ``"type_c"`` where a static packing matters). A
        :class:`ContactModel` names its own rolling model (its ``rolling``, default
        ``"type_a"``): then leave ``rolling_model`` unset or give the same model; a
        different one is refused rather than one of the two being ignored (write
        ``ContactModel(..., rolling="type_c")``).
    dt_fraction : float
        Fraction of the Rayleigh time for the automatic step (default 0.2).
    impact_speed : float
        Characteristic impact speed [m/s] for the Hertz contact-time check (default 2).
    skin : float, optional
        Neighbour-list skin [m]; default half the largest sphere radius (as the LIGGGHTS
        comparison uses).
    domain : (lo, hi), optional
        Box [m]; particles are refused if they do not fit, and particles leaving it are
        removed (counted in ``sim.escaped``).
    threads : int, optional
        Worker threads for the force and integration loops (default: numba's thread count,
        all cores unless NUMBA_NUM_THREADS or numba.set_num_threads says fewer). The
        compiled kernels release the GIL and each writes disjoint slots, so results are
        bitwise identical for any thread count.
    backend : {"cpu"}
        Compute backend (see :data:`BACKENDS`).
    """

    def __init__(self, materials, interactions, walls=None, gravity=(0.0, 0.0, -9.81),
                 dt=None, contact_model="hertz_mindlin", rolling_model=None,
                 dt_fraction=0.2, impact_speed=2.0, skin=None, domain=None,
                 threads=None, backend="cpu"):
        if backend not in BACKENDS:
            raise ConfigError(f"unknown backend {backend!r}; available: {list(BACKENDS)}.")
        self.backend = backend
        self.material_table = MaterialTable(materials, interactions)
        self.materials = self.material_table.materials
        if isinstance(contact_model, ContactModel):
            contact_model.ids()
            if rolling_model is not None:
                own = contact_model.ids()[3]
                if ContactModel(rolling=rolling_model).ids()[3] != own:
                    raise ConfigError(
                        f"rolling_model {rolling_model!r} conflicts with the contact_model's "
                        f"rolling {contact_model.rolling!r}; name the rolling model once: "
                        f"ContactModel(..., rolling={rolling_model!r}), or leave "
                        "rolling_model unset.")
            self.contact_model = contact_model
        else:
            self.contact_model = ContactModel.preset(
                contact_model, "type_a" if rolling_model is None else rolling_model)
        self._models = np.array(self.contact_model.ids(), dtype=np.int64)
        self._table = np.ascontiguousarray(self.material_table.table)
        schedule = gravity if isinstance(gravity, GravitySchedule) else None
        self.gravity = gravity.at(0.0) if schedule is not None else gravity
        if dt is not None:
            if not (_is_real(dt) and math.isfinite(dt) and dt > 0):
                raise ConfigError(f"dt must be a positive number of seconds, got {dt!r}.")
            dt = float(dt)
        if not (_is_real(dt_fraction) and 0.0 < dt_fraction <= 1.0):
            raise ConfigError(f"dt_fraction must be in (0, 1], got {dt_fraction!r}.")
        if not (_is_real(impact_speed) and math.isfinite(impact_speed)
                and impact_speed > 0):
            raise ConfigError(f"impact_speed must be a finite number > 0 m/s, got "
                              f"{impact_speed!r}.")
        self._dt_user = dt
        self.dt_fraction = float(dt_fraction)
        self.impact_speed = float(impact_speed)
        self._dt = None
        if skin is not None:
            if not (_is_real(skin) and math.isfinite(skin) and skin > 0):
                raise ConfigError(f"skin must be a finite number > 0 m, got {skin!r}.")
            skin = float(skin)
        self._skin_user = skin
        self.domain = None
        if domain is not None:
            try:
                lo, hi = (np.asarray(v, dtype=float).reshape(3) for v in domain)
            except (TypeError, ValueError):
                raise ConfigError(f"domain must be (lo, hi), two corners of three numbers "
                                  f"each [m], got {domain!r}.") from None
            if not np.all(hi > lo):
                raise ConfigError(f"domain must be (lo, hi) with hi > lo, got {domain!r}.")
            self.domain = (lo, hi)
        if threads is None:
            # numba's thread count: the cores, or what NUMBA_NUM_THREADS or a campaign
            # worker (numba.set_num_threads) allows this process
            threads = numba.get_num_threads()
        if not (_is_integer(threads) and threads >= 1):
            raise ConfigError(f"threads must be a positive integer, got {threads!r}.")
        self.threads = int(threads)
        self._pool = None
        self.walls = walls
        self.time = 0.0
        self.step_count = 0
        self.gravity_schedule = schedule
        self._wall_arrays()
        nmat = len(self.materials)
        if self._w["material"].size and (self._w["material"].min() < 0
                                         or self._w["material"].max() >= nmat):
            raise ConfigError(f"a wall's material index is out of range (there are {nmat} "
                              "materials).")
        self.templates = []
        self._unit_sphere = None   # the template of add_particles(radii=...)
        self.escaped = 0
        self._alloc_bodies(0, 0)
        self._alloc_lists(0, 0, 0)
        self._wall_travel = 0.0
        self._old_of_new = None
        self._perm = None          # (body, sphere): engine index -> user index when sorted
        self._user_view = False    # arrays in user order while the engine keeps a sort
        self._carry_engine = None  # the engine view's _old_of_new during a user view
        self._last_sort = None
        self._spare_p = None
        self._halo = None          # chunks of a split and their halo index (per list)
        self._needs_rebuild = True
        self._forces_valid = False
        self.rebuilds = 0
        self.sorts = 0             # spatial reorderings (see sort_threshold)
        self._row_width = 16   # scratch width of the neighbour search (grows as needed)
        self._wall_width = 4

    @property
    def gravity(self) -> np.ndarray:
        """Gravitational acceleration [m/s2], a live (3,) array: change it in place
        (``sim.gravity[:] = ...``) or assign three numbers; checked at every run."""
        return self._gravity

    @gravity.setter
    def gravity(self, value):
        self._gravity = _gravity_array(value)

    @property
    def gravity_schedule(self):
        """Gravity as a function of time (:mod:`demcal.dem.gravity`), or None.

        Set a :class:`~demcal.dem.gravity.GravityRamp` or
        :class:`~demcal.dem.gravity.GravityRotation` to have :meth:`run` set
        :attr:`gravity` itself, once per window of steps (from the step it is set
        at), to the schedule's value at the window's middle: within the schedule's
        ``tolerance`` [m/s2] of the exact value at every step, with no Python call per
        step. Setting it sets :attr:`gravity` to its value now; while it is set, it
        overwrites :attr:`gravity` at every window. Set None to keep gravity where it
        is from then on. Not stored in checkpoints.
        """
        return self._schedule

    @gravity_schedule.setter
    def gravity_schedule(self, value):
        self._schedule = as_schedule(value)
        self._schedule_anchor = None  # (step, time, dt, window) of its first window
        if value is not None:
            self._gravity[:] = value.at(self.time)

    def _gravity_window(self, nsteps):
        """Set gravity for the coming steps from the schedule; returns how many of the
        ``nsteps`` lie in the current window (all of them without a schedule)."""
        sch = self._schedule
        if sch is None or self.n_spheres == 0:
            if sch is not None:
                self._gravity[:] = sch.at(self.time)
            return nsteps
        dt = self.dt
        a = self._schedule_anchor
        if a is None or a[2] != dt:   # first use, or particles changed the step
            a = self._schedule_anchor = (self.step_count, self.time, dt, sch.window(dt))
        n0, t0, _, width = a
        first = n0 + (self.step_count - n0) // width * width
        self._gravity[:] = sch.at(t0 + (first - n0 + 0.5 * (width + 1)) * dt)
        return min(nsteps, first + width - self.step_count)

    def _check_gravity(self):
        """ConfigError unless gravity (perhaps changed in place) is three finite numbers."""
        g = self._gravity
        if not np.all(np.isfinite(g)):
            raise ConfigError(f"gravity must be three finite numbers [m/s2], got "
                              f"{g.tolist()}; set e.g. sim.gravity[:] = (0, 0, -9.81).")

    # ------------------------------------------------------------------ allocation --
    def _alloc_bodies(self, nb, ns):
        self._b = dict(pos=np.zeros((nb, 3)), vel=np.zeros((nb, 3)),
                       quat=np.zeros((nb, 4)), angmom=np.zeros((nb, 3)),
                       omega=np.zeros((nb, 3)), force=np.zeros((nb, 3)),
                       torque=np.zeros((nb, 3)), mass=np.zeros(nb),
                       inertia=np.zeros((nb, 3)), iso=np.zeros(nb),
                       mat=np.zeros(nb, np.int64),
                       template=np.zeros(nb, np.int64), scale=np.zeros(nb),
                       fixed=np.zeros(nb, np.bool_), start=np.zeros(nb + 1, np.int64))
        self._s = dict(body=np.zeros(ns, np.int64), offset=np.zeros((ns, 3)),
                       radius=np.zeros(ns), pos=np.zeros((ns, 3)), ref=np.zeros((ns, 3)),
                       dsq=np.zeros(ns), acc=np.zeros((ns, _forces.ACC_WIDTH)))

    def _alloc_lists(self, ns, cap, wcap):
        self._p = dict(start=np.zeros(ns + 1, np.int64), nbr=np.zeros(cap, np.int64),
                       hist=np.zeros((cap, HIST_WIDTH)),
                       out=np.zeros((cap, _forces.PAIR_OUT_WIDTH)),
                       act=np.zeros(cap, np.bool_))
        self._q = dict(start=np.zeros(ns + 1, np.int64), wid=np.zeros(wcap, np.int64),
                       hist=np.zeros((wcap, HIST_WIDTH)),
                       out=np.zeros((wcap, _forces.OUT_WIDTH)), act=np.zeros(wcap, np.bool_))

    def _wall_arrays(self):
        w = self.walls
        if w is None:
            self._w = _empty_walls()
            self._walls_moving = False
            self._walls_version = 0
            self.wall_names = []
            return
        if w.moving:
            w.update(self.time)
        self._w = dict(kind=np.ascontiguousarray(w.kind, dtype=np.int64),
                       params=np.ascontiguousarray(w.params, dtype=float),
                       velocity=np.ascontiguousarray(w.velocity, dtype=float),
                       omega=np.ascontiguousarray(w.omega, dtype=float),
                       origin=np.ascontiguousarray(w.origin, dtype=float),
                       aabb=np.ascontiguousarray(w.aabb, dtype=float),
                       material=np.ascontiguousarray(w.material, dtype=np.int64),
                       group=np.ascontiguousarray(w.group, dtype=np.int64),
                       id=np.array(getattr(w, "row_id", np.arange(len(w.kind))),
                                   dtype=np.int64))
        self._walls_moving = bool(w.moving)
        self._walls_version = getattr(w, "version", 0)
        self.wall_names = list(getattr(w, "names", []))

    # ------------------------------------------------------------------ particles --
    @property
    def n_particles(self) -> int:
        """Number of particles (rigid bodies)."""
        return self._b["pos"].shape[0]

    @property
    def n_spheres(self) -> int:
        """Number of spheres (contact entities)."""
        return self._s["pos"].shape[0]

    #: Deepest accepted overlap of a new particle's sphere with a sphere of another
    #: particle, as a fraction of the smaller radius. Beds copied from a settled
    #: checkpoint overlap a few per cent (up to 7 % in the benchmark's beds of the
    #: paper's soft soil); particles placed on top of each other by mistake would be
    #: flung apart. Pairs of fixed particles are not checked.
    overlap_tolerance = 0.25

    def add_particles(self, template=None, positions=None, orientations=None, scales=None,
                      velocities=None, angular_velocities=None, material=0, fixed=False,
                      seed=0, radii=None, rotation=True):
        """Add particles made from one template; returns the new particle indices.

        Parameters
        ----------
        template : float or template
            A sphere radius [m], or a multi-sphere template with ``radii``, ``centers``
            (principal frame, centre of mass at the origin), ``volume`` and
            ``inertia_per_density`` (see :mod:`demcal.particles.templates`). Leave it
            out when giving ``radii``.
        positions : (n, 3) array
            Centres of mass [m].
        orientations : (n, 4) or (4,) quaternions (w, x, y, z), "random", or None
            (identity).
        scales : float or (n,) array
            Size factors (radii and offsets times s, mass s^3, inertia s^5).
        velocities, angular_velocities : (3,) or (n, 3) arrays [m/s], [rad/s].
        material : int or str
            Material of the particles.
        fixed : bool or (n,) bools
            Fixed particles never move (obstacles).
        seed : int
            Seed for ``orientations="random"``.
        radii : float or (n,) array, optional
            Single spheres of these radii [m], one per particle (or one for all), in
            place of ``template`` and ``scales``:
            ``sim.add_particles(positions=xyz, radii=r)``.
        rotation : bool or (n,) bools
            False locks the particles' rotation: they translate under forces and
            gravity but never turn (omega stays 0 whatever the torque). Their
            principal moments of inertia are infinite (``state.inertias`` holds
            ``inf``; the engine's 1/I is then 0, so the compiled loops run as for
            any other particle); their mean moment, which the rolling models'
            damping uses, stays the template's. ``angular_velocities`` must be 0
            for them.

        All input is checked before anything is added: finite numbers of the right
        shapes; no particle outside ``domain`` or larger than a :class:`Box` wall it is
        placed in; no sphere overlapping a sphere of another particle (new or present)
        by more than :attr:`overlap_tolerance` of the smaller radius. A given ``dt`` is
        checked again against the new particles at the next step.
        """
        if positions is None:
            raise ConfigError("add_particles needs positions: an (n, 3) array of centres "
                              "[m].")
        pos = _floats(positions, "positions", "m")
        if pos.ndim == 1:
            pos = pos.reshape(1, -1)
        if pos.ndim != 2 or pos.shape[1] != 3 or not np.all(np.isfinite(pos)):
            raise ConfigError("positions must be an (n, 3) array of finite numbers [m].")
        n = pos.shape[0]
        by_radii = radii is not None
        if by_radii:
            if template is not None or scales is not None:
                raise ConfigError("give radii= alone, or a template (with scales=), not "
                                  "both: radii are single spheres of those radii.")
            if self._unit_sphere is None:
                self._unit_sphere = _SphereTemplate(1.0)
            template, scales = self._unit_sphere, _floats(radii, "radii", "m")
            if not (np.all(np.isfinite(scales)) and np.all(scales > 0)):
                raise ConfigError("radii must be finite numbers > 0 [m].")
        elif template is None:
            raise ConfigError("add_particles needs a template, a sphere radius [m] or "
                              "radii= (one per particle).")
        if isinstance(template, (int, float, np.floating, np.integer)) and not isinstance(
                template, (bool, np.bool_)):
            if not (math.isfinite(template) and template > 0):
                raise ConfigError(f"particle radius must be a finite number > 0 m, got "
                                  f"{template}.")
            tpl = _SphereTemplate(float(template))
        else:
            tpl = template
            for attr in ("radii", "centers", "volume", "inertia_per_density"):
                if not hasattr(tpl, attr):
                    raise ConfigError(f"template {tpl!r} has no attribute {attr!r}; use a "
                                      "demcal.particles.templates template or a radius.")
        mi = self.material_table.index(material)
        rho = self.materials[mi].density
        radii = np.asarray(tpl.radii, dtype=float).reshape(-1)
        centers = np.asarray(tpl.centers, dtype=float).reshape(-1, 3)
        ipd = np.asarray(tpl.inertia_per_density, dtype=float).reshape(3)
        if (radii.size != centers.shape[0] or not np.all(np.isfinite(radii))
                or np.any(radii <= 0) or not np.all(np.isfinite(centers))):
            raise ConfigError("template radii must be finite and positive, one per centre "
                              "(finite too).")
        if not (math.isfinite(tpl.volume) and tpl.volume > 0
                and np.all(np.isfinite(ipd)) and np.all(ipd > 0)):
            raise ConfigError("template volume and inertia_per_density must be finite and "
                              "positive.")
        k = radii.size
        if k == 1 and not np.allclose(centers, 0.0):
            raise ConfigError("a one-sphere template must have its centre at the origin.")
        sc = _floats(1.0 if scales is None else scales, "scales", "-")
        if not (sc.ndim == 0 or sc.shape in ((1,), (n,))):
            what = "radii" if by_radii else "scales"
            raise ConfigError(f"{what} must be one number or one per particle (n = {n}), "
                              f"got shape {sc.shape}.")
        sc = np.broadcast_to(sc, (n,)).copy()
        if not (np.all(np.isfinite(sc)) and np.all(sc > 0)):
            raise ConfigError("scales must be finite positive numbers, got "
                              f"{sc[~(np.isfinite(sc) & (sc > 0))][0]}.")
        if isinstance(orientations, str):
            if orientations != "random":
                raise ConfigError(
                    f"orientations must be quaternions, 'random' or None, got {orientations!r}.")
            quat = _random_quaternions(n, np.random.default_rng(seed))
        elif orientations is None:
            quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        else:
            quat = _rows(orientations, n, 4, "orientations", "w, x, y, z")
            norm = np.linalg.norm(quat, axis=1, keepdims=True)
            if np.any(norm == 0):
                raise ConfigError("orientations must be non-zero quaternions (w, x, y, z).")
            quat = quat / norm
        vel = (np.zeros((n, 3)) if velocities is None
               else _rows(velocities, n, 3, "velocities", "m/s"))
        omg = (np.zeros((n, 3)) if angular_velocities is None
               else _rows(angular_velocities, n, 3, "angular_velocities", "rad/s"))
        fx = _flags(fixed, n, "fixed")
        locked = ~_flags(rotation, n, "rotation")
        if np.any(omg[locked] != 0.0):
            raise ConfigError("angular_velocities must be 0 for particles with "
                              "rotation=False (their rotation is locked).")
        # sphere extents for the domain and box checks
        rmax_particle = (np.linalg.norm(centers, axis=1) + radii).max() * sc
        if self.domain is not None:
            lo, hi = self.domain
            size = (hi - lo).min()
            big = 2 * rmax_particle > size
            if np.any(big):
                raise ConfigError(
                    f"a particle of diameter {2 * rmax_particle[big].max():.3g} m is larger "
                    f"than the domain ({size:.3g} m across); enlarge domain or shrink the "
                    "particle.")
            out = np.any((pos < lo) | (pos > hi), axis=1)
            if np.any(out):
                raise ConfigError(f"{int(out.sum())} particle position(s) lie outside the "
                                  "domain; move them inside or enlarge domain.")
        self._check_boxes(pos, 2 * rmax_particle)
        self._release_order()
        nb0, ns0 = self.n_particles, self.n_spheres
        off = (centers[None, :, :] * sc[:, None, None]).reshape(-1, 3)
        rad = (radii[None, :] * sc[:, None]).reshape(-1)
        body = np.repeat(np.arange(nb0, nb0 + n, dtype=np.int64), k)
        spos = np.empty((n * k, 3))
        for a in range(n):
            q = quat[a]
            for c in range(k):
                o = off[a * k + c]
                spos[a * k + c] = pos[a] + np.array(
                    _integ.quat_rotate(q[0], q[1], q[2], q[3], o[0], o[1], o[2]))
        self._check_overlaps(spos, rad, body, np.repeat(fx, k))
        try:
            tid = next(k for k, t in enumerate(self.templates) if t is tpl)
        except StopIteration:
            self.templates.append(tpl)
            tid = len(self.templates) - 1
        mass = rho * tpl.volume * sc ** 3
        inertia = rho * ipd[None, :] * sc[:, None] ** 5
        iso = _mean_inertia(inertia)
        inertia[locked] = np.inf      # 1/I = 0: no torque turns them
        # angular momentum L = R I R^T w
        angmom = np.empty((n, 3))
        for a in range(n):
            q = quat[a]
            wb = _integ.quat_rotate_inv(q[0], q[1], q[2], q[3], *omg[a])
            lb = np.array(wb) * inertia[a] if not locked[a] else np.zeros(3)
            angmom[a] = _integ.quat_rotate(q[0], q[1], q[2], q[3], *lb)
        b, s = self._b, self._s
        start_new = ns0 + k * np.arange(1, n + 1, dtype=np.int64)
        self._b = dict(
            pos=np.concatenate([b["pos"], pos]), vel=np.concatenate([b["vel"], vel]),
            quat=np.concatenate([b["quat"], quat]),
            angmom=np.concatenate([b["angmom"], angmom]),
            omega=np.concatenate([b["omega"], omg]),
            force=np.concatenate([b["force"], np.zeros((n, 3))]),
            torque=np.concatenate([b["torque"], np.zeros((n, 3))]),
            mass=np.concatenate([b["mass"], mass]),
            inertia=np.concatenate([b["inertia"], inertia]),
            iso=np.concatenate([b["iso"], iso]),
            mat=np.concatenate([b["mat"], np.full(n, mi, np.int64)]),
            template=np.concatenate([b["template"], np.full(n, tid, np.int64)]),
            scale=np.concatenate([b["scale"], sc]),
            fixed=np.concatenate([b["fixed"], fx]),
            start=np.concatenate([b["start"], start_new]))
        self._s = dict(body=np.concatenate([s["body"], body]),
                       offset=np.concatenate([s["offset"], off]),
                       radius=np.concatenate([s["radius"], rad]),
                       pos=np.concatenate([s["pos"], spos]),
                       ref=np.concatenate([s["ref"], spos]),
                       dsq=np.zeros(ns0 + n * k),
                       acc=np.zeros((ns0 + n * k, _forces.ACC_WIDTH)))
        # pad the per-sphere CSR starts: new spheres have empty rows until the rebuild
        p, q = self._p, self._q
        for d in (p, q):
            d["start"] = np.concatenate([d["start"], np.full(n * k, d["start"][-1], np.int64)])
        if self._old_of_new is not None:
            self._old_of_new = np.concatenate([self._old_of_new,
                                               np.full(n * k, -1, np.int64)])
        self._needs_rebuild = True
        self._forces_valid = False
        # re-derive the automatic step (smaller particles may need a smaller one), or
        # check a given step against the new particles, at the next step
        self._dt = None
        return np.arange(nb0, nb0 + n)

    def _check_boxes(self, pos, diameter):
        """ConfigError when a particle (bounding ``diameter`` [m]) is placed inside a
        :class:`~demcal.geometry.Box` wall (its current pose) that it cannot fit in: the
        smallest inner dimension of a closed box, the smaller width of an open one."""
        for g, wall in enumerate(getattr(self.walls, "walls", None) or ()):
            if getattr(wall, "kind_name", None) != "box":
                continue
            lower = np.asarray(wall.lower, dtype=float)
            upper = np.asarray(wall.upper, dtype=float)
            rot, trans = wall.motion.transform(self.time)
            ref = (pos - trans) @ rot   # R^T (x - T): the box's reference frame
            inside = np.all((ref > lower) & (ref < upper), axis=1)
            dims = upper - lower
            size = float((dims[:2] if getattr(wall, "open_top", False) else dims).min())
            big = inside & (diameter > size)
            if np.any(big):
                name = self.wall_names[g] if g < len(self.wall_names) else f"box{g}"
                raise ConfigError(
                    f"a particle {diameter[big].max():.3g} m across is placed inside box "
                    f"{name!r}, whose smallest inner dimension is {size:.3g} m; enlarge the "
                    "box or shrink the particle.")

    def _check_overlaps(self, spos, rad, body, fixed):
        """ConfigError naming the deepest overlap, beyond :attr:`overlap_tolerance` of
        the smaller radius, of a new sphere (``spos``, ``rad``, owning ``body`` index
        to be, ``fixed``) with a sphere of another particle, new or present."""
        if spos.shape[0] == 0:
            return
        from scipy.spatial import cKDTree
        s = self._s
        reach = float(rad.max())
        if s["pos"].shape[0]:
            reach += float(s["radius"].max())
            lo, hi = spos.min(axis=0) - reach, spos.max(axis=0) + reach
            near = np.nonzero(np.all((s["pos"] >= lo) & (s["pos"] <= hi), axis=1))[0]
        else:
            reach *= 2.0
            near = np.zeros(0, np.int64)
        m = near.size
        p = np.concatenate([s["pos"][near], spos])
        r = np.concatenate([s["radius"][near], rad])
        bd = np.concatenate([s["body"][near], body])
        fx = np.concatenate([self._b["fixed"][s["body"][near]], fixed])
        ij = cKDTree(p).query_pairs(reach, output_type="ndarray")
        i, j = ij[:, 0], ij[:, 1]
        sel = (np.maximum(i, j) >= m) & (bd[i] != bd[j]) & ~(fx[i] & fx[j])
        i, j = i[sel], j[sel]
        depth = r[i] + r[j] - np.linalg.norm(p[i] - p[j], axis=1)
        rel = depth / np.minimum(r[i], r[j])
        bad = rel > self.overlap_tolerance
        if not np.any(bad):
            return
        # pairs of particles (a clump may overlap another with several spheres)
        pairs = np.unique(np.sort(np.stack([bd[i][bad], bd[j][bad]], axis=1), axis=1),
                          axis=0)
        w = np.argmax(np.where(bad, rel, -np.inf))
        a, b = sorted((int(bd[i[w]]), int(bd[j[w]])))
        more = (f", and {len(pairs) - 1} more pair(s) overlap too" if len(pairs) > 1
                else "")
        raise ConfigError(
            f"particles {a} and {b} overlap by {depth[w]:.3g} m ({rel[w]:.0%} of the "
            f"smaller sphere's radius; at most {self.overlap_tolerance:.0%} is "
            f"accepted){more}; place the particles further apart or make them smaller.")

    def remove_particles(self, which):
        """Remove particles given by a boolean mask (one entry per particle) or indices
        (negative ones count from the end); the others keep their contact history."""
        nb = self.n_particles
        w = np.asarray(which)
        if w.dtype == np.bool_:
            if w.shape != (nb,):
                raise ConfigError(f"remove_particles: a mask needs one entry per particle "
                                  f"({nb}), got shape {w.shape}.")
        elif w.size == 0:
            return
        elif not np.issubdtype(w.dtype, np.integer):
            raise ConfigError(f"remove_particles: give particle indices (whole numbers) or "
                              f"a boolean mask, got {w.dtype} values.")
        else:
            bad = (w < -nb) | (w >= nb)
            if np.any(bad):
                raise ConfigError(f"remove_particles: index {int(w[bad].flat[0])} is out of "
                                  f"range; there are {nb} particle(s) (indices 0 to "
                                  f"{nb - 1}).")
        self._release_order()
        keep = np.ones(nb, bool)
        keep[w] = False
        if keep.all():
            return
        self._compact(keep)

    def _compact(self, keep):
        b, s = self._b, self._s
        nb = self.n_particles
        counts = np.diff(b["start"])
        skeep = np.repeat(keep, counts)
        old_sphere = np.nonzero(skeep)[0]
        new_start = np.concatenate([[0], np.cumsum(counts[keep])]).astype(np.int64)
        new_body_of_old = np.full(nb, -1, np.int64)
        new_body_of_old[keep] = np.arange(keep.sum())
        self._b = {k: (v[keep] if k != "start" else new_start) for k, v in b.items()}
        self._s = {k: v[skeep] for k, v in s.items()}
        self._s["body"] = new_body_of_old[self._s["body"]]
        prev = self._old_of_new  # compose with a renumbering not yet applied
        self._old_of_new = old_sphere if prev is None else prev[old_sphere]
        if self._perm is not None:
            # the user numbering closes up in order over the particles that stay
            self._perm = tuple(_closed_up(perm, kept)
                               for perm, kept in zip(self._perm, (keep, skeep)))
        self._needs_rebuild = True
        self._forces_valid = False

    # ------------------------------------------------------------------ ordering --
    #: Particles are reordered in space (cell order, as LIGGGHTS' ``atom_modify sort``)
    #: at a neighbour rebuild at most every ``sort_interval`` steps when there are at
    #: least ``sort_threshold`` spheres: neighbours in space become neighbours in
    #: memory. Users never see it: every public method and ``run()``'s reporters get the
    #: particles in user order (insertion order), and the sort is undone and redone
    #: in place, so views of the arrays stay live and results do not depend on how a
    #: run is split into calls.
    sort_threshold = 4096
    sort_interval = 1000

    def _permute(self, border):
        """Reorder the bodies in place so that new body k is old body ``border[k]`` (its
        spheres follow it); returns the sphere order (new sphere -> old sphere)."""
        b, s = self._b, self._s
        start = b["start"]
        counts = np.diff(start)
        c_new = counts[border]
        new_start = np.concatenate([[0], np.cumsum(c_new)]).astype(np.int64)
        sorder = (np.arange(new_start[-1], dtype=np.int64) - np.repeat(new_start[:-1], c_new)
                  + np.repeat(start[:-1][border], c_new))
        new_of_old = np.empty_like(border)
        new_of_old[border] = np.arange(border.size)
        for k, v in b.items():
            v[...] = new_start if k == "start" else v[border]
        for v in s.values():
            v[...] = v[sorder]
        s["body"][...] = new_of_old[s["body"]]
        return sorder

    def _sort_spatially(self, cell):
        """Sort the bodies by the cell (side ``cell``) of their centre of mass."""
        pos = self._b["pos"]
        key = np.floor((pos - pos.min(axis=0)) / cell).astype(np.int64)
        dims = key.max(axis=0) + 1
        border = np.argsort(key[:, 0] + dims[0] * (key[:, 1] + dims[1] * key[:, 2]),
                            kind="stable")
        self._last_sort = self.step_count
        if np.array_equal(border, np.arange(border.size)):
            return
        sorder = self._permute(border)
        self.sorts += 1
        prev = self._old_of_new
        self._old_of_new = sorder if prev is None else prev[sorder]
        if self._perm is None:
            self._perm = (border, sorder)
        else:
            self._perm = (self._perm[0][border], self._perm[1][sorder])

    def _user_order(self):
        """Put the arrays in user order (a no-op unless the engine has sorted them)."""
        if self._perm is None or self._user_view:
            return
        sorder = self._permute(np.argsort(self._perm[0]))
        self._carry_engine = self._old_of_new
        self._old_of_new = sorder if self._old_of_new is None else self._old_of_new[sorder]
        self._user_view = True

    def _engine_order(self):
        """Redo the engine's sort after :meth:`_user_order` (the lists stay valid)."""
        if not self._user_view:
            return
        self._permute(self._perm[0])
        self._old_of_new = self._carry_engine
        self._carry_engine = None
        self._user_view = False

    def _release_order(self):
        """The particle set is about to change: the user order becomes the engine's
        order (the next rebuild carries the contacts over through ``_old_of_new``)."""
        self._user_order()
        self._perm = None
        self._user_view = False
        self._carry_engine = None

    #: Below this many items a loop runs in the calling thread only.
    parallel_threshold = 2048

    def _par(self, fn, n, *args):
        """Run ``fn(*args, lo, hi)`` over [0, n) in ``self.threads`` contiguous chunks.

        The kernels are compiled with ``nogil=True``; each item is written by one chunk,
        so the result does not depend on the number of threads. Whether to split follows
        the number of particles, as for the step loop (handing a few thousand spheres of
        a two-sphere-clump heap to a thread costs more than it saves).
        """
        t = self.threads
        if not self._threaded(self.n_particles):
            return [fn(*args, 0, n)]
        bounds = [n * k // t for k in range(t + 1)]
        futs = [self._thread_pool().submit(fn, *args, bounds[k], bounds[k + 1])
                for k in range(t - 1)]
        last = fn(*args, bounds[t - 1], bounds[t])
        return [f.result() for f in futs] + [last]

    def _par_chunks(self, fn):
        """Run ``fn(c)`` for each chunk c of the split (``self.threads`` of them), each in
        a thread of its own."""
        t = self.threads
        futs = [self._thread_pool().submit(fn, c) for c in range(t - 1)]
        fn(t - 1)
        for f in futs:
            f.result()

    def _thread_pool(self):
        """The engine's worker threads (``threads - 1``; the caller's is the last)."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.threads - 1,
                                            thread_name_prefix="demcal-dem")
        return self._pool

    def _threaded(self, n):
        """Whether loops over ``n`` items are split between threads."""
        return self.threads > 1 and n >= self.parallel_threshold

    # ------------------------------------------------------------------ time step --
    @property
    def dt(self) -> float:
        """Time step [s] (derived from the particles on first use when not given)."""
        if self._dt is None:
            self._dt = self._resolve_dt()
        return self._dt

    def time_scales(self):
        """(Rayleigh time, shortest contact duration) [s] for the current particles."""
        if self.n_spheres == 0:
            raise ConfigError("add particles before asking for the time step.")
        mats = np.unique(self._b["mat"])
        t_r = math.inf
        pp, pw = [], []
        wmats = np.unique(self._w["material"])
        for m in mats:
            sel = self._b["mat"] == m
            bodies = np.nonzero(sel)[0]
            smask = np.isin(self._s["body"], bodies)
            rmin = self._s["radius"][smask].min()
            mmin = self._b["mass"][sel].min()
            mat = self.materials[m]
            t_r = min(t_r, _ts.rayleigh_time(rmin, mat.density, mat.shear_modulus,
                                             mat.poisson_ratio))
            for m2 in mats:
                pp.append((m, m2, rmin / 2.0, mmin / 2.0))
            for wm in wmats:
                pw.append((m, wm, rmin, mmin))
        t_c = _ts.contact_times(int(self._models[0]), self._table, pp, pw,
                                self.impact_speed)
        return t_r, t_c

    def _resolve_dt(self):
        t_r, t_c = self.time_scales()
        if self._dt_user is not None:
            _ts.check_dt(float(self._dt_user), int(self._models[0]), t_r, t_c)
            return float(self._dt_user)
        return _ts.choose_dt(int(self._models[0]), t_r, t_c, self.dt_fraction)

    @property
    def skin(self) -> float:
        """Neighbour skin [m]."""
        if self._skin_user is not None:
            return float(self._skin_user)
        if self.n_spheres == 0:
            return 0.0
        return 0.5 * float(self._s["radius"].max())

    # ------------------------------------------------------------------ neighbours --
    def _rebuild(self):
        s = self._s
        ns = self.n_spheres
        if ns and not np.all(np.isfinite(s["pos"])):
            raise SimulationError(
                f"particle positions became NaN or infinite at t = {self.time:.6g} s: the "
                f"time step {self.dt:.3g} s is too large for these stiffnesses or speeds; "
                "reduce dt.")
        if self.domain is not None and ns:
            lo, hi = self.domain
            out_s = np.any((s["pos"] < lo) | (s["pos"] > hi), axis=1)
            if np.any(out_s):
                gone = np.zeros(self.n_particles, bool)
                gone[np.unique(s["body"][out_s])] = True
                self.escaped += int(gone.sum())
                self._compact(~gone)
                s = self._s
                ns = self.n_spheres
        skin = self.skin
        if (ns >= self.sort_threshold and (self._last_sort is None
                                           or self.step_count - self._last_sort
                                           >= self.sort_interval)):
            self._sort_spatially(2.0 * float(s["radius"].max()) + skin)
        old_p, old_q = self._p, self._q
        old_of_new = self._old_of_new
        if old_of_new is None:
            old_of_new = np.arange(ns, dtype=np.int64)
            n_old = old_p["start"].shape[0] - 1
            old_of_new[old_of_new >= n_old] = -1
        start = np.zeros(ns + 1, np.int64)
        if ns:
            max_cells = max(8 * ns, 1000)
            lo, h, dims, rmax, cell_start, cell_order = _nl.build_cells(
                s["pos"], s["radius"], skin, max_cells)
            tmp = self._search(_nl.pair_rows, "_row_width", ns, start, s["pos"],
                               s["radius"], s["body"], skin, lo, h, dims, rmax,
                               cell_start, cell_order)
        npair = _nl.prefix_sum(start)
        cap = old_p["nbr"].shape[0]
        if npair > cap:
            cap = _nl.grown(cap, npair)
        spare = getattr(self, "_spare_p", None)
        if spare is not None and spare["nbr"].shape[0] >= cap:
            new_p = spare
            new_p["start"] = start
        else:
            new_p = dict(start=start, nbr=np.empty(cap, np.int64),
                         hist=np.empty((cap, HIST_WIDTH)),
                         out=np.zeros((cap, _forces.PAIR_OUT_WIDTH)),
                         act=np.zeros(cap, np.bool_))
        if ns:
            self._par(_nl.pack_rows, ns, tmp, start, new_p["nbr"])
            self._par(_nl.carry_history, ns, start, new_p["nbr"], new_p["hist"],
                      old_p["start"], old_p["nbr"], old_p["hist"], old_of_new, True)
            self._par(_nl.touching_last, ns, start, new_p["nbr"], new_p["hist"])
        new_p["act"][:npair] = new_p["hist"][:npair, 7] != 0.0
        new_p["act"][npair:] = False
        self._spare_p = old_p if old_p["nbr"].shape[0] >= cap else None
        self._p = new_p
        self._halo = None
        # walls
        w = self._w
        wstart = np.zeros(ns + 1, np.int64)
        if ns:
            wtmp = self._search(_nl.wall_rows, "_wall_width", ns, wstart, s["pos"],
                                s["radius"], skin, w["kind"], w["params"], w["aabb"])
        nq = _nl.prefix_sum(wstart)
        wcap = max(old_q["wid"].shape[0], 0)
        if nq > wcap:
            wcap = _nl.grown(wcap, nq)
        new_q = dict(start=wstart, wid=np.empty(wcap, np.int64),
                     hist=np.empty((wcap, HIST_WIDTH)),
                     out=np.zeros((wcap, _forces.OUT_WIDTH)), act=np.zeros(wcap, np.bool_))
        if ns:
            self._par(_nl.pack_rows, ns, wtmp, wstart, new_q["wid"])
            self._par(_nl.carry_history, ns, wstart, new_q["wid"], new_q["hist"],
                      old_q["start"], old_q["wid"], old_q["hist"], old_of_new, False)
        new_q["act"][:nq] = new_q["hist"][:nq, 7] != 0.0
        self._q = new_q
        s["ref"][:] = s["pos"]
        self._wall_travel = 0.0
        self._old_of_new = None
        self._needs_rebuild = False
        self.rebuilds += 1

    def _search(self, kernel, width_attr, ns, start, *args):
        """Run a one-pass neighbour search ``kernel(*args, tmp, counts, lo, hi)`` into a
        scratch table of width ``self.<width_attr>``, widening it and searching again when
        a row did not fit; leaves the counts in ``start[1:]`` and returns the table."""
        counts = start[1:]
        while True:
            width = getattr(self, width_attr)
            tmp = np.empty((ns, width), np.int64)
            self._par(kernel, ns, *args, tmp, counts)
            longest = int(counts.max()) if ns else 0
            if longest <= width:
                return tmp
            setattr(self, width_attr, int(1.25 * longest) + 1)

    # ------------------------------------------------------------------ stepping --
    def _halo_index(self):
        """The split's chunks (``self.threads`` equal runs of bodies) and the pair list's
        halo index for them (``neighbours.halo_index``), built once per list."""
        t = self.threads
        if self._halo is None or self._halo["chunks"].shape[0] != t + 1:
            nb = self.n_particles
            chunks = np.array([nb * c // t for c in range(t + 1)], np.int64)
            bounds = self._b["start"][chunks]
            rows, row, slots, slot, slot_deferred, deferred_start = _nl.halo_index(
                self._p["start"], self._p["nbr"], bounds)
            self._halo = dict(chunks=chunks, bounds=bounds, rows=rows, row=row,
                              slots=slots, slot=slot, slot_deferred=slot_deferred,
                              deferred_start=deferred_start,
                              deferred=np.zeros((slot.shape[0], HIST_WIDTH)))
        return self._halo

    def _compute_forces(self, kick):
        b, s, p, q, w = self._b, self._s, self._p, self._q, self._w
        dt = self.dt
        ns = self.n_spheres
        if ns:
            args = (self._models, self._table, dt, s["pos"], s["radius"], s["body"],
                    b["pos"], b["vel"], b["omega"], b["mass"], b["iso"], b["mat"],
                    p["start"], p["nbr"], p["hist"], p["out"], p["act"], s["acc"])
            if self._threaded(self.n_particles):
                h = self._halo_index()
                rows, bounds, slots = h["rows"], h["bounds"], h["slots"]
                self._par_chunks(lambda c: _forces.pair_forces(
                    *args, h["row"], slots, h["slot"], rows[c], rows[c + 1], h["deferred"],
                    h["deferred_start"][c], bounds[c], bounds[c + 1]))
                self._par_chunks(lambda c: _forces.commit_deferred(
                    p["hist"], p["act"], h["deferred"], h["slot"], h["slot_deferred"],
                    slots[rows[c]], slots[rows[c + 1]]))
            else:
                _forces.pair_forces(*args, _NO_HALO, _NO_HALO, _NO_HALO, 0, 0,
                                    _NO_DEFERRED, 0, 0, ns)
            self._par(_forces.wall_forces, ns, self._models, self._table, dt, s["pos"],
                      s["radius"], s["body"], b["pos"], b["vel"], b["omega"], b["mass"],
                      b["iso"], b["mat"], q["start"], q["wid"], q["hist"], q["out"],
                      q["act"], s["acc"], w["kind"], w["params"], w["velocity"],
                      w["omega"], w["origin"], w["material"])
        self._par(_integ.gather_kick, self.n_particles, dt, self.gravity, b["vel"],
                  b["quat"], b["angmom"], b["omega"], b["force"], b["torque"], b["mass"],
                  b["inertia"], b["fixed"], b["start"], s["acc"], kick)
        self._forces_valid = True

    def _prepare(self):
        self.dt  # noqa: B018  (resolve and check)
        if self._needs_rebuild:
            self._rebuild()
        if not self._forces_valid:
            self._compute_forces(False)

    def _drift(self):
        """One drift; returns the largest sphere displacement since the last build [m]."""
        b, s = self._b, self._s
        res = self._par(_integ.drift, self.n_particles, self.dt, b["pos"], b["vel"],
                        b["quat"], b["angmom"], b["omega"], b["force"], b["torque"],
                        b["mass"], b["inertia"], b["fixed"], b["start"], s["offset"],
                        s["pos"], s["ref"], s["dsq"])
        return math.sqrt(max(res))

    def _translations(self):
        """The compiled loop's table of walls it places itself (constant-velocity
        translations, ``WallSet.translations``), or None when some moving wall must be
        placed from Python before every step (a rotation, a function of time, or a
        wall whose motion changed since it was last placed)."""
        w = self.walls
        nw = self._w["kind"].shape[0]
        if (self._walls_moving and w is not None
                and any(g.motion.moving for g in getattr(w, "walls", ()))):
            return w.translations() if hasattr(w, "translations") else None
        return (np.zeros(nw, np.int64), np.zeros((nw, 3)), np.zeros(nw), np.zeros(nw),
                np.zeros((nw, 16)), np.zeros((nw, 3)))

    def _advance(self, nsteps):
        """Advance exactly ``nsteps`` steps."""
        if nsteps <= 0:
            return
        self._engine_order()
        if self.n_spheres == 0:
            dt = self._dt_user if self._dt_user else 0.0
            for _ in range(nsteps):
                self.step_count += 1
                self.time += dt
                if self._walls_moving:
                    self.walls.update(self.time)
            return
        self._sync_walls()
        self._prepare()
        dt = self.dt
        half_skin = 0.5 * self.skin
        done = 0
        per_step = None  # wall travel per step [m]; the bound moves with the spheres
        while done < nsteps:
            moves = self._translations()
            if moves is None:
                # a moving wall: one step at a time, the walls placed before each force
                disp = self._drift()
                self.time += dt
                self.step_count += 1
                done += 1
                self._move_walls(dt)
                if disp + self._wall_travel > half_skin or self._needs_rebuild:
                    self._rebuild()
                self._compute_forces(True)
                per_step = None
                continue
            if per_step is None:
                per_step = self._wall_speed(moves) * dt
            k, rebuild, self.time, self._wall_travel = self._run_compiled(
                nsteps - done, half_skin, per_step, moves)
            if moves[0].any():
                self._place_walls()  # the WallSet (and the bounding boxes) catch up
            self.step_count += k
            done += k
            if rebuild or self._needs_rebuild:
                self._rebuild()
                self._compute_forces(True)
                per_step = None

    def _run_compiled(self, nsteps, half_skin, per_step, moves):
        """Up to ``nsteps`` steps in one compiled call (:mod:`demcal.dem.stepper`):
        :func:`~demcal.dem.stepper.run_steps_split` on numba's threads when the
        particles are split between threads, :func:`~demcal.dem.stepper.run_steps`
        otherwise."""
        b, s, p, q, w = self._b, self._s, self._p, self._q, self._w
        head = (self.dt, self.time, self.gravity, self._models, self._table, half_skin,
                self._wall_travel, per_step,
                b["pos"], b["vel"], b["quat"], b["angmom"], b["omega"], b["force"],
                b["torque"], b["mass"], b["inertia"], b["iso"], b["mat"], b["fixed"],
                b["start"],
                s["body"], s["offset"], s["radius"], s["pos"], s["ref"], s["dsq"], s["acc"],
                p["start"], p["nbr"], p["hist"], p["out"], p["act"])
        tail = (q["start"], q["wid"], q["hist"], q["out"], q["act"],
                w["kind"], w["params"], w["velocity"], w["omega"], w["origin"],
                w["material"], *moves)
        if not self._threaded(self.n_particles):
            return _stepper.run_steps(nsteps, *head, *tail)
        h = self._halo_index()
        before = numba.get_num_threads()
        numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
        try:
            return _stepper.run_steps_split(nsteps, h["chunks"], *head, h["rows"],
                                            h["row"], h["slots"], h["slot"],
                                            h["slot_deferred"], h["deferred_start"],
                                            h["deferred"], *tail)
        finally:
            numba.set_num_threads(before)

    def _wall_speed(self, moves=None):
        """Upper bound of the speed [m/s] of any wall point within reach of a sphere
        (a translating row counts with its translation speed, moving yet or not)."""
        vel = self._w["velocity"]
        om = self._w["omega"]
        if moves is not None and moves[0].any():
            vel = np.where(moves[0][:, None] == 1, moves[1], vel)
        if not vel.size or not (np.any(vel) or np.any(om)):
            return 0.0
        sp = self._s["pos"]
        lo, hi = sp.min(axis=0), sp.max(axis=0)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        reach = np.linalg.norm(corners[None, :, :] - self._w["origin"][:, None, :],
                               axis=2).max(axis=1) + self.skin
        speed = np.linalg.norm(vel, axis=1) + np.linalg.norm(om, axis=1) * reach
        return float(speed.max())

    def _place_walls(self):
        """Move the walls to the current time and copy their rows into the engine."""
        w = self.walls
        w.update(self.time)
        for key in ("params", "velocity", "omega", "origin", "aabb"):
            self._w[key][...] = getattr(w, key)

    def _sync_walls(self):
        """Pick up a wall set changed since the last run (``WallSet.set_motion``,
        ``WallSet.remove``): copy its rows into the engine, rebuild the lists (a wall
        may have jumped) and re-evaluate the forces."""
        w = self.walls
        if w is None or getattr(w, "version", 0) == self._walls_version:
            return
        ids = getattr(w, "row_id", None)
        if ids is not None and not np.array_equal(ids, self._w["id"]):
            self._renumber_wall_contacts(np.asarray(ids, dtype=np.int64))
            self._wall_arrays()
        else:
            self._walls_version = w.version
            self._walls_moving = bool(w.moving)
            self._place_walls()
        self._needs_rebuild = True
        self._forces_valid = False

    def _renumber_wall_contacts(self, ids):
        """The wall rows are now those of ``ids`` (their ``row_id``s, in order): point
        the wall contacts at their rows' new numbers, and mark the contacts with a row
        that is gone (-1, inactive), so that the next rebuild drops their history."""
        old = self._w["id"]
        lookup = np.full(max(old.max(initial=-1), ids.max(initial=-1)) + 1, -1, np.int64)
        lookup[ids] = np.arange(ids.size)
        q = self._q
        nq = int(q["start"][-1])
        wid = q["wid"][:nq]
        gone = wid < 0                # a row removed before, not rebuilt since
        wid[...] = np.where(gone, -1, lookup[old[np.where(gone, 0, wid)]])
        q["act"][:nq] &= wid >= 0

    def remove_wall(self, name: str) -> None:
        """Take the wall called ``name`` (all its rows) out of the simulation.

        Allowed at any time, also from a reporter during a run: the particles stop
        feeling it from the next step on, the contacts against it are dropped with
        their history (the other walls' contacts keep theirs), and
        :meth:`wall_forces` no longer lists it. The wall set shared with the
        simulation loses the wall too (:meth:`~demcal.geometry.WallSet.remove`), so a
        checkpoint saved afterwards restarts in a simulation built without it.

        Raises
        ------
        ConfigError
            No wall has that name (the message lists the walls there are).
        """
        if self.walls is None or not hasattr(self.walls, "remove"):
            raise ConfigError(f"no wall named {name!r}: this simulation has no walls.")
        self.walls.remove(name)
        self._sync_walls()

    def _move_walls(self, dt):
        self._place_walls()
        self._wall_travel += self._wall_speed() * dt

    def run(self, duration=None, steps=None, reporters=()):
        """Advance by ``duration`` [s] (rounded to whole steps) or ``steps``.

        Reporters (OpenMM style) are objects with ``next_report(sim) -> int`` (steps until
        they next want data, >= 1) and ``report(sim)``; see :mod:`demcal.dem.reporters`.
        A reporter may add or remove particles, change gravity, or raise to stop.

        A run by duration ends at the requested time to within half a step: when
        particles added during the run shrink the automatic time step, the steps left
        are counted again from the time left. A given ``dt`` never changes, so the run
        takes exactly ``round(duration / dt)`` steps (reporters' ``start`` get that
        count).

        With a :attr:`gravity_schedule`, gravity is set at every window of its steps.

        Returns
        -------
        RunSummary
            Steps taken, simulated time [s], wall time [s], particles and
            particle-steps per second.
        """
        if (duration is None) == (steps is None):
            raise ConfigError("give run() exactly one of duration [s] or steps.")
        if steps is not None and not (_is_real(steps) and math.isfinite(steps)
                                      and steps == int(steps) and steps >= 0):
            raise ConfigError(f"steps must be a whole number >= 0, got {steps!r}.")
        if duration is not None and not (_is_real(duration) and math.isfinite(duration)
                                         and duration >= 0):
            raise ConfigError(f"duration must be a finite number of seconds >= 0, got "
                              f"{duration!r}.")
        self._check_gravity()
        if self.n_spheres:
            dt = self.dt
        else:
            dt = self._dt_user if self._dt_user else None
        end = None   # the time a run by duration ends at [s]
        if steps is None:
            if dt is None:
                raise ConfigError("add particles (or give dt) before running by duration.")
            steps = int(round(duration / dt))
            end = self.time + float(duration)
        steps = int(steps)
        reporters = list(reporters)
        for r in reporters:
            if hasattr(r, "start"):
                r.start(self, steps)
        done = 0
        particle_steps = 0
        t_start, clock = self.time, _time.perf_counter()
        try:
            while done < steps:
                want = [max(1, int(r.next_report(self))) for r in reporters]
                nxt = self._gravity_window(min([steps - done] + want))
                self._check_gravity()
                particle_steps += self.n_particles * nxt
                self._advance(nxt)
                done += nxt
                for r, k in zip(reporters, want):
                    if k == nxt:
                        r.report(self)
                if end is not None and done < steps and self._dt is None \
                        and self.n_spheres:
                    # particles were added: the automatic step may have shrunk
                    if self.dt != dt:
                        dt = self.dt
                        steps = done + max(0, int(round((end - self.time) / dt)))
        finally:
            self._user_order()
            for r in reporters:
                if hasattr(r, "finish"):
                    r.finish(self)
        return RunSummary(steps=done, simulated_time=self.time - t_start,
                          wall_time=_time.perf_counter() - clock,
                          particles=self.n_particles, particle_steps=particle_steps,
                          simulation=self)

    # ------------------------------------------------------------------ observables --
    @property
    def state(self) -> State:
        """Live views of the arrays (see :class:`State`)."""
        self._user_order()
        b, s = self._b, self._s
        return State(positions=b["pos"], velocities=b["vel"], omegas=b["omega"],
                     quaternions=b["quat"], angular_momenta=b["angmom"],
                     forces=b["force"], torques=b["torque"], masses=b["mass"],
                     inertias=b["inertia"], materials=b["mat"], templates=b["template"],
                     scales=b["scale"], fixed=b["fixed"], sphere_positions=s["pos"],
                     radii=s["radius"], sphere_body=s["body"], time=self.time,
                     step=self.step_count)

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy [J] of the free particles."""
        b = self._b
        free = ~b["fixed"]
        et = 0.5 * np.sum(b["mass"][free] * np.sum(b["vel"][free] ** 2, axis=1))
        er = 0.5 * np.sum(b["omega"][free] * b["angmom"][free])
        return float(et + er)

    def wall_forces(self) -> dict:
        """Force [N] and torque [N m] (about each row's origin) on every wall group.

        Returns ``{group name: (force (3,), torque (3,))}``; torques of a group's rows are
        summed about their own origins (identical for rigid groups sharing an origin).
        """
        nw = self._w["kind"].shape[0]
        out = np.zeros((nw, 6))
        if nw and self.n_spheres and self._forces_valid:
            _forces.wall_totals(self._q["start"], self._q["wid"], self._q["out"],
                                self._q["act"], nw, out)
        groups = self._w["group"]
        names = self.wall_names or [f"wall{g}" for g in range(int(groups.max()) + 1
                                                               if nw else 0)]
        res = {}
        for g, name in enumerate(names):
            sel = groups == g
            res[name] = (out[sel, :3].sum(axis=0), out[sel, 3:].sum(axis=0))
        return res

    def contacts(self):
        """Current particle-particle contacts as (i_sphere, j_sphere, force on i (3,))."""
        self._user_order()
        p = self._p
        rows = np.repeat(np.arange(p["start"].shape[0] - 1), np.diff(p["start"]))
        npair = int(p["start"][-1])
        active = p["act"][:npair]
        i, j = rows[active], p["nbr"][:npair][active]
        if self._perm is not None:  # the lists are in the engine's order
            i, j = self._perm[1][i], self._perm[1][j]
        return i, j, p["out"][:npair][active, :3]

    # ------------------------------------------------------------------ checkpoints --
    def save_checkpoint(self, path):
        """Write the full state (npz) so that :meth:`load_checkpoint` restarts bit-identically."""
        self._user_order()
        arrays = {}
        for prefix, d in (("b_", self._b), ("s_", self._s), ("p_", self._p), ("q_", self._q)):
            for k, v in d.items():
                arrays[prefix + k] = v
        arrays["scalars"] = np.array([self.time, self.step_count, self.dt, self._wall_travel,
                                      self.escaped, float(self._forces_valid),
                                      float(self._needs_rebuild), CHECKPOINT_VERSION,
                                      -1.0 if self._last_sort is None else self._last_sort])
        # the engine's spatial sort (the lists are in its order) and pending renumbering
        optional = dict(perm_b=None if self._perm is None else self._perm[0],
                        perm_s=None if self._perm is None else self._perm[1],
                        carry_engine=self._carry_engine, old_of_new=self._old_of_new)
        arrays.update({k: v for k, v in optional.items() if v is not None})
        arrays["gravity"] = self.gravity
        arrays["models"] = self._models
        tmp = str(path) + ".tmp.npz"
        np.savez(tmp, **arrays)
        import os
        os.replace(tmp, str(path))

    def load_checkpoint(self, path):
        """Restore a state written by :meth:`save_checkpoint` into this simulation.

        The simulation must have been built with the same materials, walls, contact model
        and particle templates (templates are referred to by index).
        """
        try:
            z = np.load(str(path))
        except (OSError, ValueError) as exc:
            raise ConfigError(f"cannot read checkpoint {path}: {exc}.") from None
        with z:
            if not np.array_equal(z["models"], self._models):
                raise ConfigError(f"checkpoint {path} was written with another contact model.")
            self._b = {k[2:]: z[k].copy() for k in z.files if k.startswith("b_")}
            self._s = {k[2:]: z[k].copy() for k in z.files if k.startswith("s_")}
            self._p = {k[2:]: z[k].copy() for k in z.files if k.startswith("p_")}
            for key in ("rev", "rev_start"):   # written before the halo index (unused)
                self._p.pop(key, None)
            self._q = {k[2:]: z[k].copy() for k in z.files if k.startswith("q_")}
            sc = z["scalars"]
            self.gravity = z["gravity"].copy()
            opt = {k: (z[k].copy() if k in z.files else None)
                   for k in ("perm_b", "perm_s", "carry_engine", "old_of_new")}
        if int(sc[7]) < 2:
            # format 1 (before per-sphere force sums): rebuild the derived arrays; the
            # forces are evaluated again on the next step (not bit-identical)
            self._b["iso"] = _mean_inertia(self._b["inertia"])
            self._s["acc"] = np.zeros((self._s["pos"].shape[0], _forces.ACC_WIDTH))
            for d in (self._p, self._q):
                d["out"] = np.zeros((d["hist"].shape[0], _forces.OUT_WIDTH))
                if "act" not in d:
                    d["act"] = d["hist"][:, 7] != 0.0
            sc = sc.copy()
            sc[5] = 0.0
        self.time = float(sc[0])
        self.step_count = int(sc[1])
        self._dt = float(sc[2])
        self._wall_travel = float(sc[3])
        self.escaped = int(sc[4])
        self._forces_valid = bool(sc[5])
        self._needs_rebuild = bool(sc[6])
        self._old_of_new = opt["old_of_new"]
        self._halo = None
        self._perm = None if opt["perm_b"] is None else (opt["perm_b"], opt["perm_s"])
        self._user_view = self._perm is not None
        self._carry_engine = opt["carry_engine"]
        self._last_sort = int(sc[8]) if sc.shape[0] > 8 and sc[8] >= 0 else None
        self._spare_p = None
        if self.walls is not None and self._walls_moving:
            self.walls.update(self.time)
            self._wall_arrays()
        return self


