#!/usr/bin/env python3
"""The same lifted-cylinder heap in demcal and in LIGGGHTS 3.8, measured by one function.

A calibrated card exported for LIGGGHTS is worth what its values give there. This
harness runs demcal's ``repose-cylinder`` bench with spheres of radius 2-3 mm,
Hertz-Mindlin (no slip), tangential history and ``cdt`` rolling friction, the cylinder
lifted at 0.01 m/s, takes demcal's packing at the moment the lift starts (filled and
settled inside the cylinder) and runs the lift and the heap's settling from that very
packing in LIGGGHTS-PUBLIC 3.8 (Debian package ``liggghts``) for the same simulated time,
with the same time step, gravity, materials and wall interactions. Both final heaps go
through :func:`demcal.measure.heap.measure_heap` with the bench's own parameters
(``measure.views`` silhouettes, flank band ``measure.band_low``-``band_high``, plate
radius), so the two angles come from the same code.

One run of one code is one JSON line, appended to ``--out`` as soon as it ends:
``code``, ``mus``, ``mur``, ``seed``, ``angle_deg``, ``particles``, ``wall_s``,
``simulated_s``, ``steps`` and more (README, "Lifted cylinder"). demcal's run also
writes a *case* file (``--cases``, default ``OUT.cases/``): the packing at the lift
start and everything the LIGGGHTS run needs, so that a study can be resumed between the
two codes.

Usage::

    # one (mu_s, mu_r) pair, one seed, both codes (a small check: 300 spheres)
    python benchmarks/liggghts/lifted_cylinder.py --mus 0.5 --mur 0.05 --seed 1 --particles 300 --out small.jsonl
    # the study: six pairs x 4 seeds x both codes, one run at a time, resumable
    python benchmarks/liggghts/lifted_cylinder.py --plan --seeds 4 --particles 3000 --out study.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run_liggghts import _LOOP, MODEL, _f, read_dump, write_data_file  # noqa: E402

#: The six (mu_s, mu_r) pairs of the comparison (issue 42, item 6).
PAIRS = ((0.3, 0.05), (0.3, 0.15), (0.5, 0.05), (0.5, 0.15), (0.7, 0.05), (0.7, 0.15))
#: Sphere radii [m]: uniform in this range.
RADIUS_RANGE = (0.002, 0.003)
#: Cylinder lifting speed [m/s].
LIFT_SPEED = 0.01
#: Settled column height over cylinder diameter that the automatic diameter aims at.
COLUMN_ASPECT = 2.0
#: Solids fraction assumed for that column.
COLUMN_SOLIDS = 0.6
#: demcal's ``time.max_time`` [s]: each phase gives up when the simulated time passes it
#: (the lift of a 3,000-sphere column ends at about 14 s at 0.01 m/s; the bench's quick
#: default, 10 s, would cut it short).
MAX_TIME = 60.0
#: Largest gap [m] between the faceted cylinder and the true one, as a fraction of the
#: smallest radius (the facets touch the circle; their edges lie this far outside).
FACET_GAP = 0.01
#: Largest triangle height over width in the mesh: its smallest angle, atan(1/50) = 1.1
#: deg, stays above LIGGGHTS' 0.5-deg quality warning and its default ``curvature``
#: (0.256 deg), which must be below every angle of every triangle.
ROW_ASPECT = 50.0
CODES = ("demcal", "liggghts")
#: demcal with every contact's history zeroed when the lift starts, as LIGGGHTS starts from
#: the case (its tangential springs at zero): how much the history carried moves the heap.
FRESH = "demcal-fresh-history"
#: The dumps' columns (``run_liggghts.read_dump`` reads the first eight) and their format:
#: every digit, so that the start dump can be compared with the packing written.
DUMP = "id radius x y z vx vy vz omegax omegay omegaz"
FULL = '"%d' + " %.17g" * 10 + '"'


# ----------------------------------------------------------------------------- demcal --

@dataclass(frozen=True)
class Spec:
    """One lifted-cylinder heap: the pair, the count and anything else set."""

    mus: float
    mur: float
    particles: int
    profile: str = "quick"
    cylinder_diameter: float | None = None  # [m], None: COLUMN_ASPECT
    extra: dict = field(default_factory=dict)

    def diameter(self) -> float:
        """The cylinder's inner diameter [m]: given, or the one whose settled column is
        :data:`COLUMN_ASPECT` diameters high (rounded to the mm)."""
        if self.cylinder_diameter is not None:
            return float(self.cylinder_diameter)
        lo, hi = RADIUS_RANGE
        mean_cube = (hi**4 - lo**4) / (4.0 * (hi - lo))  # E[r^3], r uniform in [lo, hi]
        bulk = self.particles * 4.0 / 3.0 * math.pi * mean_cube / COLUMN_SOLIDS
        return round((4.0 * bulk / (math.pi * COLUMN_ASPECT)) ** (1.0 / 3.0), 3)

    def settings(self, scale: float) -> dict:
        """The bench settings: spheres of :data:`RADIUS_RANGE`, Hertz-Mindlin, cdt, the
        pair, the count, the cylinder (``geometry.cylinder_diameter`` is at scale 1),
        the lift speed; ``extra`` last."""
        from demcal.bench.common import template_for

        lo, hi = RADIUS_RANGE
        r_template = float(template_for({"particles.shape": "sphere"}).radii[0])
        s = {
            "contact.model": "hertz_mindlin",
            "rolling.model": "cdt",
            "particles.shape": "sphere",
            "particles.scale_min": lo / r_template,
            "particles.scale_max": hi / r_template,
            "particles.count": int(self.particles),
            "particle.static_friction": float(self.mus),
            "particle.rolling_friction": float(self.mur),
            "geometry.cylinder_diameter": self.diameter() / scale,
            "geometry.lift_speed": LIFT_SPEED,
            "time.max_time": MAX_TIME,
        }
        s.update(self.extra)
        return s


def _resolved(spec: Spec) -> tuple:
    """The bench and its resolved settings for ``spec``."""
    from demcal.bench.registry import get_experiment

    exp = get_experiment("repose-cylinder")
    scale = float(exp.resolve(spec.extra, spec.profile)["geometry.scale"])
    return exp, exp.resolve(spec.settings(scale), spec.profile)


def check(spec: Spec) -> None:
    """Refuse settings the bench refuses (ConfigError, one sentence), before any run."""
    exp, s = _resolved(spec)
    exp.check(s)


def _cylinder_wall(sim):
    walls = sim.walls
    return walls.walls[walls.names.index("cylinder")]


def run_demcal(spec: Spec, seed: int, out_dir=None, log=print, fresh: bool = False) -> tuple[dict, dict]:
    """demcal's ``repose-cylinder`` bench for ``spec`` and ``seed``, its phases run one by
    one as :meth:`BenchExperiment.run` runs them, so that the packing can be taken when
    the lift starts. Returns ``(row, case)``: the JSON row and the case (the packing and
    what LIGGGHTS needs, :func:`run_liggghts`). With ``fresh``, every contact's history
    (tangential springs, touching flags) is zeroed when the lift starts, as LIGGGHTS
    starts from the case, and the row's code is :data:`FRESH`."""
    from demcal.bench import common as C
    from demcal.bench.experiment import run_phase

    exp, s = _resolved(spec)
    exp.check(s)
    started = time.perf_counter()
    with C.showing(C.Progress(False, rest_speed=s.get("time.rest_speed"))) as shown:
        setup = exp.build(s, int(seed), out_dir, False, shown)
        sim = setup.sim
        # the bench's phases (repose.ReposeCylinder.build): fill and settle, lift, heap
        settle, lift, heap = setup.phases
        run_phase(setup, settle)
        if fresh:  # every contact starts anew, as in LIGGGHTS from the data file
            store = sim._store
            store.pairs.hist[:] = 0.0
            store.walls.hist[:] = 0.0
        st = sim.state  # the lift starts now: `lift.start` moves the cylinder
        packing = dict(positions=st.sphere_positions.copy(), radii=st.radii.copy(),
                       velocities=st.velocities.copy(), omegas=st.omegas.copy())
        t0, step0, lifted_at = sim.time, sim.step_count, time.perf_counter()
        log(f"demcal: settled at t {t0:.3f} s ({step0} steps, {lifted_at - started:.0f} s); lifting")
        run_phase(setup, lift)
        motion = _cylinder_wall(sim).motion  # the Translation `lift.start` gave it
        step1 = sim.step_count
        log(f"demcal: lifted at t {sim.time:.3f} s; the heap settles")
        run_phase(setup, heap)
        ended = time.perf_counter()
        setup.watch.check()
        out = exp.measure(setup, s, out_dir, shown)
    wall = time.perf_counter() - started
    r = out["responses"]
    dt = float(sim.dt)
    move_steps = int(round((motion.stop - motion.start) / dt))
    case = case_of(spec, seed, s, setup, packing, t0, step0, motion,
                   (move_steps, step1 - step0 - move_steps, sim.step_count - step1))
    row = dict(code=FRESH if fresh else "demcal", mus=spec.mus, mur=spec.mur, seed=int(seed), angle_deg=r["repose_angle_deg"],
               particles=case["meta"]["particles"], wall_s=wall, simulated_s=float(sim.time),
               steps=int(sim.step_count), dt=dt, lift_start_s=float(t0),
               after_lift_s=float(sim.time - t0), after_lift_steps=int(sim.step_count - step0),
               wall_after_lift_s=ended - lifted_at,
               spread_deg=out["spread"]["repose_angle_deg"], heap_height_mm=r["heap_height_mm"],
               heap_diameter_mm=r["heap_diameter_mm"], lost=int(r["particles_lost"]),
               rms_speed_end=float(sim.snapshot().rms_speed), rest_speed=float(s["time.rest_speed"]),
               cylinder_diameter_mm=2e3 * case["meta"]["cylinder"]["radius"],
               r95_start_mm=r95(packing["positions"]),
               r95_end_mm=r95(sim.state.sphere_positions))
    return row, case


def case_of(spec: Spec, seed: int, s: dict, setup, packing: dict, t0: float, step0: int, motion,
            steps) -> dict:
    """The case LIGGGHTS runs: demcal's ``packing`` at the lift start (time ``t0``, step
    ``step0``) and, from ``setup`` and the resolved settings ``s``, the step, gravity,
    materials, interactions, cylinder, lift (``motion``, the cylinder's Translation) and
    measurement, with ``steps`` = the steps demcal's cylinder moved, stood (until the
    lift phase ended) and the heap ran."""
    sim = setup.sim
    cyl = _cylinder_wall(sim)
    table = sim.description.material_table
    particle, steel = table.materials[0], table.materials[1]
    move, hold, heap = (int(n) for n in steps)
    meta = dict(
        mus=spec.mus, mur=spec.mur, seed=int(seed), particles=int(len(packing["radii"])),
        profile=spec.profile, settings={k: v for k, v in s.items() if np.isscalar(v)},
        dt=float(sim.dt), gravity=[float(g) for g in sim.gravity],
        particle=_material(particle), wall=_material(steel),
        interactions={"pp": _pair(table.interaction(0, 0)), "pw": _pair(table.interaction(0, 1)),
                      "ww": _pair(table.interaction(1, 1))},
        cylinder=dict(radius=float(cyl.radius), base_z=float(cyl.base[2]), length=float(cyl.length),
                      lift_velocity=float(motion.velocity[2])),
        lift_start_s=float(t0), lift_start_step=int(step0), move_steps=move, hold_steps=hold, heap_steps=heap,
        measure=dict(views=int(s["measure.views"]), band=[float(s["measure.band_low"]),
                                                           float(s["measure.band_high"])],
                     plate_radius=float(setup.info["r_plate"])),
        rest_speed=float(s["time.rest_speed"]),
    )
    return dict(packing, meta=meta)


def r95(positions) -> float:
    """Radius [mm] about the cylinder's axis (x = y = 0) inside which 95 % of the particle
    centres lie: the column's at the lift start, the heap's foot at the end."""
    pos = np.asarray(positions, float)
    return float(np.percentile(np.hypot(pos[:, 0], pos[:, 1]), 95.0)) * 1e3


def _material(m) -> dict:
    return dict(density=float(m.density), shear_modulus=float(m.shear_modulus),
                poisson_ratio=float(m.poisson_ratio))


def _pair(i) -> dict:
    return dict(restitution=float(i.restitution), static_friction=float(i.static_friction),
                rolling_friction=float(i.rolling_friction))


def save_case(path: Path, case: dict) -> Path:
    """The case as ``.npz``: the packing's arrays and ``meta`` (a JSON string)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez(tmp, meta=np.array(json.dumps(case["meta"])),
             **{k: case[k] for k in ("positions", "radii", "velocities", "omegas")})
    os.replace(tmp, path)
    return path


def load_case(path: Path) -> dict:
    with np.load(path) as f:
        case = {k: f[k] for k in f.files if k != "meta"}
        case["meta"] = json.loads(str(f["meta"]))
    return case


# --------------------------------------------------------------------------- LIGGGHTS --

class LiggghtsError(RuntimeError):
    """LIGGGHTS ended with an error (its last lines are the message)."""


def cylinder_stl(path: Path, radius: float, z0: float, length: float, r_min: float) -> dict:
    """An open tube of triangles (ASCII STL) standing for demcal's cylinder of ``radius``
    from ``z0`` up ``length`` [m]: ``n`` flat facets tangent to the circle, so that a
    particle overlaps the facets no more than it overlapped the cylinder, with their
    edges at most :data:`FACET_GAP` x ``r_min`` outside it; rows of triangles at most
    :data:`ROW_ASPECT` times as high as wide. Returns ``n``, the rows, the facet angle
    [deg] and the largest gap [m]."""
    tol = FACET_GAP * r_min / radius
    n = max(32, 4 * math.ceil(math.pi / math.acos(1.0 / (1.0 + tol)) / 4))
    r_vertex = radius / math.cos(math.pi / n)
    width = 2.0 * radius * math.tan(math.pi / n)
    rows = max(1, math.ceil(length / (ROW_ASPECT * width)))
    phi = 2.0 * math.pi * np.arange(n) / n
    ring = np.column_stack([r_vertex * np.cos(phi), r_vertex * np.sin(phi)])
    zs = z0 + length * np.arange(rows + 1) / rows
    lines = ["solid cylinder"]
    for k in range(rows):
        for i in range(n):
            a, b = ring[i], ring[(i + 1) % n]
            p = [(a, zs[k]), (b, zs[k]), (b, zs[k + 1]), (a, zs[k + 1])]
            mid = 0.5 * (a + b)
            normal = -mid / np.linalg.norm(mid)  # towards the axis
            for tri in ((p[0], p[1], p[2]), (p[0], p[2], p[3])):
                lines.append(f"facet normal {normal[0]:.17g} {normal[1]:.17g} 0")
                lines.append(" outer loop")
                lines += [f"  vertex {xy[0]:.17g} {xy[1]:.17g} {z:.17g}" for xy, z in tri]
                lines.append(" endloop")
                lines.append("endfacet")
    lines.append("endsolid cylinder")
    Path(path).write_text("\n".join(lines) + "\n")
    return dict(segments=n, rows=rows, facet_deg=360.0 / n, gap_m=r_vertex - radius)


def _youngs(m: dict) -> float:
    return 2.0 * m["shear_modulus"] * (1.0 + m["poisson_ratio"])


def liggghts_input(meta: dict, skin: float, mesh: dict, thermo_every: int) -> str:
    """The input script: the data file's packing (type 1 = particle, 2 = steel), the
    floor (``primitive zplane 0``) and the cylinder (``mesh/surface``) with the same
    model, the lift (``move/mesh linear``) for ``move_steps``, the cylinder held for
    ``hold_steps`` and removed, the heap for ``heap_steps``; dumps at the start and end."""
    ip = meta["interactions"]
    cyl = meta["cylinder"]
    g = np.asarray(meta["gravity"], float)
    gmag = float(np.linalg.norm(g))

    def table(key):
        pp, pw, ww = ip["pp"][key], ip["pw"][key], ip["ww"][key]
        return f"2 {_f(pp)} {_f(pw)} {_f(pw)} {_f(ww)}"

    lines = [
        "atom_style granular",
        "atom_modify map array",
        "boundary f f f",
        "newton off",
        "communicate single vel yes",
        "units si",
        "soft_particles yes",  # particle E 2.9 MPa < 5 MPa
        "hard_particles yes",  # steel E 182 GPa > 1 GPa
        "read_data data.lmp",
        f"neighbor {_f(skin)} bin",
        "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {_f(_youngs(meta['particle']))} "
        f"{_f(_youngs(meta['wall']))}",
        f"fix m2 all property/global poissonsRatio peratomtype {_f(meta['particle']['poisson_ratio'])} "
        f"{_f(meta['wall']['poisson_ratio'])}",
        f"fix m3 all property/global coefficientRestitution peratomtypepair {table('restitution')}",
        f"fix m4 all property/global coefficientFriction peratomtypepair {table('static_friction')}",
        f"fix m5 all property/global coefficientRollingFriction peratomtypepair {table('rolling_friction')}",
        f"pair_style gran {MODEL}",
        "pair_coeff * *",
        f"timestep {_f(meta['dt'])}",
        f"fix gravi all gravity {_f(gmag)} vector {_f(g[0] / gmag)} {_f(g[1] / gmag)} {_f(g[2] / gmag)}",
        f"fix floor all wall/gran {MODEL} primitive type 2 zplane 0.0",
        "fix cyl all mesh/surface file cylinder.stl type 2",
        f"fix cylwall all wall/gran {MODEL} mesh n_meshes 1 meshes cyl",
        "fix integr all nve/sphere",
        "compute rke all erotate/sphere",
        "thermo_style custom step atoms ke c_rke",
        f"thermo {thermo_every}",
        "thermo_modify lost ignore norm no",
        f"write_dump all custom start.dump {DUMP} modify format {FULL}",
        f"fix lift all move/mesh mesh cyl linear 0.0 0.0 {_f(cyl['lift_velocity'])}",
        f"run {meta['move_steps']}",
        "unfix lift",
    ]
    if meta["hold_steps"] > 0:
        lines.append(f"run {meta['hold_steps']}")
    lines += ["unfix cylwall", "unfix cyl", f"run {meta['heap_steps']}",
              f"write_dump all custom final.dump {DUMP} modify format {FULL}"]
    return "\n".join(lines) + "\n"


def _data_file(path: Path, case: dict, domain) -> None:
    """``run_liggghts.write_data_file``'s Atoms, with two atom types (the steel walls are
    type 2) and the angular velocities in the Velocities section."""
    write_data_file(path, case["positions"], case["radii"], case["meta"]["particle"]["density"], domain)
    text = path.read_text().replace("\n1 atom types\n", "\n2 atom types\n", 1)
    vel = np.column_stack([case["velocities"], case["omegas"]])
    rows = "\n".join(f"{i + 1} " + " ".join(f"{v:.17g}" for v in vel[i]) for i in range(len(vel)))
    path.write_text(text + "\nVelocities\n\n" + rows + "\n")


def _spins(path: Path) -> np.ndarray:
    """The ``omegax omegay omegaz`` columns of a dump of :data:`DUMP`, by atom id."""
    arr = np.loadtxt(path, skiprows=9, ndmin=2)
    return arr[np.argsort(arr[:, 0])][:, 8:11]


def _last_thermo(log: str) -> dict:
    """The last thermo row (step, atoms, translational and rotational KE [J])."""
    last = None
    for line in log.splitlines():
        parts = line.split()
        if len(parts) == 4:
            try:
                last = [float(p) for p in parts]
            except ValueError:
                continue
    if last is None:
        return {}
    return dict(step=int(last[0]), atoms=int(last[1]), ke=last[2], rke=last[3])


def run_liggghts(case: dict, binary: str = "liggghts", keep: Path | None = None, log=print) -> dict:
    """The lift and the heap of ``case`` in LIGGGHTS; the final heap measured as demcal
    measures its own. Returns the JSON row."""
    from demcal.measure.heap import measure_heap

    exe = shutil.which(binary)
    if exe is None:
        raise SystemExit(f"lifted_cylinder: {binary} not found: install LIGGGHTS 3.8 with "
                         "`apt-get update && apt-get install -y liggghts`.")
    meta = case["meta"]
    pos, rad = np.asarray(case["positions"], float), np.asarray(case["radii"], float)
    cyl = meta["cylinder"]
    r_max = float(rad.max())
    skin = 0.5 * r_max
    # the domain: the heap's reach on the plate (a 10-deg cone of the bulk, 1.5 x) and the
    # cylinder's top at the end of the lift; LIGGGHTS refuses a mesh that leaves it
    bulk = float(np.sum(4.0 / 3.0 * np.pi * rad**3)) / 0.55
    reach = 1.5 * (3.0 * bulk / (math.pi * math.tan(math.radians(10.0)))) ** (1.0 / 3.0)
    half = max(min(meta["measure"]["plate_radius"], reach), 2.0 * cyl["radius"])
    lift = cyl["lift_velocity"] * meta["move_steps"] * meta["dt"]
    top = max(cyl["base_z"] + cyl["length"] + lift, float((pos[:, 2] + rad).max())) + 4 * r_max
    domain = [-half, -half, -4 * r_max, half, half, top]
    work = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="liggghts-lift-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        _data_file(work / "data.lmp", case, domain)
        mesh = cylinder_stl(work / "cylinder.stl", cyl["radius"], cyl["base_z"], cyl["length"], float(rad.min()))
        thermo = max(1, int(round(0.1 / meta["dt"])))
        (work / "in.lift").write_text(liggghts_input(meta, skin, mesh, thermo))
        env = dict(os.environ, OMP_NUM_THREADS="1")
        log(f"liggghts: {len(rad)} spheres, {meta['move_steps'] + meta['hold_steps'] + meta['heap_steps']} "
            f"steps, cylinder of {mesh['segments']} x {mesh['rows']} x 2 triangles; in {work}")
        started = time.perf_counter()
        proc = subprocess.run([exe, "-in", "in.lift", "-log", "log.liggghts", "-nocite"], cwd=work,
                              capture_output=True, text=True, errors="replace", env=env)
        wall = time.perf_counter() - started
        text = proc.stdout + proc.stderr
        if proc.returncode != 0 or "ERROR" in text:
            tail = "\n".join(text.strip().splitlines()[-15:])
            raise LiggghtsError(f"LIGGGHTS failed (exit {proc.returncode}) in {work}:\n{tail}")
        start = read_dump(work / "start.dump")
        final = read_dump(work / "final.dump")
        loops = _LOOP.findall(text)
        steps = sum(int(x[2]) for x in loops)
        end = _last_thermo(text)
        mass = meta["particle"]["density"] * 4.0 / 3.0 * np.pi * final["radii"] ** 3
        rms = math.sqrt(2.0 * (end["ke"] + end["rke"]) / float(mass.sum())) if end else float("nan")
        m = meta["measure"]
        png = work / "heap.png" if keep else None
        h = measure_heap(final["positions"], final["radii"], base_z=0.0, axis_xy=(0.0, 0.0), views=m["views"],
                         band=tuple(m["band"]), plate_radius=m["plate_radius"], png=png, title=None)
        row = dict(code="liggghts", mus=meta["mus"], mur=meta["mur"], seed=meta["seed"], angle_deg=h.angle_deg,
                   particles=int(len(rad)), wall_s=wall, simulated_s=steps * meta["dt"], steps=steps,
                   dt=meta["dt"], lift_start_s=meta["lift_start_s"], after_lift_s=steps * meta["dt"],
                   after_lift_steps=steps, wall_after_lift_s=wall,
                   loop_s=sum(float(x[0]) for x in loops), spread_deg=h.spread_deg,
                   heap_height_mm=h.height * 1e3, heap_diameter_mm=h.diameter * 1e3,
                   lost=int(len(rad) - len(final["radii"])), rms_speed_end=rms,
                   rest_speed=meta["rest_speed"], cylinder_diameter_mm=2e3 * cyl["radius"],
                   r95_start_mm=r95(start["positions"]), r95_end_mm=r95(final["positions"]),
                   start_max_dev_m=float(np.abs(start["positions"] - pos).max()),
                   start_max_radius_dev_m=float(np.abs(start["radii"] - rad).max()),
                   start_max_velocity_dev=float(np.abs(start["velocities"] - case["velocities"]).max()),
                   start_max_spin_dev=float(np.abs(_spins(work / "start.dump") - case["omegas"]).max()),
                   start_count=int(len(start["radii"])), mesh=mesh)
        return row
    finally:
        if not keep:
            shutil.rmtree(work, ignore_errors=True)


# ------------------------------------------------------------------------------ study --

def _key(row: dict) -> tuple:
    return (row["code"], round(float(row["mus"]), 6), round(float(row["mur"]), 6), int(row["seed"]),
            int(row["particles"]))


def done_rows(out: Path) -> dict:
    """The rows already in ``out`` by (code, mus, mur, seed, particles); a half-written
    last line is ignored."""
    rows = {}
    if out.exists():
        for line in out.read_text().splitlines():
            try:
                row = json.loads(line)
                rows[_key(row)] = row
            except (ValueError, KeyError, TypeError):
                continue
    return rows


def append_row(out: Path, row: dict, done: dict) -> None:
    """Print ``row`` and append it to ``out`` (flushed to disk before the next run)."""
    line = json.dumps(row)
    print(line, flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "a+b") as fh:
        if fh.seek(0, os.SEEK_END) > 0:
            fh.seek(-1, os.SEEK_END)
            if fh.read(1) != b"\n":  # a half-written last line (a killed run): start a new one
                line = "\n" + line
        fh.write((line + "\n").encode())
        fh.flush()
        os.fsync(fh.fileno())
    done[_key(row)] = row


def failed(code: str, spec: Spec, seed: int, exc: BaseException) -> dict:
    """The row of a run that ended in an error (kept, so that a resumed study does not
    run it again; delete the line to retry)."""
    return dict(code=code, mus=spec.mus, mur=spec.mur, seed=int(seed), particles=int(spec.particles),
                angle_deg=None, error=str(exc) or type(exc).__name__)


def case_path(cases: Path, spec: Spec, seed: int) -> Path:
    return cases / f"mus{spec.mus:g}_mur{spec.mur:g}_seed{seed}_n{spec.particles}.npz"


def run_one(spec: Spec, seed: int, codes, out: Path, cases: Path, binary: str, keep: Path | None,
            done: dict, log=print) -> None:
    """demcal, then LIGGGHTS from demcal's case, skipping each code whose row is in
    ``done``. demcal runs again for a LIGGGHTS row whose case file is missing (its run is
    a pure function of the settings and seed) and then adds no row of its own; after a
    failed demcal run LIGGGHTS has no packing to start from and is skipped."""
    base = (round(spec.mus, 6), round(spec.mur, 6), int(seed), int(spec.particles))
    if FRESH in codes:  # demcal alone, its history zeroed at the lift; no case written
        if (FRESH,) + base in done:
            log(f"already in {out}")
            return
        try:
            row, _ = run_demcal(spec, seed, out_dir=Path(keep, "demcal") if keep else None, log=log,
                                fresh=True)
        except Exception as exc:  # a bench error: recorded, the study goes on
            log(f"demcal failed: {exc}")
            row = failed(FRESH, spec, seed, exc)
        append_row(out, row, done)
        return
    d_key, l_key = ("demcal",) + base, ("liggghts",) + base
    path = case_path(cases, spec, seed)
    if done.get(d_key, {}).get("error"):
        log(f"demcal failed here before ({done[d_key]['error']}); nothing to run")
        return
    want_d = "demcal" in codes and d_key not in done
    want_l = "liggghts" in codes and l_key not in done
    if not (want_d or want_l):
        log(f"already in {out}")
        return
    if want_d or (want_l and not path.exists()):
        try:
            row, case = run_demcal(spec, seed, out_dir=Path(keep, "demcal") if keep else None, log=log)
        except Exception as exc:  # a bench error (not at rest, no heap): recorded, the study goes on
            log(f"demcal failed: {exc}")
            if want_d:
                append_row(out, failed("demcal", spec, seed, exc), done)
            return
        save_case(path, case)
        if want_d:
            append_row(out, row, done)
    if want_l:
        try:
            row = run_liggghts(load_case(path), binary, Path(keep, "liggghts") if keep else None, log=log)
        except Exception as exc:
            log(f"liggghts failed: {exc}")
            row = failed("liggghts", spec, seed, exc)
        append_row(out, row, done)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mus", type=float, help="particle-particle static friction")
    ap.add_argument("--mur", type=float, help="particle-particle rolling friction")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--plan", action="store_true", help="the six (mus, mur) pairs x --seeds seeds x both codes")
    ap.add_argument("--seeds", type=int, default=4, help="with --plan: seeds 1..N (default 4)")
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--code", choices=CODES + ("both", FRESH), default="both",
                    help=f"demcal, liggghts, both, or {FRESH} (demcal with every contact's history "
                         "zeroed when the lift starts, as LIGGGHTS starts; no LIGGGHTS run)")
    ap.add_argument("--profile", default="quick", help="the bench profile whose other defaults apply")
    ap.add_argument("--cylinder-diameter", type=float, default=None,
                    help="cylinder inner diameter [m] (default: a settled column two diameters high)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="another bench setting (wall.static_friction=0.5, ...)")
    ap.add_argument("--out", required=True, help="JSON lines file the rows are appended to")
    ap.add_argument("--cases", help="folder of the case files (default OUT.cases)")
    ap.add_argument("--keep", help="keep LIGGGHTS' input, data, dumps, log and both heap pictures here")
    ap.add_argument("--binary", default="liggghts")
    ap.add_argument("--threads", type=int, default=1, help="demcal's threads (default 1, as LIGGGHTS' one rank)")
    args = ap.parse_args(argv)
    # demcal's numba threads, set before demcal (and numba) is first imported
    os.environ["NUMBA_NUM_THREADS"] = str(args.threads)
    extra = {}
    for item in args.set:
        k, sep, v = item.partition("=")
        if not sep:
            ap.error(f"--set {item}: write KEY=VALUE")
        extra[k.strip()] = v.strip()
    if args.code not in ("demcal", FRESH) and shutil.which(args.binary) is None:
        ap.error(f"{args.binary} not found: install LIGGGHTS 3.8 with `apt-get update && apt-get install -y "
                 "liggghts`, or run --code demcal")
    out = Path(args.out)
    cases = Path(args.cases) if args.cases else out.with_name(out.name + ".cases")
    codes = CODES if args.code == "both" else (args.code,)
    if args.plan:
        # seed by seed, so that a study stopped early has every pair at its first seeds
        runs = [(mus, mur, seed) for seed in range(1, args.seeds + 1) for mus, mur in PAIRS]
    else:
        if args.mus is None or args.mur is None:
            ap.error("give --mus and --mur, or --plan")
        runs = [(args.mus, args.mur, args.seed)]
    try:
        check(Spec(runs[0][0], runs[0][1], args.particles, args.profile, args.cylinder_diameter, extra))
    except Exception as exc:  # a setting's error, in demcal's one sentence
        ap.error(str(exc))
    done = done_rows(out)

    def log(text):
        print(f"[{time.strftime('%H:%M:%S')}] {text}", file=sys.stderr, flush=True)

    for mus, mur, seed in runs:
        spec = Spec(mus, mur, args.particles, args.profile, args.cylinder_diameter, extra)
        keep = Path(args.keep, case_path(Path("."), spec, seed).stem) if args.keep else None
        log(f"mus {mus:g}, mur {mur:g}, seed {seed}, {args.particles} spheres, cylinder "
            f"{spec.diameter() * 1e3:.0f} mm")
        run_one(spec, seed, codes, out, cases, args.binary, keep, done, log=log)
    return 0


if __name__ == "__main__":
    sys.exit(main())
