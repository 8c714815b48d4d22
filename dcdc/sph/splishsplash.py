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
summary), wall time, the largest particle speed seen and the final phase centroids.
"""
from __future__ import annotations

import json
import os
import re
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


def available() -> bool:
    """Whether ``pysplishsplash`` is installed (checked without importing it here)."""
    import importlib.util
    return importlib.util.find_spec("pysplishsplash") is not None


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
        raise DcdcError("SPlisHSPlasH is not installed (pip install 'dcdc[splash]')")
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
        env = dict(os.environ)
        if os.path.exists(GL_DISPATCH):
            env["LD_PRELOAD"] = (GL_DISPATCH + " " + env.get("LD_PRELOAD", "")).strip()
        out = os.path.join(tmp, "result.json")
        # the child stops itself after ``timeout`` wall seconds and reports how far it got
        cmd = [sys.executable, "-m", "dcdc.sph.splishsplash", scene, out, str(timeout)]
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True,
                                  timeout=timeout + 120)
        except subprocess.TimeoutExpired:
            return {"solver": solver, "status": f"timed out after {timeout:.0f} s"}
        wall = time.perf_counter() - t0
        if proc.returncode != 0 or not os.path.exists(out):
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or [""]
            return {"solver": solver, "status": f"crashed (exit {proc.returncode}) {tail[0][:120]}",
                    "process_wall_s": wall}
        with open(out) as f:
            result = json.load(f)
    its = re.findall(r"Average number: \w+ - iterations: ([0-9.eE+-]+)", proc.stdout)
    result["mean_iterations"] = float(its[0]) if its else None
    result["solver"] = solver
    exploded = not np.isfinite(result["max_speed"]) or result["max_speed"] > EXPLODED_SPEED
    when = result.get("exploded_at_s")
    result["status"] = ("ok" if not exploded else
                        f"exploded at t = {when:.3f} s" if when is not None else "exploded")
    if result.get("budget_stop") and not exploded:
        result["status"] = (f"stopped by the {timeout:g} s wall budget at t = "
                            f"{result['simulated_s']:.3f} s (mean step {1e3 * result['mean_dt']:.3f} ms)")
    return result


def _child(scene_path: str, out_path: str, budget_s: float = float("inf")) -> None:
    """Child-process entry: run the scene, write stats as JSON (see :func:`run_splishsplash`)."""
    import pysplishsplash as sph

    base = sph.Exec.SimulatorBase()
    base.init(useGui=False, sceneFile=scene_path, outputDir=str(Path(out_path).parent / "out"))
    base.initSimulation()
    sim = sph.Simulation.getCurrent()
    dts, max_speed, exploded_at, budget_stop = [], [0.0], [None], [False]

    def speeds():
        for k in range(sim.numberOfFluidModels()):
            fm = sim.getFluidModel(k)
            n = fm.numActiveParticles()
            v = np.asarray(fm.getFieldBuffer("velocity"))[:n]
            yield np.linalg.norm(v, axis=1).max() if n else 0.0

    def on_step():
        tm = sph.TimeManager.getCurrent()
        dts.append(tm.getTimeStepSize())
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
    phases = {}
    n_fluid = 0
    for k in range(sim.numberOfFluidModels()):
        fm = sim.getFluidModel(k)
        n = fm.numActiveParticles()
        n_fluid += n
        x = np.asarray(fm.getFieldBuffer("position"))[:n]
        phases[fm.getId()] = {"particles": int(n), "centroid": x.mean(0).tolist() if n else None,
                              "density0": fm.getDensity0()}
    sim_time = sph.TimeManager.getCurrent().getTime()
    n_boundary = sum(sim.getBoundaryModel(k).numberOfParticles()
                     for k in range(sim.numberOfBoundaryModels()))
    result = {"fluid_particles": n_fluid, "boundary_particles": int(n_boundary),
              "steps": len(dts), "mean_dt": float(np.mean(dts)) if dts else None,
              "simulated_s": sim_time, "wall_s": wall,
              "wall_s_per_simulated_s": wall / sim_time if sim_time > 0 else None,
              "ms_per_step": 1e3 * wall / max(len(dts), 1),
              "max_speed": float(max_speed[0]), "exploded_at_s": exploded_at[0],
              "budget_stop": budget_stop[0], "phases": phases}
    with open(out_path, "w") as f:
        json.dump(result, f)
    base.cleanup()


if __name__ == "__main__":
    _child(sys.argv[1], sys.argv[2], float(sys.argv[3]) if len(sys.argv) > 3 else float("inf"))
