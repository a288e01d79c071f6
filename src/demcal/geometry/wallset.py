"""Packing walls into the flat arrays the engine's kernels read.

A :class:`WallSet` holds, for ``nw`` kernel rows (the parameter layout of each kind is
in :mod:`demcal.geometry.kernels`):

========  ================  ===================================================
kind      int32[nw]         PLANE, DISK, CYLINDER, CONE, RECT or TRIANGLE
params    float64[nw, 16]   world-frame parameters at the current time
velocity  float64[nw, 3]    linear velocity of the row's reference point [m/s]
omega     float64[nw, 3]    angular velocity [rad/s]
origin    float64[nw, 3]    reference point (rotation centre) [m]
aabb      float64[nw, 6]    xmin, ymin, zmin, xmax, ymax, zmax (inf for planes)
material  int32[nw]         material index (-1 for a wall named by its material's name
                            until a simulation resolves it: :meth:`resolve_materials`)
group     int32[nw]         index into :attr:`WallSet.names` (one per user wall)
row_id    int64[nw]         the row's number when the set was built; it stays with
                            the row when :meth:`WallSet.remove` drops other walls
========  ================  ===================================================

The velocity of wall row ``w`` at a contact point ``xc`` is
``velocity[w] + omega[w] x (xc - origin[w])``. :meth:`WallSet.update` moves every
moving wall to time ``t``; it is cheap and only needed when :attr:`WallSet.moving`.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.errors import ConfigError
from demcal.geometry import kernels as K
from demcal.geometry.motion import Rotation
from demcal.geometry.placement import ROTATION, TRANSLATION, place_moving
from demcal.geometry.walls import Wall, aabb_rows, transform_rows

__all__ = ["WallSet", "triangulate_row"]


class WallSet:
    """The walls of one simulation as arrays, plus their motions.

    Parameters
    ----------
    walls : sequence of :class:`~demcal.geometry.walls.Wall`
        Each becomes one group; unnamed walls are called ``<kind><index>``
        (``plane0``, ``box1`` ...). Names must be unique.
    t : float
        Time [s] at which the arrays are first evaluated (default 0).
    """

    def __init__(self, walls=(), t: float = 0.0):
        walls = list(walls)
        for w in walls:
            if not isinstance(w, Wall):
                raise ConfigError(
                    f"a wall must be a Plane, Disk, Cylinder, Cone, Funnel, Rect, Box or "
                    f"TriangleMesh, got {type(w).__name__}."
                )
        self.walls = walls
        names = []
        for i, w in enumerate(walls):
            name = w.name if w.name is not None else f"{w.kind_name}{i}"
            if name in names:
                raise ConfigError(f"two walls are named {name!r}: give each wall its own name.")
            names.append(name)
        self.names: list[str] = names

        kinds, params, groups, origins = [], [], [], []
        for g, w in enumerate(walls):
            k, p = w.rows()
            kinds.append(k)
            params.append(p)
            groups.append(np.full(len(k), g, np.int32))
            origins.append(np.repeat(w.reference_origin()[None, :], len(k), axis=0))
        if walls:
            self.kind = np.concatenate(kinds).astype(np.int32)
            self._ref_params = np.ascontiguousarray(np.concatenate(params), dtype=np.float64)
            self.group = np.concatenate(groups).astype(np.int32)
            self._ref_origin = np.concatenate(origins)
        else:
            self.kind = np.zeros(0, np.int32)
            self._ref_params = np.zeros((0, K.PARAM_WIDTH))
            self.group = np.zeros(0, np.int32)
            self._ref_origin = np.zeros((0, 3))
        nw = len(self.kind)
        self.material = np.array([m if isinstance(m, int) else -1
                                  for m in (walls[g].material for g in self.group)], dtype=np.int32)
        self.params = self._ref_params.copy()
        self.velocity = np.zeros((nw, 3))
        self.omega = np.zeros((nw, 3))
        self.origin = self._ref_origin.copy()
        self.aabb = aabb_rows(self.kind, self.params) if nw else np.zeros((0, 6))
        self.row_id = np.arange(nw, dtype=np.int64)
        self._index()
        #: bumped by :meth:`set_motion` and :meth:`remove`, so that a simulation notices
        self.version: int = 0
        self.time = None
        self.update(t, force=True)

    def resolve_materials(self, index) -> None:
        """Set each row's material index from its wall's material, a name or an index,
        with ``index`` (a simulation's :meth:`~demcal.particles.materials.MaterialTable.index`,
        which says what is wrong with an unknown name or an index out of range)."""
        if len(self.group):
            self.material = np.array([index(self.walls[g].material) for g in self.group], dtype=np.int32)

    def _index(self) -> None:
        """The row slice of each group, and whether any wall moves."""
        bounds = np.searchsorted(self.group, np.arange(len(self.walls) + 1))
        self._slices = [slice(int(bounds[g]), int(bounds[g + 1]))
                        for g in range(len(self.walls))]
        self.moving: bool = any(w.motion.moving for w in self.walls)

    def __len__(self) -> int:
        return len(self.kind)

    @property
    def n_groups(self) -> int:
        return len(self.walls)

    def compiled_motions(self):
        """The moving rows the engine's compiled step loop places itself at every step
        (:func:`demcal.geometry.placement.place_moving`): those of walls that move by a
        :class:`~demcal.geometry.motion.Translation` or a
        :class:`~demcal.geometry.motion.Rotation`.

        Returns ``(flag, velocity, start, stop, ref_params, ref_origin, axis, point,
        rate)``: ``flag[w]`` (``placement.TRANSLATION`` or ``placement.ROTATION``, 0 for
        a still row), the translation velocity [m/s], the active interval [s], the
        reference rows the motion is applied to, and a rotation's unit axis, point [m]
        and rate [rad/s]; or None when some moving wall has another motion (a function
        of time: the engine then places the walls from Python every step).
        """
        from demcal.geometry.motion import Translation

        nw = len(self.kind)
        flag = np.zeros(nw, np.int64)
        vel = np.zeros((nw, 3))
        start = np.zeros(nw)
        stop = np.zeros(nw)
        axis = np.zeros((nw, 3))
        point = np.zeros((nw, 3))
        rate = np.zeros(nw)
        for g, w in enumerate(self.walls):
            m = w.motion
            if not m.moving:
                continue
            s = self._slices[g]
            if type(m) is Translation:
                flag[s] = TRANSLATION
                vel[s] = m.velocity
            elif type(m) is Rotation:
                flag[s] = ROTATION
                axis[s] = m.axis
                point[s] = m.point
                rate[s] = m.angular_speed
            else:
                return None
            start[s] = m.start
            stop[s] = m.stop
        return (flag, vel, start, stop, self._ref_params, self._ref_origin, axis, point,
                rate)

    def rows_of(self, name: str) -> slice:
        """The row slice of the wall called ``name``."""
        try:
            return self._slices[self.names.index(name)]
        except ValueError:
            raise ConfigError(
                f"no wall named {name!r}; the walls are {', '.join(self.names) or '(none)'}."
            ) from None

    def set_motion(self, name: str, motion) -> None:
        """Give the wall called ``name`` a new motion from now on: a
        :class:`~demcal.geometry.motion.Motion`, or None to hold it at its reference
        position. A motion applies to the wall's reference position, as when the wall
        was built, and the wall is placed by it at once.

        A simulation using this wall set picks the change up when it next runs: it
        copies the walls and rebuilds its contact lists, because the wall may have jumped.
        A constant-velocity :class:`~demcal.geometry.motion.Translation` is then placed
        inside the engine's compiled loop at every step (exact and fast), unlike a motion
        driven from Python between calls.
        """
        from demcal.geometry.motion import as_motion

        self.rows_of(name)  # the error that lists the walls, if there is none so called
        g = self.names.index(name)
        self.walls[g].motion = as_motion(motion)
        self.moving = self.moving or self.walls[g].motion.moving
        self._place(g, 0.0 if self.time is None else self.time)
        self.version += 1

    def remove(self, name: str) -> None:
        """Take the wall called ``name`` out of the set, with all its rows.

        The other walls keep their names, rows (in order, with their ``row_id``) and
        motions. Remove a wall from a running simulation with
        :meth:`demcal.dem.Simulation.remove_wall`, which also drops the contacts
        against it; a simulation using this set picks up a removal made here when it
        next runs.
        """
        rows = self.rows_of(name)  # the error that lists the walls, if there is none so called
        g = self.names.index(name)
        keep = np.ones(len(self.kind), bool)
        keep[rows] = False
        del self.walls[g]
        del self.names[g]
        for key in ("kind", "_ref_params", "group", "_ref_origin", "material", "params",
                    "velocity", "omega", "origin", "aabb", "row_id"):
            setattr(self, key, np.ascontiguousarray(getattr(self, key)[keep]))
        self.group[self.group > g] -= 1
        self._index()
        self.version += 1

    def _place(self, g: int, t: float) -> None:
        """Put wall group g where its motion has it at time ``t``."""
        w = self.walls[g]
        s = self._slices[g]
        if s.stop == s.start:
            return
        kinds = self.kind[s]
        if type(w.motion) is Rotation:
            # the compiled step loop's own arithmetic, so both paths agree to the bit
            n = s.stop - s.start
            place_moving(t, np.full(n, ROTATION, np.int64), np.zeros((n, 3)),
                         np.full(n, w.motion.start), np.full(n, w.motion.stop),
                         np.tile(w.motion.axis, (n, 1)), np.tile(w.motion.point, (n, 1)),
                         np.full(n, w.motion.angular_speed), self._ref_params[s],
                         self._ref_origin[s], kinds, self.params[s], self.origin[s],
                         self.velocity[s], self.omega[s])
            self.aabb[s] = aabb_rows(kinds, self.params[s])
            return
        rot, trans = w.motion.transform(t)
        omega, v0 = w.motion.twist(t)
        self.params[s] = transform_rows(kinds, self._ref_params[s], rot, trans)
        origin = self._ref_origin[s] @ rot.T + trans
        self.origin[s] = origin
        self.omega[s] = omega
        self.velocity[s] = v0 + np.cross(omega, origin)
        self.aabb[s] = aabb_rows(kinds, self.params[s])

    def update(self, t: float, force: bool = False) -> None:
        """Move every moving wall to time ``t`` [s]: rewrites ``params``, ``velocity``,
        ``omega``, ``origin`` and ``aabb`` in place (static walls are left alone)."""
        for g, w in enumerate(self.walls):
            if w.motion.moving or force:
                self._place(g, t)
        self.time = t

    def sum_by_group(self, values: np.ndarray) -> np.ndarray:
        """Sum per-row values ``(nw, ...)`` (e.g. forces) into per-group ``(n_groups, ...)``."""
        values = np.asarray(values)
        out = np.zeros((self.n_groups,) + values.shape[1:], dtype=values.dtype)
        np.add.at(out, self.group, values)
        return out

    def bounds(self) -> np.ndarray:
        """The union ``(6,)`` of the finite row bounding boxes (planes ignored)."""
        finite = np.all(np.isfinite(self.aabb), axis=1)
        if not np.any(finite):
            return np.array([np.inf] * 3 + [-np.inf] * 3)
        b = self.aabb[finite]
        return np.concatenate([b[:, :3].min(axis=0), b[:, 3:].max(axis=0)])

    def triangulate(self, resolution: int = 32, plane_size: float | None = None):
        """Triangles approximating every wall at the current time, for visualisation.

        Parameters
        ----------
        resolution : int
            Segments around a full circle (disks, cylinders, cones).
        plane_size : float, optional
            Side [m] of the square drawn for an infinite plane (default: twice the size
            of the finite walls' bounding box, or 1 m).

        Returns
        -------
        points : float64[np, 3]
        triangles : int64[nt, 3]
            Indices into ``points``.
        group : int32[nt]
            Wall group of each triangle.
        """
        if plane_size is None:
            b = self.bounds()
            size = float(np.max(b[3:] - b[:3])) if np.all(np.isfinite(b)) else 0.0
            plane_size = 2.0 * size if size > 0 else 1.0
        pts, tris, groups = [], [], []
        offset = 0
        for w in range(len(self)):
            p, t = triangulate_row(int(self.kind[w]), self.params[w], resolution, plane_size)
            pts.append(p)
            tris.append(t + offset)
            groups.append(np.full(len(t), self.group[w], np.int32))
            offset += len(p)
        if not pts:
            return np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int32)
        return np.concatenate(pts), np.concatenate(tris).astype(np.int64), np.concatenate(groups)


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1 = np.array(K.perpendicular(*axis))
    return e1, np.cross(axis, e1)


def _surface_of_revolution(c, a, radii, heights, n):
    """Quad strips between consecutive rings (radius, height along a)."""
    e1, e2 = _frame(a)
    phi = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    ring = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
    pts = np.concatenate([c + h * a + r * ring for r, h in zip(radii, heights)])
    tris = []
    j = np.arange(n)
    jn = (j + 1) % n
    for i in range(len(radii) - 1):
        lo, hi = i * n, (i + 1) * n
        tris.append(np.stack([lo + j, lo + jn, hi + jn], axis=1))
        tris.append(np.stack([lo + j, hi + jn, hi + j], axis=1))
    return pts, np.concatenate(tris)


def triangulate_row(kind: int, p: np.ndarray, resolution: int = 32, plane_size: float = 1.0):
    """Points and triangles approximating one kernel row (see :meth:`WallSet.triangulate`)."""
    n = max(int(resolution), 3)
    if kind == K.PLANE:
        c, a = p[0:3], p[3:6]
        e1, e2 = _frame(a)
        h = 0.5 * plane_size
        pts = np.array([c - h * e1 - h * e2, c + h * e1 - h * e2, c + h * e1 + h * e2, c - h * e1 + h * e2])
        return pts, np.array([[0, 1, 2], [0, 2, 3]])
    if kind == K.DISK:
        c, a, r_out, r_in = p[0:3], p[3:6], p[6], p[7]
        if r_in > 0.0:
            return _surface_of_revolution(c, a, [r_in, r_out], [0.0, 0.0], n)
        e1, e2 = _frame(a)
        phi = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
        ring = c + r_out * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
        pts = np.concatenate([c[None, :], ring])
        j = np.arange(n)
        return pts, np.stack([np.zeros(n, int), 1 + j, 1 + (j + 1) % n], axis=1)
    if kind == K.CYLINDER:
        length = p[7] if math.isfinite(p[7]) else plane_size  # an endless one, cut
        return _surface_of_revolution(p[0:3], p[3:6], [p[6], p[6]], [0.0, length], n)
    if kind == K.CONE:
        return _surface_of_revolution(p[0:3], p[3:6], [p[6], p[7]], [0.0, p[8]], n)
    if kind == K.RECT:
        c, u, v = p[0:3], p[3:6], p[6:9]
        pts = np.array([c - u - v, c + u - v, c + u + v, c - u + v])
        return pts, np.array([[0, 1, 2], [0, 2, 3]])
    if kind == K.TRIANGLE:
        return p[0:9].reshape(3, 3).copy(), np.array([[0, 1, 2]])
    raise ValueError(f"unknown wall kind {kind}")
