"""Export particle frames for ParaView and Blender: PLY, legacy VTK and XML VTU point clouds.

The writers take positions [N, d] (2-D points get z = 0) and named per-particle fields
(scalars [N] or vectors [N, d]). Files are written to a temporary name and renamed, so a
file that exists is complete. :func:`export_trajectory` (``dcdc export``) writes every
frame of a trajectory: one PLY per frame (with per-vertex phase colours, which Blender's
importer shows) or one VTU per frame plus a ``.pvd`` time index (ParaView opens the
``.pvd`` as one time series), the walls as one more file of points with their normals.

VTU (XML UnstructuredGrid of vertex cells, VTK file format spec "VTK XML Formats") rather
than VTP (PolyData): ParaView treats both alike in a ``.pvd``, and VTU is what maintained
Python readers (meshio) read back, which the tests do.
"""
from __future__ import annotations

import base64
import os
from pathlib import Path

import numpy as np

from ..outputs import atomic_file
from ..errors import DcdcError
from ..particles import active_mask


def _as_3d(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=np.float32)
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise DcdcError(f"expected an [N, 2|3] array, got shape {a.shape}")
    return a if a.shape[1] == 3 else np.concatenate([a, np.zeros((len(a), 1), np.float32)], 1)


def _columns(x: np.ndarray, fields: dict[str, np.ndarray]):
    """Positions as 3-D and each field as float32 scalar columns / 3-D vectors, checked
    (integer scalar fields keep their integer type)."""
    x3 = _as_3d(x)
    cols = {}
    for name, f in fields.items():
        f = np.asarray(f)
        if len(f) != len(x3):
            raise DcdcError(f"field '{name}' has {len(f)} values for {len(x3)} particles")
        if f.ndim == 2:
            cols[name] = _as_3d(f)
        elif f.dtype.kind in "iub":
            cols[name] = f.reshape(-1)
        else:
            cols[name] = f.astype(np.float32).reshape(-1)
    return x3, cols


def _atomic_write(path: str | os.PathLike, data: bytes) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_file(path) as tmp:
        Path(tmp).write_bytes(data)
    return path


PLY_VECTOR_NAMES = {"normal": ("nx", "ny", "nz")}  # the PLY names readers map to normals


def _ply_int_type(a: np.ndarray) -> tuple[str, str]:
    """(PLY type, numpy dtype) of an integer field: ``uchar`` when unsigned 8-bit, else ``int``
    (int32; values outside its range are refused)."""
    if a.dtype == np.uint8 or a.dtype == np.bool_:
        return "uchar", "u1"
    if len(a) and (a.min() < np.iinfo(np.int32).min or a.max() > np.iinfo(np.int32).max):
        raise DcdcError("integer field out of the int32 range of PLY 'int'")
    return "int", "<i4"


def write_ply(path, x: np.ndarray, fields: dict[str, np.ndarray] | None = None,
              colors: np.ndarray | None = None, triangles: np.ndarray | None = None) -> Path:
    """Binary little-endian PLY (Paul Bourke's "PLY - Polygon File Format"): a vertex list
    with ``x y z`` float, one property per scalar field (``float``; integer fields
    ``int`` = int32, or ``uchar`` when given as uint8), three per vector field
    (``name_x/_y/_z`` float; the field ``normal`` as ``nx ny nz``, the names Blender,
    MeshLab, Open3D and trimesh read as vertex normals), then ``red green blue`` uchar when
    ``colors`` [N, 3] in [0, 1] are given; and a face list when ``triangles`` [F, 3] are
    given. Blender and ParaView read it."""
    x3, cols = _columns(x, fields or {})
    dtype = [(n, "<f4") for n in ("x", "y", "z")]
    props = ["property float x", "property float y", "property float z"]
    columns = [x3[:, 0], x3[:, 1], x3[:, 2]]
    for name, c in cols.items():
        if c.ndim == 2:
            names = PLY_VECTOR_NAMES.get(name, (f"{name}_x", f"{name}_y", f"{name}_z"))
            dtype += [(n, "<f4") for n in names]
            props += [f"property float {n}" for n in names]
            columns += [c[:, 0], c[:, 1], c[:, 2]]
        elif c.dtype.kind in "iub":
            ply_type, np_type = _ply_int_type(c)
            dtype.append((name, np_type))
            props.append(f"property {ply_type} {name}")
            columns.append(c)
        else:
            dtype.append((name, "<f4"))
            props.append(f"property float {name}")
            columns.append(c)
    if colors is not None:
        colors = np.asarray(colors, np.float64)
        if colors.shape != (len(x3), 3):
            raise DcdcError(f"colors must be [{len(x3)}, 3], got {colors.shape}")
        rgb = np.clip(np.round(colors * 255), 0, 255).astype(np.uint8)
        dtype += [(c, "u1") for c in ("red", "green", "blue")]
        props += [f"property uchar {c}" for c in ("red", "green", "blue")]
        columns += [rgb[:, 0], rgb[:, 1], rgb[:, 2]]
    names = [d[0] for d in dtype]
    if len(set(names)) != len(names):
        raise DcdcError(f"PLY property names repeat: {', '.join(names)}")
    table = np.empty(len(x3), dtype)
    for (n, _), c in zip(dtype, columns):
        table[n] = c
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(x3)}"]
    header += props
    faces = b""
    if triangles is not None:
        tri = np.asarray(triangles).reshape(-1, 3)
        rows = np.empty(len(tri), [("n", "u1"), ("v", "<i4", (3,))])
        rows["n"], rows["v"] = 3, tri
        header += [f"element face {len(tri)}", "property list uchar int vertex_indices"]
        faces = rows.tobytes()
    header.append("end_header")
    return _atomic_write(path, ("\n".join(header) + "\n").encode() + table.tobytes() + faces)


def write_vtk(path, x: np.ndarray, fields: dict[str, np.ndarray] | None = None) -> Path:
    """Legacy binary VTK POLYDATA with one vertex cell per particle and point data."""
    x3, cols = _columns(x, fields or {})
    n = len(x3)
    out = [b"# vtk DataFile Version 3.0\ndcdc particles\nBINARY\nDATASET POLYDATA\n",
           f"POINTS {n} float\n".encode(), x3.astype(">f4").tobytes(), b"\n",
           f"VERTICES {n} {2 * n}\n".encode(),
           np.stack([np.ones(n), np.arange(n)], 1).astype(">i4").tobytes(), b"\n"]
    if cols:
        out.append(f"POINT_DATA {n}\n".encode())
    for name, c in cols.items():
        if c.ndim == 2:
            out += [f"VECTORS {name} float\n".encode(), c.astype(">f4").tobytes(), b"\n"]
        else:
            out += [f"SCALARS {name} float 1\nLOOKUP_TABLE default\n".encode(),
                    c.astype(">f4").tobytes(), b"\n"]
    return _atomic_write(path, b"".join(out))


def _b64_block(a: np.ndarray) -> str:
    """One inline binary DataArray: base64 of a UInt64 byte count followed by the data."""
    raw = np.ascontiguousarray(a).tobytes()
    return base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")


def _data_array(name: str | None, a: np.ndarray, components: int = 1) -> str:
    vtk_type = {"f4": "Float32", "i4": "Int32", "i8": "Int64", "u1": "UInt8"}[a.dtype.str[1:]]
    attr = f' Name="{name}"' if name else ""
    return (f'<DataArray type="{vtk_type}"{attr} NumberOfComponents="{components}" '
            f'format="binary">{_b64_block(a)}</DataArray>')


def write_vtu(path, x: np.ndarray, fields: dict[str, np.ndarray] | None = None,
              triangles: np.ndarray | None = None) -> Path:
    """XML UnstructuredGrid (``.vtu``): one vertex cell per point, or the ``triangles``
    [F, 3] (point indices) of a surface; point data float32 (vectors with 3 components;
    integer fields such as the phase as Int32), inline base64 binary arrays with UInt64
    headers."""
    x3, cols = _columns(x, fields or {})
    n = len(x3)
    if triangles is None:
        conn, size, vtk_type = np.arange(n), 1, 1             # VTK_VERTEX
    else:
        conn, size, vtk_type = np.asarray(triangles).reshape(-1), 3, 5  # VTK_TRIANGLE
    cells = len(conn) // size
    ints = {k for k, f in (fields or {}).items() if np.asarray(f).dtype.kind in "iub"}
    point_data = []
    for name, c in cols.items():
        if name in ints:
            c = np.asarray(fields[name]).astype("<i4")
        point_data.append(_data_array(name, c.astype(c.dtype.newbyteorder("<")),
                                      3 if c.ndim == 2 else 1))
    xml = ['<?xml version="1.0"?>',
           '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
           'header_type="UInt64">', "<UnstructuredGrid>",
           f'<Piece NumberOfPoints="{n}" NumberOfCells="{cells}">',
           "<PointData>", *point_data, "</PointData>",
           "<Points>", _data_array(None, x3.astype("<f4"), 3), "</Points>",
           "<Cells>", _data_array("connectivity", conn.astype("<i8")),
           _data_array("offsets", np.arange(1, cells + 1, dtype="<i8") * size),
           _data_array("types", np.full(cells, vtk_type, "u1")),
           "</Cells>", "</Piece>", "</UnstructuredGrid>", "</VTKFile>", ""]
    return _atomic_write(path, "\n".join(xml).encode())


def write_pvd(path, entries) -> Path:
    """ParaView collection: ``entries`` of (time, part, file name relative to ``path``)."""
    rows = "\n".join(f'<DataSet timestep="{t!r}" group="" part="{part}" file="{f}"/>'
                     for t, part, f in entries)
    xml = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
           f'byte_order="LittleEndian">\n<Collection>\n{rows}\n</Collection>\n</VTKFile>\n')
    return _atomic_write(path, xml.encode())


WRITERS = {".ply": write_ply, ".vtk": write_vtk, ".vtu": write_vtu}


def write_points(path, x: np.ndarray, fields: dict[str, np.ndarray] | None = None) -> Path:
    """Write by extension (.ply, .vtk or .vtu)."""
    ext = Path(path).suffix.lower()
    if ext not in WRITERS:
        raise DcdcError(f"unknown point-cloud format '{ext}' (use .ply, .vtk or .vtu)")
    return WRITERS[ext](path, x, fields)


EXPORT_FORMATS = {"ply": ".ply", "vtk": ".vtu"}


def export_trajectory(traj, fmt: str, out_dir, frames=None, progress=None,
                      warn=None) -> list[Path]:
    """Every frame in ``frames`` (default: all) of ``traj`` into the directory ``out_dir``:
    ``frame_NNNNN.ply`` or ``.vtu`` with the particles present at that time (fields
    ``id``, ``phase``, ``density`` = rest density [kg/m³], ``velocity`` [m/s]), the wall
    particles as ``walls.*`` (field ``normal``), each mesh wall of a 3-D scene as the
    triangle surface ``walls_mesh_NAME.*`` (:mod:`.walls`), and for VTU ``NAME.pvd`` (the
    time series; wall particles part 1, meshes parts 2, 3, … at every time).
    In PLY ``id`` is ``int`` (int32), ``phase`` ``uchar`` and the wall normals ``nx ny nz``.
    ``progress(1)`` is called per frame, ``warn(text)`` for a mesh that cannot be found.
    Returns the written files."""
    if fmt not in EXPORT_FORMATS:
        raise DcdcError(f"unknown export format {fmt!r} (use {' or '.join(EXPORT_FORMATS)})")
    ext = EXPORT_FORMATS[fmt]
    writer = WRITERS[ext]
    out_dir = Path(out_dir)
    frames = range(traj.n_frames) if frames is None else frames
    colors = np.array([p.color for p in traj.phases], np.float64).reshape(-1, 3)
    phase, density, times = traj.phase, traj.density, traj.time
    birth, death = traj.birth, getattr(traj, "death", None)
    ids = np.arange(traj.n_particles, dtype=np.int32)
    written, entries = [], []
    walls = f"walls{ext}"
    wall_fields = {"normal": traj.wall_n}
    if fmt == "ply":
        written.append(write_ply(out_dir / walls, traj.wall_x, wall_fields,
                                 colors=np.full((len(traj.wall_x), 3), 0.6)))
    else:
        written.append(writer(out_dir / walls, traj.wall_x, wall_fields))
    from .walls import wall_meshes
    meshes, notes = wall_meshes(traj)
    for note in notes if warn else ():
        warn(note)
    mesh_files = []
    for m in meshes:
        mesh_files.append(f"walls_mesh_{m.name}{ext}")
        written.append(writer(out_dir / mesh_files[-1], m.vertices, triangles=m.triangles))
    for f in frames:
        active = active_mask(birth, death, float(times[f]))
        fields = {"id": ids[active], "phase": phase[active], "density": density[active],
                  "velocity": traj._get("velocity", f)[active]}
        name = f"frame_{f:05d}{ext}"
        x = traj._get("position", f)[active]
        if fmt == "ply":
            if len(colors) <= 256:  # the phase as uchar, id as int
                fields["phase"] = fields["phase"].astype(np.uint8)
            written.append(write_ply(out_dir / name, x, fields, colors=colors[phase[active]]))
        else:
            written.append(writer(out_dir / name, x, fields))
            entries += [(float(times[f]), 0, name), (float(times[f]), 1, walls)]
            entries += [(float(times[f]), 2 + k, m) for k, m in enumerate(mesh_files)]
        if progress:
            progress(1)
    if fmt == "vtk":
        written.append(write_pvd(out_dir / f"{traj.name}.pvd", entries))
    return written
