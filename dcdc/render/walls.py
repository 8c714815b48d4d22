"""Triangle meshes of a trajectory's mesh walls (scenes with OBJ/STL/PLY walls, e.g. the
random training scenes' rocks), rebuilt from the scene file stored in the trajectory
(attributes ``scene_toml``, ``resolution``, ``source``): the same file, scale and
translation as the wall particles were sampled from (:mod:`dcdc.scene.realize`, walls of
``shape = "mesh"``). 3-D only: a 2-D trajectory's walls are a section, drawn as particles.
"""
from __future__ import annotations

from dataclasses import dataclass
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


@dataclass
class WallMesh:
    name: str
    vertices: np.ndarray   # [V, 3]
    triangles: np.ndarray  # [F, 3] vertex indices, counter-clockwise seen from outside
    hollow: bool           # the fluid is inside (a container), else around it

    def fluid_normals(self) -> np.ndarray:
        """Unit normal of each triangle pointing into the fluid (as wall normals do)."""
        v = self.vertices[self.triangles]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        if np.einsum("ij,ij->", v[:, 0], n) < 0:  # signed volume < 0: wound inside out
            n = -n
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return -n if self.hollow else n


def wall_meshes(traj) -> tuple[list[WallMesh], list[str]]:
    """The trajectory's mesh walls, and notes on meshes that cannot be found."""
    text = str(traj.attrs.get("scene_toml", "") or "")
    if traj.dim != 3 or "mesh" not in text:
        return [], []
    from ..geometry.shapes import load_mesh
    from ..scene import parse
    source = str(traj.attrs.get("source", "") or "")
    try:
        scene = parse(text, source or traj.name)
        # the walls as simulated, without the derived domain: a scene without [domain]
        # would load every mesh for it, and one missing mesh is then a note about that mesh
        # (below), not about the whole scene
        variant = scene.variant(3, float(traj.attrs.get("resolution", 1.0)), domain=False)
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
        meshes.append(WallMesh(name, np.asarray(m.vertices, np.float64),
                               np.asarray(m.faces, np.int64), bool(w["hollow"])))
    return meshes, notes
