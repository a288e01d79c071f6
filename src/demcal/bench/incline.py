"""Inclined plane: the static sliding angle of the material on agricultural film.

The paper's test (IJABE 2020, Section 3.1, Fig. 8): a plate covered by film tilts about
a spindle at a slow constant rate; a bottomless container on it holds the material; the
plate is stopped when container and material start to slide, the height ``H`` of the
container's starting point is read and ``theta = arcsin(H / L)`` with ``L = 300 mm``
(Eq. 5).

The simulation
--------------
* **Film plate.** An infinite plane of film material (``film.*`` settings: its own bulk
  values and its own particle-film interaction). It never moves: instead, *gravity is
  tilted* about the spindle axis (``y``) at ``incline.tilt_rate`` [deg/s],
  ``g(theta) = 9.81 (sin theta, 0, -cos theta)`` m/s2, so the slope runs down along
  ``+x``. In the plate's frame this is exact up to the inertial forces of a frame turning
  at a constant rate (centrifugal ``omega^2 r`` and Coriolis ``2 omega v``): at the quick
  profile's 5 deg/s, 0.3 m from the spindle and up to the detection speed they are below
  5e-4 g, and no wall motion has to be integrated. The tilt starts at
  ``incline.start_angle`` (default 5 deg; lowered automatically to
  ``atan(film.static_friction) - 5 deg`` when that is smaller): low, so the bed is at rest
  on the slope before it can slide (a bed set straight onto a 15 deg slope creeps from
  the jolt and blurs the onset).
* **Bottomless container.** A steel-coloured but *frictionless* cylinder (particle-container
  static and rolling friction 0) of diameter ``geometry.container_diameter`` x
  ``geometry.scale``, hovering a tenth of the smallest sphere radius above the film so it
  never touches it. The particles are generated in it and settle into a bed on the flat
  plate. While tilting, with ``incline.container = "follow"`` (default) the container
  moves along the slope with the material's mean velocity plus a yielding term
  ``v_ref F_x / W`` (``F_x`` the along-slope force the particles put on it, ``W`` their
  weight, ``v_ref`` = ``incline.container_yield``, 0.05 m/s), updated every 5 ms: it
  follows the material and keeps it together laterally, but gives way to any along-slope
  push instead of holding the material up (a container fixed to the plate would hold it
  by its downhill wall). The update is explicit, so ``v_ref`` must stay below about
  ``2 W / (k_bed * 5 ms)`` with ``k_bed`` the bed's stiffness against the wall: the first
  version's 1 m/s made the container oscillate against the bed (5 ms samples of the mean
  slope velocity jumping between 1 and 20 mm/s; a 1,500-particle bed "slid" at once),
  0.1 and 0.02 m/s both gave smooth signals, 0.02 about 1 deg later onsets. With
  ``"remove"`` the container is taken away once the bed has settled. With ``"rigid"``
  it moves only when pushed (:class:`RigidContainer`, updated every 0.5 ms): a container
  of ``incline.container_mass`` times the material's mass with rim friction
  ``incline.container_friction`` on the film, massless and frictionless by default, that
  gives way in proportion to the push beyond its rim's friction (overdamped). With
  ``"free"`` the container is a free body of that mass (:class:`FreeContainer`): it
  sticks while the rim's static friction holds and otherwise accelerates under the
  forces on it, as the lab's container, which slides with the material (paper §3.1).
  ``incline.container_wall_friction`` gives the container's wall friction against the
  particles (0 by default), through which it carries part of the material's weight onto
  its rim. Measured at the medium profile (docs/validation-incline.md, "A container that
  slides with the material"): a free container whose rim has the material's own friction
  raises the onset by 0.7-1.5 deg; a heavy one gripping the film harder than the material
  makes the response mostly its own (22.9-26.5 deg over mu' 0.4-0.6, 1.8 deg per 0.1 of
  mu' where atan mu' moves 4.6).
* **Onset of sliding.** Every 5 ms the mass-weighted mean velocity of the material along
  the slope ``v`` is recorded. Sliding is detected when ``v`` exceeds
  ``incline.slide_speed`` (default 0.02 m/s). A block starting to slide on a plane tilted
  at a constant rate accelerates as ``a ~ g (theta - theta_c)`` so ``v ~ (t - t_c)^2``:
  the onset ``t_c`` is found by fitting a straight line to ``sqrt(v)`` against ``t`` over
  the final rise (the samples since ``v``, averaged over 25 ms so the rattle of a loose
  bed does not count, last rose past 25 % of the detection speed) and extrapolating it
  to zero;
  ``sliding_angle_deg`` is the tilt at ``t_c`` (the tilt at detection is also reported,
  as ``sliding_angle_detected_deg``). If the material is already moving when the tilt
  begins (a bed whose own angle of repose is below the start angle collapses rather than
  slides), ``slid_at_start`` is 1 and the angle is only an upper bound.
* **Forces at the onset** (at the 5 ms sample nearest it): ``film_friction_ratio``, the
  material's along-slope force on the film over its normal force (the base friction
  mobilised, at most ``film.static_friction`` when the whole base slides), and
  ``container_push_ratio``, the material's along-slope force on the container over its
  weight. With ``base_*`` below they tell a base that slides from a bed that fails
  inside (docs/validation-incline.md).
* **Lab link.** ``equivalent_height_mm = L sin(theta)`` with ``L = incline.arm_length``
  (300 mm): the ruler reading the lab would have taken.

``incline.material = "block"`` replaces the loose particles by one rigid block -- a flat
3 x 3 clump of overlapping 5 mm spheres -- without a container: it must slide at
``atan(film.static_friction)`` (a check of the contact model and of the onset detection).

Profiles: ``tiny`` 120 particles tilted at 10 deg/s, ``quick`` 250 (about two layers in a
200 mm container at scale 4) at 5 deg/s, ``medium`` 1000 (about six layers) at 5 deg/s,
``paper`` 1500 (a bed about eight layers deep) at 1 deg/s. ``medium`` is the cheap proxy
of ``paper``: over eleven points (Table 7's box and four beyond it, mu' 0.4-1.11) its
five-seed mean lies 0.46 deg above the paper profile's (RMS 0.88 deg) at about a tenth of
the cost, where the quick bed lies 4.6 deg above (RMS 5.5 deg, up to 9.8 deg as mu' grows:
two layers slide at their base, while six and eight fail inside first;
docs/validation-incline.md, "Bed depth and the `medium` profile").
"""

from __future__ import annotations

import math

import numpy as np

from demcal.bench import common as C
from demcal.bench.experiment import BenchExperiment, Phase, Setup
from demcal.bench.registry import Setting, register
from demcal.dem.reporters import Reporter, StopRun
from demcal.errors import ConfigError

#: Controller and sampling interval [s].
CHECK = 0.005
#: Update interval of the rigid container [s].
RIGID_CHECK = 0.0005
#: Onset fit: the final rise starts where the mean slope velocity, averaged over
#: ONSET_SMOOTH samples (25 ms), last rose to ONSET_LOW x the detection speed.
ONSET_LOW = 0.25
ONSET_SMOOTH = 5


def block_template(radius: float = 0.005):
    """A flat 3 x 3 clump of spheres of ``radius`` [m] at 1.6 radius spacing."""
    from demcal.particles.templates import ParticleTemplate

    d = 1.6 * radius
    spheres = [[i * d, j * d, 0.0, radius] for i in (-1, 0, 1) for j in (-1, 0, 1)]
    return ParticleTemplate.from_spheres(spheres, name="block", resolution=128)


class Incline(BenchExperiment):
    name = "incline"
    profiles = ("tiny", "quick", C.MEDIUM, "paper")
    description = ("inclined-plane test on agricultural film: the plate tilts slowly until the "
                   "material in a bottomless container starts to slide; reports that angle")
    responses = ("sliding_angle_deg",)

    def _settings(self, profile):
        own = [
            Setting("incline.material", "particles", "-",
                    "loose particles in a container, or one rigid block (a check)",
                    choices=("particles", "block")),
            Setting("incline.container", "follow", "-",
                    "container during the tilt: follows the material's mean velocity, moves only "
                    "when pushed (rigid: overdamped; free: a free body of its own mass), or removed",
                    choices=("follow", "rigid", "free", "remove")),
            Setting("incline.tilt_rate", C.per_profile(profile, 10.0, 5.0, 1.0), "deg/s",
                    "tilting rate of the plate", 0.01, 90.0),
            Setting("incline.start_angle", 5.0, "deg",
                    "angle at which tilting starts (low, so the bed is at rest before it can slide)",
                    0.0, 80.0),
            Setting("incline.max_angle", 60.0, "deg", "give up above this angle", 1.0, 89.0),
            Setting("incline.container_yield", 0.05, "m/s",
                    "speed at which the following container gives way per unit of the "
                    "along-slope push on it over the material's weight", 0.0, 1.0),
            Setting("incline.container_mass", 0.0, "-",
                    "rigid or free container: its own mass over the material's", 0.0, 100.0),
            Setting("incline.container_friction", 0.0, "-",
                    "rigid or free container: static friction of its rim on the film", 0.0, 2.0),
            Setting("incline.container_wall_friction", 0.0, "-",
                    "static friction between the particles and the container's wall (0: a "
                    "frictionless wall; the rigid container refuses a rough one: use free)", 0.0, 2.0),
            Setting("incline.slide_speed", 0.02, "m/s",
                    "mean velocity along the slope that counts as sliding", 1e-4, 1.0),
            Setting("incline.visible_mm", 2.0, "mm",
                    "displacement of the material along the slope that counts as first visible motion "
                    "(sliding_angle_moved_deg)", 0.01, 100.0),
            Setting("incline.arm_length", 0.3, "m",
                    "L: container start to spindle, for H = L sin(theta) (paper: 300 mm)", 0.001, 10.0),
            Setting("geometry.scale", 4.0, "-", "container scale factor (as the repose platform)",
                    0.25, 20.0),
            Setting("geometry.container_diameter", 0.05, "m",
                    "bottomless container diameter at scale 1", 0.002, 2.0),
        ]
        return C.standard_settings(profile, (120, 250, 1500, 1000), own, (0.2, 0.2, 0.1), (20.0, 25.0, 60.0),
                                   film=True)

    # ------------------------------------------------------------------------------
    def build(self, s, seed, out_dir, vtk, progress):
        from demcal.geometry import Cylinder, Plane, WallSet
        from demcal.particles.insertion import CylinderRegion, insert
        from demcal.particles.materials import Interaction, steel

        block = s["incline.material"] == "block"
        if not block and s["incline.container"] == "free" and float(s["incline.container_mass"]) <= 0.0:
            FreeContainer(0.0, 0.0)  # its one sentence, before any particle is made
        if not block and s["incline.container"] == "rigid" and float(s["incline.container_wall_friction"]) > 0.0:
            # measured (benchmarks/studies/container-wall-2026-11-28, overdamped rows): a rough
            # wall drags the bed at the yield law's creeping pace, onsets 11-13 deg, detections 34-39
            raise ConfigError("incline.container = \"rigid\" gives way at a yield speed, so a rough wall "
                              "(incline.container_wall_friction > 0) would pace the material by that law; "
                              "use incline.container = \"free\" for a container with wall friction.")
        film = C.material_of(s, "film")
        mats = [C.material_of(s), film, steel()]

        def wall_of(mu_wall):
            return Interaction(restitution=s["wall.restitution"], static_friction=mu_wall, rolling_friction=0.0,
                               damping_factor=s["wall.damping_factor"],
                               stiffness_factor=s["particle.stiffness_factor"])

        slick, wall = wall_of(0.0), wall_of(float(s["incline.container_wall_friction"]))
        inter = {(0, 0): C.interaction(s, "particle"), (0, 1): C.interaction(s, "film"),
                 (0, 2): wall, "default": slick}
        mu = float(s["film.static_friction"])
        start = min(float(s["incline.start_angle"]), max(0.0, math.degrees(math.atan(mu)) - 5.0))
        max_angle = float(s["incline.max_angle"])
        if start >= max_angle:
            raise ConfigError(f"incline.start_angle ({start:g} deg) must be below incline.max_angle "
                              f"({max_angle:g} deg).")
        rate = math.radians(float(s["incline.tilt_rate"]))
        k = float(s["geometry.scale"])
        plane = Plane(point=(0, 0, 0), normal=(0, 0, 1), material=1, name="film")
        motion = C.DrivenTranslation()

        if block:
            tpl = block_template()
            walls = WallSet([plane])
            dt = C.time_step(s, mats, inter, walls, tpl, 1.0)
            sim = C.make_simulation(s, mats, inter, walls, dt)
            sim.add_particles(tpl, [[0.0, 0.0, 0.005 * 1.001]])
            n = 1
            settle_time = 0.1
            container = None
        else:
            tpl = C.template_for(s)
            sizes = C.sizes_for(s, tpl)
            n = C.count_of(s, tpl, sizes)
            b_max = float(tpl.bounding_radius) * sizes.max_scale
            r_c = 0.5 * k * float(s["geometry.container_diameter"])
            if 2 * r_c < 4 * 2 * b_max:
                raise ConfigError(
                    f"the container ({2 * r_c * 1e3:.0f} mm at scale {k:g}) is narrower than four of the "
                    f"largest particles ({2 * b_max * 1e3:.0f} mm): raise geometry.container_diameter or "
                    f"{C.size_advice(s, 2 * r_c / (4 * 2 * b_max))}.")
            fill_h = C.fill_height(n, tpl, sizes, 0.98 * r_c, b_max)
            gap = 0.1 * float(np.min(tpl.radii)) * sizes.min_scale
            container = Cylinder(base=(0, 0, gap), axis=(0, 0, 1), radius=r_c, length=fill_h + 2 * b_max,
                                 material=2, name="container", motion=motion)
            walls = WallSet([plane, container])
            dt = C.time_step(s, mats, inter, walls, tpl, sizes.min_scale)
            sim = C.make_simulation(s, mats, inter, walls, dt, skin=C.skin_for(tpl))
            region = CylinderRegion(centre=(0, 0, gap), radius=0.98 * r_c, height=fill_h)
            ins = insert(region, n, tpl, sizes=sizes, seed=seed)
            sim.add_particles(tpl, ins.positions, orientations=ins.orientations, scales=ins.scales, seed=seed)
            settle_time = None
        watch = C.Watch(sim, "incline", 1, out_dir, vtk, walls, "incline")
        progress(f"incline: {'one rigid block' if block else f'{n} particles'}, dt {sim.dt:.3g} s, "
                 f"tilt {math.degrees(rate):g} deg/s from {start:g} deg")

        # 1. the bed settles on the flat plate
        max_time = float(s["time.max_time"])
        if settle_time is not None:
            settle = Phase(duration=settle_time)
        else:
            settle = Phase(C.rest(float(s["time.rest_speed"])), max_time,
                           failure=f"the bed did not settle within time.max_time = {max_time:g} s; "
                                   "raise time.max_time.")

        # 2. tilt gravity at a constant rate; the container follows the material
        tilt = _Tilt(sim, s, motion, container, start, rate, block, progress)

        def start_tilt():
            if container is not None and s["incline.container"] == "remove":
                motion.place((0.0, 0.0, 100.0))
            progress(f"bed at rest at t {sim.time:.2f} s; tilting")

        tilting = Phase(tilt, chunk=None, start=start_tilt, reporters=[tilt.rim] if tilt.rim is not None else [],
                        ok=("sliding",),
                        failure=lambda: (f"the material did not slide up to {tilt.angles[-1]:.1f} deg "
                                         f"(incline.max_angle {max_angle:g} deg, time.max_time {max_time:g} s); "
                                         "raise them."))
        return Setup(sim, [settle, tilting], watch, info=dict(tilt=tilt, block=block, start=start, rate=rate,
                                                             particles=n))

    def measure(self, setup, s, out_dir, progress):
        tilt, block, start, rate = (setup.info[k] for k in ("tilt", "block", "start", "rate"))
        times, angles, speeds = tilt.times, tilt.angles, tilt.speeds
        film_ratio, push_ratio, moved_at = tilt.film_ratio, tilt.push_ratio, tilt.moved_at
        v_detect = tilt.v_detect
        base = base_kinematics(setup.sim.state) if not block else {}
        theta_c, theta_d = onset_angle(np.array(times), np.array(angles), np.array(speeds), v_detect)
        if not block:
            at = int(np.argmin(np.abs(np.array(angles) - theta_c)))
            base.update(film_friction_ratio=film_ratio[at], container_push_ratio=push_ratio[at])
        L = float(s["incline.arm_length"])
        progress(f"sliding at {theta_c:.2f} deg (detected at {theta_d:.2f} deg)")
        responses = {
            "sliding_angle_deg": theta_c,
            "sliding_angle_detected_deg": theta_d,
            # first visible motion, as the lab's observer reads it (paper §3.1: the plate
            # is stopped when container and material "began to slide")
            "sliding_angle_moved_deg": theta_d if moved_at is None else moved_at,
            "equivalent_height_mm": L * 1e3 * math.sin(math.radians(theta_c)),
            # 1 when the material was already moving as the tilt began: the angle is then
            # only an upper bound; lower incline.start_angle
            "slid_at_start": float(theta_c - start < 0.5),
            **base,
        }
        if theta_c - start < 0.5:
            progress(f"warning: the material moved as soon as tilting began at {start:g} deg; "
                     "the angle is an upper bound -- lower incline.start_angle")
        spread = {"sliding_angle_deg": math.degrees(rate) * CHECK}
        artifacts = {"vtk": setup.watch.path} if setup.watch.path else {}
        if out_dir is not None:
            artifacts["incline_png"] = _plot(out_dir, times, angles, speeds, theta_c, v_detect)
        return dict(responses=responses, spread=spread, particles=setup.info["particles"], artifacts=artifacts)


class _Tilt(Reporter):
    """The tilting phase as an engine reporter (:mod:`demcal.dem.reporters`): every
    ``CHECK`` seconds it samples the bed's mean slope velocity and the forces, lets a
    following container follow, ends the run when the bed slides (``StopRun("sliding")``)
    or passes ``incline.max_angle`` / ``time.max_time`` (``StopRun("limit")``), and sets
    gravity for the coming interval (its tilt at the interval's middle). A rigid container
    is a second reporter, :class:`_Rim`, every ``RIGID_CHECK`` seconds within the interval.
    """

    def __init__(self, sim, s, motion, container, start, rate, block, progress):
        self.sim, self.motion, self.block, self.progress = sim, motion, block, progress
        super().__init__(max(1, int(round(CHECK / sim.dt))))
        self.start_deg, self.rate = start, rate
        self.weight = float(sim.state.masses.sum()) * C.G
        self.follow = container is not None and s["incline.container"] == "follow"
        kind = s["incline.container"] if container is not None else None
        self.v_ref = float(s["incline.container_yield"])
        self.v_detect = float(s["incline.slide_speed"])
        self.visible = float(s["incline.visible_mm"]) * 1e-3
        self.max_angle, self.max_time = float(s["incline.max_angle"]), float(s["time.max_time"])
        self.times, self.angles, self.speeds = [], [], []
        self.film_ratio, self.push_ratio = [], []  # mobilised film friction; container push / weight
        self.moved_at = None  # tilt [deg] when the material had moved `visible` down the slope
        self._last = 0.0
        self.rim = None
        if kind in ("rigid", "free"):
            weight_c = float(s["incline.container_mass"]) * self.weight
            mu_rim = float(s["incline.container_friction"])
            body = (RigidContainer(weight_c, mu_rim, self.v_ref, self.weight) if kind == "rigid"
                    else FreeContainer(weight_c, mu_rim))
            self.rim = _Rim(self, body, max(1, int(round(RIGID_CHECK / sim.dt))))

    def start(self, sim, total_steps):
        """The tilt begins: from now (``t0``; the rigid container's reporter counts its
        steps from here too) and the bed's position now (``x0``)."""
        super().start(sim, total_steps)
        self.t0 = sim.time
        self.x0 = _mean_x(sim)
        self._set_gravity()

    def tilt_at(self, t):
        return math.radians(self.start_deg) + self.rate * (t - self.t0)

    def _set_gravity(self):
        self.theta = self.tilt_at(self.sim.time + 0.5 * self.interval * self.sim.dt)  # the coming interval's
        self.sim.gravity[:] = (C.G * math.sin(self.theta), 0.0, -C.G * math.cos(self.theta))

    def report(self, sim):
        C.show(sim)
        st = sim.state
        m = st.masses
        v = float((m * st.velocities[:, 0]).sum() / m.sum())
        self.times.append(sim.time)
        self.angles.append(math.degrees(self.tilt_at(sim.time)))
        self.speeds.append(v)
        if not self.block:
            forces = sim.wall_forces()
            fz = -float(forces["film"][0][2])
            self.film_ratio.append(float(forces["film"][0][0]) / fz if fz > 0 else float("nan"))
            self.push_ratio.append(float(forces["container"][0][0]) / self.weight)
        if self.moved_at is None and _mean_x(sim) - self.x0 >= self.visible:
            self.moved_at = self.angles[-1]
        if self.follow:  # (a container: not a block, so `forces` is this sample's)
            fx = float(forces["container"][0][0])
            xc = self.motion.offset[0] + self.motion.velocity[0] * self.interval * sim.dt
            vc = float(np.clip(v + self.v_ref * fx / self.weight, -0.5, 0.5))
            self.motion.place((xc, 0.0, 0.0), (vc, 0.0, 0.0))
        if sim.time - self._last >= 0.5:
            self._last = sim.time
            self.progress(f"tilt {self.angles[-1]:.2f} deg: mean slope velocity {v * 1e3:.2f} mm/s, "
                          f"displacement {(_mean_x(sim) - self.x0) * 1e3:.2f} mm")
        if v > self.v_detect:
            raise StopRun("sliding")
        if self.angles[-1] > self.max_angle or sim.time > self.t0 + self.max_time:
            raise StopRun("limit")
        self._set_gravity()


class _Rim:
    """A rigid or free container (:class:`RigidContainer`, :class:`FreeContainer`) moved by
    the forces on it, every ``interval`` steps within each of the tilt's intervals (counted
    from its start)."""

    def __init__(self, tilt, body, interval):
        self.tilt, self.body, self.interval = tilt, body, interval

    def next_report(self, sim) -> int:
        into = (sim.step_count - self.tilt._origin) % self.tilt.interval  # steps into the tilt's interval
        return min(self.interval - into % self.interval, self.tilt.interval - into)

    def report(self, sim):
        into = (sim.step_count - self.tilt._origin) % self.tilt.interval
        n_k = self.interval if into % self.interval == 0 else into % self.interval
        if into == 0:  # the end of a tilt interval: this piece was its last, maybe short
            n_k = self.tilt.interval % self.interval or self.interval
        motion = self.tilt.motion
        f = sim.wall_forces()["container"][0]  # the particles' force on it over the piece just run
        vc = self.body.velocity(float(f[0]), self.tilt.theta, load=-float(f[2]), dt=n_k * sim.dt)
        # A free body steps symplectic Euler (the new velocity, from the force where it
        # stood, moves it; with the old one this would be forward Euler, unstable against
        # the bed's stiffness); the overdamped rigid container keeps its first order.
        step = vc if self.body.integrates else motion.velocity[0]
        xc = motion.offset[0] + step * n_k * sim.dt
        motion.place((xc, 0.0, 0.0), (vc, 0.0, 0.0))


class _Ring:
    """What the rigid and the free container share: a ring of weight ``weight_c`` [N] on
    the film with rim friction ``mu``."""

    weight_c: float
    mu: float

    def rim(self, fx: float, theta: float, load: float) -> tuple[float, float]:
        """The along-slope drive on the ring (the particles' push ``fx`` plus its own
        weight's component) and the rim's friction limit, ``mu`` times its normal force
        (its weight's component plus the ``load`` the wall carries; a wall pulled up lifts
        the rim, never below zero)."""
        drive = fx + self.weight_c * math.sin(theta)
        return drive, self.mu * max(self.weight_c * math.cos(theta) + load, 0.0)


class RigidContainer(_Ring):
    """The along-slope motion of a rigid bottomless container moved only by the forces on it.

    The container (``incline.container = "rigid"``) is a rigid ring of weight ``weight_c``
    [N] resting on the film with rim friction ``mu``; the particles push it with ``fx``
    [N] along the slope (their contacts with its wall) and, through the wall's friction
    (``incline.container_wall_friction``), press it onto the film with ``load`` [N] (the
    part of the material's weight that the wall carries, Janssen's effect; 0 with a
    frictionless wall, the only wall the bench lets it have). It stays put while the push
    plus its own weight's slope component is within the rim's static friction
    ``mu (weight_c cos(theta) + load)``, and otherwise
    gives way at ``v_ref`` times the excess over ``weight`` (the material's weight) [m/s]:
    the overdamped limit of a free body, which needs no mass of its own (a free body,
    :class:`FreeContainer`, steps stably at the update interval only above a mass of
    ``k_bed dt^2 / 4``).
    With ``weight_c = 0`` it is a massless container that only keeps the material
    together: the downhill wall cannot hold the material back unless the uphill wall
    pushes it equally, so the bed slides only when its base does.
    """

    #: Its velocity is a function of the force, not integrated (see :class:`_Rim`).
    integrates = False

    def __init__(self, weight_c: float, mu: float, v_ref: float, weight: float):
        self.weight_c, self.mu, self.v_ref, self.weight = weight_c, mu, v_ref, weight

    def velocity(self, fx: float, theta: float, load: float = 0.0, dt: float = 0.0) -> float:
        drive, hold = self.rim(fx, theta, load)
        excess = max(abs(drive) - hold, 0.0)
        return float(np.clip(math.copysign(excess, drive) * self.v_ref / self.weight, -0.5, 0.5))


class FreeContainer(_Ring):
    """The lab's bottomless container as a free body sliding on the film (paper §3.1: the
    plate is stopped when "the bottomless container and the particulate material began to
    slide"; ``incline.container = "free"``).

    A rigid ring of weight ``weight_c`` [N] (its mass ``weight_c / g``) on the film, rim
    friction ``mu``: the rim's normal force is its own weight's normal component plus the
    ``load`` the particles put on it through the wall's friction (Janssen's effect). At
    rest it sticks while the along-slope drive (the particles' push ``fx`` plus its own
    weight's slope component) is within ``mu`` times that normal force; moving, it
    accelerates under the drive less the rim's friction against its velocity, and where
    the velocity would change sign it stops if the rim can hold it there. One step of
    ``dt`` per call; :class:`_Rim` moves it with the new velocity (symplectic Euler), which
    is stable for a container mass ``m`` while ``dt < 2 sqrt(m / k)``, ``k`` the bed's
    stiffness against the wall: at the 0.5 ms update, 2e5 N/m needs 13 g.
    """

    #: :class:`_Rim` steps its position with the velocity this returns.
    integrates = True

    def __init__(self, weight_c: float, mu: float):
        if weight_c <= 0.0:
            raise ConfigError("incline.container = \"free\" needs incline.container_mass above 0 (a free "
                              "body has a mass); set it, or use \"rigid\" for a massless container.")
        self.weight_c, self.mu = weight_c, mu
        self.mass = weight_c / C.G
        self.v = 0.0

    def velocity(self, fx: float, theta: float, load: float, dt: float) -> float:
        drive, hold = self.rim(fx, theta, load)
        held = abs(drive) <= hold
        if self.v == 0.0 and held:
            return 0.0
        against = self.v if self.v != 0.0 else drive  # friction opposes the motion, or the break-away
        v = self.v + (drive - math.copysign(hold, against)) * dt / self.mass
        if self.v != 0.0 and v * self.v <= 0.0:  # it turns within this step
            # the rim stops it there if it can; otherwise it breaks away the other way
            v = 0.0 if held else math.copysign(abs(drive) - hold, drive) * dt / self.mass
        self.v = v
        return v


def base_kinematics(st, touch: float = 0.05) -> dict[str, float]:
    """How the bed moves at the detection of sliding: on its base, and there by slip or roll.

    The basal bodies are those with a sphere within ``touch`` of its radius of the film
    (z = 0). ``base_mass_fraction`` is their share of the mass; ``base_velocity_ratio`` is
    their mass-weighted mean velocity along the slope over the whole bed's (1: the bed
    moves as one block; below 1: it shears above its base); ``base_slip_ratio`` is the
    mass-weighted mean velocity along the slope of their contact points
    (``v + omega x (p - x_com)`` at the sphere's lowest point) over their velocity (1:
    they slide on the film; 0: they roll on it without slipping).
    """
    sph_z = st.sphere_positions[:, 2] - st.radii
    touching = np.flatnonzero(sph_z < touch * st.radii)
    m = st.masses
    v_all = float((m * st.velocities[:, 0]).sum() / m.sum())
    if touching.size == 0 or abs(v_all) < 1e-12:
        return {}
    bodies = st.sphere_body[touching]
    slip = np.zeros(len(m))
    count = np.zeros(len(m))
    p = st.sphere_positions[touching].copy()
    p[:, 2] = 0.0
    arm = p - st.positions[bodies]
    w = st.omegas[bodies]
    vc = st.velocities[bodies, 0] + (w[:, 1] * arm[:, 2] - w[:, 2] * arm[:, 1])
    np.add.at(slip, bodies, vc)
    np.add.at(count, bodies, 1.0)
    base = np.flatnonzero(count > 0)
    mb = m[base]
    v_base = float((mb * st.velocities[base, 0]).sum() / mb.sum())
    slip_base = float((mb * slip[base] / count[base]).sum() / mb.sum())
    return {"base_mass_fraction": float(mb.sum() / m.sum()),
            "base_velocity_ratio": v_base / v_all,
            "base_slip_ratio": slip_base / v_base if abs(v_base) > 1e-12 else float("nan")}


def _mean_x(sim) -> float:
    st = sim.state
    return float((st.masses * st.positions[:, 0]).sum() / st.masses.sum())


def onset_angle(times, angles, speeds, v_detect, low: float = ONSET_LOW,
                smooth: int = ONSET_SMOOTH) -> tuple[float, float]:
    """(onset angle, detection angle) [deg] from the sampled mean slope velocity.

    The final rise is the last run of samples, up to the detection, whose velocity
    averaged over ``smooth`` neighbouring samples stays at or above ``low * v_detect``
    (the average keeps a bed's creep and rattle below that level from cutting the run
    short or starting it early). ``sqrt(v)`` of the raw samples of that run is fitted
    linearly in ``t`` and extrapolated to ``v = 0`` (at most two fitted spans back);
    with fewer than three samples in the run, its first sample gives the onset.
    """
    times = np.asarray(times, dtype=float)
    angles = np.asarray(angles, dtype=float)
    speeds = np.asarray(speeds, dtype=float)
    n = len(times)
    k = max(1, min(int(smooth), n))
    kernel = np.ones(k)
    mean_v = np.convolve(speeds, kernel, "same") / np.convolve(np.ones(n), kernel, "same")
    j = n - 1
    while j > 0 and mean_v[j - 1] >= low * v_detect:
        j -= 1
    t, a, v = times[j:], angles[j:], np.maximum(speeds[j:], 0.0)
    theta_d = float(angles[-1])
    if len(t) < 3:
        return float(a[0]), theta_d
    slope, intercept = np.polyfit(t, np.sqrt(v), 1)
    if slope <= 0:
        return float(a[0]), theta_d
    tc = -intercept / slope
    # an exact (t - tc)^2 rise puts tc 0.46 fitted spans back; allow at most two
    lo = max(times[0], t[0] - 2.0 * (t[-1] - t[0]))
    tc = float(np.clip(tc, lo, t[-1]))
    return float(np.interp(tc, times, angles)), theta_d


def _plot(out_dir, times, angles, speeds, theta_c, v_detect) -> str:
    from pathlib import Path

    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 3.6), dpi=110)
    ax = fig.add_subplot()
    ax.plot(angles, np.asarray(speeds) * 1e3, lw=1.2, color="C0")
    ax.axhline(v_detect * 1e3, color="0.5", ls=":", lw=1, label=f"detection {v_detect * 1e3:g} mm/s")
    ax.axvline(theta_c, color="C3", lw=1, label=f"onset {theta_c:.2f}°")
    ax.set_xlabel("tilt angle [deg]")
    ax.set_ylabel("mean velocity along the slope [mm/s]")
    ax.legend(frameon=False)
    ax.set_title("inclined plane: material velocity vs tilt")
    fig.tight_layout()
    path = Path(out_dir, "incline.png")
    from demcal._files import save_figure

    save_figure(fig, path)
    return str(path)


register(Incline())
