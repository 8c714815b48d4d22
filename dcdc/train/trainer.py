"""The training loop: batches → unrolled loss → Adam, with validation, logs, checkpoints,
resume and DistributedDataParallel.

Run directory (``--out RUN``)::

    RUN/config.toml          the full TrainConfig of the run (defaults filled in)
    RUN/metrics.csv          one row per step (loss, per-step losses, lr, stage, val_loss)
    RUN/tensorboard/         the same scalars as TensorBoard events (log.tensorboard)
    RUN/checkpoints/step_XXXXXXXX.pt   every log.checkpoint_every steps (newest log.keep)
    RUN/best.pt              lowest validation loss so far (with data.val)
    RUN/model.pt             the last checkpoint of a finished run

Every checkpoint is a regular dcdc checkpoint (:mod:`dcdc.model.checkpoint`, loadable by
``simulate``/``evaluate``) whose ``extra`` holds the training state: ``step`` (steps
done), ``train_config``, ``optimizer``, ``best_val``, ``wall_time_s``. ``--resume`` loads
the newest readable one, truncates metrics.csv after its step and continues; batches are
a pure function of (seed, step) (:mod:`.sampler`), so the continued run draws the same
windows the interrupted one would have.

Distributed: under ``torchrun --nproc-per-node P`` each rank builds the same batch of
``data.batch_scenes`` windows and trains on its shard ``windows[rank::P]``; the network is
wrapped in :class:`torch.nn.parallel.DistributedDataParallel` (gloo on CPU, nccl on CUDA),
which averages the gradients. Rank 0 alone validates, logs and writes checkpoints.
"""
from __future__ import annotations

import csv
import io
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..configs import save_toml
from ..outputs import write_text
from ..data.dataset import Dataset
from ..errors import DcdcError
from ..model.checkpoint import check_compatible, read_checkpoint, save_checkpoint
from ..model.networks import build_network
from .config import WALL_VIEW, TrainConfig
from .loss import unrolled_loss
from .sampler import (WALL_NOISE_REACH, WindowSampler, augment, collate, dataset_info,
                      load_window)

CKPT_DIR = "checkpoints"
# keys whose change does not stop a --resume (longer runs, other logging; model.init only
# sets the weights of step 0, which a resumed run takes from its own checkpoint)
RESUMABLE_CHANGES = ("optim.steps", "log.", "eval.every", "model.init")


# ------------------------------------------------------------------ distributed setup
@dataclass
class Dist:
    rank: int = 0
    world: int = 1
    local_rank: int = 0

    @property
    def main(self) -> bool:
        return self.rank == 0


def init_distributed(device: str) -> Dist:
    """Join the torchrun process group when launched by torchrun (``WORLD_SIZE`` > 1)."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return Dist()
    import torch.distributed as dist
    if not dist.is_initialized():
        dist.init_process_group("nccl" if device == "cuda" else "gloo")
    return Dist(dist.get_rank(), dist.get_world_size(), int(os.environ.get("LOCAL_RANK", "0")))


def resolve_device(device: str, d: Dist) -> torch.device:
    if device == "cpu":
        return torch.device("cpu")
    if device == "cuda":
        if not torch.cuda.is_available():
            raise DcdcError("--device cuda: no CUDA device is available to torch "
                            "(torch.cuda.is_available() is false); use --device cpu")
        return torch.device("cuda", d.local_rank % torch.cuda.device_count())
    raise DcdcError(f"--device must be cpu or cuda (got {device!r})")


def _share_threads(d: Dist) -> None:
    """Split the cores between the ranks on this machine (2 ranks on 2 cores: 1 each)."""
    local = int(os.environ.get("LOCAL_WORLD_SIZE", str(d.world)))
    if local > 1:
        n = max(1, (os.cpu_count() or 1) // local)
        torch.set_num_threads(n)
        import numba
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))


def _all_finite(loss: torch.Tensor, d: Dist) -> bool:
    ok = bool(torch.isfinite(loss.detach()))
    if d.world == 1:
        return ok
    import torch.distributed as dist
    t = torch.tensor([1.0 if ok else 0.0])
    dist.all_reduce(t, op=dist.ReduceOp.MIN)
    return bool(t.item() > 0)


def _all_mean(values: list[float], d: Dist) -> list[float]:
    if d.world == 1:
        return values
    import torch.distributed as dist
    t = torch.tensor(values, dtype=torch.float64)
    dist.all_reduce(t)
    return (t / d.world).tolist()


# ------------------------------------------------------------------ the run directory
def checkpoints(run: Path) -> list[Path]:
    """Step checkpoints of a run, newest first."""
    return sorted((run / CKPT_DIR).glob("step_*.pt"), reverse=True)


def _check_run(run: Path, resume: bool) -> None:
    """Refuse an unusable or already used run directory (before any work, no side effects)."""
    if run.exists() and not run.is_dir():
        raise DcdcError(f"--out {run} is a file, not a directory")
    if run.is_dir() and not resume and ((run / "config.toml").exists() or checkpoints(run)):
        raise DcdcError(f"{run} already holds a training run; pass --resume to continue it "
                        f"or choose another --out")
    parent = next((p for p in [run, *run.parents] if p.exists()), None)
    if parent is not None and (not parent.is_dir() or not os.access(parent, os.W_OK)):
        raise DcdcError(f"cannot create the run directory {run}: {parent} is not a "
                        f"writable directory")


def _make_run(run: Path) -> None:
    try:
        (run / CKPT_DIR).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise DcdcError(f"cannot create the run directory {run}: {e.strerror}") from None
    if not os.access(run, os.W_OK):
        raise DcdcError(f"cannot write into the run directory {run}")


def _config_differences(saved: dict, new: dict, prefix: str = "") -> list[str]:
    out = []
    for k in sorted(set(saved) | set(new)):
        a, b = saved.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            out += _config_differences(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}")
    return out


class MetricsLog:
    """metrics.csv (rewritten atomically on resume, appended and flushed every step) and
    TensorBoard events."""

    def __init__(self, run: Path, columns: list[str], start: int, tensorboard: bool):
        self.path = run / "metrics.csv"
        self.columns = columns
        rows = []
        if start > 0 and self.path.exists():
            with open(self.path, newline="") as f:
                rows = [r for r in csv.DictReader(f) if r.get("step", "").isdigit()
                        and int(r["step"]) <= start]
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
        write_text(self.path, buf.getvalue())
        self.file = open(self.path, "a", newline="")
        self.writer = csv.DictWriter(self.file, fieldnames=columns, extrasaction="ignore")
        self.tb = None
        if tensorboard:
            from torch.utils.tensorboard import SummaryWriter
            self.tb = SummaryWriter(str(run / "tensorboard"), purge_step=start + 1)

    def write(self, row: dict) -> None:
        self.writer.writerow({k: _fmt(v) for k, v in row.items()})
        self.file.flush()
        if self.tb is not None:
            for k, v in row.items():
                if k != "step" and isinstance(v, (int, float)) and v == v:
                    self.tb.add_scalar(f"train/{k}" if k != "val_loss" else "val/loss",
                                       v, row["step"])

    def close(self) -> None:
        self.file.close()
        if self.tb is not None:
            self.tb.close()


def _fmt(v):
    if isinstance(v, float):
        return "" if v != v else f"{v:.6g}"
    return v


# ------------------------------------------------------------------ the trainer
class Trainer:
    """One training run (``dcdc train``); :meth:`run` trains to ``optim.steps``."""

    def __init__(self, cfg: TrainConfig, run, resume: bool = False, device: str = "cpu",
                 progress: bool | None = None, echo=print):
        self.cfg, self.run_dir, self.echo = cfg, Path(run), echo
        self.dist = init_distributed(device)
        self.device = resolve_device(device, self.dist)
        _share_threads(self.dist)
        self.progress = cfg.log.progress if progress is None else progress
        if cfg.data.batch_scenes < self.dist.world:
            raise DcdcError(f"data.batch_scenes ({cfg.data.batch_scenes}) must be at least the "
                            f"number of ranks ({self.dist.world})")
        if self.dist.main:
            _check_run(self.run_dir, resume)

        self.train_ds = Dataset(cfg.data.train)
        self.info = dataset_info(self.train_ds, "training dataset")
        length = cfg.loss.unroll + 1
        self.sampler = WindowSampler(self.train_ds, length, cfg.data.stride, cfg.optim.seed,
                                     cfg.data.early_fraction, cfg.data.early_frames)
        self.sampler.check_stages([s.max_ratio for s in cfg.curriculum.stages])
        self.val = None
        if cfg.data.val:
            val_ds = Dataset(cfg.data.val)
            vinfo = dataset_info(val_ds, "validation dataset")
            if vinfo != self.info:
                raise DcdcError(f"validation dataset {cfg.data.val} has {vinfo}, the training "
                                f"dataset {self.info}")
            vs = WindowSampler(val_ds, length, 1, cfg.optim.seed)
            self.val = (val_ds, vs.fixed(cfg.eval.windows))

        torch.manual_seed(cfg.optim.seed)
        net = build_network(cfg.model.name, self.info["dim"],
                            **cfg.model.net_options(self.info["radius"], self.info["frame_dt"]))
        check_compatible(net, dim=self.info["dim"], radius=self.info["radius"],
                         frame_dt=self.info["frame_dt"], what=f"training dataset {cfg.data.train}")
        self.net = net.to(self.device)
        self.opt = torch.optim.Adam(self.net.parameters(), lr=cfg.optim.lr,
                                    eps=cfg.optim.adam_eps, weight_decay=cfg.optim.weight_decay)
        self.step = 0
        self.best_val = math.inf
        self.wall_time = 0.0
        if self.dist.main:  # the data and the network are fine: now the run directory
            _make_run(self.run_dir)
        self._barrier()
        if resume:
            self._resume()
        if self.step == 0 and cfg.model.init:
            self._initialise(cfg.model.init)
        self.model = self.net
        if self.dist.world > 1:
            from torch.nn.parallel import DistributedDataParallel as DDP
            ids = [self.device.index] if self.device.type == "cuda" else None
            self.model = DDP(self.net, device_ids=ids)

    # -------------------------------------------------------------- state
    def _barrier(self):
        if self.dist.world > 1:
            import torch.distributed as dist
            dist.barrier()

    def _resume(self) -> None:
        for path in checkpoints(self.run_dir):
            try:
                ck = read_checkpoint(path)
            except DcdcError as e:
                if self.dist.main:
                    self.echo(f"warning: skipping {path.name}: {e}")
                continue
            extra = ck.get("extra", {})
            diff = [k for k in _config_differences(extra.get("train_config", {}),
                                                    self.cfg.to_dict())
                    if not any(k.startswith(p) for p in RESUMABLE_CHANGES)]
            if diff:
                raise DcdcError(f"--resume: {self.run_dir} was trained with another "
                                f"{diff[0]} (and {len(diff) - 1} more setting(s)); "
                                f"continue with its config.toml or choose another --out")
            if not isinstance(extra.get("optimizer"), dict) or "step" not in extra:
                raise DcdcError(f"{path} is a model checkpoint without training state; "
                                f"--resume needs the step files dcdc train writes")
            self.net.load_state_dict(ck["state_dict"])
            self.opt.load_state_dict(extra["optimizer"])
            self.step = int(extra["step"])
            self.best_val = float(extra.get("best_val", math.inf))
            self.wall_time = float(extra.get("wall_time_s", 0.0))
            if self.dist.main:
                self.echo(f"resuming {self.run_dir} from {path.name} (step {self.step})")
            return
        if self.dist.main:
            self.echo(f"no checkpoint in {self.run_dir / CKPT_DIR}: starting at step 0")

    def _initialise(self, init: str) -> None:
        """Fine-tuning (``model.init``): the weights of a checkpoint of the same network,
        with a fresh optimizer and this run's schedule. Which wall particles the network sees
        (``wall_far_faces``, ``wall_fill_gaps``: :data:`WALL_VIEW`) is this run's choice, not
        part of the weights."""
        ck = read_checkpoint(init)
        mine, theirs = self.net.config(), ck["config"]
        diff = sorted(k for k in (set(mine) | set(theirs)) - set(WALL_VIEW)
                      if mine.get(k) != theirs.get(k))
        if diff:
            k = diff[0]
            raise DcdcError(f"model.init: {init} holds another network ({k} = "
                            f"{theirs.get(k)!r}, this run's {mine.get(k)!r})")
        self.net.load_state_dict(ck["state_dict"])
        if self.dist.main:
            self.echo(f"starting from the weights of {init}")

    def _data_summary(self) -> dict:
        r = self.sampler.ratios
        return {"train": str(self.cfg.data.train), "val": str(self.cfg.data.val),
                "trajectories": len(self.train_ds), "windows": int(len(self.sampler.windows)),
                "density_ratio_min": float(r.min()), "density_ratio_max": float(r.max()),
                **{k: v for k, v in self.info.items()}}

    def save(self, name: str | None = None, loss: float = math.nan) -> Path:
        """A checkpoint of the current state (rank 0); step files beyond log.keep go."""
        extra = {"step": self.step, "train_config": self.cfg.to_dict(),
                 "best_val": self.best_val, "wall_time_s": self.wall_time, "loss": loss}
        if not name:  # model.pt / best.pt are for running the network: no optimizer state
            extra["optimizer"] = self.opt.state_dict()
        ck_dir = self.run_dir / CKPT_DIR
        path = self.run_dir / name if name else ck_dir / f"step_{self.step:08d}.pt"
        save_checkpoint(path, self.net, data=self._data_summary(), extra=extra)
        if not name:
            for old in checkpoints(self.run_dir)[self.cfg.log.keep:]:
                old.unlink(missing_ok=True)
        return path

    # -------------------------------------------------------------- steps
    def batch(self, step: int, cap: float | None):
        """This rank's shard of the batch of ``step``, collated into one forward pass."""
        cfg = self.cfg
        windows = self.sampler.batch(step, cfg.data.batch_scenes, cap)
        samples = []
        for k in range(self.dist.rank, len(windows), self.dist.world):
            traj, start = windows[k]
            rng = np.random.default_rng([cfg.optim.seed, step, k, 1])
            s = load_window(self.train_ds, traj, start, cfg.loss.unroll + 1)
            samples.append(augment(s, rng, cfg.data.rotate, cfg.data.noise_std,
                                   cfg.data.wall_noise, cfg.data.wall_noise_fraction,
                                   WALL_NOISE_REACH * self.net.cfg.particle_radius))
        return collate(samples, next(self.net.parameters()).dtype, self.device)

    def train_step(self, step: int, cap: float | None) -> tuple[float, list[float], int]:
        cfg = self.cfg
        lr = cfg.optim.lr_at(step)
        for g in self.opt.param_groups:
            g["lr"] = lr
        batch = self.batch(step, cap)
        self.net.train()
        self.opt.zero_grad(set_to_none=True)
        loss, parts = unrolled_loss(self.model, batch, cfg.loss)
        if not _all_finite(loss, self.dist):  # every rank stops together
            raise DcdcError(f"training diverged at step {step + 1}: the loss is not finite "
                            f"(lower optim.lr or set optim.grad_clip; resume from the last "
                            f"checkpoint with --resume)")
        loss.backward()
        if cfg.optim.grad_clip > 0:
            torch.nn.utils.clip_grad_norm_(self.net.parameters(), cfg.optim.grad_clip)
        self.opt.step()
        return float(loss.detach()), parts, batch.n_particles

    @torch.no_grad()
    def validate(self) -> float:
        """Mean loss over the fixed validation windows (no augmentation)."""
        ds, windows = self.val
        self.net.eval()
        losses = []
        for traj, start in windows:
            b = collate([load_window(ds, traj, start, self.cfg.loss.unroll + 1)],
                        next(self.net.parameters()).dtype, self.device)
            losses.append(float(unrolled_loss(self.net, b, self.cfg.loss)[0]))
        return float(np.mean(losses))

    # -------------------------------------------------------------- loop
    def run(self) -> Path | None:
        """Train from the current step to optim.steps; returns RUN/model.pt (rank 0)."""
        cfg, d = self.cfg, self.dist
        steps = cfg.optim.steps
        columns = (["step", "stage", "max_ratio", "lr", "loss"]
                   + [f"loss_{k + 1}" for k in range(cfg.loss.unroll)]
                   + ["val_loss", "particles", "step_s", "wall_s"])
        log = None
        if d.main:
            save_toml(cfg.to_dict(), self.run_dir / "config.toml")
            log = MetricsLog(self.run_dir, columns, self.step, cfg.log.tensorboard)
        if d.main:
            r = self.sampler.ratios
            n_par = sum(p.numel() for p in self.net.parameters())
            self.echo(f"training {cfg.model.name} ({self.info['dim']}-D, {n_par / 1e6:.2f} M "
                      f"parameters, r = {self.info['radius']:g} m, dt = "
                      f"{self.info['frame_dt']:g} s) on {cfg.data.train}: {len(self.train_ds)} "
                      f"trajectories, {len(self.sampler.windows)} windows, density ratios "
                      f"{r.min():.3g}-{r.max():.3g}; {d.world} rank(s) on {self.device.type}; "
                      f"run {self.run_dir}")
        from tqdm import tqdm
        bar = tqdm(total=steps, initial=self.step, unit="step", dynamic_ncols=True,
                   disable=not (self.progress and d.main), desc="train")
        stage = None
        loss = math.nan
        try:
            while self.step < steps:
                s = self.step
                idx, cap = cfg.curriculum.stage_at(s, steps)
                if idx != stage and d.main:
                    what = f"max density ratio {cap:g}" if cap is not None else "all trajectories"
                    n = len(self.sampler.eligible(cap))
                    bar.write(f"step {s + 1}: curriculum stage {idx} ({what}, {n} windows)")
                stage = idx
                t0 = time.perf_counter()
                loss, parts, n_part = self.train_step(s, cap)
                # the whole batch's numbers: losses averaged over ranks, particles summed
                loss, *parts, n_part = _all_mean([loss] + parts + [n_part * d.world], d)
                n_part = int(round(n_part))
                self.step = s + 1
                dt = time.perf_counter() - t0
                self.wall_time += dt
                val = math.nan
                if self.val is not None and cfg.eval.every and (self.step % cfg.eval.every == 0
                                                                or self.step == steps):
                    if d.main:
                        val = self.validate()
                        if val < self.best_val:
                            self.best_val = val
                            self.save("best.pt", loss)
                if d.main:
                    row = {"step": self.step, "stage": idx,
                           "max_ratio": cap if cap is not None else math.nan,
                           "lr": cfg.optim.lr_at(s), "loss": loss, "val_loss": val,
                           "particles": n_part, "step_s": dt, "wall_s": self.wall_time}
                    row.update({f"loss_{k + 1}": p for k, p in enumerate(parts)})
                    log.write(row)
                    post = {"loss": f"{loss:.4g}"}
                    if val == val:
                        post["val"] = f"{val:.4g}"
                    bar.set_postfix(post, refresh=False)
                    bar.update(1)
                    if self.step % cfg.log.checkpoint_every == 0 or self.step == steps:
                        self.save(loss=loss)
        finally:
            bar.close()
            if log is not None:
                log.close()
        self._barrier()
        if not d.main:
            return None
        final = self.run_dir / "model.pt"
        if self.step >= steps:
            self.save("model.pt", loss)
        return final


def train(cfg: TrainConfig, out, resume: bool = False, device: str = "cpu",
          progress: bool | None = None, echo=print) -> Path | None:
    """Train ``cfg`` into run directory ``out``; returns the final checkpoint (rank 0)."""
    trainer = Trainer(cfg, out, resume, device, progress, echo)
    path = trainer.run()
    if trainer.dist.world > 1:
        import torch.distributed as dist
        dist.barrier()  # rank 0 has written model.pt: no rank tears gloo down under another
        dist.destroy_process_group()
    return path

