"""Scenes: a TOML scene file (docs/scenes.md) realised into a ParticleSystem.

```python
from dcdc.scene import get_scene, load, parse
scene = get_scene("cocktail")            # a built-in name or a path to a .toml file
system = scene.realize(dim=2, resolution=0.5)
```
Built-in scenes live in ``dcdc/scene/builtin/*.toml``; random training scenes come from
:func:`dcdc.scene.random.random_scene`.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..errors import DcdcError
from ..particles import FRAME_DT  # noqa: F401
from .format import Scene, load, parse  # noqa: F401
from .schema import validate  # noqa: F401

SHOWCASES = ("cocktail", "hourglass", "canyon")


def builtin_names() -> list[str]:
    """Names of the built-in scenes (showcases first)."""
    files = resources.files("dcdc.scene").joinpath("builtin")
    names = sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))
    return [n for n in SHOWCASES if n in names] + [n for n in names if n not in SHOWCASES]


def builtin_text(name: str) -> str:
    if name not in builtin_names():
        raise DcdcError(f"no built-in scene {name!r} (built-in: {', '.join(builtin_names())})")
    return resources.files("dcdc.scene").joinpath("builtin", f"{name}.toml").read_text()


def get_scene(name_or_path) -> Scene:
    """A built-in scene by name, or a scene file by path."""
    s = str(name_or_path)
    if s in builtin_names():
        return parse(builtin_text(s), f"{s}.toml", None, builtin=True)
    if s.endswith(".toml") or Path(s).exists() or "/" in s:
        return load(s)
    raise DcdcError(f"{s!r} is neither a built-in scene ({', '.join(builtin_names())}) "
                    "nor a scene file")
