"""``dcdc train CONFIG.toml [--set key=value …] [--out RUN] [--resume] [--device cpu|cuda]``."""
from __future__ import annotations

from pathlib import Path

import click


@click.command("train")
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override a config value, e.g. --set optim.lr=1e-4 (repeatable).")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Run directory (default runs/<config name>).")
@click.option("--resume", is_flag=True,
              help="Continue the run in --out from its newest checkpoint (or start it).")
@click.option("--device", default="cpu", show_default=True, type=click.Choice(["cpu", "cuda"]),
              help="Where the network runs (the neighbour search stays on the CPU).")
@click.option("--progress/--no-progress", default=None,
              help="Progress bar (default: the config's log.progress).")
def train_command(config, overrides, out, resume, device, progress):
    """Train a network on a dataset (curriculum, unrolled loss; torchrun for DDP)."""
    from .config import load_config
    from .trainer import train

    import os
    from contextlib import nullcontext

    from ..outputs import run_lock

    cfg = load_config(config, overrides)
    out = out if out is not None else Path("runs") / config.stem
    # one process per run directory (the ranks of one torchrun job share rank 0's lock)
    lock = run_lock(out, "dcdc train") if os.environ.get("RANK", "0") == "0" else nullcontext()
    with lock:
        path = train(cfg, out, resume=resume, device=device, progress=progress, echo=click.echo)
    if path is not None:
        click.echo(f"model: {path}")
