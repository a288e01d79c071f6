"""VTK XML output that ParaView opens: particles and walls as PolyData (.vtp), time
series as a collection (.pvd).

* :func:`write_particles` -- one point (and one vertex cell) per sphere with point data
  ``radius`` [m], ``velocity`` [m/s], ``id``, ``body_id`` and any extra arrays; in
  ParaView apply *Glyph* (sphere, scale by ``radius``, scale factor 2) to see balls.
* :func:`particle_fields` -- the point data of a simulation's state (:data:`STATE_FIELDS`:
  radius, ids, velocity, angular velocity, orientation, force, material), which
  :meth:`VtkSeries.write_state` writes (the engine's ``VTKReporter`` and the benches'
  ``--vtk``).
* :func:`write_triangles` / :func:`write_walls` -- triangle surfaces with cell data
  ``group`` (wall group index) and any extra per-triangle arrays;
* :func:`write_pvd` and :class:`VtkSeries` -- the time series, one ``DataSet`` per part
  per time step;
* :func:`read_vtp`, :func:`read_pvd` -- readers for our own files (tests, post-processing).

Format: VTK XML file format version 1.0, ``byte_order="LittleEndian"``,
``header_type="UInt64"``; data arrays inline, either ``ascii`` or ``binary`` (base64 of
an 8-byte byte count followed by the raw little-endian values, as in the VTK file
format documentation, "XML File Formats", section "Binary data"). Files are written to
a temporary name and renamed, so a reader never sees half a file.
"""

from __future__ import annotations

import base64
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Mapping

import numpy as np

from demcal.errors import DataError

__all__ = [
    "STATE_FIELDS",
    "particle_fields",
    "write_particles",
    "write_triangles",
    "write_walls",
    "write_pvd",
    "VtkSeries",
    "read_vtp",
    "read_pvd",
]

_VTK_TYPES = {
    np.dtype(np.float32): "Float32",
    np.dtype(np.float64): "Float64",
    np.dtype(np.int8): "Int8",
    np.dtype(np.uint8): "UInt8",
    np.dtype(np.int32): "Int32",
    np.dtype(np.uint32): "UInt32",
    np.dtype(np.int64): "Int64",
    np.dtype(np.uint64): "UInt64",
}
_NUMPY_TYPES = {v: k for k, v in _VTK_TYPES.items()}

#: Point data of a simulation frame (:func:`particle_fields`): name, components, unit,
#: meaning. One point per sphere; a multi-sphere particle's spheres share its values.
STATE_FIELDS = (
    ("radius", 1, "m", "sphere radius"),
    ("id", 1, "-", "sphere index"),
    ("body_id", 1, "-", "index of the particle (rigid body) the sphere belongs to"),
    ("velocity", 3, "m/s", "velocity of the particle's centre of mass"),
    ("angular_velocity", 3, "rad/s", "angular velocity of the particle, world frame"),
    ("orientation", 4, "-", "unit quaternion (w, x, y, z) turning the particle's principal "
     "frame into the world frame"),
    ("force", 3, "N", "total force on the particle at the last step (contacts and gravity)"),
    ("material", 1, "-", "material index of the particle"),
)
_ENCODINGS = ("binary", "ascii")


def _as_array(values) -> np.ndarray:
    a = np.asarray(values)
    if a.dtype == np.bool_:
        a = a.astype(np.uint8)
    elif np.issubdtype(a.dtype, np.integer) and a.dtype not in _VTK_TYPES:
        a = a.astype(np.int64)
    elif np.issubdtype(a.dtype, np.floating) and a.dtype not in _VTK_TYPES:
        a = a.astype(np.float64)
    if a.dtype not in _VTK_TYPES:
        raise DataError(f"cannot write an array of type {a.dtype} to VTK: use numbers.")
    return np.ascontiguousarray(a.astype(a.dtype.newbyteorder("<"), copy=False))


def _data_array(name: str, values, encoding: str, components: int | None = None) -> str:
    a = _as_array(values)
    if components is None:
        components = 1 if a.ndim == 1 else int(np.prod(a.shape[1:]))
    tuples = a.size // components if components else 0
    attrs = (
        f'type="{_VTK_TYPES[a.dtype]}" Name="{name}" NumberOfComponents="{components}" '
        f'NumberOfTuples="{tuples}"'
    )
    if encoding == "ascii":
        flat = a.ravel()
        if np.issubdtype(a.dtype, np.floating):
            text = " ".join(repr(float(v)) for v in flat)
        else:
            text = " ".join(str(int(v)) for v in flat)
        return f'<DataArray {attrs} format="ascii">{text}</DataArray>'
    raw = a.tobytes()
    payload = base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")
    return f'<DataArray {attrs} format="binary">{payload}</DataArray>'


def _atomic_write(path: Path, text: str) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from demcal._files import write_atomic

    return write_atomic(path, text.encode("ascii"))


def _polydata(points, verts=None, polys=None, point_data=None, cell_data=None, time=None, encoding="binary") -> str:
    if encoding not in _ENCODINGS:
        raise DataError(f"unknown VTK encoding {encoding!r}: use 'binary' or 'ascii'.")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n_pts = len(pts)
    n_verts = 0 if verts is None else len(verts[1])
    n_polys = 0 if polys is None else len(polys[1])
    out = [
        '<?xml version="1.0"?>',
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "<PolyData>",
    ]
    if time is not None:
        out.append("<FieldData>")
        out.append(_data_array("TimeValue", np.array([float(time)]), encoding))
        out.append("</FieldData>")
    out.append(
        f'<Piece NumberOfPoints="{n_pts}" NumberOfVerts="{n_verts}" NumberOfLines="0" '
        f'NumberOfStrips="0" NumberOfPolys="{n_polys}">'
    )
    for tag, data, count in (("PointData", point_data, n_pts), ("CellData", cell_data, n_verts + n_polys)):
        data = dict(data or {})
        attrs = ""
        scal = [k for k, v in data.items() if np.asarray(v).ndim == 1]
        vect = [k for k, v in data.items() if np.asarray(v).ndim == 2 and np.asarray(v).shape[1] == 3]
        if scal:
            attrs += f' Scalars="{scal[0]}"'
        if vect:
            attrs += f' Vectors="{vect[0]}"'
        out.append(f"<{tag}{attrs}>")
        for name, values in data.items():
            arr = np.asarray(values)
            if len(arr) != count:
                raise DataError(
                    f"VTK {tag} array {name!r} has {len(arr)} values but there are {count} "
                    f"{'points' if tag == 'PointData' else 'cells'}."
                )
            out.append(_data_array(name, arr, encoding))
        out.append(f"</{tag}>")
    out.append("<Points>")
    out.append(_data_array("Points", pts, encoding, components=3))
    out.append("</Points>")
    for tag, cells in (("Verts", verts), ("Polys", polys)):
        conn, offs = (np.zeros(0, np.int64), np.zeros(0, np.int64)) if cells is None else cells
        out.append(f"<{tag}>")
        out.append(_data_array("connectivity", np.asarray(conn, np.int64), encoding))
        out.append(_data_array("offsets", np.asarray(offs, np.int64), encoding))
        out.append(f"</{tag}>")
    out += ["</Piece>", "</PolyData>", "</VTKFile>", ""]
    return "\n".join(out)


def write_particles(
    path,
    positions,
    radius=None,
    velocity=None,
    ids=None,
    body_ids=None,
    point_data: Mapping | None = None,
    time: float | None = None,
    encoding: str = "binary",
) -> Path:
    """Write spheres as a PolyData point cloud (one vertex cell per point).

    Parameters
    ----------
    path : str or Path
        Output ``.vtp`` file.
    positions : float64[n, 3]
        Sphere centres [m].
    radius : float64[n], optional
        Sphere radii [m] (point data ``radius``).
    velocity : float64[n, 3], optional
        Velocities [m/s] (point data ``velocity``).
    ids, body_ids : int[n], optional
        Sphere ids (default 0..n-1) and the rigid body (clump) each sphere belongs to.
    point_data : mapping name -> array (n,) or (n, k), optional
        Further per-sphere arrays (forces, angular velocity, scale ...).
    time : float, optional
        Simulated time [s], stored as field data ``TimeValue``.
    encoding : {"binary", "ascii"}
    """
    pts = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    n = len(pts)
    data = {}
    if radius is not None:
        data["radius"] = np.broadcast_to(np.asarray(radius, np.float64), (n,))
    if velocity is not None:
        data["velocity"] = np.asarray(velocity, np.float64).reshape(n, 3)
    data["id"] = np.arange(n, dtype=np.int64) if ids is None else np.asarray(ids, np.int64)
    if body_ids is not None:
        data["body_id"] = np.asarray(body_ids, np.int64)
    for k, v in (point_data or {}).items():
        data[k] = np.asarray(v)
    verts = (np.arange(n, dtype=np.int64), np.arange(1, n + 1, dtype=np.int64))
    return _atomic_write(Path(path), _polydata(pts, verts=verts, point_data=data, time=time, encoding=encoding))


def particle_fields(state) -> dict[str, np.ndarray]:
    """The point data of :data:`STATE_FIELDS` (but ``id``, which
    :func:`write_particles` adds) for the spheres of ``state``.

    Parameters
    ----------
    state : demcal.dem.State
        A simulation's state (``sim.state``): per-particle ``velocities``, ``omegas``,
        ``quaternions``, ``forces``, ``materials`` and per-sphere ``radii``,
        ``sphere_body``.

    Returns
    -------
    dict
        Arrays with one row per sphere, the particle's values repeated on each of its
        spheres.
    """
    body = np.asarray(state.sphere_body, dtype=np.int64)
    return {
        "radius": np.asarray(state.radii, np.float64),
        "body_id": body,
        "velocity": np.asarray(state.velocities, np.float64)[body],
        "angular_velocity": np.asarray(state.omegas, np.float64)[body],
        "orientation": np.asarray(state.quaternions, np.float64)[body],
        "force": np.asarray(state.forces, np.float64)[body],
        "material": np.asarray(state.materials, np.int32)[body],
    }


def write_triangles(
    path, points, triangles, cell_data: Mapping | None = None, time: float | None = None, encoding: str = "binary"
) -> Path:
    """Write a triangle surface: ``points (np, 3)`` [m], ``triangles (nt, 3)`` indices,
    optional per-triangle ``cell_data``."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(tri) and (tri.min() < 0 or tri.max() >= len(pts)):
        raise DataError("triangle indices must refer to existing points.")
    polys = (tri.ravel(), 3 * np.arange(1, len(tri) + 1, dtype=np.int64))
    return _atomic_write(Path(path), _polydata(pts, polys=polys, cell_data=cell_data, time=time, encoding=encoding))


def write_walls(
    path,
    wallset,
    resolution: int = 32,
    plane_size: float | None = None,
    group_data: Mapping | None = None,
    time: float | None = None,
    encoding: str = "binary",
) -> Path:
    """Write the walls of a :class:`~demcal.geometry.WallSet` at their current pose.

    Cell data: ``group`` (index into ``wallset.names``), ``material``, and for each
    entry of ``group_data`` (name -> array ``(n_groups,)`` or ``(n_groups, 3)``, e.g. the
    force on each wall [N]) the value of the triangle's group.
    """
    pts, tri, group = wallset.triangulate(resolution=resolution, plane_size=plane_size)
    rows_material = np.zeros(wallset.n_groups, np.int32)
    if len(wallset):
        rows_material[wallset.group] = wallset.material
    cells = {"group": group.astype(np.int32), "material": rows_material[group]}
    for k, v in (group_data or {}).items():
        cells[k] = np.asarray(v)[group]
    return write_triangles(path, pts, tri, cell_data=cells, time=time, encoding=encoding)


def write_pvd(path, entries) -> Path:
    """Write a ParaView collection: ``entries`` are ``(time, file, part)`` tuples, the
    file names relative to the ``.pvd`` file's folder."""
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
        "<Collection>",
    ]
    for time, file, part in entries:
        lines.append(f'<DataSet timestep="{float(time)!r}" group="" part="{int(part)}" file="{file}"/>')
    lines += ["</Collection>", "</VTKFile>", ""]
    return _atomic_write(Path(path), "\n".join(lines))


class VtkSeries:
    """A time series of particle and wall files in ``folder`` with a ``.pvd`` index.

    ``series.write(time, positions=..., radius=..., ..., walls=wallset)`` writes
    ``<name>_particles_<k>.vtp`` and, for moving walls (or the first frame),
    ``<name>_walls_<k>.vtp``, then rewrites ``<name>.pvd`` (part 0 particles,
    part 1 walls; static walls point every time step at the first wall file).
    """

    def __init__(self, folder, name: str = "series", encoding: str = "binary", resolution: int = 32):
        self.folder = Path(folder)
        self.name = name
        self.encoding = encoding
        self.resolution = resolution
        self.entries: list[tuple[float, str, int]] = []
        self.frames = 0
        self._walls_file: str | None = None

    @property
    def pvd_path(self) -> Path:
        return self.folder / f"{self.name}.pvd"

    def write_state(self, time: float, state, walls=None, wall_data: Mapping | None = None) -> Path:
        """Write one frame of a simulation: its spheres with the point data of
        :func:`particle_fields` (:data:`STATE_FIELDS`), and ``walls``."""
        fields = particle_fields(state)
        radius, body = fields.pop("radius"), fields.pop("body_id")
        return self.write(time, state.sphere_positions, walls=walls, wall_data=wall_data,
                          radius=radius, velocity=fields.pop("velocity"), body_ids=body,
                          point_data=fields)

    def write(self, time: float, positions, walls=None, wall_data: Mapping | None = None, **fields) -> Path:
        """Write one frame; ``fields`` go to :func:`write_particles`."""
        k = self.frames
        pfile = f"{self.name}_particles_{k:06d}.vtp"
        write_particles(self.folder / pfile, positions, time=time, encoding=self.encoding, **fields)
        self.entries.append((time, pfile, 0))
        if walls is not None and len(walls):
            if walls.moving or self._walls_file is None or wall_data:
                wfile = f"{self.name}_walls_{k:06d}.vtp"
                static = not walls.moving and not wall_data
                write_walls(
                    self.folder / wfile,
                    walls,
                    self.resolution,
                    group_data=wall_data,
                    time=None if static else time,  # one file serves every time step
                    encoding=self.encoding,
                )
                if not walls.moving and not wall_data:
                    self._walls_file = wfile
            else:
                wfile = self._walls_file
            self.entries.append((time, wfile, 1))
        self.frames += 1
        return write_pvd(self.pvd_path, self.entries)


# ----------------------------------------------------------------------------- readers


def _decode(elem: ET.Element) -> np.ndarray:
    vtype = elem.get("type")
    if vtype not in _NUMPY_TYPES:
        raise DataError(f"unsupported VTK data type {vtype!r}.")
    dtype = _NUMPY_TYPES[vtype].newbyteorder("<")
    comps = int(elem.get("NumberOfComponents", "1"))
    fmt = elem.get("format", "ascii")
    text = (elem.text or "").strip()
    if fmt == "ascii":
        a = np.array(text.split(), dtype=dtype) if text else np.zeros(0, dtype)
    elif fmt == "binary":
        raw = base64.b64decode(text)
        nbytes = int(np.frombuffer(raw[:8], np.uint64)[0])
        a = np.frombuffer(raw[8 : 8 + nbytes], dtype=dtype).copy()
    else:
        raise DataError(f"unsupported VTK data format {fmt!r} (read only ascii and binary).")
    return a.reshape(-1, comps) if comps > 1 else a


def read_vtp(path) -> dict:
    """Read a ``.vtp`` written by this module.

    Returns a dict with ``points (n, 3)``, ``point_data`` and ``cell_data`` (dicts of
    arrays), ``field_data``, ``verts`` and ``polys`` (each ``(connectivity, offsets)``),
    and the piece's declared counts ``n_points``, ``n_verts``, ``n_polys``.
    """
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise DataError(f"cannot read {str(path)!r} as VTK XML ({exc}).") from None
    if root.tag != "VTKFile" or root.get("type") != "PolyData":
        raise DataError(f"{str(path)!r} is not a VTK PolyData file.")
    piece = root.find("PolyData/Piece")
    out = {
        "n_points": int(piece.get("NumberOfPoints")),
        "n_verts": int(piece.get("NumberOfVerts", "0")),
        "n_polys": int(piece.get("NumberOfPolys", "0")),
        "points": _decode(piece.find("Points/DataArray")).reshape(-1, 3),
        "field_data": {e.get("Name"): _decode(e) for e in root.findall("PolyData/FieldData/DataArray")},
    }
    for tag in ("PointData", "CellData"):
        out[tag.replace("Data", "_data").lower()] = {e.get("Name"): _decode(e) for e in piece.findall(f"{tag}/DataArray")}
    for tag in ("Verts", "Polys"):
        arrays = {e.get("Name"): _decode(e) for e in piece.findall(f"{tag}/DataArray")}
        out[tag.lower()] = (arrays.get("connectivity", np.zeros(0, np.int64)), arrays.get("offsets", np.zeros(0, np.int64)))
    return out


def read_pvd(path) -> list[tuple[float, str, int]]:
    """The ``(time, file, part)`` entries of a ``.pvd`` collection."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise DataError(f"cannot read {str(path)!r} as a ParaView collection ({exc}).") from None
    return [(float(d.get("timestep")), d.get("file"), int(d.get("part", "0"))) for d in root.iter("DataSet")]
