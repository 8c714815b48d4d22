"""``dcdc model``: work with network checkpoints (``import-dlf``: DeepLagrangianFluids'
pretrained weights as a dcdc checkpoint, :mod:`dcdc.model.dlf`)."""
from __future__ import annotations

import click


@click.group("model")
def model_group():
    """Network checkpoints: import published weights."""


@model_group.command("import-dlf")
@click.argument("weights", type=click.Path(dir_okay=False))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False),
              help="the dcdc checkpoint to write (.pt)")
@click.option("--overwrite", is_flag=True, help="replace an existing --out file")
def import_dlf_command(weights, out, overwrite):
    """Convert DeepLagrangianFluids' WEIGHTS.pt (their torch state_dict) into a dcdc
    `cconv` checkpoint without the density channel; run it with `dcdc simulate`."""
    from ..outputs import check_file
    from .dlf import LICENSE, import_dlf

    check_file(out, overwrite)
    net = import_dlf(weights, out)
    n = sum(p.numel() for p in net.parameters())
    click.echo(f"wrote {out}: DeepLagrangianFluids network as dcdc 'cconv' (3-D, no density "
               f"input, r = {net.cfg.particle_radius:g} m, dt = {net.cfg.frame_dt:g} s, "
               f"{n:,} parameters; license {LICENSE})")
