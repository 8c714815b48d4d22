"""Run a dcdc scene in SPlisHSPlasH (package ``pysplishsplash``, optional extra ``[splash]``).

The field's reference SPH implementation serves as a baseline in ``dcdc benchmark sph``.
A :class:`~dcdc.particles.ParticleSystem` whose phases are axis-aligned fluid blocks in a box
container is translated into a SPlisHSPlasH scene (``Materials`` with per-phase ``density0``,
``FluidBlocks``, a wall box sampled with Akinci et al. 2012 boundary particles, CFL time
steps) and simulated in a child process, because the library

* needs ``LD_PRELOAD=libGLdispatch.so.0`` at process start on Debian (measured), and
* may segfault or blow up at high density ratios (its DFSPH does at 10:1, MEASURED.md),
  which must not take the benchmark down with it.

The child reports steps, mean time step, solver iterations (parsed from SPlisHSPlasH's own
summary), wall time, the largest particle speed seen, the final phase centroids and, at
requested times, each fluid's particle count and centroid.

A SPlisHSPlasH scene file runs the same way from the command line, from any working
directory and virtual environment::

    python -m dcdc.sph.splishsplash path/to/scene.json [result.json] [--stop-at 6] [--times 2,4,6]

SPlisHSPlasH resolves a relative scene path, and looks for its ``resources/`` (the emitters'
housings) next to the running executable: the scene path is made absolute first, and where
the interpreter's folder lacks ``resources/`` (a virtual environment, whose interpreter links
to the base one) the child runs a copy of the interpreter in a folder that links the installed
package's ``resources/`` and ``data/``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from ..particles import ParticleSystem

SOLVERS = {"WCSPH": 0, "PCISPH": 1, "PBF": 2, "IISPH": 3, "DFSPH": 4}
GL_DISPATCH = "/lib/x86_64-linux-gnu/libGLdispatch.so.0"
EXPLODED_SPEED = 50.0  # m/s: no particle in our benchmark scenes moves this fast physically


MISSING = "pysplishsplash is not installed (pip install 'dcdc[splash]')"


def available() -> bool:
    """Whether ``pysplishsplash`` is installed (checked without importing it here)."""
    import importlib.util
    return importlib.util.find_spec("pysplishsplash") is not None


def data_root() -> Path | None:
    """The folder in which the installed ``pysplishsplash`` put SPlisHSPlasH's ``resources/``
    and ``data/`` (its wheel: ``<prefix>/bin``), or None."""
    import importlib.metadata
    try:
        files = importlib.metadata.distribution("pysplishsplash").files or []
    except importlib.metadata.PackageNotFoundError:
        return None
    for f in files:
        if f.name == "EmitterBox.obj" and f.parent.name == "emitter_boundary":
            root = Path(f.locate()).resolve().parent.parent.parent
            if (root / "resources").is_dir():
                return root
    return None


def interpreter(folder: Path) -> tuple[str, dict]:
    """(python executable, environment additions) for the child: ``sys.executable`` where
    SPlisHSPlasH finds its ``resources/`` next to the real interpreter, else a copy of the
    interpreter in ``folder/bin`` beside links to the package's ``resources/`` and ``data/``,
    set up as a virtual environment of the base interpreter that sees this ``sys.path``."""
    real = Path(os.path.realpath(sys.executable))
    root = data_root()
    if root is None or (real.parent / "resources").is_dir():
        return sys.executable, {}
    home = Path(sys.base_prefix) / "bin"
    if not (home / real.name).exists():
        home = real.parent
    bindir = folder / "bin"
    bindir.mkdir(parents=True, exist_ok=True)
    exe = bindir / real.name
    shutil.copy2(real, exe)
    (folder / "pyvenv.cfg").write_text(f"home = {home}\ninclude-system-site-packages = false\n")
    for name in ("resources", "data"):
        if (root / name).exists():
            (bindir / name).symlink_to(root / name)
    # this sys.path, led by the folder holding dcdc (an editable install's finder is a .pth hook)
    paths = [str(Path(__file__).resolve().parents[2])] + [p for p in sys.path if p and os.path.isdir(p)]
    libs = [str(real.parent.parent / "lib")] + [v for v in [os.environ.get("LD_LIBRARY_PATH")] if v]
    return str(exe), {"PYTHONPATH": os.pathsep.join(paths), "LD_LIBRARY_PATH": os.pathsep.join(libs)}


def phase_blocks(system: ParticleSystem) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(phase name, lo, hi) of each phase's fluid block: its particles' bounding box grown by
    the particle radius. Raises if a phase is not one filled box (the only shape exported)."""
    blocks = []
    s = system.spacing
    for k, ph in enumerate(system.phases):
        x = system.x[system.phase == k]
        if len(x) == 0:
            continue
        lo, hi = x.min(0) - system.radius, x.max(0) + system.radius
        expected = np.prod(np.round((hi - lo) / s))
        if abs(expected - len(x)) > 0.01 * len(x):
            raise DcdcError(f"phase '{ph.name}' is not a single filled box; SPlisHSPlasH export "
                            "supports block-shaped phases only")
        blocks.append((ph.name, lo, hi))
    return blocks


def scene_json(system: ParticleSystem, container: tuple, duration: float, solver: str,
               mesh_path: str) -> dict:
    """The SPlisHSPlasH scene (JSON dict) equivalent to ``system`` in the box ``container``."""
    if system.dim != 3:
        raise DcdcError("the SPlisHSPlasH comparison runs 3-D scenes only")
    if solver not in SOLVERS:
        raise DcdcError(f"unknown SPlisHSPlasH solver '{solver}' (choose from {', '.join(SOLVERS)})")
    # SPlisHSPlasH samples wall particles on the mesh surface; ours sit half a spacing inside
    # the solid. Grow the box by r so wall particle centres coincide with ours.
    lo, hi = (np.asarray(c, dtype=float) for c in container)
    lo, hi = lo - system.radius, hi + system.radius
    return {
        "Configuration": {
            "particleRadius": system.radius, "simulationMethod": SOLVERS[solver],
            "gravitation": system.gravity.tolist(), "timeStepSize": 0.001,
            "cflMethod": 1, "cflFactor": 1.0, "cflMaxTimeStepSize": 0.005,
            "maxIterations": 100, "maxError": 0.01, "maxIterationsV": 100, "maxErrorV": 0.1,
            "enableDivergenceSolver": True, "boundaryHandlingMethod": 0, "stopAt": duration,
            "enablePartioExport": False, "enableVTKExport": False,
        },
        "Materials": [{"id": p.name, "density0": p.density, "viscosity": 0.01, "viscosityMethod": 1}
                      for p in system.phases],
        "RigidBodies": [{"geometryFile": mesh_path, "translation": ((lo + hi) / 2).tolist(),
                         "scale": (hi - lo).tolist(), "isDynamic": False, "isWall": True}],
        # SPlisHSPlasH's regular block sampling puts L/(2r) - 1 particles along an edge of
        # length L: grow each block by r per side so it holds as many particles as ours.
        "FluidBlocks": [{"id": name, "denseMode": 0, "start": (blo - system.radius).tolist(),
                         "end": (bhi + system.radius).tolist()}
                        for name, blo, bhi in phase_blocks(system)],
    }


def run_splishsplash(system: ParticleSystem, duration: float, solver: str = "IISPH",
                     container: tuple | None = None, timeout: float = 1800.0) -> dict:
    """Simulate ``system`` for ``duration`` seconds in SPlisHSPlasH; return measured stats.

    ``container`` is the (lo, hi) inner box of the tank; it defaults to
    ``system.meta["container"]``.
    """
    if not available():
        raise DcdcError(MISSING)
    container = container if container is not None else system.meta.get("container")
    if container is None:
        raise DcdcError("the SPlisHSPlasH comparison needs the scene's container box")
    import trimesh

    with tempfile.TemporaryDirectory(prefix="dcdc-splash-") as tmp:
        mesh = os.path.join(tmp, "UnitBox.obj")
        trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(mesh)
        scene = os.path.join(tmp, "scene.json")
        with open(scene, "w") as f:
            json.dump(scene_json(system, container, duration, solver, mesh), f)
        result = run_scene(scene, timeout=timeout)
    result["solver"] = solver
    return result


def run_scene(scene, stop_at: float | None = None, times=(), timeout: float = 1800.0) -> dict:
    """Run the SPlisHSPlasH scene file ``scene`` in a child process (until ``stop_at``
    seconds, else the scene's ``stopAt``) and return its stats (:func:`_child`) with a
    ``status``: "ok", exploded, stopped by the ``timeout`` wall budget, or crashed with
    the last line SPlisHSPlasH wrote. ``times``: simulated times at which each fluid's
    particle count and centroid are recorded (``result["at"]``)."""
    if not available():
        raise DcdcError(MISSING)
    scene = Path(scene).expanduser().resolve()  # SPlisHSPlasH resolves relative paths elsewhere
    if not scene.is_file():
        raise DcdcError(f"{scene}: no such scene file")
    with tempfile.TemporaryDirectory(prefix="dcdc-splash-") as tmp:
        exe, extra = interpreter(Path(tmp) / "python")
        env = {**os.environ, **extra}
        if os.path.exists(GL_DISPATCH):
            env["LD_PRELOAD"] = (GL_DISPATCH + " " + env.get("LD_PRELOAD", "")).strip()
        out = os.path.join(tmp, "result.json")
        # the child stops itself after ``timeout`` wall seconds and reports how far it got
        cmd = [exe, "-m", "dcdc.sph.splishsplash", "--child", str(scene), out, "--budget", str(timeout)]
        if stop_at is not None:
            cmd += ["--stop-at", repr(float(stop_at))]
        if len(times):
            cmd += ["--times", ",".join(repr(float(t)) for t in times)]
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp,
                                  timeout=timeout + 120)
        except subprocess.TimeoutExpired:
            return {"status": f"timed out after {timeout:.0f} s"}
        wall = time.perf_counter() - t0
        if proc.returncode != 0 or not os.path.exists(out):
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or [""]
            return {"status": f"crashed (exit {proc.returncode}) {tail[0][:160]}",
                    "process_wall_s": wall}
        with open(out) as f:
            result = json.load(f)
    its = re.findall(r"Average number: \w+ - iterations: ([0-9.eE+-]+)", proc.stdout)
    result["mean_iterations"] = float(its[0]) if its else None
    exploded = not np.isfinite(result["max_speed"]) or result["max_speed"] > EXPLODED_SPEED
    when = result.get("exploded_at_s")
    result["status"] = ("ok" if not exploded else
                        f"exploded at t = {when:.3f} s" if when is not None else "exploded")
    if result.get("budget_stop") and not exploded:
        result["status"] = (f"stopped by the {timeout:g} s wall budget at t = "
                            f"{result['simulated_s']:.3f} s (mean step {1e3 * result['mean_dt']:.3f} ms)")
    return result


def _fluids(sim) -> dict:
    """Each fluid model's active particle count and centroid."""
    out = {}
    for k in range(sim.numberOfFluidModels()):
        fm = sim.getFluidModel(k)
        n = fm.numActiveParticles()
        x = np.asarray(fm.getFieldBuffer("position"))[:n]
        out[fm.getId()] = {"particles": int(n), "centroid": x.mean(0).tolist() if n else None,
                           "density0": fm.getDensity0(), "y_quantiles": height_quantiles(x[:, 1])}
    return out


QUANTILES = (0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0)


def height_quantiles(y) -> list | None:
    """Heights at the :data:`QUANTILES` of ``y`` (how a fluid's particles spread vertically)."""
    y = np.asarray(y, dtype=np.float64)
    return np.quantile(y, QUANTILES).tolist() if len(y) else None


def floor_row_height(y: np.ndarray, radius: float) -> float | None:
    """Mean height of the lowest particle row: the particles less than a radius above the
    lowest one (``y``: heights of all fluid particles)."""
    y = np.asarray(y, dtype=np.float64)
    return float(y[y < y.min() + radius].mean()) if len(y) else None


def _floor_row(sim) -> float | None:
    ys = [np.asarray(sim.getFluidModel(k).getFieldBuffer("position"))[:sim.getFluidModel(k).numActiveParticles(), 1]
          for k in range(sim.numberOfFluidModels())]
    return floor_row_height(np.concatenate(ys), sim.getParticleRadius())


def _boundary(sim) -> tuple[int, list]:
    """(boundary particles, boundary kinds): particle boundaries (Akinci 2012) have
    particles; volume and density maps (Bender 2019, Koschier 2017) have none."""
    n, kinds = 0, []
    for k in range(sim.numberOfBoundaryModels()):
        bm = sim.getBoundaryModel(k)
        kinds.append(type(bm).__name__)
        count = getattr(bm, "numberOfParticles", None)
        if count is not None:
            n += int(count())
    return n, kinds


def _child(scene_path: str, out_path: str, budget_s: float = float("inf"),
           stop_at: float | None = None, times=()) -> None:
    """Child-process entry: run the scene, write stats as JSON (see :func:`run_scene`)."""
    import pysplishsplash as sph

    base = sph.Exec.SimulatorBase()
    # no cache: SPlisHSPlasH would write its volume maps into a Cache folder beside the scene
    base.init(useGui=False, useCache=False, sceneFile=scene_path,
              outputDir=str(Path(out_path).parent / "out"),
              **({"stopAt": float(stop_at)} if stop_at is not None else {}))
    base.initSimulation()
    sim = sph.Simulation.getCurrent()
    dts, max_speed, exploded_at, budget_stop = [], [0.0], [None], [False]
    pending, at = sorted(float(t) for t in times), []

    def speeds():
        for k in range(sim.numberOfFluidModels()):
            fm = sim.getFluidModel(k)
            n = fm.numActiveParticles()
            v = np.asarray(fm.getFieldBuffer("velocity"))[:n]
            yield np.linalg.norm(v, axis=1).max() if n else 0.0

    def on_step():
        tm = sph.TimeManager.getCurrent()
        dts.append(tm.getTimeStepSize())
        while pending and tm.getTime() >= pending[0] - 1e-9:
            at.append({"t": pending.pop(0), "time": tm.getTime(), "fluids": _fluids(sim),
                       "floor_row_y": _floor_row(sim)})
        if len(dts) % 10 == 0:
            max_speed[0] = max(max_speed[0], *speeds())
            if exploded_at[0] is None and not max_speed[0] <= EXPLODED_SPEED:
                # a blown-up run crawls at tiny steps for hours: stop it here
                exploded_at[0] = tm.getTime()
                base.setValueFloat(base.STOP_AT, tm.getTime())
            elif not budget_stop[0] and time.perf_counter() - t0 > budget_s:
                budget_stop[0] = True
                base.setValueFloat(base.STOP_AT, tm.getTime())

    base.setTimeStepCB(on_step)
    t0 = time.perf_counter()  # read by on_step
    base.runSimulation()
    wall = time.perf_counter() - t0
    max_speed[0] = max(max_speed[0], *speeds())
    phases = _fluids(sim)
    sim_time = sph.TimeManager.getCurrent().getTime()
    n_boundary, kinds = _boundary(sim)
    result = {"fluid_particles": sum(p["particles"] for p in phases.values()),
              "boundary_particles": n_boundary, "boundary_models": kinds,
              "steps": len(dts), "mean_dt": float(np.mean(dts)) if dts else None,
              "simulated_s": sim_time, "wall_s": wall,
              "wall_s_per_simulated_s": wall / sim_time if sim_time > 0 else None,
              "ms_per_step": 1e3 * wall / max(len(dts), 1),
              "max_speed": float(max_speed[0]), "exploded_at_s": exploded_at[0],
              "budget_stop": budget_stop[0], "phases": phases, "at": at}
    with open(out_path, "w") as f:
        json.dump(result, f)
    base.cleanup()


def _times(text: str) -> list[float]:
    try:
        return [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a comma-separated list of times: {text!r}") from None


def main(argv=None) -> int:
    """``python -m dcdc.sph.splishsplash SCENE.json [RESULT.json]``: run a SPlisHSPlasH scene
    file and write (or print) its stats as JSON; failures are one ``error:`` line."""
    ap = argparse.ArgumentParser(prog="python -m dcdc.sph.splishsplash",
                                 description="Run a SPlisHSPlasH scene file; stats as JSON.")
    ap.add_argument("scene", help="SPlisHSPlasH scene JSON (any working directory)")
    ap.add_argument("result", nargs="?", help="where to write the stats (default: print them)")
    ap.add_argument("--stop-at", type=float, help="simulated seconds (default: the scene's stopAt)")
    ap.add_argument("--times", type=_times, default=[],
                    help="comma-separated times at which to record each fluid's centroid")
    ap.add_argument("--budget", type=float, default=1800.0, help="wall seconds before stopping")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if not available():
        print(f"error: {MISSING}", file=sys.stderr)
        return 2
    if a.child:
        _child(a.scene, a.result, a.budget, a.stop_at, a.times)
        return 0
    try:
        result = run_scene(a.scene, a.stop_at, a.times, a.budget)
    except DcdcError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = json.dumps(result, indent=1)
    if a.result:
        from ..outputs import write_text
        write_text(a.result, text + "\n")
    else:
        print(text)
    if result["status"] != "ok":
        print(f"error: SPlisHSPlasH {result['status']}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
