"""The rotating drum: the dynamic angle of repose of a turning bed.

drum
----
A closed steel drum (``geometry.drum_diameter`` across, ``geometry.drum_width`` between
its end walls, axis horizontal along y) is filled to ``geometry.fill`` of its volume (at
a bulk solids fraction of :data:`BED_SOLIDS`, so the count follows from the fill and the
particles' mean volume) by random insertion into a box inside it, as many at a time as
fit while the first ones fall; the bed settles
(rest criterion as the heaps'), then the drum turns at ``drum.rpm`` about its axis (the
engine's compiled rotating walls: shell and both ends). After ``drum.spin_up_turns``
turns, ``measure.frames`` frames spread over ``measure.frame_turns`` turns are measured
(:func:`demcal.measure.drum.surface_angle`: the bed's outline seen along the axis, read
along the bed's own normal, a line fitted to its central part between
``measure.band_low`` and ``measure.band_high`` of its length). The response
``dynamic_angle_deg`` is the frames' mean, its spread their standard deviation;
``froude_number`` (omega^2 R / g) and ``regime_index`` (0 slumping, 1 rolling, 2
cascading, 3 cataracting: :data:`demcal.measure.drum.REGIMES`) go with it.
A picture of the last frame with its fitted line is written to ``out_dir/drum.png``,
the frames' angles to ``drum.json``.

The drum is checked before anything runs: the fill in (0, 1), a bed that centrifuges
(Fr >= 1) refused, the width at least two of the largest particles (their bounding
spheres: 26 mm for the paper's unit at size factor 1.5).

Profiles, sized for the paper's particles (a 4 mm + 5 mm radius two-sphere unit, 17 mm
long at size factor 1, 0.5-1.5x: the paper scales its platform 4x for them): ``tiny`` a
200 mm drum 60 mm wide (about 320 particles), ``quick`` 300 mm x 80 mm (about 980),
``paper`` 600 mm x 160 mm (about 7,800), all at 30 % fill and 5 rpm (rolling: Fr
0.003-0.008); the drum is 8-23 of the largest particles across (a laboratory drum is
30 or more grain sizes across: these drums measure the paper's scaled particles as its
scaled platform does). The tiny bed is four or five particles deep: its surface swings
by 6-8 deg (sd) from frame to frame as it avalanches, so tiny reads 24 frames over half a
turn (their mean within 1.2-1.7 deg of the run's time average; six frames left 2.5-3.4);
a drum 100 mm wide read 2 deg lower for 1.7 times the particles and the time
(benchmarks/studies/drum-physics-2026-11-29).
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
from demcal.measure.drum import froude, plot_surface, regime, surface_angle

#: Bulk solids fraction of the settled bed, for the particle count from the fill.
BED_SOLIDS = 0.55


class Drum(BenchExperiment):
    name = "drum"
    description = ("dynamic angle of repose in a rotating drum: a closed drum partly filled turns "
                   "at a set speed; the free surface of the flowing bed is measured over frames")
    responses = ("dynamic_angle_deg",)

    def _settings(self, profile):
        P = C.per_profile
        own = [
            Setting("geometry.drum_diameter", P(profile, 0.2, 0.3, 0.6), "m", "drum inner diameter", 0.01, 5.0),
            Setting("geometry.drum_width", P(profile, 0.06, 0.08, 0.16), "m",
                    "drum inner width between its end walls", 0.005, 5.0),
            Setting("geometry.fill", 0.3, "-", "fill fraction of the drum's volume (bulk)", 0.01, 0.99),
            Setting("drum.rpm", 5.0, "1/min", "drum speed", 0.01, 1000.0),
            Setting("drum.spin_up_turns", P(profile, 0.25, 0.5, 1.0), "-",
                    "turns before the first frame (the bed reaches its steady flow)", 0.0, 100.0),
            Setting("measure.frames", P(profile, 24, 10, 20), "-", "frames measured", 1, 1000),
            Setting("measure.frame_turns", P(profile, 0.5, 0.5, 1.0), "-",
                    "turns the frames are spread over", 0.0, 100.0),
            Setting("measure.band_low", 0.25, "-", "lower end of the surface fit, fraction of the outline's "
                    "length", 0.0, 0.9),
            Setting("measure.band_high", 0.75, "-", "upper end of the surface fit, fraction of the outline's "
                    "length", 0.1, 1.0),
        ]
        particles = [p for p in C.particle_settings(profile, 1) if p.key != "particles.count"]
        return (C.material_settings() + particles + own
                + C.time_settings(profile, P(profile, 0.2, 0.2, 0.1), P(profile, 6.0, 10.0, 40.0)))

    def build(self, s, seed, out_dir, vtk, progress):
        from demcal.geometry import Rotation, WallSet, closed_drum
        from demcal.particles.insertion import BoxRegion, Inserter
        from demcal.particles.materials import steel

        tpl = C.template_for(s)
        sizes = C.sizes_for(s, tpl)
        b_max = C.bounding_radius(tpl) * sizes.max_scale
        radius, width = 0.5 * float(s["geometry.drum_diameter"]), float(s["geometry.drum_width"])
        fill, rpm = float(s["geometry.fill"]), float(s["drum.rpm"])
        fr = froude(rpm, radius)
        if not 0.0 < fill < 1.0:
            raise ConfigError(f"geometry.fill must lie between 0 and 1 (a fraction of the drum's volume), "
                              f"got {fill:g}.")
        if fr >= 1.0:
            raise ConfigError(f"at {rpm:g} rpm the {2 * radius * 1e3:.0f} mm drum centrifuges its bed "
                              f"(Froude number {fr:.2f} >= 1): no surface to measure; lower drum.rpm.")
        if width < 4.0 * b_max:
            raise ConfigError(f"the drum ({width * 1e3:.0f} mm wide) is narrower than two of the largest "
                              f"particles ({2 * b_max * 1e3:.0f} mm): raise geometry.drum_width or "
                              f"{C.size_advice(s, width / (4.0 * b_max))}.")
        bed = fill * math.pi * radius ** 2 * width * BED_SOLIDS
        n = int(round(bed / (tpl.volume * sizes.mean_cube())))
        if n < 10:
            raise ConfigError(f"a {fill:g} fill of the drum holds only {n} particles; raise geometry.fill "
                              "or the drum's size.")
        mats = [C.material_of(s), steel()]
        inter = {(0, 0): C.interaction(s, "particle"), (0, 1): C.interaction(s, "wall")}
        walls = WallSet(closed_drum(radius, width, material=1, name="drum"))
        domain = ((-radius - 0.05, -0.5 * width - 0.05, -radius - 0.05),
                  (radius + 0.05, 0.5 * width + 0.05, radius + 0.05))
        dt = C.time_step(s, mats, inter, walls, tpl, sizes.min_scale)
        sim = C.make_simulation(s, mats, inter, walls, dt, domain=domain, skin=C.skin_for(tpl))
        side = 0.7 * radius - b_max
        region = BoxRegion((-side, -0.5 * width + 1.05 * b_max, -side), (side, 0.5 * width - 1.05 * b_max, side))
        # all now, the rest as room frees up: a particle that finds no room in 64 tries waits for
        # the next look
        inserter = Inserter(region, n, tpl, sizes=sizes, seed=seed, max_attempts=64)
        watch = C.Watch(sim, "drum", 1, out_dir, vtk, walls, "drum")
        omega = 2.0 * math.pi * rpm / 60.0
        turn = 2.0 * math.pi / omega
        progress(f"drum: {n} particles, dt {dt:.3g} s, {2 * radius * 1e3:.0f} x {width * 1e3:.0f} mm, "
                 f"{rpm:g} rpm, Fr {fr:.3g} ({regime(fr)[1]})")

        def add():
            C.insert_due(sim, inserter, tpl, seed)

        settle = C.rest(float(s["time.rest_speed"]))
        frames: list = []
        n_frames = int(s["measure.frames"])
        band = (float(s["measure.band_low"]), float(s["measure.band_high"]))
        if band[1] <= band[0]:
            raise ConfigError(f"measure.band_high ({band[1]}) must exceed measure.band_low ({band[0]}).")
        spacing = float(s["measure.frame_turns"]) * turn / max(n_frames - 1, 1)
        max_time = float(s["time.max_time"])

        def turn_drum():
            progress(f"filled and settled at t {sim.time:.2f} s; turning at {rpm:g} rpm")
            motion = Rotation(point=(0, 0, 0), axis=(0, 1, 0), angular_speed=omega, start=sim.time)
            for name in ("drum", "drum-front", "drum-back"):
                walls.set_motion(name, motion)

        def frame():
            st = sim.state
            try:
                fit = surface_angle(st.sphere_positions, st.radii, radius, band)
            except DemcalError as exc:
                raise SimulationError(f"the drum's surface could not be measured: {exc}") from None
            frames.append((sim.time, fit, st.sphere_positions.copy()))
            progress(f"t {sim.time:.2f} s: frame {len(frames)} of {n_frames}, surface {fit.angle_deg:.1f} deg")

        add()
        phases = [
            Phase(lambda: inserter.done and settle.at_rest(sim, True), max_time, each=add,
                  failure=f"the drum's bed did not settle within time.max_time = {max_time:g} s; "
                          "raise time.max_time."),
            Phase(duration=float(s["drum.spin_up_turns"]) * turn, start=turn_drum),
            Phase(lambda: len(frames) >= n_frames, None, chunk=spacing if n_frames > 1 else dt, each=frame),
        ]
        return Setup(sim, phases, watch, info=dict(radius=radius, frames=frames, froude=fr, n=n))

    def measure(self, setup, s, out_dir, progress):
        info = setup.info
        frames = info["frames"]
        angles = np.array([f.angle_deg for _, f, _ in frames])
        fr = info["froude"]
        index, name = regime(fr)
        progress(f"dynamic angle {angles.mean():.2f} deg over {len(angles)} frames ({name})")
        artifacts = {}
        if out_dir is not None:
            from demcal._files import write_atomic

            t, last, pos = frames[-1]
            png = Path(out_dir, "drum.png")
            plot_surface(last, pos, setup.sim.state.radii, info["radius"], png,
                         title=f"{s['drum.rpm']:g} rpm, Fr {fr:.3g} ({name})")
            path = Path(out_dir, "drum.json")
            write_atomic(path, json.dumps({"frames": [{"t_s": tf, "angle_deg": f.angle_deg, "r2": f.r2}
                                                      for tf, f, _ in frames],
                                           "froude_number": fr, "regime": name}, indent=1))
            artifacts.update(drum_png=str(png), drum_json=str(path))
        if setup.watch is not None and setup.watch.path:
            artifacts["vtk"] = setup.watch.path
        sd = float(angles.std(ddof=1)) if angles.size > 1 else 0.0
        responses = {"dynamic_angle_deg": float(angles.mean()), "froude_number": fr,
                     "regime_index": float(index), "surface_fit_r2": float(np.mean([f.r2 for _, f, _ in frames])),
                     "particles_lost": float(setup.sim.escaped)}
        return dict(responses=responses, spread={"dynamic_angle_deg": sd}, particles=setup.sim.n_particles,
                    steps=setup.sim.step_count, simulated_s=setup.sim.time, artifacts=artifacts)


register(Drum())
