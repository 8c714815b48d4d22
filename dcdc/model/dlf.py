"""DeepLagrangianFluids (Ummenhofer et al., ICLR 2020) as a dcdc network, without open3d.

Their published network (isl-org/DeepLagrangianFluids, ``models/default_torch.py``) is our
``cconv`` layout without the density channel (``density_input=False``), so its pretrained
weights convert into a dcdc checkpoint by renaming and reshaping alone:

* open3d ``ContinuousConv`` filters are [K, K, K, C_in, C_out] indexed [z, y, x]; ours are
  [K³, C_in, C_out] with the cell index c = x + K y + K² z (docs/model.md), i.e. the same
  array reshaped. Both use the volume-preserving ball-to-cube map, linear interpolation with
  align_corners, the poly6 window (1 − d²/R²)³, no normalisation, sender − receiver
  coordinates, self excluded; their ``offset`` must be zero (we have none).
* Their filter extent is 1.5 · 6 r, i.e. R = 4.5 r with r = 0.025 m; Δt = 1/50 s; gravity
  (0, −9.81, 0); fluid features [1, v*], wall features the normals; output / 128 — all as
  our defaults.
* They concatenate the first layer's outputs as [obstacle, fluid, dense], we as [fluid,
  wall, dense]: the input channels of ``conv1`` and ``dense1`` are permuted accordingly.

:func:`scene_system` realises their scene JSON (``scripts/example_scene.json``: OBJ walls
sampled on the surface with normals pointing inwards, OBJ fluid volumes sampled on a lattice
of spacing 2r, emitted at steps ``range(start, stop, step)``) as a ParticleSystem.
"""
from __future__ import annotations

import json
import pickle
import zipfile
from pathlib import Path

import numpy as np
import torch

from ..errors import DcdcError

LICENSE = "CDLA-Permissive-1.0 (weights); MIT (their code)"
PARTICLE_RADIUS = 0.025  # m, their default
FRAME_DT = 1.0 / 50.0  # s
RADIUS_SCALE = 1.5 * 6 / 2  # filter extent 1.5 · 6 r is the diameter: R = 4.5 r
SHAPES = {  # their parameter -> shape
    "conv0_fluid.kernel": (4, 4, 4, 4, 32), "conv0_fluid.bias": (32,),
    "conv0_obstacle.kernel": (4, 4, 4, 3, 32), "conv0_obstacle.bias": (32,),
    "dense0_fluid.weight": (32, 4), "dense0_fluid.bias": (32,),
    "conv1.kernel": (4, 4, 4, 96, 64), "conv1.bias": (64,),
    "dense1.weight": (64, 96), "dense1.bias": (64,),
    "conv2.kernel": (4, 4, 4, 64, 64), "conv2.bias": (64,),
    "dense2.weight": (64, 64), "dense2.bias": (64,),
    "conv3.kernel": (4, 4, 4, 64, 3), "conv3.bias": (3,),
    "dense3.weight": (3, 64), "dense3.bias": (3,),
}


def read_weights(path) -> dict:
    """Their state_dict (``torch.load(weights_only=True)``), checked key by key."""
    path = Path(path)
    if not path.is_file():
        raise DcdcError(f"{path}: no such file")
    try:
        sd = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, zipfile.BadZipFile, RuntimeError, EOFError, OSError,
            ValueError, AttributeError, TypeError, KeyError) as e:
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise DcdcError(f"{path} is not a torch state_dict ({first[:100]})") from None
    if not isinstance(sd, dict):
        raise DcdcError(f"{path} is not a torch state_dict")
    missing = [k for k in SHAPES if k not in sd]
    if missing:
        raise DcdcError(f"{path} is not a DeepLagrangianFluids network: it lacks "
                        f"{', '.join(missing[:4])}")
    for k, shape in SHAPES.items():
        t = sd[k]
        if not isinstance(t, torch.Tensor) or tuple(t.shape) != shape:
            got = tuple(t.shape) if isinstance(t, torch.Tensor) else type(t).__name__
            raise DcdcError(f"{path}: {k} has shape {got}, expected {shape} (only the "
                            "default 4³ kernel, 32/64/64 layout without extra features converts)")
        if not torch.isfinite(t).all():
            raise DcdcError(f"{path}: {k} holds NaN or inf values")
    for k in [k for k in sd if k.endswith(".offset")]:
        if torch.any(sd[k] != 0):
            raise DcdcError(f"{path}: {k} is not zero; dcdc's convolution has no filter offset")
    g = sd.get("gravity")
    if g is not None and not torch.allclose(g.float(), torch.tensor([0.0, -9.81, 0.0])):
        raise DcdcError(f"{path}: trained with gravity {g.tolist()}, dcdc takes gravity from "
                        "the scene; only (0, -9.81, 0) converts")
    return sd


def _kernel(t: torch.Tensor) -> torch.Tensor:
    """open3d [z, y, x, C_in, C_out] → dcdc [x + K y + K² z, C_in, C_out]."""
    K = t.shape[0]
    return t.reshape(K ** 3, t.shape[3], t.shape[4]).clone()


def convert(sd: dict):
    """A dcdc ``cconv`` network (3-D, no density channel) holding their weights."""
    from .networks import build_network

    net = build_network("cconv", 3, density_input=False, particle_radius=PARTICLE_RADIUS,
                        radius_scale=RADIUS_SCALE, frame_dt=FRAME_DT, kernel_size=4,
                        channels=(32, 64, 64), normalize=False, out_scale=1.0 / 128.0)
    c0 = SHAPES["conv0_fluid.bias"][0]
    # ours: [fluid 0:32, wall 32:64, dense 64:96] = theirs [32:64, 0:32, 64:96]
    perm = torch.cat([torch.arange(c0, 2 * c0), torch.arange(0, c0), torch.arange(2 * c0, 3 * c0)])
    new = {
        "conv0_fluid.weight": _kernel(sd["conv0_fluid.kernel"]),
        "conv0_fluid.bias": sd["conv0_fluid.bias"],
        "conv0_wall.weight": _kernel(sd["conv0_obstacle.kernel"]),
        "conv0_wall.bias": sd["conv0_obstacle.bias"],
        "dense0.weight": sd["dense0_fluid.weight"], "dense0.bias": sd["dense0_fluid.bias"],
        "convs.0.weight": _kernel(sd["conv1.kernel"])[:, perm, :],
        "convs.0.bias": sd["conv1.bias"],
        "denses.0.weight": sd["dense1.weight"][:, perm], "denses.0.bias": sd["dense1.bias"],
    }
    for i in (2, 3):
        new[f"convs.{i - 1}.weight"] = _kernel(sd[f"conv{i}.kernel"])
        new[f"convs.{i - 1}.bias"] = sd[f"conv{i}.bias"]
        new[f"denses.{i - 1}.weight"] = sd[f"dense{i}.weight"]
        new[f"denses.{i - 1}.bias"] = sd[f"dense{i}.bias"]
    net.load_state_dict({k: v.float().clone() for k, v in new.items()}, strict=True)
    return net.eval()


def import_dlf(weights, out):
    """Convert their ``.pt`` weights into a dcdc checkpoint at ``out``; returns the network."""
    from .checkpoint import save_checkpoint

    net = convert(read_weights(weights))
    save_checkpoint(out, net, data={
        "source": "DeepLagrangianFluids (Ummenhofer et al. 2020) pretrained weights",
        "repository": "isl-org/DeepLagrangianFluids", "file": Path(weights).name,
        "license": LICENSE, "training_data": "their single-phase SPlisHSPlasH box scenes",
    }, extra={"converted_by": "dcdc model import-dlf"})
    return net


# ---------------------------------------------------------------------------- their scenes
def surface_points(mesh, radius: float = PARTICLE_RADIUS):
    """Wall particles on a mesh surface with their normals pointing inwards (−face normal),
    at their surface density 1.9 / (π r²) (run_network.py samples that many Poisson-disk
    points; we use a square grid of the same density in the plane of each triangle,
    anchored per plane so that coplanar triangles share one grid)."""
    s = float(np.sqrt(np.pi * radius ** 2 / 1.9))
    pts, nrm = [], []
    for tri, n in zip(np.asarray(mesh.triangles), np.asarray(mesh.face_normals)):
        # a tangent frame fixed by the normal alone
        a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
        u = np.cross(n, a)
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        off = float(tri[0] @ n) * n  # the plane's point nearest the origin
        uv = np.stack([(tri - off) @ u, (tri - off) @ w], axis=1)
        lo, hi = uv.min(0), uv.max(0)
        i = np.arange(np.floor(lo[0] / s) - 1, np.ceil(hi[0] / s) + 2) * s + s / 2
        j = np.arange(np.floor(lo[1] / s) - 1, np.ceil(hi[1] / s) + 2) * s + s / 2
        g = np.stack(np.meshgrid(i, j, indexing="ij"), -1).reshape(-1, 2)
        # inside the triangle (half-open on shared edges by the + s/2 grid offset)
        T = np.array([uv[1] - uv[0], uv[2] - uv[0]]).T
        bc = np.linalg.solve(T, (g - uv[0]).T).T
        inside = (bc >= 0).all(1) & (bc.sum(1) < 1)
        g = g[inside]
        pts.append(off + g[:, :1] * u + g[:, 1:] * w)
        nrm.append(np.tile(-n, (len(g), 1)))
    pts, nrm = np.concatenate(pts), np.concatenate(nrm)
    # a grid point on an edge shared by coplanar triangles is found by both: keep one
    _, keep = np.unique(np.round(np.c_[pts, nrm] / (1e-6 * s)), axis=0, return_index=True)
    keep.sort()
    return pts[keep], nrm[keep]


def _load(path: str, base: Path, translation):
    """A scene mesh; vertices split by per-face OBJ normals are merged first (their Box.obj
    and Fluid.obj are closed cubes written with one normal per face)."""
    import trimesh

    from ..geometry.shapes import load_mesh

    p = _mesh_path(path, base)
    try:
        raw = trimesh.load(str(p), force="mesh")
        raw.merge_vertices(merge_tex=True, merge_norm=True)
    except Exception as e:  # trimesh raises many types for broken files
        raise DcdcError(f"cannot read mesh {p}: {e}") from None
    if raw.is_watertight:
        raw.apply_translation(np.asarray(translation, dtype=np.float64).reshape(3))
        return raw
    return load_mesh(p, translate=translation)  # patches small holes or says why not


def _mesh_path(path: str, base: Path) -> Path:
    p = Path(path)
    p = p if p.is_absolute() else base / p
    if not p.exists() and (base / p.name).exists():
        p = base / p.name  # the JSON's ../datasets/models/X.obj, shipped beside it
    if not p.exists():
        raise DcdcError(f"mesh {path} of the scene not found (looked in {base})")
    return p


def scene_system(path, radius: float = PARTICLE_RADIUS, frames: int = 1,
                 dt: float = FRAME_DT):
    """Their scene JSON as a 3-D :class:`~dcdc.particles.ParticleSystem` (one phase,
    1000 kg/m³). A fluid with ``start``/``stop``/``step`` is emitted (whole) at each step of
    ``range(start, stop, step)`` below ``frames``; the domain is the walls' bounding box
    grown by 5 % of its size (their run_network.py drops particles 5 % below the box)."""
    from ..geometry.sampling import fill_region
    from ..geometry.shapes import mesh_solid
    from ..particles import ParticleSystem, Phase

    path = Path(path)
    try:
        scene = json.loads(path.read_text())
    except FileNotFoundError:
        raise DcdcError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DcdcError(f"{path}: not a JSON scene ({str(e).splitlines()[0]})") from None
    if not isinstance(scene, dict) or not scene.get("walls") or not scene.get("fluids"):
        raise DcdcError(f"{path}: a DeepLagrangianFluids scene needs 'walls' and 'fluids' lists")
    base = path.parent
    wx, wn = [], []
    for i, w in enumerate(scene["walls"]):
        try:
            mesh = _load(w["path"], base, w.get("translation", [0, 0, 0]))
        except (KeyError, TypeError, ValueError):
            raise DcdcError(f"{path}: walls[{i}] needs a 'path' (and optional 'translation')") from None
        p, n = surface_points(mesh, radius)
        wx.append(p)
        wn.append(-n if w.get("invert_normals") else n)
    xs, vs, births = [], [], []
    spacing = 2 * radius
    for i, f in enumerate(scene["fluids"]):
        try:
            mesh = _load(f["path"], base, f.get("translation", [0, 0, 0]))
            vel = np.asarray(f.get("velocity", [0, 0, 0]), dtype=np.float64).reshape(3)
            steps = range(int(f.get("start", 0)), int(f.get("stop", 1)), int(f.get("step", 1)))
        except (KeyError, TypeError, ValueError):
            raise DcdcError(f"{path}: fluids[{i}] needs 'path', 'velocity' (3 numbers), "
                            "'translation', and integer 'start', 'stop', 'step'") from None
        sdf = mesh_solid(mesh)
        lo, hi = mesh.bounds
        pts = fill_region(lambda q: sdf(q) < 0, lo + radius, hi - radius, spacing, lo + radius)
        for k in steps:
            if k >= max(frames, 1):
                break
            xs.append(pts)
            vs.append(np.tile(vel, (len(pts), 1)))
            births.append(np.full(len(pts), k * dt))
    if not xs:
        raise DcdcError(f"{path}: no fluid particles (empty fluid volume or no emission step)")
    wall_x = np.concatenate(wx)
    lo, hi = wall_x.min(0), wall_x.max(0)
    pad = 0.05 * (hi - lo)
    return ParticleSystem(3, radius, np.concatenate(xs), np.concatenate(vs),
                          np.zeros(sum(len(x) for x in xs), dtype=np.int32),
                          [Phase("fluid", 1000.0)], wall_x, np.concatenate(wn),
                          (0.0, -9.81, 0.0), (lo - pad, hi + pad), np.concatenate(births),
                          path.stem)
