"""``dcdc scene``: list, show, check, copy, randomise and import scenes."""
from __future__ import annotations

import click
import numpy as np

from ..outputs import check_file, write_text
from .schema import SEED_MAX


def _summary(system, scene) -> str:
    lo, hi = (np.asarray(c) for c in system.meta.get("scene_domain", system.domain))
    lines = [f"scene     {scene.name} ({system.dim}-D{', cross-section of the 3-D scene' if system.dim < scene.dim else ''})",
             f"about     {scene.data['description']}" if scene.data["description"] else None,
             f"domain    {lo.round(3).tolist()} .. {hi.round(3).tolist()} m"
             + (" (derived: the box around walls and fluid)" if scene.data["domain"] is None else ""),
             f"radius    {system.radius:g} m (spacing {system.spacing:g} m)",
             f"duration  {scene.duration:g} s ({int(round(scene.duration / scene.frame_dt))} frames of {scene.frame_dt:g} s)",
             f"gravity   {system.gravity.round(4).tolist()} m/s²",
             f"fluid     {system.n_fluid} particles"
             + (f" ({int((system.birth > 0).sum())} emitted later)" if (system.birth > 0).any() else ""),
             ]
    for p, (name, n) in zip(system.phases, system.counts_per_phase().items()):
        lines.append(f"  {name:<12} {n:>7}   ρ₀ = {p.density:g} kg/m³, ν = {p.viscosity:g} m²/s")
    lines.append(f"walls     {system.n_wall} particles ({', '.join(scene.data['walls']) or 'none'})")
    if scene.data["solver"]:
        lines.append(f"solver    {scene.data['solver']}")
    return "\n".join(ln for ln in lines if ln)


@click.group("scene")
def scene_group():
    """Scene files: built-in scenes, validation, pictures, random training scenes."""


@scene_group.command("list")
def list_command():
    """List the built-in scenes."""
    from . import builtin_names, get_scene
    for n in builtin_names():
        s = get_scene(n)
        click.echo(f"{n:<18} {s.data['description']}")


@scene_group.command("show")
@click.argument("scene")
@click.option("--dim", type=click.IntRange(2, 3), default=None, help="2 = cross-section of a 3-D scene.")
@click.option("--resolution", type=float, default=1.0, show_default=True,
              help="Scale every length by S at fixed particle radius (fluid count ~S^dim).")
@click.option("--image", type=click.Path(dir_okay=False), default=None, help="Draw the initial state (PNG).")
@click.option("--overwrite", is_flag=True, help="Replace an existing --image file.")
@click.option("--max-particles", type=float, default=None,
              help="Particle budget (default 1e7 or $DCDC_MAX_PARTICLES).")
def show_command(scene, dim, resolution, image, overwrite, max_particles):
    """Validate and describe SCENE (a built-in name or a .toml file)."""
    from . import get_scene
    if image:
        from .draw import check_image
        check_image(image, overwrite)
    sc = get_scene(scene)
    sc.check_solver()
    from .budget import check_run
    check_run(sc)  # as dcdc generate does
    system = sc.realize(dim=dim, resolution=resolution, max_particles=max_particles)
    click.echo(_summary(system, sc))
    if image:
        from .draw import draw
        draw(system, image)
        click.echo(f"image     {image}")


@scene_group.command("copy")
@click.argument("name")
@click.argument("output", type=click.Path(dir_okay=False))
@click.option("--overwrite", is_flag=True, help="Replace an existing OUTPUT.")
def copy_command(name, output, overwrite):
    """Write built-in scene NAME to OUTPUT (a starting point for your own scene)."""
    from . import builtin_text
    check_file(output, overwrite)
    write_text(output, builtin_text(name))
    click.echo(f"wrote {output}")


@scene_group.command("random")
@click.option("--seed", type=click.IntRange(0, SEED_MAX), required=True)
@click.option("--dim", type=click.IntRange(2, 3), default=2, show_default=True)
@click.option("--max-ratio", type=float, default=10.0, show_default=True,
              help="Largest density ratio between phases (curriculum parameter; 1 = single density).")
@click.option("--min-ratio", type=float, default=1.0, show_default=True,
              help="Smallest max/min density ratio (e.g. held-out tests beyond the training range).")
@click.option("--density-range", type=(float, float), default=(500.0, 5000.0), show_default=True)
@click.option("--tension", type=float, default=0.0, show_default=True,
              help="Interfacial tension σ [N/m] between every pair of phases (0 = none).")
@click.option("--duration", type=float, default=None, help="Seconds (default: drawn 2-3 s).")
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None,
              help="Write the scene file here (default: stdout).")
@click.option("--image", type=click.Path(dir_okay=False), default=None)
@click.option("--overwrite", is_flag=True, help="Replace existing --output / --image files.")
def random_command(seed, dim, max_ratio, min_ratio, density_range, tension, duration, output, image,
                   overwrite):
    """A random training scene, reproducible from --seed."""
    from .budget import check_duration
    from .random import RandomSceneConfig, random_scene_text
    if output:
        check_file(output, overwrite)
    if image:
        from .draw import check_image
        check_image(image, overwrite)
    check_duration(duration)
    cfg = RandomSceneConfig(dim=dim, max_ratio=max_ratio, min_ratio=min_ratio,
                            density_range=density_range, duration=duration, tension=tension)
    cfg.check()
    text = random_scene_text(seed, cfg)
    if output:
        write_text(output, text)
        click.echo(f"wrote {output}", err=True)
    else:
        click.echo(text, nl=False)
    if image:
        from . import parse
        from .draw import draw
        draw(parse(text, f"random seed {seed}").realize(), image)


@scene_group.command("import")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None,
              help="Write the scene TOML here (default: stdout, with absolute mesh paths).")
@click.option("--name", default=None, help="Scene name (default: the JSON file's name).")
@click.option("--overwrite", is_flag=True, help="Replace an existing OUTPUT.")
def import_command(source, output, name, overwrite):
    """Convert a DeepLagrangianFluids or SPlisHSPlasH scene JSON into a dcdc scene TOML.

    Prints one warning line per item that has no dcdc equivalent (docs/scenes.md,
    "Importing scenes"); the import succeeds all the same."""
    from .importers import import_scene
    if output:
        check_file(output, overwrite)
    res = import_scene(source, output, name)
    for w in res.warnings:
        click.echo(f"warning: {w}", err=True)
    if output:
        write_text(output, res.text)
        click.echo(f"wrote {output} ({res.summary()})", err=True)
    else:
        click.echo(res.text, nl=False)
