"""The typed training configuration (``dcdc train CONFIG.toml``), one dataclass per TOML
table: ``[data] [model] [optim] [curriculum] [loss] [eval] [log]``.

Read with :func:`load_config` (TOML + ``--set key=value`` overrides, :mod:`dcdc.configs`);
every field is documented in docs/training.md. The whole config is written to
``RUN/config.toml`` and into every checkpoint (``extra["train_config"]``).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

from ..configs import apply_overrides, check, check_types, from_dict, load_toml, to_dict
from ..errors import DcdcError
from ..model.networks import NETWORKS, NetConfig
from .curriculum import CurriculumConfig


@dataclass
class DataConfig:
    """Where the windows come from and how they are augmented."""

    train: str = "datasets/2d/train"  # dataset directory or merged .h5
    val: str = ""  # validation dataset ("" = no validation loss)
    batch_scenes: int = 4  # windows per batch, concatenated into ONE forward pass
    stride: int = 1  # frames between the starts of consecutive windows
    rotate: bool = True  # 3-D: random rotation about gravity; 2-D: random mirror across it
    noise_std: float = 0.0  # Gaussian noise on the input positions [m] (0 = off)
    # oversample the start of the trajectories (a scene's lattice start settling onto its
    # walls, docs/models.md "The cocktail's start-up burst"): this fraction of each batch's
    # windows starts at a frame < early_frames (0 = uniform over all windows)
    early_fraction: float = 0.0
    early_frames: int = 10
    # move this share of the particles beside a wall (nearest wall particle within 2 r) to a
    # random depth in [0, wall_noise] behind it in the input, the target unchanged
    # (sampler.push_into_walls; 0 = off)
    wall_noise: float = 0.0  # [m]
    wall_noise_fraction: float = 0.2

    def validate(self):
        check(bool(self.train), "data.train", "a dataset path", self.train)
        check(self.batch_scenes >= 1, "data.batch_scenes", ">= 1", self.batch_scenes)
        check(self.stride >= 1, "data.stride", ">= 1", self.stride)
        check(self.noise_std >= 0, "data.noise_std", ">= 0", self.noise_std)
        check(0 <= self.early_fraction <= 1, "data.early_fraction", "in [0, 1]",
              self.early_fraction)
        check(self.early_frames >= 1, "data.early_frames", ">= 1", self.early_frames)
        check(self.wall_noise >= 0, "data.wall_noise", ">= 0", self.wall_noise)
        check(0 <= self.wall_noise_fraction <= 1, "data.wall_noise_fraction", "in [0, 1]",
              self.wall_noise_fraction)


@dataclass
class ModelConfig(NetConfig):
    """The network: a registry name plus every :class:`NetConfig` option. ``particle_radius``
    and ``frame_dt`` default to the training data's (they must match it anyway)."""

    name: str = "dcdc"
    particle_radius: float | None = None
    frame_dt: float | None = None
    init: str = ""  # start from these weights (a checkpoint or shipped model name): fine-tuning

    def validate(self):
        check_types(self, "model.")
        check(self.name in NETWORKS, "model.name", f"one of {', '.join(NETWORKS)}", self.name)
        try:
            NetConfig(**self.net_options(self.particle_radius or 1.0, self.frame_dt or 1.0))
        except DcdcError as e:
            raise DcdcError(str(e).replace("network option ", "model.")) from None
        for k in ("particle_radius", "frame_dt"):
            v = getattr(self, k)
            check(v is None or v > 0, f"model.{k}", "> 0", v)
        return self

    def net_options(self, particle_radius: float, frame_dt: float) -> dict:
        """Keyword options of :func:`~dcdc.model.networks.build_network`."""
        d = {f.name: getattr(self, f.name) for f in fields(NetConfig)}
        d["particle_radius"] = self.particle_radius if self.particle_radius is not None \
            else particle_radius
        d["frame_dt"] = self.frame_dt if self.frame_dt is not None else frame_dt
        return d


@dataclass
class OptimConfig:
    """Adam with a step-wise decaying learning rate (DeepLagrangianFluids' schedule: 1e-3
    halved at 50, 60, 70, 80 and 90 % of the steps)."""

    steps: int = 1000
    lr: float = 1e-3
    lr_decay: float = 0.5  # factor applied at each milestone
    lr_milestones: tuple[float, ...] = (0.5, 0.6, 0.7, 0.8, 0.9)  # fractions of ``steps``
    adam_eps: float = 1e-6
    weight_decay: float = 0.0
    grad_clip: float = 0.0  # max global gradient norm (0 = off)
    seed: int = 0  # network initialisation, window order, augmentation

    def validate(self):
        check(self.steps >= 1, "optim.steps", ">= 1", self.steps)
        check(self.lr > 0, "optim.lr", "> 0", self.lr)
        check(0 < self.lr_decay <= 1, "optim.lr_decay", "in (0, 1]", self.lr_decay)
        check(all(0 < m < 1 for m in self.lr_milestones), "optim.lr_milestones",
              "fractions in (0, 1)", list(self.lr_milestones))
        check(self.adam_eps > 0, "optim.adam_eps", "> 0", self.adam_eps)
        check(self.weight_decay >= 0, "optim.weight_decay", ">= 0", self.weight_decay)
        check(self.grad_clip >= 0, "optim.grad_clip", ">= 0", self.grad_clip)

    def lr_at(self, step: int) -> float:
        """Learning rate of (0-based) ``step``."""
        passed = sum(step >= m * self.steps for m in self.lr_milestones)
        return self.lr * self.lr_decay ** passed


@dataclass
class LossConfig:
    """Unrolled, neighbour-weighted position loss (Ummenhofer et al. 2020, see loss.py)."""

    unroll: int = 2  # neural steps per sample (window of unroll + 1 frames)
    step_weights: tuple[float, ...] = ()  # weight per unrolled step; () = 1/unroll each
    gamma: float = 0.5  # exponent of the distance ‖x − x_true‖^γ
    neighbor_scale: float = 40.0  # weight exp(−n_i / neighbor_scale); 0 = unweighted
    # wall term (loss.py): weight of the penalty (0 = off) on predicted centres closer than
    # wall_margin particle radii in front of the nearest wall particle (0 = behind it)
    wall_weight: float = 0.0
    wall_margin: float = 0.0
    # phase term (loss.py): weight of the error of each phase's centre of mass (0 = off)
    phase_weight: float = 0.0

    def validate(self):
        check(self.unroll >= 1, "loss.unroll", ">= 1", self.unroll)
        check(not self.step_weights or len(self.step_weights) == self.unroll,
              "loss.step_weights", f"empty or {self.unroll} numbers (one per unrolled step)",
              list(self.step_weights))
        check(all(w >= 0 for w in self.step_weights) and (not self.step_weights
              or sum(self.step_weights) > 0), "loss.step_weights",
              "non-negative with a positive sum", list(self.step_weights))
        check(0 < self.gamma <= 2, "loss.gamma", "in (0, 2]", self.gamma)
        check(self.neighbor_scale >= 0, "loss.neighbor_scale", ">= 0", self.neighbor_scale)
        check(self.wall_weight >= 0, "loss.wall_weight", ">= 0", self.wall_weight)
        check(0 <= self.wall_margin <= 4.5, "loss.wall_margin", "in [0, 4.5] particle radii",
              self.wall_margin)
        check(self.phase_weight >= 0, "loss.phase_weight", ">= 0", self.phase_weight)

    def weights(self) -> list[float]:
        w = list(self.step_weights) or [1.0] * self.unroll
        return [x / sum(w) for x in w]


@dataclass
class EvalConfig:
    every: int = 100  # validation loss every K steps (0 = never; needs data.val)
    windows: int = 16  # fixed validation windows, spread evenly over data.val

    def validate(self):
        check(self.every >= 0, "eval.every", ">= 0", self.every)
        check(self.windows >= 1, "eval.windows", ">= 1", self.windows)


@dataclass
class LogConfig:
    checkpoint_every: int = 100  # steps between checkpoints (the last step always saves)
    keep: int = 3  # newest step checkpoints kept (best.pt and model.pt are extra)
    tensorboard: bool = True  # RUN/tensorboard/ event files
    progress: bool = True  # tqdm bar with loss and ETA

    def validate(self):
        check(self.checkpoint_every >= 1, "log.checkpoint_every", ">= 1", self.checkpoint_every)
        check(self.keep >= 1, "log.keep", ">= 1", self.keep)


SECTIONS = ("data", "model", "optim", "curriculum", "loss", "eval", "log")
# NetConfig fields that say which wall particles the network sees: an input choice, not part
# of the weights (a fine-tuning or a recipe's stage may change them)
WALL_VIEW = ("wall_far_faces", "wall_fill_gaps")


@dataclass
class TrainConfig:
    data: DataConfig = field(default_factory=DataConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    optim: OptimConfig = field(default_factory=OptimConfig)
    curriculum: CurriculumConfig = field(default_factory=CurriculumConfig)
    loss: LossConfig = field(default_factory=LossConfig)
    eval: EvalConfig = field(default_factory=EvalConfig)
    log: LogConfig = field(default_factory=LogConfig)

    def __post_init__(self):
        for name in SECTIONS:
            section = getattr(self, name)
            if name != "model":
                check_types(section, f"{name}.")
            section.validate()

    def to_dict(self) -> dict:
        return to_dict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "TrainConfig":
        return from_dict(cls, d, "")


def load_config(path=None, overrides=()) -> TrainConfig:
    """The config of TOML file ``path`` (None: the defaults) with ``--set`` overrides."""
    d = load_toml(path) if path is not None else {}
    d = apply_overrides(d, overrides)
    try:
        return TrainConfig.from_dict(d)
    except DcdcError as e:
        where = f"{path}: " if path is not None else ""
        raise DcdcError(f"{where}{e}") from None
