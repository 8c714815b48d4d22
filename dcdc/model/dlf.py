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

Their scene JSON is read by :mod:`dcdc.scene.importers.dlf` (``scene_system`` for their
own wall sampling, ``dcdc scene import`` for a dcdc scene file).
"""
from __future__ import annotations

import pickle
import zipfile
from pathlib import Path

import torch

from ..errors import DcdcError
from ..particles import DEFAULT_RADIUS, FRAME_DT

LICENSE = "CDLA-Permissive-1.0 (weights); MIT (their code)"
PARTICLE_RADIUS = DEFAULT_RADIUS  # m, their default r = 0.025 m is ours
# their frame Δt = 1/50 s is ours (FRAME_DT)
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
                        channels=(32, 64, 64), normalize=False, out_scale=1.0 / 128.0,
                        wall_far_faces=True)  # their network sees every wall particle in R
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
