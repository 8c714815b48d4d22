"""A particle and memory budget, checked before a scene allocates anything.

Realising a scene samples lattices: the fluid blocks, the emitters' layers and, for the
walls, every lattice point of the padded domain (``sample_walls`` evaluates the walls'
signed distance there). A tiny ``radius``, a large ``--resolution`` or an emitter with a
huge ``rate`` makes those lattices astronomically large, and numpy would try to allocate
them (or the kernel's out-of-memory killer would stop the process). :func:`check` counts
them from the scene's numbers alone — boxes, radii, rates — and refuses, in one line that
names the estimate and the override, when

- the points to sample exceed ``max_particles`` (default :data:`DEFAULT_MAX_PARTICLES`,
  or ``$DCDC_MAX_PARTICLES``; the CLI's ``--max-particles N`` raises it), or
- the memory estimate exceeds this machine's physical memory (no override: it cannot fit).
"""
from __future__ import annotations

import math
import os

import click

from ..errors import DcdcError
from ..particles import FRAME_DT

DEFAULT_MAX_PARTICLES = 10_000_000
# bytes per sampled point while realising (coordinates, signed distances per solid, masks)
# and per simulated particle (state, neighbour lists, solver arrays): generous upper bounds
BYTES_PER_LATTICE_POINT = 200
BYTES_PER_PARTICLE = 2_000


def default_limit() -> float:
    v = os.environ.get("DCDC_MAX_PARTICLES")
    if not v:
        return DEFAULT_MAX_PARTICLES
    try:
        limit = float(v)
    except ValueError:
        limit = math.nan
    if not limit > 0:
        raise DcdcError(f"DCDC_MAX_PARTICLES must be a number > 0 (inf: no limit; got {v!r})")
    return limit


def _floor(x: float) -> float:
    """math.floor for a count that may be infinite (a radius of 5e-324 m)."""
    return float(math.floor(x)) if math.isfinite(x) else x


def _ceil(x: float) -> float:
    return float(math.ceil(x)) if math.isfinite(x) else x


def _box_points(lo, hi, spacing: float) -> float:
    n = 1.0
    for a, b in zip(lo, hi):
        n *= max(0.0, _floor(max(b - a, 0.0) / spacing) + 1)
    return n


def estimate(s: dict) -> dict:
    """Points a validated scene variant (``Scene.variant``) samples: ``fluid`` (upper bound
    on fluid particles: lattice points of each block's bounding box), ``emitted`` (emitter
    particles) and ``wall_lattice`` (lattice points scanned for walls)."""
    dim, r = s["dim"], s["radius"]
    sp = 2 * r
    lo, hi = s["domain"]["min"], s["domain"]["max"]
    fluid = 0.0
    for f in s["fluid"]:
        if f["shape"] in ("box",):
            a, b = f["min"], f["max"]
        elif f["shape"] == "fill":
            a = f["min"] if f["min"] is not None else lo
            b = f["max"] if f["max"] is not None else hi
        elif f["shape"] == "mesh":  # its box is known only once the mesh is read: the domain
            a, b = lo, hi
        else:  # sphere, cylinder: bounding box
            half = [f["radius"]] * dim
            if f["shape"] == "cylinder":
                half[f["axis"]] = f["height"] / 2
            a = [c - h for c, h in zip(f["center"], half)]
            b = [c + h for c, h in zip(f["center"], half)]
        grow = max(abs((f.get("top_wave") or [0])[0]), abs((f.get("bottom_wave") or [0])[0]))
        a = [v - (grow if k == 1 else 0) for k, v in enumerate(a)]
        b = [v + (grow if k == 1 else 0) for k, v in enumerate(b)]
        fluid += _box_points(a, b, sp)
    emitted = 0.0
    for e in s["emitter"]:
        if e.get("shape") == "box":  # floor(side / spacing) points per side, at least one
            side = (lambda v: max(1, _floor(v / sp + 1e-9)))
            per_layer = side(e["height"]) * (1 if dim == 2 else side(e["width"]))
        else:
            rad = e["radius"] if e["radius"] is not None else 2 * sp
            n = 2 * _floor(rad / sp + 1e-9) + 1
            per_layer = n if dim == 2 else n * n
        interval = sp / e["speed"] if e["rate"] is None else per_layer / e["rate"]
        emitted += per_layer * _ceil((e["stop"] - e["start"]) / interval)
    walls = 0.0
    if s["walls"]:
        pad = (s["wall_thickness"] or 4 * r) + sp
        walls = _box_points([v - pad for v in lo], [v + pad for v in hi], sp)
    return {"fluid": fluid, "emitted": emitted, "wall_lattice": walls}


def physical_memory() -> float | None:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return None


def _human(n: float) -> str:
    return f"{int(n):,}" if n < 1e6 else f"{n:.2e}".replace("e+0", "e").replace("e+", "e")


def _gib(nbytes: float) -> str:
    g = nbytes / 2**30
    return f"{g:.3g} GiB" if g < 1000 else f"{g:,.0f} GiB"


def check(s: dict, source: str, frames: int | None = None,
          max_particles: float | None = None) -> dict:
    """Refuse the scene variant ``s`` (named ``source`` in the message) if it is over
    budget; ``frames`` adds the trajectory kept in memory by ``dcdc generate`` and its file
    image."""
    est = estimate(s)
    points = est["fluid"] + est["emitted"] + est["wall_lattice"]
    particles = est["fluid"] + est["emitted"]
    nbytes = (est["wall_lattice"] * BYTES_PER_LATTICE_POINT
              + (est["fluid"] + est["emitted"]) * BYTES_PER_PARTICLE
              # float32 positions and velocities, and the file's image built from them in
              # memory before it is written (dcdc.outputs.atomic_h5): at most as large
              + (frames * particles * s["dim"] * 4 * 2 * 2 if frames else 0.0))
    est.update(points=points, bytes=nbytes)
    limit = default_limit() if max_particles is None else float(max_particles)
    if not limit > 0:  # nan would turn the budget off
        raise DcdcError(f"--max-particles must be a number > 0 (inf: no limit; got {limit:g})")
    what = (f"{source}: needs ~{_human(points)} particles to sample (fluid {_human(particles)}, "
            f"wall lattice {_human(est['wall_lattice'])}; ~{_gib(nbytes)} of memory)")
    if points > limit:
        raise DcdcError(f"{what}, over the limit of {_human(limit)}: check radius, resolution and "
                        "emitter rates, or raise the limit with --max-particles N")
    mem = physical_memory()
    if mem and nbytes > mem:
        raise DcdcError(f"{what}, more than this machine's {_gib(mem)}: "
                        "check radius, resolution, emitter rates and duration")
    return est


def check_duration(duration: float | None, frame_dt: float = FRAME_DT, what: str = "--duration") -> None:
    """A run must cover at least one frame: a finite duration >= frame_dt."""
    if duration is None:
        return
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise DcdcError(f"{what} must be a finite positive number of seconds (got {duration})")
    if int(round(duration / frame_dt)) < 1:
        raise DcdcError(f"{what} {duration:g} s is shorter than one frame ({frame_dt:g} s): "
                        "nothing would be simulated")


def check_run(scene, duration: float | None = None, source: str | None = None,
              warn: bool = True) -> float:
    """What a run of ``scene`` must pass before it starts (``dcdc generate`` and ``dcdc
    scene show`` alike): it covers at least one frame, and no emitter starts after its end
    (a warning, with ``warn``, when ``duration`` — ``--duration`` — overrides the scene's).
    Returns the run's duration."""
    run = duration if duration is not None else scene.duration
    src = source or scene.source
    check_duration(run, scene.frame_dt, "--duration" if duration is not None else f"{src}: duration")
    if duration is None or warn:
        check_emitters(scene, run, src, override=duration is not None)
    return run


def check_emitters(scene, duration: float, source: str, override: bool = False) -> None:
    """An emitter that starts when the run is already over stores particles that are never
    born: an error in the scene itself, a warning when ``--duration`` (``override``) cuts
    a run short on purpose."""
    for i, e in enumerate(scene.data["emitter"]):
        if e["start"] >= duration:
            msg = (f"{source}: emitter[{i}] starts at {e['start']:g} s, when the run "
                   f"({duration:g} s) is over")
            if not override:
                raise DcdcError(f"{msg}: lower its start or lengthen the scene's duration")
            click.echo(f"warning: {msg}; its particles stay unborn in this trajectory", err=True)
