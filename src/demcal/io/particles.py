"""Particles to and from a CSV file, one row per particle (SI units).

:func:`save_particles` writes a simulation's particles (or a :class:`State`'s) whole
or not at all (:func:`demcal._files.write_atomic`); :func:`load_particles` reads them
back as :class:`Particles`, which :meth:`Particles.add_to` puts into a simulation.
Numbers are written with Python's shortest exact form, so positions, velocities and
sizes come back bitwise. The columns:

============  ==============================================================
id            the particle's index in the simulation (user order)
template      template name (its index when saved from a ``State``)
spheres       spheres in the particle
x, y, z       centre of mass [m]
qw .. qz      orientation, quaternion (w, x, y, z), body frame -> world
vx, vy, vz    velocity [m/s]
wx, wy, wz    angular velocity [rad/s] (world frame)
scale         size factor applied to the template (for ``radii=`` spheres:
              the radius [m])
radius        bounding radius [m] (a single sphere's radius)
material      material name (its index when saved from a ``State``)
fixed         1 for a fixed particle, else 0
rotation      0 for a particle whose rotation is locked, else 1
============  ==============================================================

A single sphere is put back as a sphere of its radius (``add_particles(radii=...)``,
so its ``scale`` becomes its radius and its mass may differ in the last bit). A
particle of several spheres needs its template, passed by name to
:meth:`Particles.add_to`. Angular momenta are
derived again from the angular velocities (equal to rounding), and contact history is
not stored: a checkpoint (:meth:`Simulation.save_checkpoint`) restarts bitwise, this
file restarts a packing.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from demcal._files import write_atomic
from demcal.errors import ConfigError, DataError

__all__ = ["COLUMNS", "Particles", "save_particles", "load_particles"]

COLUMNS = ("id", "template", "spheres", "x", "y", "z", "qw", "qx", "qy", "qz",
           "vx", "vy", "vz", "wx", "wy", "wz", "scale", "radius", "material", "fixed",
           "rotation")
_TEXT = ("template", "material")
_INTEGER = ("id", "spheres", "fixed", "rotation")


@dataclass(frozen=True)
class Particles:
    """Particles read by :func:`load_particles` (one entry per particle, file order).

    ``ids``, ``templates`` and ``materials`` (names, or indices as text),
    ``spheres``, ``positions`` (n, 3) [m], ``quaternions`` (n, 4), ``velocities``
    (n, 3) [m/s], ``omegas`` (n, 3) [rad/s], ``scales``, ``radii`` [m] (bounding),
    ``fixed`` and ``rotation`` (bools).
    """

    ids: np.ndarray
    templates: np.ndarray
    spheres: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    velocities: np.ndarray
    omegas: np.ndarray
    scales: np.ndarray
    radii: np.ndarray
    materials: np.ndarray
    fixed: np.ndarray
    rotation: np.ndarray

    def __len__(self) -> int:
        return self.ids.shape[0]

    def add_to(self, sim, templates=None) -> np.ndarray:
        """Add these particles to ``sim`` (in file order); returns their indices.

        Parameters
        ----------
        sim : Simulation
        templates : dict, optional
            ``{name: template}`` for the multi-sphere particles' templates (single
            spheres need none). A template listed here is used for single spheres
            of that name too.

        Materials are looked up by name in ``sim``, else taken as indices.
        """
        templates = dict(templates or {})
        keys = [(t, m) for t, m in zip(self.templates, self.materials)]
        out = []
        start = 0
        for stop in range(1, len(keys) + 1):  # runs of rows sharing template and material
            if stop < len(keys) and keys[stop] == keys[start]:
                continue
            out.append(self._add_run(sim, templates, start, stop))
            start = stop
        return np.concatenate(out) if out else np.zeros(0, np.int64)

    def _add_run(self, sim, templates, a, b):
        name, material = self.templates[a], self.materials[a]
        rows = slice(a, b)
        common = dict(positions=self.positions[rows], velocities=self.velocities[rows],
                      angular_velocities=np.where(self.rotation[rows, None],
                                                  self.omegas[rows], 0.0),
                      material=_material(sim, material), fixed=self.fixed[rows],
                      rotation=self.rotation[rows])
        if name in templates:
            return sim.add_particles(templates[name], orientations=self.quaternions[rows],
                                     scales=self.scales[rows], **common)
        if np.any(self.spheres[rows] != 1):
            raise ConfigError(f"particles of template {name!r} have several spheres: pass "
                              f"the template, add_to(sim, templates={{{name!r}: ...}}).")
        return sim.add_particles(radii=self.radii[rows], orientations=self.quaternions[rows],
                                 **common)


def _material(sim, ref):
    """A material of ``sim`` by name, else by index (text)."""
    if any(m.name == ref for m in sim.materials):
        return ref
    try:
        return int(ref)
    except ValueError:
        return ref  # unknown: add_particles names the materials there are


def save_particles(path, source) -> Path:
    """Write the particles of ``source`` (a :class:`Simulation`, or its ``state``) to a
    CSV file at ``path``, whole or not at all; returns the path.

    From a simulation the file names templates and materials; from a state it gives
    their indices.
    """
    if hasattr(source, "state"):  # a simulation (io never imports the engine: dem imports io)
        st = source.state
        tnames = [getattr(t, "name", str(k)) for k, t in enumerate(source.templates)]
        mnames = [m.name for m in source.materials]
        template = [tnames[t] for t in st.templates]
        material = [mnames[m] for m in st.materials]
    else:
        st = source
        template = [str(t) for t in st.templates]
        material = [str(m) for m in st.materials]
    n = st.positions.shape[0]
    body = st.sphere_body
    spheres = np.bincount(body, minlength=n)
    reach = np.linalg.norm(st.sphere_positions - st.positions[body], axis=1) + st.radii
    radius = np.zeros(n)
    np.maximum.at(radius, body, reach)   # a single sphere's: 0 + its radius
    numbers = np.column_stack([st.positions, st.quaternions, st.velocities, st.omegas,
                               st.scales, radius]).tolist()
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    locked = np.isinf(st.inertias).any(axis=1)
    for i in range(n):
        writer.writerow([i, template[i], int(spheres[i]), *numbers[i], material[i],
                         int(st.fixed[i]), int(not locked[i])])
    return write_atomic(path, buf.getvalue())


def load_particles(path) -> Particles:
    """Read a file written by :func:`save_particles`; a :class:`DataError` naming the
    file and the problem when it cannot be read."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"cannot read particle file {str(path)!r} "
                        f"({exc.strerror or exc}): check the path.") from None
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or tuple(rows[0]) != COLUMNS:
        raise DataError(f"{str(path)!r} is not a demcal particle file: its first line "
                        f"must be the header {','.join(COLUMNS)}.")
    cols = {name: [] for name in COLUMNS}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(COLUMNS):
            raise DataError(f"{str(path)!r} line {line} has {len(row)} fields, not "
                            f"{len(COLUMNS)}: the file is damaged; write it again.")
        for name, value in zip(COLUMNS, row):
            cols[name].append(value)
    out = {}
    for name, values in cols.items():
        if name in _TEXT:
            out[name] = np.array(values, dtype=object)
            continue
        try:
            out[name] = np.array(values, dtype=np.int64 if name in _INTEGER else float)
        except ValueError:
            raise DataError(f"{str(path)!r}: column {name!r} holds a value that is not a "
                            f"number; the file is damaged; write it again.") from None
    return Particles(ids=out["id"], templates=out["template"], spheres=out["spheres"],
                     positions=_stack(out, "x", "y", "z"),
                     quaternions=_stack(out, "qw", "qx", "qy", "qz"),
                     velocities=_stack(out, "vx", "vy", "vz"),
                     omegas=_stack(out, "wx", "wy", "wz"), scales=out["scale"],
                     radii=out["radius"], materials=out["material"],
                     fixed=out["fixed"] != 0, rotation=out["rotation"] != 0)


def _stack(cols, *names):
    return np.column_stack([cols[k] for k in names]).reshape(-1, len(names))
