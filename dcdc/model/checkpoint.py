"""One checkpoint format for training and running a correction network.

A checkpoint is a plain dict saved with :func:`torch.save` and read back with
``torch.load(..., weights_only=True)`` (no pickled code is ever executed)::

    {"format": "dcdc-checkpoint", "format_version": 2,
     "config": {"name": "dcdc", "dim": 3, "particle_radius": 0.025, "frame_dt": 0.02, ...},
     "state_dict": {...},                                         # tensors only
     "code_version": "0.1.0",                                     # dcdc.__version__
     "data": {...},                                               # training-data summary
     "extra": {...},                                              # e.g. step, loss, the
                                                                  # training config and state
     "digest": "sha256:..."}                                      # of everything above

Version 2 (this one) added the particle radius and frame Δt the network is trained for
(:class:`~dcdc.model.networks.NetConfig`) and the digest; version 1 files are refused.

Anything else — a missing, corrupt or non-checkpoint file, another format or version, a
digest that does not match (flipped bytes), NaN/inf weights, an unknown architecture, an
invalid config (negative channels, a string kernel size, ρ_ref ≤ 0, radius 0), weights that
do not fit the config, or a checkpoint of another architecture than the caller expects —
raises :class:`~dcdc.errors.DcdcError` with one line. :func:`check_compatible` is the one
test training, ``simulate`` and ``evaluate`` use to refuse data the model is not made for.
"""
from __future__ import annotations

import hashlib
import io
import math
import zipfile
from pathlib import Path

import numpy as np
import torch

from ..version import __version__
from ..errors import DcdcError
from .networks import NETWORKS, CorrectionNet, NetConfig, build_network

FORMAT = "dcdc-checkpoint"
FORMAT_VERSION = 2


def save_checkpoint(path, model: CorrectionNet, data: dict | None = None,
                    extra: dict | None = None, contact: bool | None = None) -> Path:
    """Write ``model`` (config + weights) with a training-data summary; atomic rename.

    ``contact``: whether rollouts of this network apply the walls' contact by default
    (:func:`dcdc.evaluate.rollout.uses_contact`); None leaves it unsaid (= True).

    ``extra`` may hold anything ``torch.load(weights_only=True)`` reads back (tensors,
    numbers, strings, lists, dicts: e.g. an optimizer's state_dict); it is covered by the
    digest like the weights."""
    payload = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "config": model.config(),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "code_version": __version__,
        "data": dict(data or {}),
        "extra": dict(extra or {}),
    }
    if contact is not None:
        payload["contact"] = bool(contact)
    return _write(path, payload)


def _write(path, payload: dict) -> Path:
    """``payload`` with its digest, written atomically to ``path``."""
    from ..outputs import write_bytes

    payload["digest"] = digest(payload)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    torch.save(payload, buf)  # in memory: a full disk is one error line, no torch traceback
    return write_bytes(path, buf.getvalue())


def serve_checkpoint(src, dst, wall_far_faces: bool | None = None,
                     contact: bool | None = None, wall_fill_gaps: bool | None = None) -> Path:
    """Copy checkpoint ``src`` to ``dst`` with how its weights are served changed: the wall
    conv's view of thin walls' far faces (``NetConfig.wall_far_faces``) and of the gaps of
    slanted lattice walls (``NetConfig.wall_fill_gaps``), input choices the weights do not
    fix, and whether its rollouts apply the walls' contact by default (``contact``); None
    keeps the stored value. The digest is recomputed."""
    ck = dict(read_checkpoint(src))
    ck["config"] = dict(ck["config"])
    for key, val in (("wall_far_faces", wall_far_faces), ("wall_fill_gaps", wall_fill_gaps)):
        if val is not None:
            ck["config"][key] = bool(val)
    if contact is not None:
        ck["contact"] = bool(contact)
    return _write(dst, ck)


def digest(payload: dict) -> str:
    """SHA-256 over every key and value of the checkpoint dict except ``digest`` itself
    (tensors by dtype, shape and bytes; dict keys in sorted order)."""
    h = hashlib.sha256()
    _feed(h, {k: v for k, v in payload.items() if k != "digest"})
    return "sha256:" + h.hexdigest()


def _feed(h, obj) -> None:
    if isinstance(obj, torch.Tensor):
        t = obj.detach().cpu().contiguous()
        h.update(f"T{t.dtype}{tuple(t.shape)}".encode())
        h.update(t.reshape(-1).view(torch.uint8).numpy().tobytes() if t.numel() else b"")
    elif isinstance(obj, dict):
        h.update(f"D{len(obj)}".encode())
        for k in sorted(obj, key=repr):
            _feed(h, k)
            _feed(h, obj[k])
    elif isinstance(obj, (list, tuple)):
        h.update(f"L{len(obj)}".encode())
        for x in obj:
            _feed(h, x)
    else:
        h.update(f"{type(obj).__name__}:{obj!r};".encode())


def shipped_models() -> dict[str, Path]:
    """The pretrained checkpoints shipped with dcdc (``dcdc/assets/models/NAME.pt``, model
    card in docs/models.md), by name."""
    from importlib import resources

    root = Path(str(resources.files("dcdc").joinpath("assets", "models")))
    return {p.stem: p for p in sorted(root.glob("*.pt"))} if root.is_dir() else {}


def resolve_model(path) -> Path:
    """``path`` itself, or for the bare name of a shipped model (``dcdc2d``) its file."""
    p = Path(path)
    if not p.exists() and p.suffix == "" and len(p.parts) == 1:
        shipped = shipped_models()
        if str(path) in shipped:
            return shipped[str(path)]
    return p


def read_checkpoint(path) -> dict:
    """The validated checkpoint dict (no network built): format, version and digest.
    ``path`` may be the name of a shipped model (:func:`shipped_models`)."""
    path = resolve_model(path)
    if not path.is_file():
        names = ", ".join(shipped_models()) or "none"
        raise DcdcError(f"checkpoint {path} does not exist (shipped models: {names})")
    if not zipfile.is_zipfile(path):  # torch.save writes a zip archive
        raise DcdcError(f"checkpoint {path} is corrupt or not a dcdc checkpoint (not a "
                        f"PyTorch zip archive)")
    try:
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - any failure to unpickle is a bad file
        text = str(e).strip()
        first = text.splitlines()[0] if text else type(e).__name__
        raise DcdcError(f"checkpoint {path} is corrupt or not a dcdc checkpoint "
                        f"({type(e).__name__}: {first[:120]})") from None
    if not isinstance(ck, dict) or ck.get("format") != FORMAT:
        raise DcdcError(f"{path} is not a dcdc checkpoint (no '{FORMAT}' format tag)")
    ver = ck.get("format_version")
    if not isinstance(ver, int) or ver != FORMAT_VERSION:
        raise DcdcError(f"checkpoint {path} has format version {ver!r}; this dcdc "
                        f"({__version__}) reads version {FORMAT_VERSION}")
    for key in ("config", "state_dict"):
        if not isinstance(ck.get(key), dict):
            raise DcdcError(f"checkpoint {path} lacks its '{key}'")
    stored = ck.get("digest")
    if not isinstance(stored, str):
        raise DcdcError(f"checkpoint {path} has no digest of its contents")
    if digest(ck) != stored:
        raise DcdcError(f"checkpoint {path} is damaged: its contents do not match the stored "
                        f"digest (flipped bytes?)")
    for k, t in ck["state_dict"].items():
        if not isinstance(t, torch.Tensor):
            raise DcdcError(f"checkpoint {path}: weight {k!r} is not a tensor")
        if t.is_floating_point() and not bool(torch.isfinite(t).all()):
            raise DcdcError(f"checkpoint {path}: weight {k!r} holds NaN or inf values")
    return ck


def load_checkpoint(path, expect: str | None = None, dim: int | None = None,
                    device: str | torch.device = "cpu"):
    """(model, checkpoint dict). ``expect``/``dim``: fail unless the checkpoint matches."""
    ck = read_checkpoint(path)
    cfg = dict(ck["config"])
    # a network saved before NetConfig.wall_far_faces existed saw every wall particle
    cfg.setdefault("wall_far_faces", True)
    name, cdim = cfg.pop("name", None), cfg.pop("dim", None)
    if name not in NETWORKS:
        raise DcdcError(f"checkpoint {path} holds an unknown architecture {name!r} "
                        f"(known: {', '.join(NETWORKS)})")
    if expect is not None and name != expect:
        raise DcdcError(f"checkpoint {path} holds a {name!r} network, expected {expect!r}")
    if dim is not None and cdim != dim:
        raise DcdcError(f"checkpoint {path} is a {cdim}-D model, expected {dim}-D")
    try:
        model = build_network(name, cdim, **cfg)
    except DcdcError as e:
        raise DcdcError(f"checkpoint {path}: invalid config: {e}") from None
    try:
        model.load_state_dict(ck["state_dict"], strict=True)
    except RuntimeError as e:
        msg = " ".join(str(e).split())
        raise DcdcError(f"checkpoint {path}: weights do not fit a {name!r} network with its "
                        f"stored config ({msg[:160]})") from None
    model.eval()
    # whether its rollouts apply the walls' contact by default (dcdc.evaluate.rollout)
    model.contact_default = bool(ck.get("contact", True))
    return model.to(device), ck


def check_compatible(config, dim: int | None = None, radius: float | None = None,
                     frame_dt: float | None = None, what: str = "the data",
                     rtol: float = 1e-5) -> None:
    """Refuse data a network is not made for: a one-line DcdcError unless the
    data's dimension, particle radius [m] and frame Δt [s] equal the network's.

    ``config``: a network, its :meth:`~CorrectionNet.config` dict, a :class:`NetConfig`,
    or a checkpoint dict (its ``"config"``). ``None`` for a value skips that test; ``what``
    names the data in the message (``"dataset datasets/2d/train"``)."""
    if isinstance(config, CorrectionNet):
        mdim, cfg = config.dim, config.cfg
    elif isinstance(config, NetConfig):
        mdim, cfg = None, config
    elif isinstance(config, dict):
        d = config.get("config", config) if "state_dict" in config else config
        mdim = d.get("dim")
        try:
            cfg = NetConfig(**{k: v for k, v in d.items() if k not in ("name", "dim")})
        except TypeError as e:  # a key this version does not know
            raise DcdcError(f"model config: {e}") from None
    else:
        raise TypeError(f"check_compatible needs a network or its config, got {type(config)}")
    if dim is not None and mdim is not None and int(dim) != int(mdim):
        raise DcdcError(f"the model is {mdim}-D but {what} is {int(dim)}-D")
    if radius is not None and not _close(cfg.particle_radius, radius, rtol):
        raise DcdcError(f"the model is trained for particle radius {cfg.particle_radius:g} m "
                        f"but {what} has {float(radius):g} m")
    if frame_dt is not None and not _close(cfg.frame_dt, frame_dt, rtol):
        raise DcdcError(f"the model steps dt = {cfg.frame_dt:g} s but {what} has frames every "
                        f"{float(frame_dt):g} s")


def _close(a: float, b, rtol: float) -> bool:
    b = float(np.asarray(b).reshape(-1)[0]) if np.ndim(b) else float(b)
    return math.isfinite(b) and abs(a - b) <= rtol * max(abs(a), abs(b))
