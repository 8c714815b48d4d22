"""``dcdc suite``: the generalisation suite (docs/evaluation.md, "Generalisation suite").

``dcdc suite build --dim D -o DIR`` draws N scenes of the scene families
(:mod:`dcdc.scene.families`, the families in turn) with the suite's seeds (from
:data:`~dcdc.scene.families.SUITE_SEED0` = 900 000 on, which no training set uses),
simulates them with the SPH solver (``DIR/truth``, the machinery and resumability of
``dcdc generate``) and builds the **SPH ensemble floor**: for each scene K - 1 more SPH runs
from starts displaced by 1 µm rms (:func:`dcdc.evaluate.scores.displace`, member k: seed k),
each scored at its last frame against the stored run with the functions the models are
scored with (:func:`dcdc.evaluate.scores.compare_states`): ``DIR/floor/NAME_mK.json``.
``DIR/suite.json`` indexes the scenes (family, seed, density ratio, particles) and the floor.

``dcdc suite score --model M --suite DIR`` rolls every model out on every scene
(:func:`dcdc.evaluate.scores.score_trajectory`) and prints per family, per density-ratio
bin and overall, for each model and the SPH floor: runs to the end, final order right, COM
heights within 5 % of SPH, layers like SPH, the median of the smallest per-phase purity
ratio.
"""
from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import click
import numpy as np

from ..errors import DcdcError, SimulationDiverged
from . import CONTACT_DEFAULT

DEFAULT_SCENES = {2: 40, 3: 12}
PERTURB = 1e-6  # m rms: the floor's starts
COM_TOL = 0.05  # "COM heights within 5 % of SPH": com_height_error <= COM_TOL
RATIO_BINS = ((1.1, 1.5), (1.5, 3.0), (3.0, 20.0))
FLOOR = "SPH floor"


# ------------------------------------------------------------------ build
def suite_jobs(dim: int, n: int, duration: float | None = None):
    """The suite's ``dcdc generate`` jobs: scene i of family FAMILIES[i mod 8], seed
    SUITE_SEED0 + i, split "test"."""
    from ..data.jobs import family_jobs
    from ..scene.families import SUITE_SEED0
    return family_jobs("all", n, SUITE_SEED0, dim, duration, split="test")


def _set_threads(threads: int) -> None:
    os.environ["NUMBA_NUM_THREADS"] = os.environ["OMP_NUM_THREADS"] = str(threads)
    try:
        import numba
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    except Exception:  # pragma: no cover
        pass


def floor_member(truth_dir, name: str, k: int, perturb: float = PERTURB) -> dict:
    """One member of the SPH ensemble floor: the stored scene of trajectory ``name``
    realised again, its fluid displaced by ``perturb`` m rms (seed ``k``), run by the SPH
    solver with the stored run's settings to the stored run's last frame, and scored there
    against the stored run (:func:`dcdc.evaluate.scores.compare_states`)."""
    from ..data import interrupt
    from ..data.dataset import Dataset
    from ..scene import parse
    from ..sph import Simulator, SPHConfig
    from .scores import _finite, _nanmax, _nanmin, compare_states, displace

    traj = Dataset(truth_dir)[name]
    scene = parse(traj.attrs["scene_toml"], name)
    system = scene.realize(traj.dim, float(traj.attrs.get("resolution", 1.0)))
    if system.n_fluid != traj.n_particles:
        raise DcdcError(f"{name}: the scene realises {system.n_fluid} particles, the stored run "
                        f"has {traj.n_particles}")
    displace(system, perturb, k)
    try:
        settings = json.loads(traj.attrs["solver_settings"])
    except (KeyError, ValueError):
        settings = scene.solver
    sim = Simulator(system, SPHConfig.from_dict(settings))
    T = traj.n_frames
    t0 = time.time()
    rec = {"trajectory": name, "member": k, "perturb_m": perturb, "frames": T - 1}
    try:
        for _ in range(1, T):
            sim.advance(traj.frame_dt)
            interrupt.check()
    except SimulationDiverged as e:
        rec.update(stable=False, stopped=str(e), wall_s=round(time.time() - t0, 1))
        return rec
    act = traj.active(T - 1)
    pred, true, com = compare_states(sim.system.x, traj.position[T - 1], traj, act)
    rec.update({
        "stable": True, "wall_s": round(time.time() - t0, 1),
        "com_height_error": _finite(np.nanmax(com)) if np.isfinite(com).any() else None,
        "order_ok": bool(pred["order_ok"]), "order_ok_true": bool(true["order_ok"]),
        "layers_ok": bool(pred["layers_ok"]),
        "purity_ratio_min": _nanmin(pred["purity_ratio"]),
        "height_w1_rel_max": _nanmax(pred["height_w1_rel"]),
        "purity": _finite(pred["purity"]), "purity_true": _finite(true["purity"]),
    })
    return rec


def _member_task(args):
    truth, name, k, perturb, path, threads = args
    _set_threads(threads)
    rec = floor_member(truth, name, k, perturb)
    from ..outputs import write_text
    write_text(path, json.dumps(rec, indent=1, sort_keys=True))
    return rec


def _scene_info(traj) -> dict:
    from ..scene.families import density_ratio
    fam, seed, _ = traj.name.rsplit("_", 2)
    return {"family": fam, "seed": int(seed), "density_ratio": round(density_ratio(traj.attrs["scene_toml"]), 4),
            "particles": traj.n_particles, "phases": len(traj.phases), "frames": traj.n_frames,
            "sph_wall_s": _num(traj.attrs.get("wall_time_s"))}


def _num(v):
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def build(dim: int, out, scenes: int | None = None, members: int = 3, workers: int = 1,
          duration: float | None = None, perturb: float = PERTURB, progress: bool = True,
          echo=click.echo, retry_failed: bool = False) -> dict:
    """Build (or resume) the suite in ``out``; returns the index written to suite.json."""
    from ..data import interrupt
    from ..data.dataset import Dataset, is_complete
    from ..data.generate import generate
    from ..outputs import check_dir, write_text

    if dim not in (2, 3):
        raise DcdcError(f"--dim must be 2 or 3 (got {dim})")
    n = DEFAULT_SCENES[dim] if scenes is None else int(scenes)
    if n < 1:
        raise DcdcError(f"--scenes must be >= 1 (got {n})")
    if members < 1:
        raise DcdcError(f"--members must be >= 1 (got {members})")
    if workers < 1:
        raise DcdcError(f"--workers must be >= 1 (got {workers})")
    out = check_dir(out)
    truth, floor = out / "truth", out / "floor"
    t0 = time.time()
    jobs = suite_jobs(dim, n, duration)
    echo(f"suite: {n} {dim}-D scenes, SPH ground truth in {truth}")
    summary = generate(jobs, truth, workers, progress=progress, retry_failed=retry_failed,
                       command=f"dcdc suite build --dim {dim} -o {out}")
    ok = [j.name for j in jobs if is_complete(truth / f"{j.name}.h5")]
    failed = [j.name for j in jobs if j.name not in ok]
    floor.mkdir(parents=True, exist_ok=True)
    todo = [(str(truth), name, k, perturb, str(floor / f"{name}_m{k}.json"))
            for name in ok for k in range(1, members) if not (floor / f"{name}_m{k}.json").exists()]
    echo(f"SPH ensemble floor: {len(todo)} run(s) to do ({members - 1} per scene, starts "
         f"displaced by {perturb:g} m rms)")
    with interrupt.handling():
        if workers == 1 or len(todo) <= 1:
            for i, t in enumerate(todo):
                rec = _member_task(t + (int(os.environ.get("NUMBA_NUM_THREADS", "1") or 1),))
                echo(f"  [{i + 1}/{len(todo)}] {t[1]} member {t[2]}: " + _floor_line(rec))
        else:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor
            threads = max(1, (os.cpu_count() or 1) // workers)
            with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
                for i, rec in enumerate(pool.map(_member_task, [t + (threads,) for t in todo])):
                    echo(f"  [{i + 1}/{len(todo)}] {rec['trajectory']} member {rec['member']}: "
                         + _floor_line(rec))
    ds = Dataset(truth)
    index = {"format": "dcdc-suite", "dim": dim, "scenes_requested": n, "members": members,
             "perturb_m": perturb, "duration": duration, "truth": "truth", "failed": failed,
             "scenes": {}}
    for name in ok:
        info = _scene_info(ds[name])
        info["floor"] = [json.loads((floor / f"{name}_m{k}.json").read_text())
                         for k in range(1, members) if (floor / f"{name}_m{k}.json").exists()]
        index["scenes"][name] = info
    prev = out / "suite.json"
    spent = round(time.time() - t0, 1)
    try:
        before = json.loads(prev.read_text()).get("build_wall_s", 0.0) if prev.exists() else 0.0
    except (OSError, ValueError):
        before = 0.0
    index["build_wall_s"] = round(float(before or 0.0) + spent, 1)
    index["generate"] = {k: summary[k] for k in ("done", "skipped", "wall_time_s")}
    write_text(prev, json.dumps(index, indent=1, sort_keys=True))
    echo(f"suite: {len(ok)} scenes, {sum(len(s['floor']) for s in index['scenes'].values())} floor "
         f"runs, {len(failed)} diverged, in {spent:.0f} s -> {prev}")
    return index


def _floor_line(rec: dict) -> str:
    if not rec.get("stable"):
        return f"diverged ({rec.get('stopped', '')})"
    c = rec.get("com_height_error")
    return (f"COM err {c:.3f}, order {'ok' if rec['order_ok'] else 'WRONG'}, layers "
            f"{'like SPH' if rec['layers_ok'] else 'unlike'}, {rec['wall_s']:.0f} s"
            if c is not None else f"{rec['wall_s']:.0f} s")


# ------------------------------------------------------------------ score
def ratio_bin(r: float) -> str:
    for a, b in RATIO_BINS:
        if r <= b * (1 + 1e-9):
            return f"ratio {a:g}-{b:g}"
    return f"ratio {RATIO_BINS[-1][0]:g}-{RATIO_BINS[-1][1]:g}"


def summarise(rows: list[dict]) -> dict:
    """One table row from per-run records (model rollouts or floor members): runs, runs to
    the end, and over the runs: final order right, COM within 5 %, layers like SPH
    (fractions; a run that stopped early counts as a miss), and the median smallest purity
    ratio over the runs to the end (None if none got there: a rollout stopped after a few
    steps is still as unmixed as its start)."""
    n = len(rows)
    if not n:
        return {"runs": 0}

    def frac(f):
        return round(float(np.mean([bool(r.get("stable")) and f(r) for r in rows])), 4)
    pr = [r["purity_ratio_min"] for r in rows
          if r.get("stable") and r.get("purity_ratio_min") is not None]
    return {"runs": n, "stable": int(sum(bool(r.get("stable")) for r in rows)),
            "order_ok": frac(lambda r: bool(r.get("order_ok"))),
            "com_within_5pct": frac(lambda r: r.get("com_height_error") is not None
                                    and r["com_height_error"] <= COM_TOL),
            "layers_ok": frac(lambda r: bool(r.get("layers_ok"))),
            "order_ok_sph": round(float(np.mean([bool(r.get("order_ok_true")) for r in rows])), 4),
            "purity_ratio_median": round(float(np.median(pr)), 4) if pr else None}


def table_rows(index: dict, per_model: dict) -> list[dict]:
    """Rows per group (each family, each density-ratio bin, all) and per model plus the
    SPH floor. ``per_model``: label -> {scene name: score row}."""
    from ..scene.families import FAMILIES
    scenes = index["scenes"]
    fams = [f for f in FAMILIES if any(s["family"] == f for s in scenes.values())]
    groups = [("all", lambda s: True)]
    groups += [(f, (lambda f: lambda s: s["family"] == f)(f)) for f in fams]
    groups += [(b, (lambda b: lambda s: ratio_bin(s["density_ratio"]) == b)(b))
               for b in dict.fromkeys(ratio_bin(a * 1.01) for a, _ in RATIO_BINS)]
    out = []
    for g, keep in groups:
        names = [n for n, s in scenes.items() if keep(s)]
        if not names:
            continue
        # the stored SPH run's order at its last frame (a stopped rollout's rows see an
        # earlier frame), from the floor's records where the suite has them
        truth = [next((m["order_ok_true"] for m in scenes[n]["floor"] if "order_ok_true" in m), None)
                 for n in names]
        sph = round(float(np.mean(truth)), 4) if None not in truth else None
        grp = []
        for label, rows in per_model.items():
            grp.append({"group": g, "model": label, "scenes": len(names),
                        **summarise([rows[n] for n in names if n in rows])})
        grp.append({"group": g, "model": FLOOR, "scenes": len(names),
                    **summarise([m for n in names for m in scenes[n]["floor"]])})
        for r in grp:
            if sph is not None and r.get("runs"):
                r["order_ok_sph"] = sph
        out += grp
    return out


def format_table(rows: list[dict]) -> str:
    head = (f"{'group':<16} {'model':<14} {'scenes':>6} {'to end':>9} {'order':>6} "
            f"{'COM<=5%':>8} {'layers':>7} {'purity/SPH':>10} {'SPH order':>9}")
    lines = [head, "-" * len(head)]
    last = None
    for r in rows:
        if last is not None and r["group"] != last:
            lines.append("")
        last = r["group"]
        if not r.get("runs"):
            lines.append(f"{r['group']:<16} {r['model']:<14} {r['scenes']:>6} {'-':>9}")
            continue
        pr = "-" if r["purity_ratio_median"] is None else f"{r['purity_ratio_median']:.3f}"
        lines.append(f"{r['group']:<16} {r['model']:<14} {r['scenes']:>6} "
                     f"{str(r['stable']) + '/' + str(r['runs']):>9} {r['order_ok']:>6.2f} "
                     f"{r['com_within_5pct']:>8.2f} {r['layers_ok']:>7.2f} {pr:>10} "
                     f"{r['order_ok_sph']:>9.2f}")
    return "\n".join(lines)


def load_index(suite) -> dict:
    p = Path(suite) / "suite.json"
    if not p.is_file():
        raise DcdcError(f"{suite}: no suite.json (build it with dcdc suite build)")
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError) as e:
        raise DcdcError(f"{p}: unreadable ({e})") from None


def score(models, suite, contact: bool | None = CONTACT_DEFAULT, max_speed: float = 50.0,
          max_in_walls: float = 0.01, progress: bool = True, bf16: bool = False,
          perturb: float = 0.0) -> dict:
    """Every model on every suite scene (a rollout over the whole trajectory from its
    stored start; ``contact`` None: each model's own default); returns {"rows": table rows,
    "scenes": per-scene rows, "contact": {label: used}, ...}.

    ``bf16``: the convolutions' GEMMs in bf16 (:func:`dcdc.model.cconv.bf16_mm`);
    ``perturb`` > 0: every start displaced by up to that many metres
    (:func:`~dcdc.evaluate.scores.perturbed_start`, seed 1), a member of the network's own
    ensemble — how far the measures move for a change far below the network's own error."""
    from ..data import interrupt
    from ..data.dataset import Dataset
    from ..model.checkpoint import check_compatible, load_checkpoint
    from .cli import _labels
    from .rollout import Guard, uses_contact
    from .scores import score_trajectory

    index = load_index(suite)
    ds = Dataset(Path(suite) / index.get("truth", "truth"))
    names = list(index["scenes"])
    if not names:
        raise DcdcError(f"{suite}: the suite holds no finished scenes")
    trajs = {n: ds[n] for n in names}
    nets = [load_checkpoint(m)[0] for m in models]
    if bf16:
        import torch
        for net in nets:
            net.set_backend("auto", torch.bfloat16)
    labels = _labels(models)
    for net, m in zip(nets, models):
        for t in trajs.values():
            check_compatible(net, dim=t.dim, radius=t.radius, frame_dt=t.frame_dt,
                             what=f"suite scene {t.name}")
    guard = Guard(max_speed=max_speed, max_in_walls=max_in_walls)
    per_model = {label: {} for label in labels}
    from tqdm import tqdm
    with interrupt.handling(), tqdm(total=len(names) * len(nets), unit="rollout",
                                    disable=not progress) as bar:
        for n, t in trajs.items():
            for label, net in zip(labels, nets):
                bar.set_postfix_str(f"{n} / {label}")
                row = score_trajectory(net, t, guard=guard, contact=contact, one_two_step=False,
                                       perturb=perturb, seed=1)
                row.pop("curves", None)
                per_model[label][n] = row
                interrupt.check()
                bar.update(1)
    rows = table_rows(index, per_model)
    return {"suite": str(suite), "dim": index["dim"], "models": dict(zip(labels, map(str, models))),
            "contact": {lab: uses_contact(net, contact) for lab, net in zip(labels, nets)},
            "com_tolerance": COM_TOL, "rows": rows, "bf16": bool(bf16), "perturb_m": float(perturb),
            "scenes": {n: {**index["scenes"][n], "models": {lab: per_model[lab][n] for lab in labels}}
                       for n in names}}


# ------------------------------------------------------------------ CLI
@click.group("suite")
def suite_group():
    """The generalisation suite: scene families with seeds no training set uses."""


@suite_group.command("build")
@click.option("--dim", type=click.IntRange(2, 3), required=True)
@click.option("-o", "--out", required=True, type=click.Path(file_okay=False),
              help="suite directory (truth/, floor/, suite.json); re-running resumes")
@click.option("--scenes", type=int, default=None, help="number of scenes (default 40 in 2-D, 12 in 3-D)")
@click.option("--members", type=int, default=3, show_default=True,
              help="SPH runs per scene: the stored one and K-1 from displaced starts (the floor)")
@click.option("--workers", type=int, default=1, show_default=True, help="SPH runs in parallel")
@click.option("--duration", type=float, default=None,
              help="override the scenes' 4 s (a shorter suite, for tests)")
@click.option("--retry-failed", is_flag=True, help="re-run scenes whose SPH run diverged before")
@click.option("--no-progress", is_flag=True)
def build_command(dim, out, scenes, members, workers, duration, retry_failed, no_progress):
    """Simulate the suite's scenes with SPH and their ensemble floor (resumable)."""
    from ..data.generate import check_duration
    check_duration(duration)
    build(dim, out, scenes, members, workers, duration, progress=not no_progress,
          retry_failed=retry_failed)


@suite_group.command("score")
@click.option("--model", "models", multiple=True, required=True, type=click.Path(dir_okay=False),
              help="a checkpoint or shipped model name; repeat for several")
@click.option("--suite", required=True, type=click.Path(file_okay=False), help="a built suite")
@click.option("--contact/--no-contact", default=CONTACT_DEFAULT,
              help="the walls' contact in the rollouts [default: each model's own; dcdc "
                   "simulate --help]")
@click.option("--bf16", is_flag=True,
              help="the convolutions' GEMMs in bf16 (emulated in float32 where the CPU has "
                   "no bf16 instructions: same numbers, not faster)")
@click.option("--perturb", type=click.FloatRange(min=0.0), default=0.0, show_default=True,
              help="displace every start by up to this many metres (a member of the "
                   "network's ensemble)")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None,
              help="write every row (and every scene's scores) here")
@click.option("--no-progress", is_flag=True)
def score_command(models, suite, contact, bf16, perturb, json_path, no_progress):
    """Score models on the suite against SPH and the SPH ensemble floor."""
    from ..outputs import write_text
    res = score(models, suite, contact, progress=not no_progress, bf16=bf16, perturb=perturb)
    used = ", ".join(f"{lab} {'on' if on else 'off'}" for lab, on in res["contact"].items())
    click.echo(f"suite {suite}: {len(res['scenes'])} {res['dim']}-D scenes; wall contact: "
               f"{used}; fractions of runs; 'to end' = runs that reach "
               f"the last frame; COM<=5% = COM height error <= {COM_TOL:g}; purity/SPH = "
               "median of the smallest per-phase purity ratio; SPH order = the stored SPH "
               "run's final order right")
    click.echo(format_table(res["rows"]))
    if json_path:
        write_text(json_path, json.dumps(res, indent=1, sort_keys=True))
        click.echo(f"wrote {json_path}")
