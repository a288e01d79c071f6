#!/usr/bin/env python3
"""Time LIGGGHTS 3.8 on a given sphere packing, for a side-by-side with demcal.

Runs LIGGGHTS-PUBLIC 3.8 (Debian package ``liggghts``, binary ``/usr/bin/liggghts``)
on the packing with Hertz-Mindlin no slip, tangential history and relative-velocity
rolling friction (``pair_style gran model hertz tangential history rolling_friction
cdt``), gravity, a floor and (when the packing gives a box) four side walls, with the
same time step and material values as our run, and reports particle-steps per second
of the timed loop (LIGGGHTS' own "Loop time", so start-up, input parsing and the
untimed settling/warm-up steps are excluded).

Packing file (written by ``benchmarks/throughput.py`` or by ``--make-packing``):

* ``.npz`` with ``positions (n, 3)`` [m], ``radii (n,)`` [m], optionally
  ``velocities (n, 3)`` [m/s], ``box (6,)`` = xmin, ymin, zmin, xmax, ymax, zmax [m]
  (floor at zmin, side walls at the x/y bounds), and scalar model values ``dt`` [s],
  ``density`` [kg/m3], ``shear_modulus`` [Pa], ``poisson_ratio``, ``restitution``,
  ``static_friction``, ``rolling_friction``, ``skin`` [m];
* or a text/CSV file with columns x, y, z, radius [m] (header lines starting with ``#``
  or a non-numeric first line are skipped).

Command-line values override the file's; missing ones default to the paper's soil
(Xie et al. 2020, Table 2: density 1687.85 kg/m3, G = 1 MPa, Poisson 0.46, e = 0.6,
mu_s = 0.4, mu_r = 0.2). LIGGGHTS takes Young's modulus: E = 2 G (1 + nu).

Usage::

    python benchmarks/liggghts/run_liggghts.py --packing packing.npz --steps 2000 --json
    python benchmarks/liggghts/run_liggghts.py --make-packing 5000 --out p.npz --settle-steps 40000
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

PAPER_SOIL = {
    "density": 1687.85,
    "shear_modulus": 1.0e6,
    "poisson_ratio": 0.46,
    "restitution": 0.6,
    "static_friction": 0.4,
    "rolling_friction": 0.2,
}
MODEL = "model hertz tangential history rolling_friction cdt"
_LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs(?: \(\d+ MPI x \d+ OpenMP\))? for (\d+) steps with (\d+) atoms")


def load_packing(path: Path) -> dict:
    """Positions, radii and optional box/velocities/model values from ``path``."""
    if path.suffix == ".npz":
        with np.load(path) as f:
            data = {k: f[k] for k in f.files}
        out = {"positions": np.asarray(data.pop("positions"), float).reshape(-1, 3), "radii": np.asarray(data.pop("radii"), float).reshape(-1)}
        for k, v in data.items():
            out[k] = v if np.ndim(v) else float(v)
        return out
    rows = []
    with open(path) as fh:
        for line in fh:
            parts = line.replace(",", " ").split()
            if not parts or parts[0].startswith("#"):
                continue
            try:
                rows.append([float(p) for p in parts[:4]])
            except ValueError:
                continue  # header
    arr = np.array(rows)
    return {"positions": arr[:, :3], "radii": arr[:, 3]}


def _f(v) -> str:
    return f"{float(v):.17g}"


def write_data_file(path: Path, positions, radii, density, box, velocities=None) -> None:
    """A LIGGGHTS ``read_data`` file for ``atom_style granular``
    (Atoms: id type diameter density x y z)."""
    n = len(radii)
    box = [_f(v) for v in box]
    with open(path, "w") as fh:
        fh.write("LIGGGHTS data file written by demcal benchmarks/liggghts/run_liggghts.py\n\n")
        fh.write(f"{n} atoms\n1 atom types\n\n")
        fh.write(f"{box[0]} {box[3]} xlo xhi\n{box[1]} {box[4]} ylo yhi\n{box[2]} {box[5]} zlo zhi\n\n")
        fh.write("Atoms\n\n")
        for i in range(n):
            x, y, z = positions[i]
            fh.write(f"{i + 1} 1 {_f(2.0 * radii[i])} {_f(density)} {_f(x)} {_f(y)} {_f(z)}\n")
        if velocities is not None:
            fh.write("\nVelocities\n\n")
            for i in range(n):
                vx, vy, vz = velocities[i]
                fh.write(f"{i + 1} {_f(vx)} {_f(vy)} {_f(vz)} 0.0 0.0 0.0\n")


def input_script(p: dict, walls_box, settle_steps: int, warmup_steps: int, steps: int, dump: str | None) -> str:
    youngs = 2.0 * p["shear_modulus"] * (1.0 + p["poisson_ratio"])
    lines = [
        "atom_style granular",
        "atom_modify map array",
        "boundary f f f",
        # split the domain across the bed, never along gravity: the bed lies in the
        # lower part of the domain, so a split along z leaves the upper ranks empty
        "processors * * 1",
        "newton off",
        "communicate single vel yes",
        "units si",
        "soft_particles yes",  # LIGGGHTS refuses E < 5 MPa otherwise; the paper's soil has 2.9 MPa
        "read_data data.lmp",
        f"neighbor {p['skin']} bin",
        "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {youngs}",
        f"fix m2 all property/global poissonsRatio peratomtype {p['poisson_ratio']}",
        f"fix m3 all property/global coefficientRestitution peratomtypepair 1 {p['restitution']}",
        f"fix m4 all property/global coefficientFriction peratomtypepair 1 {p['static_friction']}",
        f"fix m5 all property/global coefficientRollingFriction peratomtypepair 1 {p['rolling_friction']}",
        f"pair_style gran {MODEL}",
        "pair_coeff * *",
        f"timestep {p['dt']}",
        "fix gravi all gravity 9.81 vector 0.0 0.0 -1.0",
        f"fix wz all wall/gran {MODEL} primitive type 1 zplane {walls_box[2]}",
    ]
    if walls_box is not None and np.all(np.isfinite(walls_box)):
        lines += [
            f"fix wx0 all wall/gran {MODEL} primitive type 1 xplane {walls_box[0]}",
            f"fix wx1 all wall/gran {MODEL} primitive type 1 xplane {walls_box[3]}",
            f"fix wy0 all wall/gran {MODEL} primitive type 1 yplane {walls_box[1]}",
            f"fix wy1 all wall/gran {MODEL} primitive type 1 yplane {walls_box[4]}",
        ]
    lines += [
        "fix integr all nve/sphere",
        "compute rke all erotate/sphere",
        "thermo_style custom step atoms ke c_rke",
        "thermo 5000",
        "thermo_modify lost ignore norm no",
    ]
    if settle_steps > 0:
        lines.append(f"run {settle_steps}")
    if dump:
        lines.append(f"write_dump all custom {dump} id radius x y z vx vy vz")
    if warmup_steps > 0:
        lines.append(f"run {warmup_steps}")
    lines.append(f"run {steps}")
    return "\n".join(lines) + "\n"


def run(args) -> dict:
    binary = shutil.which(args.binary)
    if binary is None:
        raise SystemExit(
            f"run_liggghts: {args.binary} not found: install LIGGGHTS 3.8 with "
            f"`apt-get update && apt-get install -y liggghts`."
        )
    pk = load_packing(Path(args.packing))
    pos, rad = pk["positions"], pk["radii"]
    p = {}
    for key, default in {**PAPER_SOIL, "dt": None, "skin": None}.items():
        cli = getattr(args, key)
        p[key] = float(cli) if cli is not None else pk.get(key, default)
    if p["dt"] is None:
        # 20 % of the Rayleigh time of the smallest sphere (demcal's automatic step is also
        # capped at a tenth of the Hertz contact time; throughput.py passes demcal's step)
        g = p["shear_modulus"]
        nu = p["poisson_ratio"]
        rmin = float(rad.min())
        p["dt"] = 0.2 * math.pi * rmin * math.sqrt(p["density"] / g) / (0.1631 * nu + 0.8766)
    if p["skin"] is None:
        p["skin"] = 0.5 * float(rad.max())  # half the largest radius
    box = pk.get("box")
    if box is not None:
        walls = np.asarray(box, float)
    else:
        lo = (pos - rad[:, None]).min(axis=0)
        hi = (pos + rad[:, None]).max(axis=0)
        walls = np.array([-np.inf, -np.inf, lo[2], np.inf, np.inf, np.inf])
        box = np.concatenate([lo, hi])
    # simulation domain: the walls' box with room above for bouncing particles
    lo = np.minimum(np.asarray(box)[:3], (pos - rad[:, None]).min(axis=0))
    hi = np.maximum(np.asarray(box)[3:], (pos + rad[:, None]).max(axis=0))
    pad = 4.0 * float(rad.max())
    domain = np.concatenate([lo - pad, hi + pad])
    domain[5] = hi[2] + max(pad, 0.5 * (hi[2] - lo[2]))
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="liggghts-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        write_data_file(work / "data.lmp", pos, rad, p["density"], domain, pk.get("velocities"))
        dump = "settled.dump" if args.out else None
        (work / "in.bench").write_text(input_script(p, walls, args.settle_steps, args.warmup_steps, args.steps, dump))
        cmd = [binary, "-in", "in.bench", "-log", "log.liggghts", "-nocite"]
        if args.procs > 1:
            mpirun = shutil.which("mpirun")
            if mpirun is None:
                raise SystemExit("run_liggghts: --procs > 1 needs mpirun (apt-get install -y openmpi-bin).")
            cmd = [mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(args.procs), "--bind-to", "core"] + cmd
        env = dict(os.environ, OMP_NUM_THREADS="1")
        proc = subprocess.run(cmd, cwd=work, capture_output=True, text=True, errors="replace", env=env)
        text = proc.stdout + proc.stderr
        if proc.returncode != 0 or "ERROR" in text:
            tail = "\n".join(text.strip().splitlines()[-15:])
            raise SystemExit(f"run_liggghts: LIGGGHTS failed (exit {proc.returncode}) in {work}:\n{tail}")
        loops = _LOOP.findall(text)
        loop_s, procs, steps, atoms = loops[-1]
        loop_s, steps, atoms = float(loop_s), int(steps), int(atoms)
        result = {
            "code": "LIGGGHTS-PUBLIC 3.8.0",
            "model": "pair_style gran " + MODEL,
            "particles": int(len(rad)),
            "atoms_at_end": atoms,
            "procs": int(procs),
            "steps": steps,
            "dt": p["dt"],
            "skin": p["skin"],
            "loop_s": loop_s,
            "particle_steps_per_s": len(rad) * steps / loop_s,
            "material": {k: p[k] for k in PAPER_SOIL},
        }
        if args.out:
            settled = read_dump(work / "settled.dump")
            np.savez(
                args.out,
                positions=settled["positions"],
                radii=settled["radii"],
                box=np.asarray(box, float),
                dt=p["dt"],
                skin=p["skin"],
                **{k: p[k] for k in PAPER_SOIL},
            )
            result["settled_packing"] = str(args.out)
        return result
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


def read_dump(path: Path) -> dict:
    """Positions and radii from a ``write_dump ... custom id radius x y z ...`` file."""
    lines = Path(path).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS")) + 1
    arr = np.array([[float(v) for v in line.split()] for line in lines[start:] if line.strip()])
    arr = arr[np.argsort(arr[:, 0])]
    return {"positions": arr[:, 2:5], "radii": arr[:, 1], "velocities": arr[:, 5:8]}


def make_packing(n: int, path: Path, seed: int, radius: float, box_side: float | None) -> Path:
    """A loose random packing of ``n`` spheres (radius ``radius`` x U(0.5, 1.5)) in a
    square box with a floor, by demcal's insertion if available, else a simple fill."""
    if box_side is None:
        box_side = radius * 2.0 * round(n ** (1.0 / 3.0) * 1.2)
    height = n * (4.0 / 3.0 * math.pi * radius**3 * 1.25) / (0.25 * box_side**2)
    try:
        sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src"))
        from demcal.particles.insertion import BoxRegion, insert

        ins = insert(
            BoxRegion((0, 0, 0), (box_side, box_side, height)),
            n,
            template=radius,
            sizes={"kind": "uniform", "low": 0.5, "high": 1.5},
            seed=seed,
        )
        positions, radii = ins.positions, ins.radii
    except ImportError:
        rng = np.random.default_rng(seed)
        radii = radius * rng.uniform(0.5, 1.5, n)
        positions = np.empty((n, 3))
        for i in range(n):  # O(n^2) fallback
            while True:
                x = rng.uniform([radii[i]] * 3, [box_side - radii[i], box_side - radii[i], height - radii[i]])
                if i == 0 or np.all(np.linalg.norm(positions[:i] - x, axis=1) >= radii[:i] + radii[i]):
                    positions[i] = x
                    break
    np.savez(path, positions=positions, radii=radii, box=np.array([0, 0, 0, box_side, box_side, height]))
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--packing", help="packing file (.npz or x y z r text)")
    ap.add_argument("--steps", type=int, default=2000, help="timed steps (default 2000)")
    ap.add_argument("--warmup-steps", type=int, default=200, help="untimed steps before the timed run")
    ap.add_argument("--settle-steps", type=int, default=0, help="untimed settling steps first (then dumped with --out)")
    ap.add_argument("--procs", type=int, default=1, help="MPI processes (default 1)")
    ap.add_argument("--binary", default="liggghts")
    for key in list(PAPER_SOIL) + ["dt", "skin"]:
        ap.add_argument("--" + key.replace("_", "-"), dest=key, type=float, default=None)
    ap.add_argument("--keep", help="keep LIGGGHTS' input, data and log in this folder")
    ap.add_argument("--out", help="write the packing after the settling steps to this .npz")
    ap.add_argument("--make-packing", type=int, metavar="N", help="write a loose random packing of N spheres to --out and exit")
    ap.add_argument("--radius", type=float, default=0.0025, help="mean radius for --make-packing [m]")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true", help="print one JSON line")
    args = ap.parse_args(argv)
    if args.make_packing:
        if not args.out:
            ap.error("--make-packing needs --out FILE.npz")
        make_packing(args.make_packing, Path(args.out), args.seed, args.radius, None)
        print(args.out)
        return 0
    if not args.packing:
        ap.error("--packing FILE is required")
    result = run(args)
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"LIGGGHTS 3.8: {result['particles']} particles x {result['steps']} steps on {result['procs']} proc(s) "
            f"in {result['loop_s']:.3g} s = {result['particle_steps_per_s']:.4g} particle-steps/s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
