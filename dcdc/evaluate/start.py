"""Where a neural rollout starts: a scene's lattice (built-in, .toml, or a
DeepLagrangianFluids .json), that scene settled by its own SPH solver first, or a frame of a
ground-truth trajectory. Shared by ``dcdc simulate``, ``dcdc demo`` and the benchmarks."""
from __future__ import annotations

from pathlib import Path

from ..errors import DcdcError


def start_from_scene(scene: str, dim, resolution: float, model, steps, max_particles):
    """(system, n_steps, attrs) of a dcdc scene (built-in, .toml) or a DeepLagrangianFluids
    scene (.json). Without ``--dim`` a 3-D scene is run in the model's dimension."""
    from ..model.checkpoint import check_compatible

    if scene.endswith(".json"):
        from ..scene.importers.dlf import scene_system
        if dim is not None and int(dim) != 3:
            raise DcdcError("a DeepLagrangianFluids scene (.json) is 3-D; drop --dim")
        n = steps or 250  # run_network.py's default
        system = scene_system(scene, radius=model.cfg.particle_radius, frames=n,
                              dt=model.cfg.frame_dt)
        return system, n, {"scene": Path(scene).stem, "source": str(scene)}
    from ..scene import get_scene
    sc = get_scene(scene)
    if dim is None:
        dim = model.dim if sc.dim == 3 else sc.dim
    check_compatible(model, dim=int(dim), frame_dt=sc.frame_dt, what=f"scene {sc.name}")
    n = steps if steps is not None else max(1, int(round(sc.duration / model.cfg.frame_dt)))
    system = sc.realize(dim=int(dim), resolution=resolution, frames=n + 1,
                        max_particles=max_particles)
    return system, n, {"scene": sc.name, "scene_toml": sc.text, "source": scene,
                       "scene_dim": sc.dim, "resolution": resolution}


def settle_frames(seconds: float, frame_dt: float) -> int:
    """Frames of ``frame_dt`` in ``seconds``; one-line error unless a positive whole number."""
    frames = int(round(seconds / frame_dt))
    if frames < 1 or abs(frames * frame_dt - seconds) > 1e-6 * frame_dt:
        raise DcdcError(f"--settle must be a positive multiple of the model's frame Δt "
                        f"{frame_dt:g} s (got {seconds:g})")
    return frames


def settle_with_sph(system, scene: str, frames: int, frame_dt: float, progress=None) -> float:
    """Advance ``system`` in place by the scene's own SPH solver (its ``[solver]`` table) for
    ``frames`` frames of ``frame_dt`` (:func:`settle_frames`) and return the time reached.

    A scene starts from a lattice one particle radius off its walls; the SPH solver settles
    it onto the walls and compresses deep columns within the first ≈ 0.15 s, a transient the
    3-D networks turn into a burst in deep containers (docs/models.md, "The cocktail's
    start-up burst"). ``dcdc simulate --settle`` hands the network the settled state."""
    from ..scene import get_scene
    from ..sph import Simulator

    sph = Simulator(system, get_scene(scene).check_solver())
    for _ in range(frames):
        sph.advance(frame_dt)
        if progress:
            progress(1)
    return frames * frame_dt


def check_start_frame(name: str, n_frames: int, frame: int, *, need_next: bool = True,
                      flag: str = "--start-frame", hint: str = "") -> None:
    """One-line error unless a rollout can start at ``frame`` of trajectory ``name`` with
    ``n_frames`` frames. With ``need_next`` (no --steps: the rollout runs to the last frame;
    an evaluation compares with the frames after the start) a frame after the start must
    exist, so a one-frame trajectory is refused as such, whatever ``frame`` is; ``hint`` ends
    that message (e.g. how to roll out anyway)."""
    if n_frames < 1:
        raise DcdcError(f"trajectory {name} holds no frames; a rollout needs a frame to start from")
    if need_next and n_frames < 2:
        raise DcdcError(f"trajectory {name} has one frame; a rollout needs at least two (a "
                        f"start and a frame after it){hint}")
    last = n_frames - 2 if need_next else n_frames - 1
    if not 0 <= frame <= last:
        where = ("the last frame of", "which no frame follows") if frame == n_frames - 1 else \
            ("outside", f"which has {n_frames} frames")
        raise DcdcError(f"{flag} {frame} is {where[0]} {name}, {where[1]} (a rollout can start "
                        f"at frames 0..{last}){hint if frame == n_frames - 1 else ''}")


def start_from_dataset(dataset: str, name: str, frame: int, steps):
    """(system, start time, n_steps, attrs) of a ground-truth trajectory's frame."""
    from ..data.dataset import Dataset
    traj = Dataset(dataset)[name]
    check_start_frame(name, traj.n_frames, frame, need_next=steps is None,
                      hint="; or give --steps N to roll out past the trajectory's end")
    n = steps if steps is not None else traj.n_frames - 1 - frame
    attrs = {"scene": str(traj.attrs.get("scene", name)), "source": f"{dataset}:{name}",
             "ground_truth": str(Path(dataset)), "ground_truth_trajectory": name,
             "start_frame": frame, "scene_toml": str(traj.attrs.get("scene_toml", ""))}
    return traj.system(frame), float(traj.time[frame]), n, attrs, traj.frame_dt
