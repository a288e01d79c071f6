"""Wall descriptions: plane, disk, cylinder, cone, funnel, rectangle, box, triangle mesh.

A wall is a pure description of a surface in its *reference* pose (time 0), with a
``name``, a ``material`` index and a :class:`~demcal.geometry.motion.Motion`. It lowers
itself to one or more kernel rows (``kind``, 16 float64 parameters, see
:mod:`demcal.geometry.kernels`) with :meth:`Wall.rows`; a
:class:`~demcal.geometry.wallset.WallSet` packs the rows of many walls into arrays and
moves them with :func:`transform_rows`.

All lengths are in metres [m]; direction vectors need not be normalised.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from demcal._checks import as_float
from demcal.errors import ConfigError, DataError
from demcal.geometry import kernels as K
from demcal.geometry.motion import Motion, _unit, _vec3, as_motion

__all__ = [
    "Wall",
    "Plane",
    "Disk",
    "Cylinder",
    "Cone",
    "Funnel",
    "Rect",
    "Box",
    "TriangleMesh",
    "transform_rows",
]


def _positive(value, name: str, allow_zero: bool = False) -> float:
    v = as_float(value)
    if not np.isfinite(v) or v < 0.0 or (v == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ConfigError(f"{name} must be a finite number {bound} [m], got {value!r}.")
    return v


def _material_ref(material) -> int | str:
    """A wall's material: its name (a non-empty string, looked up in the list given to
    :class:`~demcal.dem.simulation.Simulation` when the simulation is built) or its
    position in that list (a whole number >= 0)."""
    if isinstance(material, str):
        if not material.strip():
            raise ConfigError("a wall material name must not be empty; give the material's "
                              "name or its position in the list given to Simulation.")
        return material
    ok = False
    if isinstance(material, (int, np.integer)) and not isinstance(material, (bool, np.bool_)):
        ok = material >= 0
    elif isinstance(material, (float, np.floating)):
        ok = bool(np.isfinite(material)) and material >= 0 and material == int(material)
    if not ok:
        raise ConfigError(
            f"a wall material must be a material's name or an index >= 0 (its position in "
            f"the list given to Simulation), got {material!r}."
        )
    return int(material)


def _row(point=None, direction=None, *values) -> np.ndarray:
    """A kernel parameter row: ``point`` in slots 0:3, ``direction`` in 3:6 and the scalar
    ``values`` from slot 6 on (the layouts of plane, disk, cylinder and cone rows); zeros
    elsewhere."""
    p = np.zeros(K.PARAM_WIDTH)
    if point is not None:
        p[0:3] = point
        p[3:6] = direction
        p[6:6 + len(values)] = values
    return p


class Wall:
    """Base class: a named surface with a material (name or index) and a motion."""

    kind_name = "wall"

    def __init__(self, name: str | None = None, material: int | str = 0, motion=None):
        if name is not None and (not isinstance(name, str) or not name):
            raise ConfigError(f"a wall name must be a non-empty string, got {name!r}.")
        self.name = name
        self.material = _material_ref(material)
        self.motion: Motion = as_motion(motion)

    def rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Kernel rows in the reference pose: ``kind int32[k]``, ``params float64[k, 16]``."""
        raise NotImplementedError

    def reference_origin(self) -> np.ndarray:
        """Reference point [m] about which torques on this wall are reported.

        The rotation point of a :class:`~demcal.geometry.motion.Rotation`, otherwise
        the centre of the wall's bounding box (the origin for infinite planes: their
        point).
        """
        point = getattr(self.motion, "point", None)
        if point is not None:
            return np.asarray(point, dtype=float)
        return self._centre()

    def _centre(self) -> np.ndarray:
        kinds, params = self.rows()
        box = aabb_rows(kinds, params)
        lo = box[:, :3].min(axis=0)
        hi = box[:, 3:].max(axis=0)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            return params[0, 0:3].copy()
        return 0.5 * (lo + hi)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, material={self.material})"


class Plane(Wall):
    """An infinite plane through ``point`` with unit ``normal`` pointing into the domain.

    One-sided: a particle behind the plane (signed distance < radius) is pushed back
    along the normal.
    """

    kind_name = "plane"

    def __init__(self, point=(0, 0, 0), normal=(0, 0, 1), **kw):
        super().__init__(**kw)
        self.point = _vec3(point, "plane point")
        self.normal = _unit(normal, "plane normal")

    def rows(self):
        return np.array([K.PLANE], np.int32), _row(self.point, self.normal)[None, :]


class Disk(Wall):
    """A flat disk (or annulus when ``inner_radius > 0``) centred at ``centre`` with
    unit ``normal``; two-sided."""

    kind_name = "disk"

    def __init__(self, centre=(0, 0, 0), normal=(0, 0, 1), radius=1.0, inner_radius=0.0, **kw):
        super().__init__(**kw)
        self.centre = _vec3(centre, "disk centre")
        self.normal = _unit(normal, "disk normal")
        self.radius = _positive(radius, "disk radius")
        self.inner_radius = _positive(inner_radius, "disk inner_radius", allow_zero=True)
        if self.inner_radius >= self.radius:
            raise ConfigError(
                f"disk inner_radius ({inner_radius}) must be smaller than its radius ({radius})."
            )

    def rows(self):
        p = _row(self.centre, self.normal, self.radius, self.inner_radius)
        return np.array([K.DISK], np.int32), p[None, :]


class Cylinder(Wall):
    """A cylindrical shell: base circle centre ``base`` [m], ``axis`` towards the top,
    ``radius`` [m], ``length`` [m]; two-sided, open ends unless ``bottom``/``top`` caps
    are asked for (flat disks, same group).

    ``length=math.inf`` gives a cylinder without end: from the base circle on along
    ``axis`` (the distance kernel clamps the axial coordinate to ``[0, length]``, which
    an infinite length leaves unclamped above the base). Put the base below every
    particle (e.g. at or under the floor) for a cylinder that is infinite both ways as
    far as the particles can tell. Such a cylinder may have a ``bottom`` cap, not a
    ``top`` one; it is drawn (:meth:`WallSet.triangulate`) as long as an infinite plane.
    """

    kind_name = "cylinder"

    def __init__(
        self,
        base=(0, 0, 0),
        axis=(0, 0, 1),
        radius=1.0,
        length=1.0,
        bottom: bool = False,
        top: bool = False,
        **kw,
    ):
        super().__init__(**kw)
        self.base = _vec3(base, "cylinder base")
        self.axis = _unit(axis, "cylinder axis")
        self.radius = _positive(radius, "cylinder radius")
        self.length = as_float(length)
        if not self.length > 0.0:  # NaN (not a number) too
            raise ConfigError(f"cylinder length must be a number > 0 [m] or math.inf (no "
                              f"end), got {length!r}.")
        if top and math.isinf(self.length):
            raise ConfigError("a cylinder of infinite length has no top to close: drop "
                              "top=True or give a finite length.")
        self.bottom = bool(bottom)
        self.top = bool(top)

    def rows(self):
        kinds = [K.CYLINDER]
        params = [_row(self.base, self.axis, self.radius, self.length)]
        for on, height in ((self.bottom, 0.0), (self.top, self.length)):
            if on:  # (an endless cylinder has no top)
                kinds.append(K.DISK)
                params.append(_row(self.base + height * self.axis, self.axis, self.radius))
        return np.array(kinds, np.int32), np.array(params)


class Cone(Wall):
    """A conical frustum shell from the circle of radius ``r1`` centred at ``base`` to
    the circle of radius ``r2`` at ``base + length * axis``; two-sided, open ends."""

    kind_name = "cone"

    def __init__(self, base=(0, 0, 0), axis=(0, 0, 1), r1=0.5, r2=1.0, length=1.0, **kw):
        super().__init__(**kw)
        self.base = _vec3(base, "cone base")
        self.axis = _unit(axis, "cone axis")
        self.r1 = _positive(r1, "cone r1", allow_zero=True)
        self.r2 = _positive(r2, "cone r2", allow_zero=True)
        if self.r1 == 0.0 and self.r2 == 0.0:
            raise ConfigError("a cone needs r1 > 0 or r2 > 0.")
        self.length = _positive(length, "cone length")

    def rows(self):
        p = _row(self.base, self.axis, self.r1, self.r2, self.length)
        return np.array([K.CONE], np.int32), p[None, :]


class Funnel(Wall):
    """A funnel: an optional outlet pipe (cylinder) below a conical hopper.

    Parameters
    ----------
    outlet : (3,) array
        Centre of the outlet's lower opening [m].
    outlet_radius : float
        Inner radius of the outlet [m].
    top_radius : float
        Radius of the funnel's upper rim [m].
    cone_height : float
        Axial height of the conical part [m].
    outlet_length : float
        Length of the outlet pipe below the cone [m]; 0 for none.
    axis : (3,) array
        Direction from the outlet up to the rim (default +z).
    """

    kind_name = "funnel"

    def __init__(
        self,
        outlet=(0, 0, 0),
        outlet_radius=0.01,
        top_radius=0.05,
        cone_height=0.05,
        outlet_length=0.0,
        axis=(0, 0, 1),
        **kw,
    ):
        super().__init__(**kw)
        self.outlet = _vec3(outlet, "funnel outlet")
        self.axis = _unit(axis, "funnel axis")
        self.outlet_radius = _positive(outlet_radius, "funnel outlet_radius")
        self.top_radius = _positive(top_radius, "funnel top_radius")
        self.cone_height = _positive(cone_height, "funnel cone_height")
        self.outlet_length = _positive(outlet_length, "funnel outlet_length", allow_zero=True)

    @property
    def rim(self) -> np.ndarray:
        """Centre of the upper rim [m]."""
        return self.outlet + (self.outlet_length + self.cone_height) * self.axis

    def rows(self):
        kinds = []
        params = []
        if self.outlet_length > 0.0:
            kinds.append(K.CYLINDER)
            params.append(_row(self.outlet, self.axis, self.outlet_radius, self.outlet_length))
        kinds.append(K.CONE)
        params.append(_row(self.outlet + self.outlet_length * self.axis, self.axis,
                           self.outlet_radius, self.top_radius, self.cone_height))
        return np.array(kinds, np.int32), np.array(params)


class Rect(Wall):
    """A finite rectangle: ``centre`` and two orthogonal half-extent edge vectors
    ``u``, ``v`` (the rectangle is ``centre + s u + t v``, ``|s|, |t| <= 1``); two-sided.

    Use :meth:`from_size` for a rectangle given by normal and side lengths.
    """

    kind_name = "rect"

    def __init__(self, centre=(0, 0, 0), u=(0.5, 0, 0), v=(0, 0.5, 0), **kw):
        super().__init__(**kw)
        self.centre = _vec3(centre, "rect centre")
        self.u = _vec3(u, "rect u")
        self.v = _vec3(v, "rect v")
        lu = float(np.linalg.norm(self.u))
        lv = float(np.linalg.norm(self.v))
        if lu == 0.0 or lv == 0.0:
            raise ConfigError("rect half-extent vectors u and v must be non-zero.")
        if abs(float(self.u @ self.v)) > 1e-9 * lu * lv:
            raise ConfigError("rect half-extent vectors u and v must be orthogonal.")

    @classmethod
    def from_size(cls, centre, normal, width, length, width_direction=None, **kw) -> "Rect":
        """A ``width`` x ``length`` [m] rectangle with unit ``normal``; ``width`` runs along
        ``width_direction`` (projected onto the plane; default: any in-plane direction)."""
        n = _unit(normal, "rect normal")
        if width_direction is None:
            e1 = np.array(K.perpendicular(*n))
        else:
            w = _vec3(width_direction, "rect width_direction")
            e1 = w - (w @ n) * n
            if np.linalg.norm(e1) < 1e-12:
                raise ConfigError("rect width_direction must not be parallel to its normal.")
            e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        width = _positive(width, "rect width")
        length = _positive(length, "rect length")
        return cls(centre, 0.5 * width * e1, 0.5 * length * e2, **kw)

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.u, self.v)
        return n / np.linalg.norm(n)

    def rows(self):
        p = _row()
        p[0:3] = self.centre
        p[3:6] = self.u
        p[6:9] = self.v
        p[9:12] = self.normal
        p[12] = self.u @ self.u
        p[13] = self.v @ self.v
        return np.array([K.RECT], np.int32), p[None, :]


class Box(Wall):
    """An axis-aligned box from corner ``lower`` to corner ``upper`` made of six
    rectangles (five with ``open_top=True``: no face at ``z = upper[2]``).

    Face normals point into the box; all faces are one group named after the box.
    """

    kind_name = "box"

    def __init__(self, lower=(0, 0, 0), upper=(1, 1, 1), open_top: bool = False, **kw):
        super().__init__(**kw)
        self.lower = _vec3(lower, "box lower corner")
        self.upper = _vec3(upper, "box upper corner")
        if np.any(self.upper <= self.lower):
            raise ConfigError(
                f"box upper corner {self.upper.tolist()} must exceed its lower corner "
                f"{self.lower.tolist()} in x, y and z."
            )
        self.open_top = bool(open_top)

    def faces(self) -> list[Rect]:
        lo, hi = self.lower, self.upper
        c = 0.5 * (lo + hi)
        h = 0.5 * (hi - lo)
        ex, ey, ez = np.eye(3)
        faces = [
            # (centre, u, v) with u x v pointing inwards
            (np.array([c[0], c[1], lo[2]]), h[0] * ex, h[1] * ey),  # bottom, +z
            (np.array([lo[0], c[1], c[2]]), h[1] * ey, h[2] * ez),  # x-, +x
            (np.array([hi[0], c[1], c[2]]), h[2] * ez, h[1] * ey),  # x+, -x
            (np.array([c[0], lo[1], c[2]]), h[2] * ez, h[0] * ex),  # y-, +y
            (np.array([c[0], hi[1], c[2]]), h[0] * ex, h[2] * ez),  # y+, -y
        ]
        if not self.open_top:
            faces.append((np.array([c[0], c[1], hi[2]]), h[1] * ey, h[0] * ex))  # top, -z
        return [Rect(cc, u, v, material=self.material) for cc, u, v in faces]

    def rows(self):
        parts = [f.rows() for f in self.faces()]
        return (
            np.concatenate([k for k, _ in parts]).astype(np.int32),
            np.concatenate([p for _, p in parts]),
        )


class TriangleMesh(Wall):
    """A surface of triangles (one wall group, one kernel row per triangle); two-sided.

    Build it from ``vertices (n, 3)`` and ``faces (m, 3)`` integer indices, or from
    ``triangles (m, 3, 3)`` with :meth:`from_triangles`, or from an ASCII or binary STL
    file with :meth:`from_stl` (every solid of an ASCII file; a malformed facet or a
    binary file whose size does not match its triangle count is refused with a
    :class:`~demcal.errors.DataError`). Degenerate (zero-area) triangles are dropped.
    """

    kind_name = "mesh"

    def __init__(self, vertices, faces, **kw):
        super().__init__(**kw)
        vertices = np.asarray(vertices, dtype=float)
        faces = np.asarray(faces)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.all(np.isfinite(vertices)):
            raise ConfigError("mesh vertices must be an (n, 3) array of finite numbers.")
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.size == 0:
            raise ConfigError("mesh faces must be a non-empty (m, 3) array of vertex indices.")
        if not np.issubdtype(faces.dtype, np.integer):
            raise ConfigError("mesh faces must hold integer vertex indices.")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise ConfigError(
                f"mesh faces refer to vertex {int(faces.max())} but there are only "
                f"{len(vertices)} vertices."
            )
        tri = vertices[faces]
        area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        scale = max(float(np.ptp(vertices, axis=0).max()), 1e-300)
        keep = area2 > 1e-12 * scale * scale
        if not np.any(keep):
            raise ConfigError("mesh has no triangle with a non-zero area.")
        self.dropped = int((~keep).sum())
        self.vertices = vertices
        self.faces = faces[keep].astype(np.int64)

    @classmethod
    def from_triangles(cls, triangles, **kw) -> "TriangleMesh":
        """A mesh from an ``(m, 3, 3)`` array of triangle corner coordinates [m]."""
        tri = np.asarray(triangles, dtype=float)
        if tri.ndim != 3 or tri.shape[1:] != (3, 3):
            raise ConfigError("triangles must be an (m, 3, 3) array of corner coordinates.")
        return cls(tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), **kw)

    @classmethod
    def from_stl(cls, path, scale: float = 1.0, translate=(0.0, 0.0, 0.0), **kw) -> "TriangleMesh":
        """Read an ASCII or binary STL file.

        ``scale`` multiplies the coordinates (``0.001`` for a CAD file in millimetres),
        then ``translate`` [m] is added. The name defaults to the file's stem.
        """
        path = Path(path)
        if not path.is_file():
            raise DataError(f"STL file {str(path)!r} does not exist: check the path.")
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise DataError(f"cannot read STL file {str(path)!r} ({exc.strerror or exc}): "
                            f"check its permissions.") from None
        factor = as_float(scale)
        if not (math.isfinite(factor) and factor != 0.0):
            raise ConfigError(f"STL scale must be a finite non-zero number (0.001 for a file in "
                              f"millimetres), got {scale!r}.")
        offset = _vec3(translate, "STL translate")
        vectors = _read_stl(data, str(path))
        if len(vectors) == 0:
            raise DataError(f"STL file {str(path)!r} holds no triangles: export the surface again.")
        tri = vectors * factor + offset
        kw.setdefault("name", path.stem)
        return cls.from_triangles(tri, **kw)

    def triangles(self) -> np.ndarray:
        """The ``(m, 3, 3)`` corner coordinates in the reference pose [m]."""
        return self.vertices[self.faces]

    def rows(self):
        tri = self.triangles()
        m = len(tri)
        p = np.zeros((m, K.PARAM_WIDTH))
        p[:, 0:9] = tri.reshape(m, 9)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        p[:, 9:12] = n / np.linalg.norm(n, axis=1)[:, None]
        return np.full(m, K.TRIANGLE, np.int32), p


_STL_HEADER = 84   # binary STL: 80-byte header + uint32 triangle count
_STL_RECORD = 50   # binary STL: normal and three corners (12 float32) + uint16


def closed_drum(radius, length, motion=None, material=0, name="drum") -> list:
    """A closed drum about the y axis, centred on the origin: its shell (a
    :class:`Cylinder` called ``name``, ``radius`` and ``length`` [m]) and two end
    :class:`Disk` walls (``name``-front, ``name``-back), all moved by ``motion`` (e.g. a
    :class:`~demcal.geometry.motion.Rotation` about the y axis through the origin).
    Returns the three walls, for a :class:`~demcal.geometry.WallSet`."""
    half = 0.5 * _positive(length, f"{name} length")
    return [Cylinder(base=(0, -half, 0), axis=(0, 1, 0), radius=radius, length=2 * half,
                     material=material, name=name, motion=motion),
            Disk(centre=(0, -half, 0), normal=(0, 1, 0), radius=radius, material=material,
                 name=f"{name}-front", motion=motion),
            Disk(centre=(0, half, 0), normal=(0, -1, 0), radius=radius, material=material,
                 name=f"{name}-back", motion=motion)]


def _read_stl(data: bytes, path: str) -> np.ndarray:
    """Triangles ``(m, 3, 3)`` of an ASCII or binary STL file (read by numpy-stl, every
    solid of an ASCII file); a :class:`DataError` naming the problem otherwise."""
    from stl import Mode
    from stl import mesh as stl_mesh

    if not data.strip():
        raise DataError(f"cannot read {path!r}: the STL file is empty; export the surface again.")
    count = int.from_bytes(data[80:84], "little") if len(data) >= _STL_HEADER else -1
    binary = count >= 0 and len(data) == _STL_HEADER + _STL_RECORD * count
    if not binary and data.lstrip()[:5].lower() != b"solid":
        if count < 0:
            problem = f"{len(data)} bytes, fewer than the 84 of a binary STL header"
        elif len(data) < _STL_HEADER + _STL_RECORD * count:
            problem = (f"it is truncated: its header promises {count} triangles, the file "
                       f"holds {(len(data) - _STL_HEADER) // _STL_RECORD}")
        else:
            problem = (f"it has {len(data) - _STL_HEADER - _STL_RECORD * count} bytes after "
                       f"the {count} triangles its header promises")
        raise DataError(f"cannot read {path!r} as a binary STL file ({problem}); export it "
                        f"again as ASCII or binary STL.")
    try:
        if binary:
            meshes = [stl_mesh.Mesh.from_file(path, mode=Mode.BINARY)]
        else:
            meshes = list(stl_mesh.Mesh.from_multi_file(path, mode=Mode.ASCII))
    except Exception as exc:  # numpy-stl raises several types on bad input
        detail = exc.args[-1] if isinstance(exc, RuntimeError) and exc.args else exc
        kind = "binary" if binary else "ASCII"
        raise DataError(f"cannot read {path!r}: it is not a valid {kind} STL file ({detail}); "
                        f"export it again as ASCII or binary STL.") from None
    if not meshes:
        return np.zeros((0, 3, 3))
    return np.concatenate([np.asarray(m.vectors, dtype=float) for m in meshes])


def transform_rows(kinds: np.ndarray, params: np.ndarray, rot: np.ndarray, trans: np.ndarray):
    """Apply the rigid transform ``x -> rot @ x + trans`` to kernel rows.

    Points (slots 0:3 of every kind, 3:9 of triangles) are moved; direction and edge
    vectors (3:6 of other kinds, 6:9 of rects, 9:12 of rects and triangles) are rotated;
    radii, lengths and squared lengths are unchanged. Returns new arrays.
    """
    out = params.copy()
    rt = rot.T
    out[:, 0:3] = params[:, 0:3] @ rt + trans
    tri = kinds == K.TRIANGLE
    rect = kinds == K.RECT
    if np.any(tri):
        out[tri, 3:6] = params[tri, 3:6] @ rt + trans
        out[tri, 6:9] = params[tri, 6:9] @ rt + trans
    other = ~tri
    if np.any(other):
        out[other, 3:6] = params[other, 3:6] @ rt
    if np.any(rect):
        out[rect, 6:9] = params[rect, 6:9] @ rt
    both = tri | rect
    if np.any(both):
        out[both, 9:12] = params[both, 9:12] @ rt
    return out


def _circle_extent(axis: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Half-extents along x, y, z of circles with unit ``axis`` (k, 3), ``radius`` (k,)."""
    return radius[:, None] * np.sqrt(np.clip(1.0 - axis * axis, 0.0, None))


def aabb_rows(kinds: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Axis-aligned bounding boxes ``(k, 6)`` = xmin, ymin, zmin, xmax, ymax, zmax of
    kernel rows (``inf`` for infinite planes)."""
    k = len(kinds)
    box = np.empty((k, 6))
    box[:, :3] = -np.inf
    box[:, 3:] = np.inf
    c = params[:, 0:3]
    a = params[:, 3:6]

    m = kinds == K.DISK
    if np.any(m):
        e = _circle_extent(a[m], params[m, 6])
        box[m, :3] = c[m] - e
        box[m, 3:] = c[m] + e

    for kind, r_a, r_b, length_slot in ((K.CYLINDER, 6, 6, 7), (K.CONE, 6, 7, 8)):
        m = kinds == kind
        if np.any(m):
            # the far end; an infinite cylinder reaches infinity where its axis has a
            # component and stays within its circle where it has none (not 0 * inf)
            far = params[m, length_slot][:, None] * np.where(a[m] != 0.0, a[m], 1.0)
            c2 = c[m] + np.where(a[m] != 0.0, far, 0.0)
            e1 = _circle_extent(a[m], params[m, r_a])
            e2 = _circle_extent(a[m], params[m, r_b])
            box[m, :3] = np.minimum(c[m] - e1, c2 - e2)
            box[m, 3:] = np.maximum(c[m] + e1, c2 + e2)

    m = kinds == K.RECT
    if np.any(m):
        e = np.abs(params[m, 3:6]) + np.abs(params[m, 6:9])
        box[m, :3] = c[m] - e
        box[m, 3:] = c[m] + e

    m = kinds == K.TRIANGLE
    if np.any(m):
        corners = params[m, 0:9].reshape(-1, 3, 3)
        box[m, :3] = corners.min(axis=1)
        box[m, 3:] = corners.max(axis=1)
    return box
