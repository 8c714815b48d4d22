"""SPlisHSPlasH's own multiphase scene, DoubleDamBreakMultiPhase, in both solvers.

The scene (SPlisHSPlasH's data/Scenes: two dam-break columns of 1000 and 500 kg/m³ in the
corners of a 2.1 × 2.1 m tank and a jet of 250 kg/m³ from an emitter in the middle, r =
2.5 cm, DFSPH, volume-map walls) is imported with ``dcdc scene import``'s importer and run
by dcdc's SPH solver, and run by SPlisHSPlasH itself (``pysplishsplash``, the ``splash``
extra) through ``dcdc.sph.splishsplash``, one after the other. Reported per fluid at 2, 4
and 6 s: the particle count and the centre-of-mass height in each solver and their relative
difference (dcdc − SPlisHSPlasH) / SPlisHSPlasH.

    python benchmarks/splishsplash_double_dam_break.py [--duration 6] [--scene FILE.json]
        [--solvers dcdc,splishsplash] [--json benchmarks/results/splishsplash_double_dam_break.json]

The scene is looked up in ``$DCDC_SPLISHSPLASH_DATA/Scenes`` or in the data the installed
pysplishsplash brought; ``--scene`` names it directly. A solver left out of ``--solvers``
keeps its results from the existing JSON when they are for the same duration.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from dcdc.errors import DcdcError
from dcdc.outputs import write_text
from dcdc.particles import active_mask

SCENE = "DoubleDamBreakMultiPhase.json"
TIMES = (2.0, 4.0, 6.0)
OUT = Path(__file__).parent / "results" / "splishsplash_double_dam_break.json"


def find_scene(given: str | None) -> Path:
    """The scene file: ``given``, else in $DCDC_SPLISHSPLASH_DATA/Scenes, else in the data
    the installed pysplishsplash brought."""
    if given:
        p = Path(given).expanduser()
        if not p.is_file():
            raise DcdcError(f"{p}: no such scene file")
        return p.resolve()
    from dcdc.sph.splishsplash import data_root
    roots = [Path(os.environ["DCDC_SPLISHSPLASH_DATA"]).expanduser()] if os.environ.get(
        "DCDC_SPLISHSPLASH_DATA") else []
    root = data_root()
    roots += [root / "data"] if root else []
    for r in roots:
        if (r / "Scenes" / SCENE).is_file():
            return (r / "Scenes" / SCENE).resolve()
    raise DcdcError(f"{SCENE} not found (looked in {', '.join(map(str, roots)) or 'no folder'}); "
                    "install pysplishsplash (pip install 'dcdc[splash]'), set "
                    "DCDC_SPLISHSPLASH_DATA=path/to/SPlisHSPlasH/data or pass --scene")


def run_dcdc(scene: Path, times: list[float], tmp: Path) -> dict:
    """Import the scene, run dcdc's SPH solver to each time; per phase: active particles,
    centre-of-mass height."""
    from dcdc.scene import load
    from dcdc.scene.importers import import_scene
    from dcdc.sph import Simulator, SPHConfig
    from dcdc.sph.splishsplash import floor_row_height, height_quantiles

    toml = tmp / "scene.toml"
    res = import_scene(scene, toml)
    toml.write_text(res.text)
    sc = load(toml)
    system = sc.realize(dim=3)
    cfg = SPHConfig.from_dict(sc.solver)
    sim = Simulator(system, cfg)
    at = []
    t0 = time.perf_counter()
    for t in times:
        sim.advance(t - sim.time)
        s = sim.system
        alive = active_mask(s.birth, s.death, sim.time)
        fluids = {}
        for k, ph in enumerate(s.phases):
            sel = alive & (s.phase == k)
            fluids[ph.name] = {"particles": int(sel.sum()),
                               "com_y": float(s.x[sel, 1].mean()) if sel.any() else None,
                               "y_quantiles": height_quantiles(s.x[sel, 1])}
        at.append({"t": t, "fluids": fluids, "wall_s": time.perf_counter() - t0,
                   "floor_row_y": floor_row_height(s.x[alive, 1], s.radius)})
        print(f"dcdc: t = {t:g} s after {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return {"status": "ok", "at": at, "wall_s": time.perf_counter() - t0,
            "import_warnings": res.warnings, "settings": cfg.to_dict(),
            "initial_particles": {ph.name: int((system.phase == k).sum())
                                  for k, ph in enumerate(system.phases)}}


def run_splash(scene: Path, duration: float, times: list[float], budget: float) -> dict:
    """SPlisHSPlasH on the scene file itself (its own settings), stopped at ``duration``."""
    from dcdc.sph.splishsplash import run_scene
    t0 = time.perf_counter()
    r = run_scene(scene, stop_at=duration, times=times, timeout=budget)
    at = [{"t": a["t"], "time": a["time"],
           "fluids": {k: {"particles": f["particles"],
                          "com_y": f["centroid"][1] if f["centroid"] else None,
                          "y_quantiles": f.get("y_quantiles")}
                      for k, f in a["fluids"].items()},
           "floor_row_y": a.get("floor_row_y")} for a in r.get("at", [])]
    keep = ("status", "steps", "mean_dt", "simulated_s", "mean_iterations", "max_speed",
            "boundary_models")
    return {**{k: r.get(k) for k in keep}, "at": at, "wall_s": time.perf_counter() - t0}


def rows(dcdc: dict | None, splash: dict | None) -> list[dict]:
    """Per time and fluid: both heights and counts, (dcdc − SPlisHSPlasH) / SPlisHSPlasH."""
    out = []
    by_t = {a["t"]: a for a in (splash or {}).get("at", [])}
    rel = lambda a, b: (a - b) / b if a is not None and b else None  # noqa: E731
    for a in (dcdc or {}).get("at", []):
        other = by_t.get(a["t"], {})
        floor, floor_o = a.get("floor_row_y"), other.get("floor_row_y")
        for name, f in a["fluids"].items():
            o = other.get("fluids", {}).get(name, {})
            y, yo = f["com_y"], o.get("com_y")
            above = y - floor if y is not None and floor is not None else None
            above_o = yo - floor_o if yo is not None and floor_o is not None else None
            out.append({"t": a["t"], "fluid": name, "dcdc_com_y": y, "splishsplash_com_y": yo,
                        "dcdc_particles": f["particles"], "splishsplash_particles": o.get("particles"),
                        "relative_difference": rel(y, yo),
                        "dcdc_floor_row_y": floor, "splishsplash_floor_row_y": floor_o,
                        "relative_difference_above_floor_row": rel(above, above_o)})
    return out


def table(rs: list[dict]) -> str:
    """Markdown: per time and fluid, particles and centre-of-mass height in each solver, the
    relative difference, and that of the heights above each solver's floor row."""
    lines = ["| t [s] | fluid | dcdc: particles, COM height [m] | SPlisHSPlasH | difference "
             "| difference above the floor row |", "|---|---|---|---|---|---|"]
    f = lambda v, fmt: "–" if v is None else format(v, fmt)  # noqa: E731
    pc = lambda v: "–" if v is None else format(100 * v, "+.1f") + " %"  # noqa: E731
    for r in rs:
        lines.append(f"| {r['t']:g} | {r['fluid']} | {f(r['dcdc_particles'], 'd')}, "
                     f"{f(r['dcdc_com_y'], '.3f')} | {f(r['splishsplash_particles'], 'd')}, "
                     f"{f(r['splishsplash_com_y'], '.3f')} | {pc(r['relative_difference'])} "
                     f"| {pc(r['relative_difference_above_floor_row'])} |")
    floors = {r["t"]: (r["dcdc_floor_row_y"], r["splishsplash_floor_row_y"]) for r in rs}
    lines += ["", "floor row (mean height of the lowest particle row) [m], dcdc / SPlisHSPlasH: "
              + ", ".join(f"{t:g} s: {f(a, '.4f')} / {f(b, '.4f')}" for t, (a, b) in floors.items())]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", help=f"the scene file (default: {SCENE} from SPlisHSPlasH's data)")
    ap.add_argument("--duration", type=float, default=6.0, help="simulated seconds [6]")
    ap.add_argument("--solvers", default="dcdc,splishsplash",
                    help="which to run (the other's results are kept from --json) [both]")
    ap.add_argument("--budget", type=float, default=3600.0,
                    help="wall seconds SPlisHSPlasH may take [3600]")
    ap.add_argument("--json", default=str(OUT), help=f"result file [{OUT}]")
    a = ap.parse_args(argv)
    solvers = {s.strip() for s in a.solvers.split(",") if s.strip()}
    try:
        if not a.duration > 0:
            raise DcdcError(f"--duration must be > 0 (got {a.duration:g})")
        if solvers - {"dcdc", "splishsplash"} or not solvers:
            raise DcdcError(f"--solvers: dcdc and/or splishsplash (got {a.solvers!r})")
        scene = find_scene(a.scene)
        times = [t for t in TIMES if t <= a.duration + 1e-9] or [a.duration]
        old = {}
        if Path(a.json).is_file():
            old = json.loads(Path(a.json).read_text())
            if old.get("duration") != a.duration:
                old = {}
        result = {"scene": scene.name, "duration": a.duration, "times": times,
                  "command": "python benchmarks/splishsplash_double_dam_break.py " + " ".join(
                      sys.argv[1:] if argv is None else argv),
                  "machine": {"cpu": platform.processor() or platform.machine(),
                              "threads": os.environ.get("OMP_NUM_THREADS")}}
        with tempfile.TemporaryDirectory(prefix="dcdc-ddb-") as tmp:
            if "splishsplash" in solvers:
                from dcdc.sph.splishsplash import MISSING, available
                if not available():
                    raise DcdcError(MISSING)
                result["splishsplash"] = run_splash(scene, a.duration, times, a.budget)
                if result["splishsplash"]["status"] != "ok":
                    raise DcdcError(f"SPlisHSPlasH {result['splishsplash']['status']}")
            else:
                result["splishsplash"] = old.get("splishsplash")
            result["dcdc"] = run_dcdc(scene, times, Path(tmp)) if "dcdc" in solvers else old.get("dcdc")
    except DcdcError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    result["rows"] = rows(result["dcdc"], result["splishsplash"])
    write_text(a.json, json.dumps(result, indent=1) + "\n")
    print(table(result["rows"]))
    print(f"wrote {a.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
