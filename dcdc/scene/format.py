"""Scene files: TOML text -> validated scene -> :class:`~dcdc.particles.ParticleSystem`.

The format is documented in ``docs/scenes.md``. Every key is checked against a schema:
unknown keys, wrong types and out-of-range values raise :class:`DcdcError` naming the
dotted field and, where it can be found, its line ("phases.oil.density must be > 0
(line 12)"). Realising a scene reports (never repairs) overlapping fluid blocks, fluid
inside walls, fluid outside the domain and missing mesh files.

A scene without ``[domain]`` gets the axis-aligned box around its walls, fluid blocks and
emitters (:func:`derive_domain`, per variant; ``meta["scene_domain"]`` of the realised
system holds it); a wall without such a box (terrain) asks for ``[domain]``.

Meshes (OBJ, STL, ... scaled per axis, rotated, translated) are walls (closed solids,
containers or shells), fluid blocks (``shape = "mesh"``: a closed mesh's inside on the
global lattice) and emitters (``shape = "mesh"``: that fluid released repeatedly).
Nozzle emitters are round (``shape = "nozzle"``) or rectangular (``shape = "box"``).

A 3-D scene also yields its 2-D cross-section (``dim=2``): every vector drops its z
component, solids of revolution become their section through the axis, terrain is cut at
``slice_z`` and meshes are sectioned by the plane z = ``slice_z``. ``resolution`` S
multiplies every length by S at a fixed particle radius, so the fluid count scales ~S^dim.

This module reads the text and holds :class:`Scene`; the schema and its checks are in
:mod:`.schema`, the line finder of the messages in :mod:`.lines`, the variants in
:mod:`.variant`, the particles in :mod:`.realize` and :mod:`.nozzles`.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as a package
    import tomli as tomllib

from ..errors import DcdcError
from ..particles import ParticleSystem
from .lines import find_line
from .realize import derive_domain, realize_variant
from .schema import validate
from .variant import transform


@dataclass
class Scene:
    """A validated scene. ``data`` holds every field with defaults filled in."""

    data: dict
    text: str = ""
    path: Path | None = None
    builtin: bool = False
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        return self.data["name"]

    @property
    def dim(self) -> int:
        return self.data["dim"]

    @property
    def duration(self) -> float:
        return self.data["duration"]

    @property
    def frame_dt(self) -> float:
        return self.data["frame_dt"]

    @property
    def solver(self) -> dict:
        return copy.deepcopy(self.data["solver"])

    def check_solver(self):
        """Validate the [solver] table against dcdc.sph.SPHConfig and the tension tables'
        phase names against the scene's phases; returns the config."""
        from ..sph import SPHConfig
        from ..sph.interfaces import tension_matrix, wall_tension_vector
        try:
            cfg = SPHConfig.from_dict(self.solver)
            names = list(self.data["phases"])
            tension_matrix(cfg.interfacial_tension, names)
            wall_tension_vector(cfg.wall_tension, names)
            return cfg
        except DcdcError as e:
            src = self.path.name if self.path else f"{self.name}.toml"
            line = find_line(self.text, "solver")
            raise DcdcError(f"{src}: [solver]: {e}" + (f" (table at line {line})" if line else "")) from None

    @property
    def source(self) -> str:
        """The scene as messages name it: its file name, or NAME."""
        return self.path.name if self.path else self.name

    def variant(self, dim: int | None = None, resolution: float = 1.0,
                meshes: dict | None = None, domain: bool = True) -> dict:
        """The ``dim``-D variant at ``resolution`` (:func:`.variant.transform`); a scene without
        ``[domain]`` gets the box around its walls and fluid (:func:`derive_domain`;
        ``meshes`` caches the placed meshes it loads) unless ``domain`` is False (its
        ``domain`` then stays None and no mesh is loaded)."""
        s = transform(self.data, dim or self.dim, resolution)
        if domain and s["domain"] is None:
            s["domain"] = derive_domain(s, self.path.parent if self.path else None,
                                        {} if meshes is None else meshes, self.source)
        return s

    def realize(self, dim: int | None = None, resolution: float = 1.0,
                check: bool = True, frames: int | None = None,
                max_particles: float | None = None) -> ParticleSystem:
        """Particles of this scene (the ``dim``-D variant at ``resolution``); with ``check``,
        overlaps and fluid inside walls/outside the domain raise :class:`DcdcError`.
        The particle and memory budget (:mod:`.budget`; ``frames`` stored frames, a
        ``max_particles`` override) is checked before anything is allocated."""
        meshes: dict = {}  # placed meshes, each loaded once
        s = self.variant(dim, resolution, meshes)
        return realize_variant(s, self.text, str(self.path.name) if self.path else self.name,
                               self.path.parent if self.path else None, meshes, resolution,
                               self.dim, check, frames, max_particles)


def parse(text: str, source: str = "scene", path: Path | None = None, builtin=False) -> Scene:
    """Parse and validate scene TOML text."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DcdcError(f"{source}: not valid TOML: {e}") from None
    except RecursionError:
        raise DcdcError(f"{source}: arrays or tables nested too deeply to read") from None
    return Scene(validate(raw, text, source), text, path, builtin)


def load(path) -> Scene:
    """Load and validate a scene file."""
    p = Path(path)
    if not p.is_file():
        raise DcdcError(f"scene file {p} not found")
    try:
        text = p.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise DcdcError(f"cannot read scene file {p}: {e}") from None
    return parse(text, p.name, p.resolve())
