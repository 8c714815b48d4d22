"""``dcdc benchmark geometry``: seconds to prepare mesh walls, and the test meshes.

Each case writes a closed mesh to an OBJ file, builds a 3-D scene around it (the mesh as
a wall, a small fluid block in a corner of the domain, r = 2.5 cm) and times
:meth:`Scene.realize`: loading the file (vertices merged, orientation checked), the
signed distance over the domain's lattice, the wall particles and their normals, and the
fluid checks. Wall-clock and CPU seconds are both reported: on a shared machine the
wall-clock time depends on the load, the CPU time much less.

Meshes: subdivided icospheres (1 280 - 81 920 triangles), a (2, 3) torus knot tube
(non-convex, 100 000 triangles) as an obstacle, and a subdivided box (49 152 triangles)
used as a hollow container, whose interior points are all far from the surface; with
``--mesh FILE`` any mesh of yours as an obstacle, and SPlisHSPlasH's ``Dragon_50k.obj``
when ``pysplishsplash`` (the ``splash`` extra) is installed.
"""
from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import click
import numpy as np

RADIUS = 0.025


def torus_knot(p: int = 2, q: int = 3, segments: int = 1000, sides: int = 50,
               tube: float = 0.08, scale: float = 0.25):
    """A closed tube of radius ``tube`` around the (p, q) torus knot (2 x segments x sides
    triangles), outward-oriented, about 3.2 x ``scale`` across."""
    import trimesh
    t = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    r = 2 + np.cos(q * t)
    c = np.stack([r * np.cos(p * t), r * np.sin(p * t), -np.sin(q * t)], 1) * scale
    tan = np.gradient(c, axis=0)
    tan[0], tan[-1] = c[1] - c[-1], c[0] - c[-2]
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    ref = np.cross(tan, [0.0, 0.0, 1.0])
    ref /= np.linalg.norm(ref, axis=1, keepdims=True)
    bin_ = np.cross(tan, ref)
    a = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    v = (c[:, None] + tube * (np.cos(a)[None, :, None] * ref[:, None]
                              + np.sin(a)[None, :, None] * bin_[:, None])).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(segments), np.arange(sides), indexing="ij")
    a0 = i * sides + j
    a1 = ((i + 1) % segments) * sides + j
    a2 = i * sides + (j + 1) % sides
    a3 = ((i + 1) % segments) * sides + (j + 1) % sides
    f = np.concatenate([np.stack([a0, a1, a3], -1).reshape(-1, 3),
                        np.stack([a0, a3, a2], -1).reshape(-1, 3)])
    m = trimesh.Trimesh(v, f, process=False)
    if m.volume < 0:
        m.invert()
    return m


def icosphere(subdivisions: int, radius: float = 0.5):
    import trimesh
    return trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)


def subdivided_box(levels: int, size: float = 1.6):
    """A closed cube of side ``size`` centred at the origin, 12 x 4^levels triangles."""
    import trimesh
    m = trimesh.creation.box(extents=[size] * 3)
    for _ in range(levels):
        m = m.subdivide()
    return m


CASES = [  # (name, mesh factory, hollow)
    ("icosphere 3", lambda: icosphere(3), False),
    ("icosphere 5", lambda: icosphere(5), False),
    ("icosphere 6", lambda: icosphere(6), False),
    ("torus knot", lambda: torus_knot(), False),
    ("box container", lambda: subdivided_box(6), True),
]


def _scene_text(obj: Path, lo, hi, hollow: bool, fluid_lo, fluid_hi) -> str:
    v = (lambda a: "[" + ", ".join(f"{c:.4f}" for c in a) + "]")
    return f"""name = "geometry_benchmark"
dim = 3
radius = {RADIUS}

[domain]
min = {v(lo)}
max = {v(hi)}

[phases.water]
density = 1000

[walls.mesh]
shape = "mesh"
file = "{obj.name}"
hollow = {str(hollow).lower()}

[[fluid]]
phase = "water"
shape = "box"
min = {v(fluid_lo)}
max = {v(fluid_hi)}
"""


def run_case(name: str, mesh, hollow: bool, tmp: Path, volume_map: bool = False) -> dict:
    """Realise the benchmark scene around ``mesh``; seconds and counts (and, with
    ``volume_map``, the seconds of the SPH solver's volume map of its walls)."""
    from . import load
    obj = tmp / (name.replace(" ", "_") + ".obj")
    mesh.export(obj)
    mlo, mhi = np.asarray(mesh.bounds[0]), np.asarray(mesh.bounds[1])
    if hollow:  # the container is the domain; fluid in its lower corner
        lo, hi = mlo, mhi
        flo, fhi = mlo + 0.1, mlo + 0.4
    else:  # the obstacle in a domain 0.3 m larger on every side; fluid in a corner
        lo, hi = mlo - 0.3, mhi + 0.3
        flo, fhi = lo, lo + 0.2
    path = tmp / "scene.toml"
    path.write_text(_scene_text(obj, lo, hi, hollow, flo, fhi))
    t0, c0 = time.perf_counter(), time.process_time()
    system = load(path).realize()
    wall_s, cpu_s = time.perf_counter() - t0, time.process_time() - c0
    rec = {"mesh": name, "triangles": int(len(mesh.faces)), "hollow": hollow, "radius": RADIUS,
           "wall_particles": int(system.n_wall), "fluid_particles": int(system.n_fluid),
           "seconds": round(wall_s, 3), "cpu_seconds": round(cpu_s, 3)}
    if volume_map:
        # what the SPH solver builds next from the same SDF (its default support h = 4r)
        from ..sph.kernels import lattice_volume
        from ..sph.volume_map import for_system
        h = 4 * RADIUS
        t0, c0 = time.perf_counter(), time.process_time()
        for_system(system, h, lattice_volume(2 * RADIUS, h, 3), True)
        rec.update(volume_map_seconds=round(time.perf_counter() - t0, 3),
                   volume_map_cpu_seconds=round(time.process_time() - c0, 3))
    return rec


@click.command("geometry")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None,
              help="write the table as JSON")
@click.option("--quick", is_flag=True, help="only the two smallest meshes")
@click.option("--volume-map/--no-volume-map", default=True, show_default=True,
              help="also time the SPH solver's volume map of the walls (cell r/2)")
@click.option("--mesh", "mesh_files", multiple=True, type=click.Path(exists=True, dir_okay=False),
              help="also a mesh file of yours, as an obstacle (repeatable); SPlisHSPlasH's "
                   "Dragon_50k.obj is added when pysplishsplash is installed")
@click.option("--note", default="", help="free text stored in the JSON (e.g. what else ran)")
def benchmark_command(json_path, quick, volume_map, mesh_files, note):
    """Seconds to prepare mesh walls (r = 2.5 cm) for meshes of 1 280 - 100 000 triangles."""
    from importlib.metadata import version

    import trimesh

    cases = list(CASES[:2] if quick else CASES)
    files = [Path(f) for f in mesh_files]
    dragon = Path(sys.prefix) / "bin" / "data" / "models" / "Dragon_50k.obj"  # pysplishsplash's data
    if not quick and dragon.is_file() and dragon not in files:
        files.append(dragon)
    for f in files:
        cases.append((f.name, (lambda f: lambda: trimesh.load(str(f), force="mesh"))(f), False))
    load0 = os.getloadavg()
    rows = []
    click.echo(f"{'mesh':<18}{'triangles':>10}{'walls':>9}{'s':>8}{'CPU s':>8}"
               + (f"{'map s':>8}{'map CPU s':>11}" if volume_map else ""))
    with tempfile.TemporaryDirectory() as tmp:
        for name, make, hollow in cases:
            r = run_case(name, make(), hollow, Path(tmp), volume_map)
            rows.append(r)
            click.echo(f"{name[:17]:<18}{r['triangles']:>10}{r['wall_particles']:>9}"
                       f"{r['seconds']:>8.2f}{r['cpu_seconds']:>8.2f}"
                       + (f"{r['volume_map_seconds']:>8.2f}{r['volume_map_cpu_seconds']:>11.2f}"
                          if volume_map else ""))
    rec = {"benchmark": "geometry",
           "what": "Scene.realize() of a 3-D scene with one mesh wall (r = 2.5 cm): load the "
                   "OBJ, signed distance on the domain lattice, wall particles + normals, "
                   "fluid checks (seconds, cpu_seconds); then the SPH solver's volume map "
                   "of those walls from the same SDF (volume_map_*)",
           "note": "wall-clock seconds depend on the machine's load (load averages below); "
                   "CPU seconds are this process's own" + (f"; {note}" if note else ""),
           "machine": {"cores": os.cpu_count(), "loadavg_1_5_15min_start": [round(x, 2) for x in load0],
                       "loadavg_1_5_15min_end": [round(x, 2) for x in os.getloadavg()],
                       "libigl": version("libigl"), "trimesh": trimesh.__version__,
                       "time": time.strftime("%Y-%m-%d %H:%M:%S")},
           "cases": rows}
    if json_path:
        from ..outputs import write_text
        write_text(json_path, json.dumps(rec, indent=1) + "\n")
