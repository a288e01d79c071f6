"""Non-overlapping particle insertion in a box or a cylinder region.

Particles are placed by random sequential addition: each new particle (largest first)
gets uniformly random centre positions inside the region until its bounding sphere
(template bounding radius x scale factor, plus an optional ``gap``) overlaps neither the
particles already there nor those placed before it, and lies wholly inside the region.
A hashed cell list makes each try O(1), so 100,000 particles take about a second.
Random insertion jams near 30-38 % solids; a request beyond what the region can hold
raises a :class:`~demcal.errors.ConfigError` saying so.

Everything is drawn from one :class:`numpy.random.Generator` (seeded by the caller):
the same seed, region and existing particles give the same particles.

* :func:`insert` -- all at once;
* :class:`Inserter` -- at a rate: call it with the time and the particles present, it
  returns the particles due since the last call (deferring those that do not fit yet).

Orientations are unit quaternions, scalar first ``(q0, q1, q2, q3)``, uniformly random
(K. Shoemake, "Uniform random rotations", Graphics Gems III, 1992) unless
``random_orientation=False``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from demcal._checks import checked_float, checked_whole
from demcal.errors import ConfigError
from demcal.particles.sizes import SizeDistribution, as_generator, size_distribution

__all__ = ["BoxRegion", "CylinderRegion", "Insertion", "insert", "Inserter", "random_quaternions"]

_BOX = 0
_CYLINDER = 1
#: Solid fraction above which :func:`insert` refuses without trying (random close packing
#: of spheres is about 64 %, random sequential insertion jams near 30-38 %).
_MAX_FILL = 0.55


def _vec3(value, name):
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f"{name} must be three finite numbers, got {value!r}.")
    return arr


def _gap(value) -> float:
    return checked_float(value, "insertion gap", "a finite number >= 0 [m] (the extra clearance "
                         "between particles)", lambda x: math.isfinite(x) and x >= 0.0)


def _existing(positions, radii, pos_name="existing_positions", rad_name="existing_radii"):
    """Validated centres ``(n, 3)`` and bounding radii ``(n,)`` of the particles already
    there (both None: none)."""
    if positions is None and radii is None:
        return np.zeros((0, 3)), np.zeros(0)
    if radii is None:
        raise ConfigError(
            f"{pos_name} was given without {rad_name}: pass the particles' bounding radii [m] "
            f"too (one number or one per particle), or the insertion cannot avoid them."
        )
    if positions is None:
        raise ConfigError(
            f"{rad_name} was given without {pos_name}: pass the particles' centres [m] too."
        )
    try:
        ep = np.asarray(positions, dtype=float)
    except (TypeError, ValueError):
        ep = None
    if ep is not None and ep.ndim == 1 and ep.size == 3:
        ep = ep[None, :]
    if ep is not None and ep.size == 0:
        ep = np.zeros((0, 3))
    if ep is None or ep.ndim != 2 or ep.shape[1] != 3:
        got = "unreadable" if ep is None else f"shape {ep.shape}"
        raise ConfigError(f"{pos_name} must be an (n, 3) array of centres [m], got {got}.")
    if not np.all(np.isfinite(ep)):
        k = int(np.nonzero(~np.all(np.isfinite(ep), axis=1))[0][0])
        raise ConfigError(
            f"{pos_name} must be finite, but particle {k} is at {ep[k].tolist()} (a simulation "
            f"that blew up?): pass the centres of the particles present."
        )
    try:
        er = np.asarray(radii, dtype=float)
    except (TypeError, ValueError):
        er = None
    if er is None or not (er.ndim == 0 or er.shape == (len(ep),)):
        got = "unreadable" if er is None else f"shape {er.shape}"
        raise ConfigError(
            f"{rad_name} must be one radius or one per particle ({len(ep)}) [m], got {got}."
        )
    if not (np.all(np.isfinite(er)) and np.all(er > 0.0)):
        raise ConfigError(f"{rad_name} must be finite numbers > 0 [m].")
    return ep, np.broadcast_to(er, (len(ep),))


@dataclass(frozen=True)
class BoxRegion:
    """Axis-aligned box from ``lower`` to ``upper`` [m]."""

    lower: tuple = (0.0, 0.0, 0.0)
    upper: tuple = (1.0, 1.0, 1.0)

    def __post_init__(self):
        lo = _vec3(self.lower, "box region lower corner")
        hi = _vec3(self.upper, "box region upper corner")
        if np.any(hi <= lo):
            raise ConfigError(
                f"box region upper corner {hi.tolist()} must exceed its lower corner {lo.tolist()}."
            )
        object.__setattr__(self, "lower", tuple(lo))
        object.__setattr__(self, "upper", tuple(hi))

    @property
    def volume(self) -> float:
        return float(np.prod(np.subtract(self.upper, self.lower)))

    @property
    def min_width(self) -> float:
        return float(np.min(np.subtract(self.upper, self.lower)))

    def bounds(self) -> np.ndarray:
        return np.array(self.lower + self.upper)

    def _code(self):
        return _BOX, np.array(self.lower + self.upper + (0.0,))


@dataclass(frozen=True)
class CylinderRegion:
    """Vertical cylinder (axis along z): bottom-face ``centre``, ``radius``, ``height`` [m]."""

    centre: tuple = (0.0, 0.0, 0.0)
    radius: float = 0.5
    height: float = 1.0

    def __post_init__(self):
        c = _vec3(self.centre, "cylinder region centre")
        for name in ("radius", "height"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"cylinder region {name} must be > 0 [m], got {v!r}.")
        object.__setattr__(self, "centre", tuple(c))

    @property
    def volume(self) -> float:
        return math.pi * self.radius**2 * self.height

    @property
    def min_width(self) -> float:
        return min(2.0 * self.radius, self.height)

    def bounds(self) -> np.ndarray:
        cx, cy, cz = self.centre
        r = self.radius
        return np.array([cx - r, cy - r, cz, cx + r, cy + r, cz + self.height])

    def _code(self):
        cx, cy, cz = self.centre
        return _CYLINDER, np.array([cx, cy, cz, self.radius, self.height, 0.0, 0.0])


@dataclass
class Insertion:
    """Particles to add: ``positions (n, 3)`` [m], ``orientations (n, 4)`` unit
    quaternions (scalar first), ``scales (n,)``, ``velocities (n, 3)`` [m/s] and the
    bounding ``radii (n,)`` [m] used for the overlap test."""

    positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    orientations: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    scales: np.ndarray = field(default_factory=lambda: np.zeros(0))
    velocities: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    radii: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.scales)


def random_quaternions(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` uniformly distributed unit quaternions, scalar first.

    Marsaglia's method (Ann. Math. Statist. 43 (1972) 645, DOI 10.1214/aoms/1177692644):
    (x1, y1) and (x2, y2) uniform in the unit disc (by rejection from the square),
    s_k = x_k^2 + y_k^2, q = (x1, y1, x2 f, y2 f) with f = sqrt((1 - s1) / s2). Only
    arithmetic and a square root, which IEEE 754 rounds the same on every CPU; numpy's
    ``sin`` and ``cos`` (Shoemake's method) pick an implementation per instruction set
    and change the last bits of the orientations, and with them the whole simulation.
    """
    out = np.empty((n, 4))
    filled = 0
    while filled < n:
        left = n - filled
        u = 2.0 * rng.random((2 * left + 8, 4)) - 1.0  # 62 % of the rows are kept
        s1 = u[:, 0] * u[:, 0] + u[:, 1] * u[:, 1]
        s2 = u[:, 2] * u[:, 2] + u[:, 3] * u[:, 3]
        keep = np.flatnonzero((s1 < 1.0) & (s2 < 1.0) & (s2 > 0.0))[:left]
        f = np.sqrt((1.0 - s1[keep]) / s2[keep])
        out[filled:filled + keep.size, :2] = u[keep, :2]
        out[filled:filled + keep.size, 2] = u[keep, 2] * f
        out[filled:filled + keep.size, 3] = u[keep, 3] * f
        filled += keep.size
    return out


@njit(cache=True)
def _hash(ix, iy, iz, mask):
    return ((ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791)) & mask


@njit(cache=True)
def _place(kind, rp, pos, rad, n_done, n_total, uniforms, u_next, gap, max_attempts, cell, origin, head, nxt, mask,
           tried):
    """Random sequential addition of particles n_done..n_total-1.

    ``pos``/``rad`` hold the fixed (existing) particles and those placed so far in
    their first ``n_done`` rows (already linked into the hash grid ``head``/``nxt``);
    particle ``n_done`` has had ``tried`` tries in an earlier call. Returns (n_done,
    u_next, status, tries): status 0 all placed, 1 a particle failed ``max_attempts``
    tries, 2 ran out of uniforms, with ``tries`` those of particle ``n_done`` so far
    (the next call carries them on, so a particle that never fits fails after
    ``max_attempts`` tries however many calls they span).
    """
    inv = 1.0 / cell
    i = n_done
    while i < n_total:
        r = rad[i]
        placed = False
        tries = tried if i == n_done else 0
        while tries < max_attempts:
            if u_next >= uniforms.shape[0]:
                return i, u_next, 2, tries
            u0 = uniforms[u_next, 0]
            u1 = uniforms[u_next, 1]
            u2 = uniforms[u_next, 2]
            u_next += 1
            tries += 1
            if kind == 0:
                x = rp[0] + r + u0 * (rp[3] - rp[0] - 2.0 * r)
                y = rp[1] + r + u1 * (rp[4] - rp[1] - 2.0 * r)
                z = rp[2] + r + u2 * (rp[5] - rp[2] - 2.0 * r)
            else:
                rho = (rp[3] - r) * math.sqrt(u0)
                phi = 2.0 * math.pi * u1
                x = rp[0] + rho * math.cos(phi)
                y = rp[1] + rho * math.sin(phi)
                z = rp[2] + r + u2 * (rp[4] - 2.0 * r)
            ix = int(math.floor((x - origin[0]) * inv))
            iy = int(math.floor((y - origin[1]) * inv))
            iz = int(math.floor((z - origin[2]) * inv))
            ok = True
            for dx in range(-1, 2):
                if not ok:
                    break
                for dy in range(-1, 2):
                    if not ok:
                        break
                    for dz in range(-1, 2):
                        j = head[_hash(ix + dx, iy + dy, iz + dz, mask)]
                        while j >= 0:
                            ddx = pos[j, 0] - x
                            ddy = pos[j, 1] - y
                            ddz = pos[j, 2] - z
                            lim = rad[j] + r + gap
                            if ddx * ddx + ddy * ddy + ddz * ddz < lim * lim:
                                ok = False
                                break
                            j = nxt[j]
                        if not ok:
                            break
            if ok:
                pos[i, 0] = x
                pos[i, 1] = y
                pos[i, 2] = z
                h = _hash(ix, iy, iz, mask)
                nxt[i] = head[h]
                head[h] = i
                placed = True
                break
        if not placed:
            return i, u_next, 1, tries
        i += 1
    return i, u_next, 0, 0


@njit(cache=True)
def _link(pos, n, cell, origin, head, nxt, mask):
    inv = 1.0 / cell
    for i in range(n):
        ix = int(math.floor((pos[i, 0] - origin[0]) * inv))
        iy = int(math.floor((pos[i, 1] - origin[1]) * inv))
        iz = int(math.floor((pos[i, 2] - origin[2]) * inv))
        h = _hash(ix, iy, iz, mask)
        nxt[i] = head[h]
        head[h] = i


def _bounding_radius(template) -> float:
    if template is None:
        raise ConfigError("insertion needs a template or a particle radius [m].")
    if isinstance(template, (int, float)):
        r = float(template)
    else:
        r = float(getattr(template, "bounding_radius"))
    if not (math.isfinite(r) and r > 0):
        raise ConfigError(f"particle radius for insertion must be > 0 [m], got {r!r}.")
    return r


def _fill(region, radii_new, rng, existing_positions, existing_radii, gap, max_attempts):
    """Place particles of bounding radii ``radii_new`` (in order); returns
    (positions of the placed ones, number placed, status).

    ``existing_positions`` ``(n, 3)`` and ``existing_radii`` ``(n,)`` come checked from
    :func:`_existing`, ``gap`` from :func:`_gap`."""
    n_new = len(radii_new)
    kind, rp = region._code()
    b = region.bounds()
    rmax = float(radii_new.max()) if n_new else 0.0
    if len(existing_positions):
        ep = existing_positions
        er = existing_radii
        reach = er + rmax + gap
        near = np.all((ep >= b[:3] - reach[:, None]) & (ep <= b[3:] + reach[:, None]), axis=1)
        ep = ep[near]
        er = er[near]
    else:
        ep = np.zeros((0, 3))
        er = np.zeros(0)
    n_fix = len(ep)
    n_total = n_fix + n_new
    pos = np.zeros((n_total, 3))
    pos[:n_fix] = ep
    rad = np.concatenate([er, radii_new])
    cell = max(2.0 * float(rad.max()) + gap, 1e-12) if n_total else 1.0
    size = 1 << max(10, int(math.ceil(math.log2(2 * n_total + 1))))
    head = np.full(size, -1, np.int64)
    nxt = np.full(n_total, -1, np.int64)
    origin = b[:3].copy()
    _link(pos, n_fix, cell, origin, head, nxt, size - 1)
    done = n_fix
    status = 2
    tries = 0
    batch = max(64, 40 * n_new)
    while status == 2:
        uniforms = rng.random((batch, 3))
        done, _, status, tries = _place(kind, rp, pos, rad, done, n_total, uniforms, 0, float(gap),
                                        int(max_attempts), cell, origin, head, nxt, size - 1, tries)
    return pos[n_fix:done], done - n_fix, status


def _too_dense(count, rmax, solid, region, gap) -> ConfigError:
    """The pre-check's refusal: more solid than random packing can put in the region."""
    plus = " (plus half the gap)" if gap > 0 else ""
    return ConfigError(
        f"region too small for {count} particles of radius up to {rmax:.3g} m: their bounding "
        f"spheres{plus} fill {solid:.3g} m3, {solid / region.volume:.0%} of the "
        f"region's volume {region.volume:.3g} m3, above the {_MAX_FILL:.0%} that random packing "
        f"can reach (insertion was not tried); enlarge the region, insert fewer particles, or "
        f"insert them at a rate."
    )


def _too_full(count, rmax, placed, region) -> ConfigError:
    return ConfigError(
        f"region too small for {count} particles of radius up to {rmax:.3g} m: only {placed} "
        f"fitted (random insertion jams near 30 % solids, region volume {region.volume:.3g} m3); "
        f"enlarge the region, insert fewer particles, or insert them at a rate."
    )


def _assemble(rng, positions, scales, radii, velocity, random_orientation) -> Insertion:
    n = len(scales)
    q = random_quaternions(n, rng) if random_orientation else np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    vel = np.tile(_vec3(velocity, "insertion velocity"), (n, 1))
    return Insertion(np.ascontiguousarray(positions), q, scales, vel, radii)


def insert(
    region,
    count: int,
    template=None,
    sizes: SizeDistribution | float | dict = 1.0,
    seed=None,
    velocity=(0.0, 0.0, 0.0),
    existing_positions=None,
    existing_radii=None,
    gap: float = 0.0,
    random_orientation: bool = True,
    max_attempts: int = 2000,
) -> Insertion:
    """Insert ``count`` non-overlapping particles in ``region`` all at once.

    Parameters
    ----------
    region : BoxRegion or CylinderRegion
    count : int
    template : ParticleTemplate or float
        The particle at scale 1 (its ``bounding_radius`` is used), or a sphere radius [m].
    sizes : SizeDistribution, number or mapping
        Scale factors (see :func:`demcal.particles.sizes.size_distribution`).
    seed : int or numpy.random.Generator
    velocity : (3,) array
        Initial velocity of every particle [m/s].
    existing_positions, existing_radii : arrays, optional
        Particles already in the simulation to avoid: centres ``(n, 3)`` [m] and bounding
        radii [m] (one number for all, or ``(n,)``). Give both or neither.
    gap : float
        Extra clearance between bounding spheres [m], finite and >= 0.
    max_attempts : int
        Tries per particle (>= 1) before the region is declared full.

    Raises
    ------
    ConfigError
        If a particle cannot fit in the region, or the region fills up before ``count``.
    """
    count = checked_whole(count, "particle count", 0)
    gap = _gap(gap)
    max_attempts = checked_whole(max_attempts, "max_attempts", 1)
    existing_positions, existing_radii = _existing(existing_positions, existing_radii)
    rng = as_generator(seed)
    r0 = _bounding_radius(template)
    dist = size_distribution(sizes)
    scales = np.sort(dist.sample(count, rng))[::-1].copy()  # largest first packs best
    radii = r0 * scales
    if count == 0:
        return Insertion()
    rmax = float(radii[0])
    if 2.0 * rmax >= region.min_width:
        raise ConfigError(
            f"a particle of radius {rmax:.3g} m does not fit in a region {region.min_width:.3g} m "
            f"wide: enlarge the region or use smaller particles."
        )
    solid = float(np.sum(4.0 / 3.0 * math.pi * (radii + 0.5 * gap) ** 3))
    if solid > _MAX_FILL * region.volume:
        raise _too_dense(count, rmax, solid, region, gap)
    positions, placed, status = _fill(region, radii, rng, existing_positions, existing_radii, gap, max_attempts)
    if placed < count:
        raise _too_full(count, rmax, placed, region)
    return _assemble(rng, positions, scales, radii, velocity, random_orientation)


class Inserter:
    """Insert particles at a rate (or all at ``start``) during a simulation.

    Parameters
    ----------
    region, template, sizes, velocity, gap, random_orientation, max_attempts
        As in :func:`insert`.
    total : int
        Particles to insert in all.
    rate : float, optional
        Particles per second [1/s]; ``None`` inserts all ``total`` at ``start``.
    start : float
        Time [s] of the first insertion.
    seed : int or numpy.random.Generator

    Call it as ``inserter(t, positions, radii)`` with the current time [s] and the
    centres and bounding radii of the particles present (both or neither); it returns an
    :class:`Insertion` of the particles due by ``t`` that fit now. Those that do not fit
    (the region is still full) are deferred to later calls, so a rate that outpaces the
    outflow slows down instead of failing. All scale factors are drawn up front, so the
    sizes do not depend on how often it is called.
    """

    def __init__(
        self,
        region,
        total: int,
        template=None,
        sizes: SizeDistribution | float | dict = 1.0,
        rate: float | None = None,
        start: float = 0.0,
        seed=None,
        velocity=(0.0, 0.0, 0.0),
        gap: float = 0.0,
        random_orientation: bool = True,
        max_attempts: int = 200,
    ):
        self.region = region
        self.total = checked_whole(total, "particle count", 0)
        if rate is not None:
            rate = checked_float(rate, "insertion rate", "a finite number > 0 particles/s (or None to "
                           "insert all at start)", lambda x: math.isfinite(x) and x > 0)
        self.rate = rate
        self.start = checked_float(start, "insertion start", "a finite time [s]")
        gap = _gap(gap)
        max_attempts = checked_whole(max_attempts, "max_attempts", 1)
        self.rng = as_generator(seed)
        self.r0 = _bounding_radius(template)
        self.scales = size_distribution(sizes).sample(self.total, self.rng)
        self.velocity = _vec3(velocity, "insertion velocity")
        self.gap = float(gap)
        self.random_orientation = bool(random_orientation)
        self.max_attempts = int(max_attempts)
        self.inserted = 0
        rmax = self.r0 * float(self.scales.max()) if self.total else 0.0
        if 2.0 * rmax >= region.min_width:
            raise ConfigError(
                f"a particle of radius {rmax:.3g} m does not fit in a region {region.min_width:.3g} m "
                f"wide: enlarge the region or use smaller particles."
            )

    @property
    def done(self) -> bool:
        """True once all ``total`` particles are in."""
        return self.inserted >= self.total

    def due(self, t: float) -> int:
        """Number of particles that should be in by time ``t`` [s]."""
        if t < self.start:
            return 0
        if self.rate is None:
            return self.total
        return min(self.total, int(math.floor(self.rate * (t - self.start) + 1e-9)) + 1)

    def __call__(self, t: float, positions=None, radii=None) -> Insertion:
        t = checked_float(t, "insertion time", "a finite time [s]")
        positions, radii = _existing(positions, radii, "positions", "radii")
        n = self.due(t) - self.inserted
        if n <= 0:
            return Insertion()
        scales = self.scales[self.inserted : self.inserted + n]
        radii_new = self.r0 * scales
        pos, placed, _ = _fill(self.region, radii_new, self.rng, positions, radii, self.gap, self.max_attempts)
        self.inserted += placed
        return _assemble(self.rng, pos, scales[:placed].copy(), radii_new[:placed].copy(), self.velocity, self.random_orientation)
