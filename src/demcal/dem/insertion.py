"""New particles: the checks of :meth:`~demcal.dem.Simulation.add_particles` and the
rows they become.

:func:`batch` checks the user's arguments (finite numbers of the right shapes, a usable
template) and returns a :class:`Batch`; :func:`check_placement` refuses particles outside
the domain, too large for a :class:`~demcal.geometry.Box` they are placed in, or
overlapping another particle; :func:`rows` makes the new bodies and spheres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from demcal.errors import ConfigError
from demcal.particles.insertion import random_quaternions

from . import integrator as _integ
from .checks import flags, floats, rows as _rows
from .storage import Bodies, Spheres


class SphereTemplate:
    """A single sphere of radius ``radius`` [m] (duck-types a template)."""

    def __init__(self, radius: float):
        self.name = f"sphere({radius:g})"
        self.radii = np.array([radius])
        self.centers = np.zeros((1, 3))
        self.volume = 4.0 / 3.0 * math.pi * radius ** 3
        i = 0.4 * radius ** 2 * self.volume
        self.inertia_per_density = np.array([i, i, i])


#: The template of ``add_particles(radii=...)``: unit spheres scaled to the radii.
UNIT_SPHERE = SphereTemplate(1.0)


@dataclass
class Batch:
    """Checked input of one :meth:`add_particles` call (``n`` particles of ``k``
    spheres each)."""

    template: object
    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    omega: np.ndarray
    scales: np.ndarray
    fixed: np.ndarray
    locked: np.ndarray
    radii: np.ndarray         # the template's sphere radii [m]
    centers: np.ndarray       # the template's sphere centres [m]
    inertia_per_density: np.ndarray
    material: int

    @property
    def n(self) -> int:
        return self.pos.shape[0]

    @property
    def k(self) -> int:
        return self.radii.size

    @property
    def diameters(self) -> np.ndarray:
        """Bounding diameter of each new particle [m]."""
        return 2 * (np.linalg.norm(self.centers, axis=1) + self.radii).max() * self.scales


def _template(template, radii, scales):
    """(template, scales) from ``template`` or ``radii``."""
    if radii is not None:
        if template is not None or scales is not None:
            raise ConfigError("give radii= alone, or a template (with scales=), not "
                              "both: radii are single spheres of those radii.")
        sc = floats(radii, "radii", "m")
        if not (np.all(np.isfinite(sc)) and np.all(sc > 0)):
            raise ConfigError("radii must be finite numbers > 0 [m].")
        return UNIT_SPHERE, sc
    if template is None:
        raise ConfigError("add_particles needs a template, a sphere radius [m] or "
                          "radii= (one per particle).")
    if isinstance(template, (int, float, np.floating, np.integer)) and not isinstance(
            template, (bool, np.bool_)):
        if not (math.isfinite(template) and template > 0):
            raise ConfigError(f"particle radius must be a finite number > 0 m, got "
                              f"{template}.")
        return SphereTemplate(float(template)), scales
    for attr in ("radii", "centers", "volume", "inertia_per_density"):
        if not hasattr(template, attr):
            raise ConfigError(f"template {template!r} has no attribute {attr!r}; use a "
                              "demcal.particles.templates template or a radius.")
    return template, scales


def _orientations(orientations, n, seed):
    if isinstance(orientations, str):
        if orientations != "random":
            raise ConfigError(
                f"orientations must be quaternions, 'random' or None, got {orientations!r}.")
        return random_quaternions(n, np.random.default_rng(seed))
    if orientations is None:
        return np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    quat = _rows(orientations, n, 4, "orientations", "w, x, y, z")
    norm = np.linalg.norm(quat, axis=1, keepdims=True)
    if np.any(norm == 0):
        raise ConfigError("orientations must be non-zero quaternions (w, x, y, z).")
    return quat / norm


def batch(material_index, template=None, positions=None, orientations=None, scales=None,
          velocities=None, angular_velocities=None, fixed=False, seed=0, radii=None,
          rotation=True) -> Batch:
    """Check :meth:`~demcal.dem.Simulation.add_particles`' arguments (the material
    already resolved to its index)."""
    if positions is None:
        raise ConfigError("add_particles needs positions: an (n, 3) array of centres "
                          "[m].")
    pos = floats(positions, "positions", "m")
    if pos.ndim == 1:
        pos = pos.reshape(1, -1)
    if pos.ndim != 2 or pos.shape[1] != 3 or not np.all(np.isfinite(pos)):
        raise ConfigError("positions must be an (n, 3) array of finite numbers [m].")
    n = pos.shape[0]
    tpl, scales = _template(template, radii, scales)
    t_radii = np.asarray(tpl.radii, dtype=float).reshape(-1)
    centers = np.asarray(tpl.centers, dtype=float).reshape(-1, 3)
    ipd = np.asarray(tpl.inertia_per_density, dtype=float).reshape(3)
    if (t_radii.size != centers.shape[0] or not np.all(np.isfinite(t_radii))
            or np.any(t_radii <= 0) or not np.all(np.isfinite(centers))):
        raise ConfigError("template radii must be finite and positive, one per centre "
                          "(finite too).")
    if not (math.isfinite(tpl.volume) and tpl.volume > 0
            and np.all(np.isfinite(ipd)) and np.all(ipd > 0)):
        raise ConfigError("template volume and inertia_per_density must be finite and "
                          "positive.")
    if t_radii.size == 1 and not np.allclose(centers, 0.0):
        raise ConfigError("a one-sphere template must have its centre at the origin.")
    sc = floats(1.0 if scales is None else scales, "scales", "-")
    if not (sc.ndim == 0 or sc.shape in ((1,), (n,))):
        what = "radii" if radii is not None else "scales"
        raise ConfigError(f"{what} must be one number or one per particle (n = {n}), "
                          f"got shape {sc.shape}.")
    sc = np.broadcast_to(sc, (n,)).copy()
    if not (np.all(np.isfinite(sc)) and np.all(sc > 0)):
        raise ConfigError("scales must be finite positive numbers, got "
                          f"{sc[~(np.isfinite(sc) & (sc > 0))][0]}.")
    quat = _orientations(orientations, n, seed)
    vel = (np.zeros((n, 3)) if velocities is None
           else _rows(velocities, n, 3, "velocities", "m/s"))
    omg = (np.zeros((n, 3)) if angular_velocities is None
           else _rows(angular_velocities, n, 3, "angular_velocities", "rad/s"))
    fx = flags(fixed, n, "fixed")
    locked = ~flags(rotation, n, "rotation")
    if np.any(omg[locked] != 0.0):
        raise ConfigError("angular_velocities must be 0 for particles with "
                          "rotation=False (their rotation is locked).")
    return Batch(tpl, pos, quat, vel, omg, sc, fx, locked, t_radii, centers, ipd,
                 material_index)


def check_domain(b: Batch, domain) -> None:
    """ConfigError when a new particle lies outside ``domain`` or cannot fit in it."""
    if domain is None:
        return
    lo, hi = domain
    size = (hi - lo).min()
    big = b.diameters > size
    if np.any(big):
        raise ConfigError(
            f"a particle of diameter {b.diameters[big].max():.3g} m is larger "
            f"than the domain ({size:.3g} m across); enlarge domain or shrink the "
            "particle.")
    out = np.any((b.pos < lo) | (b.pos > hi), axis=1)
    if np.any(out):
        raise ConfigError(f"{int(out.sum())} particle position(s) lie outside the "
                          "domain; move them inside or enlarge domain.")


def check_boxes(walls, wall_names, time, pos, diameter) -> None:
    """ConfigError when a particle (bounding ``diameter`` [m]) is placed inside a
    :class:`~demcal.geometry.Box` wall (its pose at ``time``) that it cannot fit in: the
    smallest inner dimension of a closed box, the smaller width of an open one."""
    for g, wall in enumerate(getattr(walls, "walls", None) or ()):
        if getattr(wall, "kind_name", None) != "box":
            continue
        lower = np.asarray(wall.lower, dtype=float)
        upper = np.asarray(wall.upper, dtype=float)
        rot, trans = wall.motion.transform(time)
        ref = (pos - trans) @ rot   # R^T (x - T): the box's reference frame
        inside = np.all((ref > lower) & (ref < upper), axis=1)
        dims = upper - lower
        size = float((dims[:2] if getattr(wall, "open_top", False) else dims).min())
        big = inside & (diameter > size)
        if np.any(big):
            name = wall_names[g] if g < len(wall_names) else f"box{g}"
            raise ConfigError(
                f"a particle {diameter[big].max():.3g} m across is placed inside box "
                f"{name!r}, whose smallest inner dimension is {size:.3g} m; enlarge the "
                "box or shrink the particle.")


def check_overlaps(present, spos, rad, body, fixed, tolerance) -> None:
    """ConfigError naming the deepest overlap, beyond ``tolerance`` of the smaller
    radius, of a new sphere (``spos``, ``rad``, owning ``body`` index to be, ``fixed``)
    with a sphere of another particle, new or present (``present``: the simulation's
    :class:`~demcal.dem.storage.State`, user order, so the message names user indices)."""
    if spos.shape[0] == 0:
        return
    from scipy.spatial import cKDTree
    s_pos, s_rad, s_body = present.sphere_positions, present.radii, present.sphere_body
    reach = float(rad.max())
    if s_pos.shape[0]:
        reach += float(s_rad.max())
        lo, hi = spos.min(axis=0) - reach, spos.max(axis=0) + reach
        near = np.nonzero(np.all((s_pos >= lo) & (s_pos <= hi), axis=1))[0]
    else:
        reach *= 2.0
        near = np.zeros(0, np.int64)
    m = near.size
    p = np.concatenate([s_pos[near], spos])
    r = np.concatenate([s_rad[near], rad])
    bd = np.concatenate([s_body[near], body])
    fx = np.concatenate([present.fixed[s_body[near]], fixed])
    ij = cKDTree(p).query_pairs(reach, output_type="ndarray")
    i, j = ij[:, 0], ij[:, 1]
    sel = (np.maximum(i, j) >= m) & (bd[i] != bd[j]) & ~(fx[i] & fx[j])
    i, j = i[sel], j[sel]
    depth = r[i] + r[j] - np.linalg.norm(p[i] - p[j], axis=1)
    rel = depth / np.minimum(r[i], r[j])
    bad = rel > tolerance
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
        f"smaller sphere's radius; at most {tolerance:.0%} is "
        f"accepted){more}; place the particles further apart or make them smaller.")


def sphere_rows(b: Batch, first_body: int):
    """World positions, offsets [m], radii [m] and owning bodies (numbered from
    ``first_body``) of the batch's spheres."""
    n, k = b.n, b.k
    off = (b.centers[None, :, :] * b.scales[:, None, None]).reshape(-1, 3)
    rad = (b.radii[None, :] * b.scales[:, None]).reshape(-1)
    body = np.repeat(np.arange(first_body, first_body + n, dtype=np.int64), k)
    spos = np.empty((n * k, 3))
    for a in range(n):
        q = b.quat[a]
        for c in range(k):
            o = off[a * k + c]
            spos[a * k + c] = b.pos[a] + np.array(
                _integ.quat_rotate(q[0], q[1], q[2], q[3], o[0], o[1], o[2]))
    return spos, off, rad, body


def rows(b: Batch, density, template_id, spheres) -> tuple:
    """The new :class:`Bodies` and :class:`Spheres` (``spheres``: :func:`sphere_rows`)."""
    n, k = b.n, b.k
    spos, off, rad, body = spheres
    mass = density * b.template.volume * b.scales ** 3
    inertia = density * b.inertia_per_density[None, :] * b.scales[:, None] ** 5
    iso = (inertia[:, 0] + inertia[:, 1] + inertia[:, 2]) / 3.0   # Ai et al. 2011
    inertia[b.locked] = np.inf      # 1/I = 0: no torque turns them
    # angular momentum L = R I R^T w
    angmom = np.empty((n, 3))
    for a in range(n):
        q = b.quat[a]
        wb = _integ.quat_rotate_inv(q[0], q[1], q[2], q[3], *b.omega[a])
        lb = np.array(wb) * inertia[a] if not b.locked[a] else np.zeros(3)
        angmom[a] = _integ.quat_rotate(q[0], q[1], q[2], q[3], *lb)
    bodies = Bodies(pos=b.pos, vel=b.vel, quat=b.quat, angmom=angmom, omega=b.omega,
                    force=np.zeros((n, 3)), torque=np.zeros((n, 3)), mass=mass,
                    inertia=inertia, iso=iso, mat=np.full(n, b.material, np.int64),
                    template=np.full(n, template_id, np.int64), scale=b.scales,
                    fixed=b.fixed, start=k * np.arange(n + 1, dtype=np.int64))
    new = Spheres(body=body, offset=off, radius=rad, pos=spos, ref=spos.copy(),
                  dsq=np.zeros(n * k), acc=np.zeros((n * k, 0)))
    return bodies, new
