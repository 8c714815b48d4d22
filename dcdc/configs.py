"""Typed settings: dataclass ⇄ plain dict ⇄ TOML, plus ``--set key=value`` overrides.

One idiom for every settings object of the project (the idiom of
:class:`dcdc.sph.config.SPHConfig`, made generic): a dataclass whose field annotations are
the types, a ``validate()`` for ranges, and these helpers for the rest::

    cfg = from_dict(TrainConfig, load_toml("run.toml"), "")    # unknown key -> DcdcError
    cfg = from_dict(TrainConfig, apply_overrides(d, ["optim.lr=1e-4"]), "")
    save_toml(to_dict(cfg), "runs/a/config.toml")              # atomic

Types understood: ``bool``, ``int``, ``float`` (an int is accepted and converted), ``str``,
``tuple[X, ...]`` / ``list[X]`` (from TOML arrays), ``X | None``, ``dict`` and nested
dataclasses (TOML tables). Every mistake — an unknown key, a wrong type, a NaN, a value out
of range — is one :class:`~dcdc.errors.DcdcError` line naming the key (``optim.lr``).
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing
from pathlib import Path

import numpy as np

from .errors import DcdcError

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib


# ------------------------------------------------------------------ dataclass <-> dict
def to_dict(obj) -> dict:
    """A plain dict (tuples become lists, ``None`` values are left out: TOML has no null)."""
    out = {}
    for f in dataclasses.fields(obj):
        v = _plain(getattr(obj, f.name))
        if v is not None:
            out[f.name] = v
    return out


def _plain(v):
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return to_dict(v)
    if isinstance(v, (tuple, list)):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items() if x is not None}
    return v


def from_dict(cls, d, section: str = ""):
    """An instance of dataclass ``cls`` from ``d`` (missing keys keep their defaults).

    ``section`` prefixes the key names in error messages (``"optim."``)."""
    if d is None:
        d = {}
    if not isinstance(d, dict):
        raise DcdcError(f"{section.rstrip('.') or 'settings'} must be a table (got {d!r})")
    hints = typing.get_type_hints(cls)
    known = [f.name for f in dataclasses.fields(cls) if f.init]
    unknown = [k for k in d if k not in known]
    if unknown:
        raise DcdcError(f"unknown setting {section}{unknown[0]} (known in "
                        f"{section.rstrip('.') or 'this file'}: {', '.join(known)})")
    kw = {k: coerce(v, hints[k], f"{section}{k}") for k, v in d.items()}
    return cls(**kw)


def check_types(obj, section: str = "") -> None:
    """Coerce every field of dataclass instance ``obj`` in place to its annotated type, or
    raise (for objects built directly in Python rather than by :func:`from_dict`)."""
    hints = typing.get_type_hints(type(obj))
    for f in dataclasses.fields(obj):
        setattr(obj, f.name, coerce(getattr(obj, f.name), hints[f.name], f"{section}{f.name}"))


def coerce(v, tp, name: str):
    """``v`` as type ``tp`` (see the module docstring), or a one-line DcdcError for ``name``."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if v is None and type(None) in args:
            return None
        rest = [a for a in args if a is not type(None)]
        if len(rest) == 1:
            return coerce(v, rest[0], name)
        for a in rest:
            try:
                return coerce(v, a, name)
            except DcdcError:
                pass
        raise DcdcError(f"{name} must be one of {', '.join(_tname(a) for a in rest)} (got {v!r})")
    if dataclasses.is_dataclass(tp):
        if isinstance(v, tp):
            return v
        return from_dict(tp, v, name + ".")
    if tp is bool:
        if not isinstance(v, (bool, np.bool_)):
            raise DcdcError(f"{name} must be true or false (got {v!r})")
        return bool(v)
    if tp is int:  # numpy integers too; never a bool or a float such as 4.0
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral):
            raise DcdcError(f"{name} must be an integer (got {v!r})")
        return int(v)
    if tp is float:
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real) \
                or not math.isfinite(v):
            raise DcdcError(f"{name} must be a finite number (got {v!r})")
        return float(v)
    if tp is str:
        if not isinstance(v, str):
            raise DcdcError(f"{name} must be a string (got {v!r})")
        return v
    if tp in (tuple, list) or origin in (tuple, list):
        if isinstance(v, np.ndarray) and v.ndim == 1:
            v = v.tolist()
        if not isinstance(v, (list, tuple)):
            raise DcdcError(f"{name} must be a list (got {v!r})")
        item = args[0] if args else None
        vals = [coerce(x, item, f"{name}[{i}]") if item is not None else x for i, x in enumerate(v)]
        return tuple(vals) if (tp is tuple or origin is tuple) else vals
    if tp is dict or origin is dict:
        if not isinstance(v, dict):
            raise DcdcError(f"{name} must be a table (got {v!r})")
        return dict(v)
    return v


def _tname(tp) -> str:
    return getattr(tp, "__name__", str(tp))


def check(ok: bool, name: str, what: str, value) -> None:
    """Range check for ``validate()`` methods: ``name must be <what> (got value)``."""
    if not ok:
        raise DcdcError(f"{name} must be {what} (got {value!r})")


# ------------------------------------------------------------------ TOML files
def load_toml(path) -> dict:
    """The tables of a TOML file; a missing or malformed file is one DcdcError line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DcdcError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DcdcError(f"{path}: cannot read ({e})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DcdcError(f"{path}: not valid TOML ({e})") from None
    except RecursionError:
        raise DcdcError(f"{path}: arrays or tables nested too deeply to read") from None


def dumps_toml(d: dict) -> str:
    import tomli_w
    return tomli_w.dumps(d)


def save_toml(d: dict, path) -> Path:
    """Write ``d`` as TOML atomically (temporary name in the same folder, then rename)."""
    from .outputs import write_text
    return write_text(path, dumps_toml(d))


# ------------------------------------------------------------------ --set key=value
def parse_override(text: str) -> tuple[list[str], object]:
    """``"optim.lr=1e-4"`` → (["optim", "lr"], 1e-4). The value is read as a TOML value
    (numbers, true/false, [lists], "quoted strings"); anything else is a bare string."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key or any(not part for part in key.split(".")):
        raise DcdcError(f"--set wants key=value, e.g. optim.lr=1e-4 (got {text!r})")
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key.split("."), value


def apply_overrides(d: dict, overrides) -> dict:
    """A copy of nested dict ``d`` with each ``key=value`` of ``overrides`` set. Unknown keys
    are reported by the :func:`from_dict` that reads the result."""
    out = _deepcopy(d)
    for text in overrides or ():
        keys, value = parse_override(text)
        node = out
        for k in keys[:-1]:
            nxt = node.setdefault(k, {})
            if not isinstance(nxt, dict):
                raise DcdcError(f"--set {text!r}: {k} is a value, not a table")
            node = nxt
        node[keys[-1]] = value
    return out


def _deepcopy(d):
    if isinstance(d, dict):
        return {k: _deepcopy(v) for k, v in d.items()}
    if isinstance(d, list):
        return [_deepcopy(v) for v in d]
    return d
