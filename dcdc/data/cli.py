"""``dcdc dataset``: summarise, merge and export trajectory datasets."""
from __future__ import annotations

import json

import click

from ..errors import DcdcError


@click.group("dataset")
def dataset_group():
    """Inspect, merge and export datasets written by `dcdc generate`."""


@dataset_group.command("info")
@click.argument("path", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--list", "list_trajs", is_flag=True, help="One line per trajectory.")
@click.option("--verify", is_flag=True,
              help="Read every array and check its checksum (exit 2 if any trajectory is corrupt).")
def info_command(path, as_json, list_trajs, verify):
    """Summarise the dataset at PATH (a directory or a merged .h5 file; a folder whose
    sub-folders are datasets, such as data/sample, is summarised one dataset after another)."""
    subs = sub_datasets(path)
    if not subs:
        s, check = _describe(path, as_json, list_trajs, verify)
        if as_json:
            click.echo(json.dumps(s, indent=1))
        _report_corrupt(check)
        return
    summaries, corrupt = [], {}
    for k, sub in enumerate(subs):
        if k and not as_json:
            click.echo("")
        s, check = _describe(sub, as_json, list_trajs, verify)
        summaries.append(s)
        if check:
            corrupt.update({f"{sub}:{name}": why for name, why in check["corrupt"].items()})
    if as_json:
        click.echo(json.dumps({"path": str(path), "datasets": summaries}, indent=1))
    _report_corrupt({"corrupt": corrupt} if corrupt else None)


def sub_datasets(path) -> list:
    """The datasets one level below ``path`` when ``path`` is a folder holding no trajectory
    files of its own but sub-folders that do (``data/sample``: train2d, test2d)."""
    from pathlib import Path

    from ..outputs import TMP_MARK
    p = Path(path)
    if not p.is_dir() or any(p.glob("*.h5")) or any(p.glob(f".*.h5{TMP_MARK}*")):
        return []
    return sorted(d for d in p.iterdir()
                  if d.is_dir() and not d.name.startswith(".") and any(d.glob("*.h5")))


def _describe(path, as_json: bool, list_trajs: bool, verify: bool):
    """Print the summary of one dataset (unless ``as_json``); returns it and the check."""
    from .dataset import Dataset
    ds = Dataset(path)
    check = _verify(ds) if verify else None
    s = ds.summary()
    if check is not None:
        s["verify"] = check
    if as_json:
        return s, check
    click.echo(f"dataset     {s['path']}")
    click.echo(f"trajectories {s['trajectories']} finished" +
               (f", {s['incomplete']} unfinished (ignored)" if s["incomplete"] else "") +
               (f"; {len(s['stopped_rollouts'])} of them PARTIAL rollouts stopped by the "
                f"guard ({', '.join(s['stopped_rollouts'])})" if s["stopped_rollouts"] else ""))
    if s["trajectories"]:
        click.echo(f"dims        {s['dims']}   splits {s['splits']}")
        click.echo(f"frames      {s['frames']} in all, dt = {s['frame_dt']} s, radius = {s['radius']} m")
        click.echo(f"particles   {s['particles_min']} .. {s['particles_max']} fluid per trajectory")
        click.echo(f"phases      {s['phases_per_traj']} per trajectory, densities "
                   f"{s['density_range'][0]:g} .. {s['density_range'][1]:g} kg/m³, max ratio "
                   f"{s['density_ratio_max']:.2f}")
        click.echo(f"solver      {', '.join(s['solvers'])}")
        click.echo(f"generation  {s['wall_time_s']:.1f} s of simulation wall time; "
                   f"{s['bytes'] / 1e6:.1f} MB on disk")
    if list_trajs:
        for t in ds:
            d = sorted(set(t.density.tolist()))
            click.echo(f"  {t.name:<28} {t.dim}-D {t.n_frames:>4} frames {t.n_particles:>6} particles "
                       f"densities {', '.join(f'{v:g}' for v in d)}  {float(t.attrs.get('wall_time_s', 0)):.1f} s")
    if check is not None:
        click.echo(f"verify      {len(check['verified'])} checksummed and intact"
                   + (f", {len(check['unverifiable'])} without checksums (format 1, not verifiable)"
                      if check["unverifiable"] else "")
                   + (f", {len(check['corrupt'])} CORRUPT" if check["corrupt"] else ""))
    return s, check


def _verify(ds):
    from .dataset import verify
    check = verify(ds)
    if check["corrupt"]:  # summary() would trip over the damaged ones; describe the rest
        ds._refs = [r for r in ds._refs if r.group not in check["corrupt"]]
    return check


def _report_corrupt(check) -> None:
    if check and check["corrupt"]:
        for name, why in check["corrupt"].items():
            click.echo(f"  corrupt {name}: {why}")
        first = next(iter(check["corrupt"].values()))
        raise DcdcError(f"{len(check['corrupt'])} corrupt trajectory(ies), e.g. {first}")


@dataset_group.command("merge")
@click.argument("output", type=click.Path())
@click.argument("inputs", nargs=-1, required=True, type=click.Path(exists=True))
@click.option("--overwrite", is_flag=True)
def merge_command(output, inputs, overwrite):
    """Join INPUTS (shard directories or .h5 files) into OUTPUT (a .h5 file, or a directory)."""
    from .dataset import merge
    from ..outputs import check_dir, check_file
    if output.endswith(".h5"):
        check_file(output, overwrite)
    else:
        check_dir(output, overwrite)
    n = merge(inputs, output, overwrite)
    click.echo(f"merged {n} trajectories into {output}")


@dataset_group.command("export-lagrangebench")
@click.option("--train", type=click.Path(exists=True), required=True)
@click.option("--valid", type=click.Path(exists=True), default=None)
@click.option("--test", type=click.Path(exists=True), default=None)
@click.option("-o", "--out", type=click.Path(), required=True)
@click.option("--overwrite", is_flag=True, help="Replace an existing non-empty OUT directory.")
def export_lb_command(train, valid, test, out, overwrite):
    """Write train/valid/test.h5 + metadata.json (+ force.py: gravity) in the LagrangeBench layout."""
    from .lagrangebench import export_lagrangebench
    splits = {k: v for k, v in (("train", train), ("valid", valid), ("test", test)) if v}
    meta = export_lagrangebench(splits, out, overwrite=overwrite,
                                warn=lambda text: click.echo(f"note: {text}", err=True))
    click.echo(f"wrote {', '.join(f'{k}.h5' for k in splits)} + metadata.json"
               f"{' + force.py' if any(meta['gravity']) else ''} to {out} "
               f"({meta['num_trajs_train']} train trajectories, {meta['num_particles_max']} particles max)")
