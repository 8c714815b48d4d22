"""One checkpoint format for training and running a correction network.

A checkpoint is a plain dict saved with :func:`torch.save` and read back with
``torch.load(..., weights_only=True)`` (no pickled code is ever executed)::

    {"format": "dcdc-checkpoint", "format_version": 1,
     "config": {"name": "dcdc", "dim": 3, "radius": ..., ...},   # rebuilds the network
     "state_dict": {...},                                         # tensors only
     "code_version": "0.1.0",                                     # dcdc.__version__
     "data": {...},                                               # training-data summary
     "extra": {...}}                                              # e.g. step, loss (optional)

Anything else — a missing or corrupt file, another format or a newer format version, an
unknown architecture, weights that do not fit the config, or a checkpoint of another
architecture than the caller expects — raises :class:`~dcdc.errors.DcdcError` with one line.
"""
from __future__ import annotations

import os
import pickle
import zipfile
from pathlib import Path

import torch

from .. import __version__
from ..errors import DcdcError
from .networks import NETWORKS, CorrectionNet, build_network

FORMAT = "dcdc-checkpoint"
FORMAT_VERSION = 1


def save_checkpoint(path, model: CorrectionNet, data: dict | None = None,
                    extra: dict | None = None) -> Path:
    """Write ``model`` (config + weights) with a training-data summary; atomic rename."""
    path = Path(path)
    payload = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "config": model.config(),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "code_version": __version__,
        "data": dict(data or {}),
        "extra": dict(extra or {}),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    torch.save(payload, tmp)
    os.replace(tmp, path)
    return path


def read_checkpoint(path) -> dict:
    """The validated checkpoint dict (no network built)."""
    path = Path(path)
    if not path.is_file():
        raise DcdcError(f"checkpoint {path} does not exist")
    try:
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, zipfile.BadZipFile, RuntimeError, EOFError, OSError,
            ValueError, AttributeError, TypeError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise DcdcError(f"checkpoint {path} is corrupt or not a dcdc checkpoint ({first[:120]})") from None
    if not isinstance(ck, dict) or ck.get("format") != FORMAT:
        raise DcdcError(f"{path} is not a dcdc checkpoint (no '{FORMAT}' format tag)")
    ver = ck.get("format_version")
    if not isinstance(ver, int) or ver > FORMAT_VERSION or ver < 1:
        raise DcdcError(f"checkpoint {path} has format version {ver!r}; this dcdc "
                        f"({__version__}) reads version {FORMAT_VERSION}")
    for key in ("config", "state_dict"):
        if not isinstance(ck.get(key), dict):
            raise DcdcError(f"checkpoint {path} lacks its '{key}'")
    return ck


def load_checkpoint(path, expect: str | None = None, dim: int | None = None,
                    device: str | torch.device = "cpu"):
    """(model, checkpoint dict). ``expect``/``dim``: fail unless the checkpoint matches."""
    ck = read_checkpoint(path)
    cfg = dict(ck["config"])
    name, cdim = cfg.pop("name", None), cfg.pop("dim", None)
    if name not in NETWORKS:
        raise DcdcError(f"checkpoint {path} holds an unknown architecture {name!r} "
                        f"(known: {', '.join(NETWORKS)})")
    if expect is not None and name != expect:
        raise DcdcError(f"checkpoint {path} holds a {name!r} network, expected {expect!r}")
    if dim is not None and cdim != dim:
        raise DcdcError(f"checkpoint {path} is a {cdim}-D model, expected {dim}-D")
    model = build_network(name, cdim, **cfg)
    try:
        model.load_state_dict(ck["state_dict"], strict=True)
    except RuntimeError as e:
        msg = " ".join(str(e).split())
        raise DcdcError(f"checkpoint {path}: weights do not fit a {name!r} network with its "
                        f"stored config ({msg[:160]})") from None
    model.eval()
    return model.to(device), ck
