"""Export particle frames for ParaView and Blender: binary PLY and legacy VTK point clouds.

Both writers take positions [N, d] (2-D points get z = 0) and named per-particle fields
(scalars [N] or vectors [N, d]). Files are written to a temporary name and renamed, so a
file that exists is complete.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import DcdcError


def _as_3d(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=np.float32)
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise DcdcError(f"expected an [N, 2|3] array, got shape {a.shape}")
    return a if a.shape[1] == 3 else np.concatenate([a, np.zeros((len(a), 1), np.float32)], 1)


def _columns(x: np.ndarray, fields: dict[str, np.ndarray]):
    """Positions as 3-D and each field as float32 scalar columns / 3-D vectors, checked."""
    x3 = _as_3d(x)
    cols = {}
    for name, f in fields.items():
        f = np.asarray(f)
        if len(f) != len(x3):
            raise DcdcError(f"field '{name}' has {len(f)} values for {len(x3)} particles")
        cols[name] = _as_3d(f) if f.ndim == 2 else f.astype(np.float32).reshape(-1)
    return x3, cols


def _atomic_write(path: str | os.PathLike, data: bytes) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    tmp.write_bytes(data)
    os.replace(tmp, path)
    return path


def write_ply(path, x: np.ndarray, fields: dict[str, np.ndarray] | None = None) -> Path:
    """Binary little-endian PLY vertex list (x, y, z + one float property per scalar and
    ``name_x/_y/_z`` per vector field); Blender and ParaView read it."""
    x3, cols = _columns(x, fields or {})
    names, arrays = ["x", "y", "z"], [x3]
    for name, c in cols.items():
        if c.ndim == 2:
            names += [f"{name}_x", f"{name}_y", f"{name}_z"]
        else:
            names.append(name)
            c = c[:, None]
        arrays.append(c)
    table = np.ascontiguousarray(np.concatenate(arrays, 1).astype("<f4"))
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(x3)}"]
    header += [f"property float {n}" for n in names] + ["end_header"]
    return _atomic_write(path, ("\n".join(header) + "\n").encode() + table.tobytes())


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


WRITERS = {".ply": write_ply, ".vtk": write_vtk}


def write_points(path, x: np.ndarray, fields: dict[str, np.ndarray] | None = None) -> Path:
    """Write by extension (.ply or .vtk)."""
    ext = Path(path).suffix.lower()
    if ext not in WRITERS:
        raise DcdcError(f"unknown point-cloud format '{ext}' (use .ply or .vtk)")
    return WRITERS[ext](path, x, fields)
