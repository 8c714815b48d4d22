"""``dcdc train CONFIG.toml [--set key=value …] [--out RUN] [--resume] [--device cpu|cuda]``.

CONFIG is one run's config or a recipe (``[[stage]]`` tables, :mod:`dcdc.train.recipe`):
a recipe trains its stages in order into ``RUN/<stage>/`` and resumes by itself;
``--plan`` prints its stages, datasets and estimated time instead.
"""
from __future__ import annotations

from pathlib import Path

import click


@click.command("train")
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override a config value, e.g. --set optim.lr=1e-4 (repeatable; in a "
                   "recipe, of every stage).")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Run directory (default runs/<config name>).")
@click.option("--resume", is_flag=True,
              help="Continue the run in --out from its newest checkpoint (or start it); "
                   "a recipe always does.")
@click.option("--device", default="cpu", show_default=True, type=click.Choice(["cpu", "cuda"]),
              help="Where the network runs (the neighbour search stays on the CPU).")
@click.option("--progress/--no-progress", default=None,
              help="Progress bar (default: the config's log.progress).")
@click.option("--plan", is_flag=True,
              help="Recipe: print its stages, datasets (with the commands that make them) "
                   "and estimated time; train nothing.")
def train_command(config, overrides, out, resume, device, progress, plan):
    """Train a network on a dataset (curriculum, unrolled loss; torchrun for DDP), or
    every stage of a recipe (configs/models/*.toml)."""
    import os
    from contextlib import nullcontext

    from ..configs import load_toml
    from ..errors import DcdcError
    from ..outputs import run_lock
    from .recipe import is_recipe, parse_recipe, plan_text, run_recipe

    out = out if out is not None else Path("runs") / config.stem
    d = load_toml(config)
    recipe = parse_recipe(d, config) if is_recipe(d) else None
    if plan:
        if recipe is None:
            raise DcdcError(f"--plan is for recipes ([[stage]] tables); {config} is the "
                            f"config of one run")
        click.echo(plan_text(recipe, out, overrides))
        return
    # one process per run directory (the ranks of one torchrun job share rank 0's lock)
    lock = run_lock(out, "dcdc train") if os.environ.get("RANK", "0") == "0" else nullcontext()
    if recipe is not None:
        with lock:
            path = run_recipe(recipe, out, overrides, device=device, progress=progress,
                              echo=click.echo)
        if os.environ.get("RANK", "0") == "0":
            click.echo(f"model: {path}")
        return

    from .config import load_config
    from .trainer import train

    cfg = load_config(config, overrides)
    with lock:
        path = train(cfg, out, resume=resume, device=device, progress=progress, echo=click.echo)
    if path is not None:
        click.echo(f"model: {path}")
