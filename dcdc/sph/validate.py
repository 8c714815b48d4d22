"""``dcdc validate-sph``: the solver's physics validation suite (cases in :mod:`.cases`)."""
from __future__ import annotations

import json
import time

import click

from ..configs import apply_overrides
from ..errors import DcdcError
from ..outputs import write_text
from .cases import CASES, Row
from .config import SPHConfig


def validate(dim: int = 2, quick: bool = False, cases: list[str] | None = None,
             cfg: SPHConfig | None = None, echo=None) -> list[Row]:
    """Run the validation cases; returns all rows (``echo(row)`` is called as they come)."""
    if dim not in (2, 3):
        raise DcdcError(f"dim must be 2 or 3 (got {dim})")
    names = list(CASES) if not cases else cases
    unknown = [c for c in names if c not in CASES]
    if unknown:
        raise DcdcError(f"unknown validation case {unknown[0]!r} (known: {', '.join(CASES)})")
    cfg = cfg or SPHConfig()
    rows: list[Row] = []
    for name in names:
        for row in CASES[name](dim, quick, cfg):
            rows.append(row)
            if echo:
                echo(row)
    return rows


def format_row(r: Row) -> str:
    m = f"{r.measured:.4g}" if isinstance(r.measured, float) else str(r.measured)
    return (f"{r.case:<38} {r.quantity:<36} {m:>10} {r.reference:>22} {r.tolerance:>16} "
            f"{'info' if r.passed is None else 'PASS' if r.passed else 'FAIL':>5}")


@click.command("validate-sph")
@click.option("--quick", is_flag=True, help="coarser and shorter variants (the test suite's)")
@click.option("--dim", type=click.Choice(["2", "3"]), default="2", show_default=True)
@click.option("--case", "cases", multiple=True, type=click.Choice(list(CASES)),
              help="run only this case (repeatable)")
@click.option("--solver", type=click.Choice(["dfsph", "wcsph"]), default="dfsph", show_default=True)
@click.option("--sph", "sph_set", multiple=True, metavar="KEY=VALUE",
              help="Override a solver setting (repeatable), e.g. --sph xsph=0.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None,
              help="also write the table as JSON")
def validate_command(quick, dim, cases, solver, sph_set, json_path):
    """Physics validation of the multiphase SPH solver; exits 1 if any check fails."""
    header = (f"{'case':<38} {'quantity':<36} {'measured':>10} {'reference':>22} "
              f"{'tolerance':>16} {'pass':>5}")
    click.echo(header)
    click.echo("-" * len(header))
    t0 = time.perf_counter()
    cfg = SPHConfig.from_dict(apply_overrides({"solver": solver}, sph_set))
    rows = validate(int(dim), quick, list(cases), cfg,
                    echo=lambda r: click.echo(format_row(r)))
    wall = time.perf_counter() - t0
    checks = [r for r in rows if r.passed is not None]
    n_fail = sum(r.failed for r in checks)
    click.echo(f"{len(checks) - n_fail}/{len(checks)} checks passed in {wall:.0f} s "
               f"({'quick' if quick else 'full'}, {dim}-D, {solver})")
    if json_path:
        doc = {"dim": int(dim), "quick": quick, "solver": solver, "sph": cfg.to_dict(), "wall_s": wall,
               "passed": n_fail == 0, "rows": [r.as_dict() for r in rows]}
        write_text(json_path, json.dumps(doc, indent=2, default=float) + "\n")
    if n_fail:
        raise SystemExit(1)
