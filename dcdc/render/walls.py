"""Triangle meshes of a trajectory's mesh walls (scenes with OBJ/STL/PLY walls, e.g. the
random training scenes' rocks), rebuilt from the scene file stored in the trajectory
(attributes ``scene_toml``, ``resolution``, ``source``): the same file, scale and
translation as the wall particles were sampled from (:mod:`dcdc.scene.format`, walls of
``shape = "mesh"``). 3-D only: a 2-D trajectory's walls are a section, drawn as particles.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import DcdcError


def _mesh_file(name: str, source: str) -> Path:
    """``asset:NAME`` (shipped in dcdc/assets), absolute, or relative to the scene file."""
    if name.startswith("asset:"):
        return Path(str(resources.files("dcdc").joinpath("assets", name[len("asset:"):])))
    p = Path(name)
    src = Path(source)
    return p if p.is_absolute() or not src.is_file() else src.parent / p


def wall_meshes(traj) -> tuple[list[tuple[str, np.ndarray, np.ndarray]], list[str]]:
    """([(wall name, vertices [V, 3], triangles [F, 3])], notes on meshes not found)."""
    text = str(traj.attrs.get("scene_toml", "") or "")
    if traj.dim != 3 or "mesh" not in text:
        return [], []
    from ..geometry.shapes import load_mesh
    from ..scene import parse
    source = str(traj.attrs.get("source", "") or "")
    try:
        variant = parse(text, source or traj.name).variant(3, float(traj.attrs.get("resolution", 1.0)))
    except DcdcError as e:
        return [], [f"scene stored in {traj.name} unreadable: {e}"]
    meshes, notes = [], []
    for name, w in variant["walls"].items():
        if w["shape"] != "mesh":
            continue
        path = _mesh_file(w["file"], source)
        if not path.is_file():
            notes.append(f"wall {name}: mesh {w['file']} not found; exported as particles only")
            continue
        m = load_mesh(path, w["scale"], w["translate"])
        meshes.append((name, np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)))
    return meshes, notes
