"""Scene import: DeepLagrangianFluids and SPlisHSPlasH scene JSON as a dcdc scene TOML.

``dcdc scene import FILE.json -o scene.toml`` (docs/scenes.md, "Importing scenes") reads
the JSON, recognises its format by its sections (DLF: ``walls`` and ``fluids``;
SPlisHSPlasH: ``Configuration``, ``RigidBodies``, ``FluidBlocks``, ``FluidModels``,
``Emitters``, ``Materials``), and writes the equivalent scene: mesh walls, box and mesh
fluid blocks, nozzle and mesh emitters, one phase per material. What has no dcdc
equivalent is listed, one line per item, in :attr:`Imported.warnings` (and as comments at
the top of the TOML); the import still succeeds. Input that is wrong — not JSON, neither
format, an unknown key, a value of the wrong type, a missing mesh — is a one-line
:class:`~dcdc.errors.DcdcError`.

```python
from dcdc.scene.importers import import_scene
res = import_scene("example_scene.json", "scene.toml")
res.text, res.warnings, res.format
```
"""
from __future__ import annotations

from pathlib import Path

from ...errors import DcdcError
from .common import Imported, read_json  # noqa: F401

FORMATS = ("DeepLagrangianFluids", "SPlisHSPlasH")


def detect(data, source: str = "scene") -> str:
    """``"DeepLagrangianFluids"`` or ``"SPlisHSPlasH"`` from the JSON's top-level keys."""
    from .dlf import is_dlf
    from .splishsplash import is_splishsplash
    if is_dlf(data):
        return "DeepLagrangianFluids"
    if is_splishsplash(data):
        return "SPlisHSPlasH"
    keys = ", ".join(sorted(data)[:6]) if isinstance(data, dict) else type(data).__name__
    raise DcdcError(f"{source}: neither a DeepLagrangianFluids scene (top-level 'walls' and "
                    "'fluids') nor a SPlisHSPlasH scene ('Configuration', 'RigidBodies', "
                    f"'FluidBlocks', 'FluidModels', 'Emitters', ...); it has {keys or 'no keys'}")


def import_scene(path, output=None, name: str | None = None) -> Imported:
    """Import the scene JSON at ``path``; mesh paths in the result are relative to the
    directory of ``output`` (the TOML to be written; None: absolute paths)."""
    from . import dlf, splishsplash
    path = Path(path)
    data = read_json(path)
    fmt = detect(data, path.name)
    mod = dlf if fmt == "DeepLagrangianFluids" else splishsplash
    return mod.convert(data, path, Path(output) if output else None, name)
