"""Angle of repose: the funnel (injection) method and the lifted cylinder.

repose-funnel (the paper's method, IJABE 2020 Section 2.2, Fig. 4b)
--------------------------------------------------------------------
Particles are generated at a rate in a cylindrical region above a conical funnel; they
fall into it, flow out of its outlet onto a round steel base plate and build a heap.
The run ends when every particle has been generated, the funnel is empty and the heap is
at rest: the root-mean-square particle speed ``sqrt(2 KE / M)`` (KE with rotation) stays
below ``time.rest_speed`` at two checks 0.02 s apart. Particles that roll off the plate
fall out of the domain and are removed. The heap is then measured by
:func:`demcal.measure.heap.measure_heap`: the silhouette seen from ``measure.views``
directions, a least-squares line on each flank between ``measure.band_low`` and
``measure.band_high`` of the heap height, averaged over flanks and views (the response
``repose_angle_deg``; its spread over the flanks in ``spread``), with ``atan(2H/D)`` and
the centre-of-mass cone ``atan(4 z_com / R)`` alongside. A picture of the silhouette with
the fitted lines is written to ``out_dir/heap.png``, the measurement to ``heap.json`` and
the final spheres to ``heap_spheres.npz`` (:mod:`demcal.io.spheres`).

Geometry. The paper scales its test platform 4x because its particles are large
(Section 2.2) but gives no dimensions. Our instrument, at scale 1 (lab size): a base
plate 250 mm across; a funnel with a 25 mm outlet, a 100 mm rim and a 50 mm high cone
(wall 53 deg from horizontal); the outlet ``geometry.outlet_height`` above the plate.
Every length is multiplied by ``geometry.scale`` (default 4, as in the paper); the
particles are not scaled (they are the paper's 4 mm + 5 mm two-sphere unit with size
factors ``particles.scale_min``-``particles.scale_max``, or a lab sieve table with
``particles.sizes = sieve``: :mod:`demcal.bench.common`). Before running, the geometry is
checked against the particle count: a heap of ``particles.count`` particles at 20 deg must
fit on the plate and one at 50 deg must stay below the outlet; the outlet must be at
least three of the largest particles wide.

Profiles: ``tiny`` 150 particles (outlet 20 mm high at scale 1), ``quick`` 1500 (50 mm),
``paper`` 20 000 (100 mm) -- the paper's 500 g
sample with the platform scaled 4x in every direction (500 g x 4^3 = 32 kg of particles
of 1.62 g on average).

repose-cylinder
---------------
A steel cylinder (``geometry.cylinder_diameter`` x scale) standing on the plate is filled
by random insertion, the particles settle (rest criterion as above), the cylinder lifts
at ``geometry.lift_speed`` until it clears the particles, and the heap comes to rest; it
is measured as above.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from demcal.bench import common as C
from demcal.bench.experiment import BenchExperiment, Phase, Setup
from demcal.bench.registry import Setting, register
from demcal.errors import ConfigError, DemcalError, SimulationError

#: Bulk solids fraction assumed for the pre-run size checks.
HEAP_SOLIDS = 0.55


def _repose_settings(profile, counts, before: list[Setting], after: list[Setting]) -> list[Setting]:
    """The table of both repose tests: the common keys around the platform scale and
    plate (test keys ``before`` and ``after`` them) and the heap measurement keys."""
    platform = [
        Setting("geometry.scale", 4.0, "-", "platform scale factor (paper: 4)", 0.25, 20.0),
        Setting("geometry.plate_diameter", 0.25, "m", "base plate diameter at scale 1", 0.01, 10.0),
    ]
    measure = [
        Setting("measure.views", 8, "-", "view directions around the heap axis (over 180 deg)", 1, 64),
        Setting("measure.band_low", 0.1, "-", "lower end of the flank fit, fraction of heap height", 0.0, 0.9),
        Setting("measure.band_high", 0.9, "-", "upper end of the flank fit, fraction of heap height", 0.1, 1.0),
    ]
    return C.standard_settings(profile, counts, before + platform + after, (0.2, 0.2, 0.1),
                               (6.0, 10.0, 40.0)) + measure


def _materials(s):
    from demcal.particles.materials import steel

    mats = [C.material_of(s), steel()]
    inter = {(0, 0): C.interaction(s, "particle"), (0, 1): C.interaction(s, "wall"),
             (1, 1): C.interaction(s, "wall")}
    return mats, inter


def _heap_volume(n, template, sizes) -> float:
    """Bulk volume [m3] of the particles at :data:`HEAP_SOLIDS`."""
    return n * template.volume * sizes.mean_cube() / HEAP_SOLIDS


def _cone_radius(volume: float, angle_deg: float) -> float:
    """Base radius [m] of a cone of ``volume`` with flank angle ``angle_deg``."""
    return (3.0 * volume / (math.pi * math.tan(math.radians(angle_deg)))) ** (1.0 / 3.0)


def _platform(s):
    """What both tests derive first: scale, template, sizes, count, plate radius [m] and
    the largest bounding radius [m]."""
    k = float(s["geometry.scale"])
    tpl = C.template_for(s)
    sizes = C.sizes_for(s, tpl)
    n = C.count_of(s, tpl, sizes)
    r_plate = 0.5 * k * s["geometry.plate_diameter"]
    return k, tpl, sizes, n, r_plate, C.bounding_radius(tpl) * sizes.max_scale


def _check_plate(tpl, sizes, n, k, r_plate) -> float:
    """The heap's bulk volume [m3]; raises unless its 20-deg cone fits on the plate."""
    vol = _heap_volume(n, tpl, sizes)
    r20 = _cone_radius(vol, 20.0)
    if r20 > r_plate:
        raise ConfigError(
            f"the base plate ({2 * r_plate:.2f} m across at scale {k:g}) is too small for "
            f"{n} particles: their heap at 20 deg would be {2 * r20:.2f} m across; raise "
            "geometry.plate_diameter or lower particles.count.")
    return vol


def _measure(sim, s, plate_radius, out_dir, watch, progress) -> dict:
    """Measure the heap at rest; write heap.png, heap.json and heap_spheres.npz to
    ``out_dir``; the run's result (responses, spread, counts, artifacts)."""
    from demcal.measure.heap import measure_heap

    progress(f"at rest at t {sim.time:.2f} s; measuring")
    st = sim.state
    png = Path(out_dir, "heap.png") if out_dir is not None else None
    lo, hi = float(s["measure.band_low"]), float(s["measure.band_high"])
    if hi <= lo:
        raise ConfigError(f"measure.band_high ({hi}) must exceed measure.band_low ({lo}).")
    try:
        m = measure_heap(st.sphere_positions.copy(), st.radii.copy(), base_z=0.0, axis_xy=(0.0, 0.0),
                         views=int(s["measure.views"]), band=(lo, hi), plate_radius=plate_radius,
                         png=png, title=None)
    except DemcalError as exc:
        raise SimulationError(f"the heap could not be measured: {exc}") from None
    artifacts = {}
    if png is not None:
        from demcal._files import write_atomic
        from demcal.io.spheres import SPHERES_FILE, write_spheres

        artifacts["heap_png"] = str(png)
        path = Path(out_dir, "heap.json")
        write_atomic(path, json.dumps(m.to_dict(), indent=1))
        artifacts["heap_json"] = str(path)
        # the final spheres, for the report's 3-D view of the heap and for measuring it again
        artifacts["heap_spheres"] = str(write_spheres(Path(out_dir, SPHERES_FILE), st.sphere_positions,
                                                      st.radii, base_z=0.0, plate_radius=plate_radius))
    responses = {
        "repose_angle_deg": m.angle_deg,
        "repose_angle_hd_deg": m.h_over_d_angle_deg,
        "repose_angle_com_deg": m.com_cone_angle_deg,
        "heap_fit_r2": m.r2,
        "heap_height_mm": m.height * 1e3,
        "heap_diameter_mm": m.diameter * 1e3,
        "particles_lost": float(sim.escaped),
    }
    if watch.path:
        artifacts["vtk"] = watch.path
    return dict(responses=responses, spread={"repose_angle_deg": m.spread_deg},
                particles=sim.n_particles + sim.escaped, steps=sim.step_count, simulated_s=sim.time,
                artifacts=artifacts)


class ReposeFunnel(BenchExperiment):
    name = "repose-funnel"
    description = ("angle of repose by the funnel (injection) method: particles flow through "
                   "a funnel onto a round plate; the heap at rest is measured from its silhouette")
    responses = ("repose_angle_deg",)

    def _settings(self, profile):
        P = C.per_profile
        rate = Setting("particles.rate", P(profile, 4000.0, 4000.0, 3000.0), "1/s",
                       "generation rate above the funnel (slowed down while the region is full)",
                       1.0, 1e6)
        return _repose_settings(profile, (150, 1500, 20000), [rate], [
            Setting("geometry.outlet_diameter", 0.025, "m", "funnel outlet diameter at scale 1", 0.001, 1.0),
            Setting("geometry.funnel_diameter", 0.1, "m", "funnel rim diameter at scale 1", 0.002, 2.0),
            Setting("geometry.funnel_height", 0.05, "m", "funnel cone height at scale 1", 0.001, 2.0),
            Setting("geometry.outlet_height", P(profile, 0.02, 0.05, 0.1), "m",
                    "outlet height above the plate at scale 1", 0.001, 5.0),
        ])

    def check(self, s):
        """Refuse settings whose funnel, plate or particles do not fit together, before any
        simulation is built (a campaign calls it when it loads)."""
        self._geometry(s)

    def _geometry(self, s):
        """Scale, template, sizes, count, plate radius, largest bounding radius, and the
        outlet radius, rim radius, cone height and outlet height [m], each checked."""
        k, tpl, sizes, n, r_plate, b_max = _platform(s)
        r_out = 0.5 * k * s["geometry.outlet_diameter"]
        r_top = 0.5 * k * s["geometry.funnel_diameter"]
        h_cone = k * s["geometry.funnel_height"]
        h_out = k * s["geometry.outlet_height"]
        if r_top <= r_out:
            raise ConfigError("geometry.funnel_diameter must exceed geometry.outlet_diameter.")
        if 2 * r_out < 3 * 2 * b_max:
            raise ConfigError(
                f"the funnel outlet ({2 * r_out * 1e3:.0f} mm at scale {k:g}) is narrower than three of "
                f"the largest particles ({2 * b_max * 1e3:.0f} mm): raise geometry.outlet_diameter or "
                f"geometry.scale, or {C.size_advice(s, 2 * r_out / (3 * 2 * b_max))}.")
        vol = _check_plate(tpl, sizes, n, k, r_plate)
        h50 = _cone_radius(vol, 50.0) * math.tan(math.radians(50.0))
        if h50 > h_out:
            raise ConfigError(
                f"the funnel outlet ({h_out:.2f} m above the plate at scale {k:g}) is too low for "
                f"{n} particles: their heap at 50 deg would be {h50:.2f} m high; raise "
                "geometry.outlet_height or lower particles.count.")
        return k, tpl, sizes, n, r_plate, b_max, r_out, r_top, h_cone, h_out

    def build(self, s, seed, out_dir, vtk, progress):
        from demcal.geometry import Disk, Funnel, WallSet
        from demcal.particles.insertion import CylinderRegion, Inserter

        k, tpl, sizes, n, r_plate, b_max, r_out, r_top, h_cone, h_out = self._geometry(s)
        mats, inter = _materials(s)
        walls = WallSet([
            Disk(centre=(0, 0, 0), normal=(0, 0, 1), radius=r_plate, material=1, name="plate"),
            Funnel(outlet=(0, 0, h_out), outlet_radius=r_out, top_radius=r_top, cone_height=h_cone,
                   material=1, name="funnel"),
        ])
        rim = h_out + h_cone
        region_h = max(2.0 * r_top, 6 * b_max)
        region = CylinderRegion(centre=(0.0, 0.0, rim + b_max), radius=r_top - 1.05 * b_max, height=region_h)
        if region.radius < 1.5 * b_max:
            raise ConfigError("the funnel rim is too narrow for the particles: raise geometry.funnel_diameter.")
        top = rim + b_max + region_h
        domain = ((-r_plate - 0.2, -r_plate - 0.2, -0.05), (r_plate + 0.2, r_plate + 0.2, top + 1.0))
        dt = C.time_step(s, mats, inter, walls, tpl, sizes.min_scale)
        sim = C.make_simulation(s, mats, inter, walls, dt, domain=domain, skin=C.skin_for(tpl))
        inserter = Inserter(region, n, tpl, sizes=sizes, rate=float(s["particles.rate"]), seed=seed)
        watch = C.Watch(sim, "repose-funnel", 1, out_dir, vtk, walls, "repose_funnel")
        progress(f"repose-funnel: {n} particles, dt {dt:.3g} s, plate {2 * r_plate:.2f} m, "
                 f"outlet {2 * r_out * 1e3:.0f} mm at {h_out:.2f} m")

        def add():
            C.insert_due(sim, inserter, tpl, seed)

        add()
        settle = C.rest(float(s["time.rest_speed"]))
        last_report = [0.0]
        held = [0]      # particles held on the funnel wall at the end, left out

        def each():
            add()
            if sim.time - last_report[0] >= 0.25:
                last_report[0] = sim.time
                progress(f"t {sim.time:.2f} s: {sim.n_particles} particles in, {sim.escaped} off the plate, "
                         f"rms speed {C.rms_speed(sim):.3f} m/s")

        def stop():
            st = sim.state
            if not inserter.done:
                return False
            inside = st.positions[:, 2] > h_out - 0.5 * b_max
            in_funnel = int(inside.sum())
            if in_funnel and _jammed(sim, h_out, b_max):
                if in_funnel > _held_limit(st.n + held[0]):
                    raise SimulationError(
                        f"the funnel jammed with {in_funnel} particles in it at t = "
                        f"{sim.time:.2f} s; raise geometry.outlet_diameter or geometry.scale.")
                # a few grains held on the funnel's wall, not an arch: as in the lab they
                # stay in the funnel, out of the heap and out of its silhouette
                progress(f"t {sim.time:.2f} s: {in_funnel} particle(s) held on the funnel wall, "
                         "left out of the heap")
                held[0] += in_funnel
                sim.remove_particles(inside)
                in_funnel = 0
            return settle.at_rest(sim, in_funnel == 0)

        def not_at_rest():
            in_funnel = int(np.sum(sim.state.positions[:, 2] > h_out - 0.5 * b_max))
            return (f"the heap was not at rest after time.max_time = {s['time.max_time']:g} s "
                    f"({in_funnel} particles still in the funnel, rms speed {C.rms_speed(sim):.3g} m/s); "
                    "raise time.max_time.")

        # one phase: the pour through the funnel until the heap is at rest
        pour = Phase(stop, float(s["time.max_time"]), each=each, failure=not_at_rest)
        return Setup(sim, [pour], watch, info=dict(r_plate=r_plate, held=held))

    def measure(self, setup, s, out_dir, progress):
        out = _measure(setup.sim, s, setup.info["r_plate"], out_dir, setup.watch, progress)
        held = setup.info["held"][0]
        out["responses"]["particles_held"] = float(held)
        out["particles"] += held
        return out


def _held_limit(n: int) -> int:
    """At most this many static particles left in the funnel count as grains held on its
    wall (0.5 % of the particles, at least 3); more are an arch over the outlet."""
    return max(3, int(0.005 * n))


def _jammed(sim, h_out, b_max) -> bool:
    """Particles in the funnel and none of them moving: an arch over the outlet."""
    st = sim.state
    inside = st.positions[:, 2] > h_out - 0.5 * b_max
    if not inside.any():
        return False
    speed = np.linalg.norm(st.velocities[inside], axis=1)
    return bool(speed.max() < 1e-3)


class ReposeCylinder(BenchExperiment):
    name = "repose-cylinder"
    description = ("angle of repose by the lifted cylinder: a cylinder on the plate is filled, "
                   "lifted, and the heap at rest is measured from its silhouette")
    responses = ("repose_angle_deg",)

    def _settings(self, profile):
        P = C.per_profile
        return _repose_settings(profile, (250, 1000, 20000), [], [
            Setting("geometry.cylinder_diameter", P(profile, 0.03, 0.03, 0.08), "m",
                    "cylinder inner diameter at scale 1", 0.002, 2.0),
            Setting("geometry.lift_speed", P(profile, 0.1, 0.1, 0.05), "m/s",
                    "cylinder lifting speed", 0.001, 10.0),
        ])

    def check(self, s):
        """Refuse settings whose cylinder, plate or particles do not fit together, before
        any simulation is built (a campaign calls it when it loads)."""
        self._geometry(s)

    def _geometry(self, s):
        """Scale, template, sizes, count, plate radius, largest bounding radius and
        cylinder radius [m], each checked."""
        k, tpl, sizes, n, r_plate, b_max = _platform(s)
        r_cyl = 0.5 * k * s["geometry.cylinder_diameter"]
        if 2 * r_cyl < 4 * 2 * b_max:
            raise ConfigError(
                f"the cylinder ({2 * r_cyl * 1e3:.0f} mm at scale {k:g}) is narrower than four of the "
                f"largest particles ({2 * b_max * 1e3:.0f} mm): raise geometry.cylinder_diameter or "
                f"{C.size_advice(s, 2 * r_cyl / (4 * 2 * b_max))}.")
        _check_plate(tpl, sizes, n, k, r_plate)
        return k, tpl, sizes, n, r_plate, b_max, r_cyl

    def build(self, s, seed, out_dir, vtk, progress):
        from demcal.geometry import Cylinder, Disk, Translation, WallSet
        from demcal.particles.insertion import CylinderRegion, insert

        k, tpl, sizes, n, r_plate, b_max, r_cyl = self._geometry(s)
        fill_h = C.fill_height(n, tpl, sizes, r_cyl - 0.01 * r_cyl, b_max)
        motion = C.DrivenTranslation()
        mats, inter = _materials(s)
        gap = 0.1 * float(np.min(tpl.radii)) * sizes.min_scale
        walls = WallSet([
            Disk(centre=(0, 0, 0), normal=(0, 0, 1), radius=r_plate, material=1, name="plate"),
            Cylinder(base=(0, 0, gap), axis=(0, 0, 1), radius=r_cyl, length=fill_h + 2 * b_max,
                     material=1, name="cylinder", motion=motion),
        ])
        domain = ((-r_plate - 0.2, -r_plate - 0.2, -0.05), (r_plate + 0.2, r_plate + 0.2, 4 * fill_h + 1.0))
        dt = C.time_step(s, mats, inter, walls, tpl, sizes.min_scale)
        sim = C.make_simulation(s, mats, inter, walls, dt, domain=domain, skin=C.skin_for(tpl))
        region = CylinderRegion(centre=(0, 0, 0), radius=r_cyl * 0.99, height=fill_h)
        ins = insert(region, n, tpl, sizes=sizes, seed=seed)
        sim.add_particles(tpl, ins.positions, orientations=ins.orientations, scales=ins.scales, seed=seed)
        watch = C.Watch(sim, "repose-cylinder", 1, out_dir, vtk, walls, "repose_cylinder")
        progress(f"repose-cylinder: {n} particles, dt {dt:.3g} s, cylinder {2 * r_cyl * 1e3:.0f} mm")
        max_time = float(s["time.max_time"])
        limit = float(s["time.rest_speed"])
        v = float(s["geometry.lift_speed"])
        lift = {}

        def start_lift():
            progress(f"settled at t {sim.time:.2f} s; lifting")
            st = sim.state
            top = float((st.sphere_positions[:, 2] + st.radii).max())
            lift["clear"] = sim.time + (top + b_max) / v
            # a steady lift, placed at every step by the engine's compiled loop
            walls.set_motion("cylinder", Translation(velocity=(0.0, 0.0, v), start=sim.time, stop=lift["clear"]))

        def out_of_the_way():
            motion.place((0.0, 0.0, 10.0 * (fill_h + 1.0)))
            walls.set_motion("cylinder", motion)

        phases = [
            Phase(C.rest(limit), max_time, failure=f"the filled cylinder did not settle within "
                                                   f"time.max_time = {max_time:g} s; raise time.max_time."),
            Phase(lambda: sim.time >= lift["clear"], max_time, start=start_lift),
            Phase(C.rest(limit), max_time, start=out_of_the_way,
                  failure=f"the heap was not at rest after time.max_time = {max_time:g} s; raise time.max_time."),
        ]
        return Setup(sim, phases, watch, info=dict(r_plate=r_plate))

    def measure(self, setup, s, out_dir, progress):
        return _measure(setup.sim, s, setup.info["r_plate"], out_dir, setup.watch, progress)


register(ReposeFunnel())
register(ReposeCylinder())
