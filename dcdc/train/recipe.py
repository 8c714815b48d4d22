"""Training recipes: every stage of a model's training as data in one TOML file.

A recipe is a training config (the tables of :mod:`dcdc.train.config`, shared by every
stage) plus ``[[stage]]`` tables, each a name, a number of steps and the settings that
stage changes; ``[[dataset]]`` tables say which commands make the data the stages read::

    [recipe]
    name = "dcdc2d"                       # what RUN/model.pt is
    description = "..."

    [data]                                # shared: every stage starts from these tables
    batch_scenes = 4
    [loss]
    unroll = 5

    [[dataset]]                           # a folder the stages read and how to make it
    path = "datasets/2d"
    minutes = 14                          # its generation time (optional, for --plan)
    generate = ["dcdc generate --dim 2 --random 200 --seed 0 -o datasets/2d/train", "..."]

    [[stage]]
    name = "curriculum"                   # the stage's run directory: RUN/curriculum/
    steps = 10000
    minutes = 58                          # measured or estimated time (optional)
    optim = { lr = 1e-3, seed = 0 }       # overrides of the shared tables
    data = { train = "datasets/2d/train", val = "datasets/2d/valid" }

    [[stage]]
    name = "noise"
    ...

``dcdc train RECIPE.toml --out RUN`` (:func:`run_recipe`) trains the stages in order into
``RUN/<stage name>/``, each an ordinary run directory (docs/training.md), the first from
``model.init`` (empty: from scratch) and every later one from the previous stage's
``model.pt``. A stage whose ``model.pt`` is there is skipped and an interrupted one
resumes from its newest checkpoint, so the same command, re-run after any interruption,
finishes the recipe. The last stage's network is copied to ``RUN/model.pt``.
An optional ``[serve]`` table says how ``RUN/model.pt`` serves those weights:
``wall_far_faces`` and ``wall_fill_gaps`` (the wall conv's view of thin walls' far faces
and of slanted walls' gaps, ``NetConfig``) and ``contact`` (whether its rollouts apply the walls' contact by default;
:func:`dcdc.model.checkpoint.serve_checkpoint`).
``dcdc train RECIPE.toml --plan`` (:func:`plan_text`) prints the stages, the datasets with
their commands and the estimated time, and trains nothing.

Every mistake in a recipe (a missing stage field, an unknown key, a setting out of range,
a stage whose data folder is missing) is one :class:`~dcdc.errors.DcdcError` line naming
the file and the stage; a missing folder's error names the commands that make it.
"""
from __future__ import annotations

import copy
import os
import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from ..configs import apply_overrides, load_toml
from ..errors import DcdcError
from .config import SECTIONS, WALL_VIEW, TrainConfig

RECIPE_KEYS = ("recipe", "dataset", "stage", "serve") + SECTIONS
SERVE_FIELDS = ("wall_far_faces", "wall_fill_gaps", "contact")
RECIPE_FIELDS = ("name", "description")
DATASET_FIELDS = ("path", "generate", "minutes", "note")
STAGE_FIELDS = ("name", "steps", "minutes") + SECTIONS
STAGE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
FINAL = "model.pt"


def is_recipe(d: dict) -> bool:
    """Whether the tables ``d`` of a TOML file are a recipe (it has ``[[stage]]`` or
    ``[recipe]``) rather than one run's config."""
    return "stage" in d or "recipe" in d


@dataclass
class DataSource:
    """A folder the stages read (``path``) and the shell commands that make it."""

    path: str
    generate: list[str] = field(default_factory=list)
    minutes: float | None = None  # how long the commands take (for --plan)
    note: str = ""

    def covers(self, path: str) -> bool:
        """Whether ``path`` is this folder or lies inside it."""
        mine, theirs = Path(self.path), Path(path)
        return theirs == mine or mine in theirs.parents


@dataclass
class Stage:
    """One stage: its name (the run directory under RUN), steps, and its settings."""

    name: str
    steps: int
    minutes: float | None
    overrides: dict  # tables of TrainConfig settings that replace the shared ones


@dataclass
class Recipe:
    """A parsed recipe: the shared settings, the datasets and the stages in order."""

    path: Path
    name: str
    description: str
    base: dict
    datasets: list[DataSource]
    stages: list[Stage]
    serve: dict = field(default_factory=dict)  # [serve]: how RUN/model.pt serves the weights

    # ------------------------------------------------------------------ configs
    def config(self, i: int, run, overrides=()) -> TrainConfig:
        """The full config of stage ``i`` trained under run directory ``run``: the shared
        tables, the stage's overrides, its steps, ``--set`` ``overrides`` and, from the
        second stage on, ``model.init`` = the previous stage's ``model.pt``."""
        stage = self.stages[i]
        d = _merge(self.base, stage.overrides)
        d.setdefault("optim", {})["steps"] = stage.steps
        try:
            d = apply_overrides(d, overrides)
            if i > 0:
                d.setdefault("model", {})["init"] = str(self.stage_dir(run, i - 1) / FINAL)
            return TrainConfig.from_dict(d)
        except DcdcError as e:
            raise self.error(f"{e}", stage) from None

    def stage_dir(self, run, i: int) -> Path:
        return Path(run) / self.stages[i].name

    def error(self, what: str, stage: Stage | None = None) -> DcdcError:
        where = f", stage {stage.name!r}" if stage is not None else ""
        return DcdcError(f"{self.path}{where}: {what}")

    # ------------------------------------------------------------------ data
    def source_of(self, path: str) -> DataSource | None:
        """The dataset entry whose folder holds ``path`` (the innermost one)."""
        found = [s for s in self.datasets if s.covers(path)]
        return max(found, key=lambda s: len(Path(s.path).parts)) if found else None

    def check_data(self, cfgs: dict[int, TrainConfig]) -> None:
        """Refuse, before any training, a stage whose data folder is missing, naming the
        commands of the dataset that makes it."""
        for i, cfg in cfgs.items():
            for key in ("train", "val"):
                path = getattr(cfg.data, key)
                if not path or Path(path).exists():
                    continue
                src = self.source_of(path)
                if src is None or not src.generate:
                    how = "no [[dataset]] of the recipe says how to make it"
                elif len(src.generate) == 1:
                    how = f"make it with: {src.generate[0]}"
                else:
                    how = (f"make it with the {len(src.generate)} commands of [[dataset]] "
                           f"{src.path!r} (dcdc train {self.path} --plan prints them and the "
                           f"datasets to make first), the first: {src.generate[0]}")
                raise self.error(f"data.{key} {path} does not exist; {how}", self.stages[i])

    # ------------------------------------------------------------------ time
    def minutes(self) -> tuple[float, float]:
        """(training, data generation) minutes of the whole recipe, from the stages' and
        datasets' ``minutes`` (those without one count 0)."""
        return (sum(s.minutes or 0.0 for s in self.stages),
                sum(s.minutes or 0.0 for s in self.datasets))


# ---------------------------------------------------------------------- reading
def _merge(base: dict, over: dict) -> dict:
    """``base`` with ``over`` laid on top: tables merged key by key, everything else
    (numbers, strings, lists) replaced."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _unknown(d: dict, known, what: str) -> str | None:
    bad = [k for k in d if k not in known]
    return f"unknown {what} key {bad[0]!r} (known: {', '.join(known)})" if bad else None


def _table(d: dict, key: str, known, path) -> dict:
    """The optional table ``[key]`` of a recipe (empty when absent), with only ``known`` keys."""
    t = d.get(key, {})
    if not isinstance(t, dict):
        raise DcdcError(f"{path}: [{key}] must be a table")
    bad = _unknown(t, known, f"[{key}]")
    if bad:
        raise DcdcError(f"{path}: {bad}")
    return t


def _number(v, name: str, integer: bool = False):
    ok = isinstance(v, int) if integer else isinstance(v, (int, float))
    if isinstance(v, bool) or not ok or v < (1 if integer else 0):
        kind = "a positive integer" if integer else "a number >= 0"
        raise DcdcError(f"{name} must be {kind} (got {v!r})")
    return v


def parse_recipe(d: dict, path) -> Recipe:
    """A :class:`Recipe` from the tables ``d`` of file ``path``, with every stage's
    config checked (a one-line DcdcError naming the file and the stage otherwise)."""
    path = Path(path)
    bad = _unknown(d, RECIPE_KEYS, "top-level")
    if bad:
        raise DcdcError(f"{path}: {bad}")
    head = _table(d, "recipe", RECIPE_FIELDS, path)
    raw_stages = d.get("stage")
    if not isinstance(raw_stages, list) or not raw_stages \
            or not all(isinstance(s, dict) for s in raw_stages):
        raise DcdcError(f"{path}: a recipe needs at least one [[stage]] table")
    base = {k: d[k] for k in SECTIONS if k in d}
    for k, v in base.items():
        if not isinstance(v, dict):
            raise DcdcError(f"{path}: [{k}] must be a table")

    datasets = []
    raw_data = d.get("dataset", [])
    if not isinstance(raw_data, list) or not all(isinstance(s, dict) for s in raw_data):
        raise DcdcError(f"{path}: dataset entries must be [[dataset]] tables")
    for n, s in enumerate(raw_data):
        where = f"{path}, [[dataset]] {s.get('path', n + 1)!r}"
        bad = _unknown(s, DATASET_FIELDS, "[[dataset]]")
        if bad:
            raise DcdcError(f"{where}: {bad}")
        if not isinstance(s.get("path"), str) or not s["path"]:
            raise DcdcError(f"{where}: path must be a folder name")
        gen = s.get("generate", [])
        if not isinstance(gen, list) or not all(isinstance(c, str) and c for c in gen):
            raise DcdcError(f"{where}: generate must be a list of shell commands")
        try:
            minutes = _number(s["minutes"], "minutes") if "minutes" in s else None
        except DcdcError as e:
            raise DcdcError(f"{where}: {e}") from None
        datasets.append(DataSource(s["path"], list(gen), minutes, str(s.get("note", ""))))

    stages, names = [], set()
    for n, s in enumerate(raw_stages):
        label = s.get("name", f"#{n + 1}")
        where = f"{path}, stage {label!r}"
        for k in ("name", "steps"):
            if k not in s:
                raise DcdcError(f"{where}: missing {k!r} (every [[stage]] has a name and "
                                f"its steps)")
        bad = _unknown(s, STAGE_FIELDS, "[[stage]]")
        if bad:
            raise DcdcError(f"{where}: {bad}")
        name = s["name"]
        if not isinstance(name, str) or not STAGE_NAME.match(name):
            raise DcdcError(f"{where}: name must be a folder name (letters, digits, '-', "
                            f"'_', '.'; got {name!r})")
        if name in names:
            raise DcdcError(f"{where}: two stages are named {name!r}")
        names.add(name)
        try:
            steps = _number(s["steps"], "steps", integer=True)
            minutes = _number(s["minutes"], "minutes") if "minutes" in s else None
        except DcdcError as e:
            raise DcdcError(f"{where}: {e}") from None
        over = {k: s[k] for k in SECTIONS if k in s}
        for k, v in over.items():
            if not isinstance(v, dict):
                raise DcdcError(f"{where}: {k} must be a table of settings")
        if "steps" in over.get("optim", {}):
            raise DcdcError(f"{where}: optim.steps is the stage's own 'steps'")
        if n > 0 and "init" in over.get("model", {}):
            raise DcdcError(f"{where}: model.init is set by the recipe (the previous "
                            f"stage's weights); only the first stage may name one")
        stages.append(Stage(name, steps, minutes, over))

    serve = _table(d, "serve", SERVE_FIELDS, path)
    for k, v in serve.items():
        if not isinstance(v, bool):
            raise DcdcError(f"{path}: serve.{k} must be true or false (got {v!r})")
    recipe = Recipe(path, str(head.get("name", path.stem)), str(head.get("description", "")),
                    base, datasets, stages, dict(serve))
    first = None
    for i, stage in enumerate(recipe.stages):  # every stage's config is valid and
        net = {k: v for k, v in recipe.config(i, "RUN").to_dict()["model"].items()
               if k != "init" and k not in WALL_VIEW}  # every stage trains the same network
                                                       # (which walls it sees may change)
        if first is None:
            first = net
        elif net != first:
            k = sorted(k for k in set(net) | set(first) if net.get(k) != first.get(k))[0]
            raise recipe.error(f"model.{k} differs from the first stage's (every stage "
                               f"trains the same network)", stage)
    return recipe


def load_recipe(path) -> Recipe:
    """The recipe in TOML file ``path`` (a one-line DcdcError if it is not a valid one)."""
    d = load_toml(path)
    if not is_recipe(d):
        raise DcdcError(f"{path}: not a recipe (no [[stage]] tables)")
    return parse_recipe(d, path)


# ---------------------------------------------------------------------- state of a run
def stage_done(cfg: TrainConfig, run_dir: Path) -> bool:
    """Whether ``run_dir`` holds the finished run of ``cfg``: its ``model.pt`` reached
    ``optim.steps`` with the same settings (logging and ``model.init`` aside)."""
    from ..model.checkpoint import read_checkpoint
    from .trainer import RESUMABLE_CHANGES, _config_differences

    final = run_dir / FINAL
    if not final.exists():
        return False
    try:
        extra = read_checkpoint(final).get("extra", {})
    except DcdcError:
        return False
    diff = [k for k in _config_differences(extra.get("train_config", {}), cfg.to_dict())
            if not any(k.startswith(p) for p in RESUMABLE_CHANGES)]
    return not diff and int(extra.get("step", -1)) == cfg.optim.steps


def stage_progress(cfg: TrainConfig, run_dir: Path) -> str:
    """'done', 'N of M steps' (an interrupted stage) or 'to do'."""
    from .trainer import checkpoints

    if stage_done(cfg, run_dir):
        return "done"
    steps = [int(p.stem.split("_")[1]) for p in checkpoints(run_dir)]
    return f"{max(steps)} of {cfg.optim.steps} steps" if steps else "to do"


# ---------------------------------------------------------------------- --plan
def _fmt_minutes(m: float | None) -> str:
    if m is None:
        return "?"
    if m < 10:
        return f"{m:.1f} min"
    return f"{m:.0f} min" if m < 90 else f"{m / 60:.1f} h"


def plan_text(recipe: Recipe, run, overrides=()) -> str:
    """What ``dcdc train RECIPE --out RUN`` would do: the datasets with their commands
    (and whether each is there), the stages with their data and settings (and how far
    ``RUN`` has got with each) and the estimated time."""
    run = Path(run)
    train_min, data_min = recipe.minutes()
    steps = sum(s.steps for s in recipe.stages)
    lines = [f"recipe {recipe.path}: {recipe.name}, {len(recipe.stages)} stage(s), "
             f"{steps:,} steps".replace(f"{steps:,}", f"{steps:,}".replace(",", " "))]
    if recipe.description:
        lines.append(f"  {recipe.description}")
    cfgs = [recipe.config(i, run, overrides) for i in range(len(recipe.stages))]
    used = {p for c in cfgs for p in (c.data.train, c.data.val) if p}
    if recipe.datasets:
        lines += ["", "datasets (make the missing ones first, in this order):"]
        for s in recipe.datasets:
            mine = [p for p in used if recipe.source_of(p) is s]
            there = ("missing" if not Path(s.path).exists()
                     else "incomplete" if any(not Path(p).exists() for p in mine) else "there")
            lines.append(f"  {s.path}  [{there}]  {_fmt_minutes(s.minutes)}")
            if s.note:
                lines.append(f"    # {s.note}")
            lines += [f"    {c}" for c in s.generate]
    orphans = sorted(p for p in used if recipe.source_of(p) is None)
    if orphans:
        lines.append(f"  no [[dataset]] makes: {', '.join(orphans)}")
    lines += ["", f"stages (run directory {run}/<name>/):"]
    width = max(len(s.name) for s in recipe.stages)
    for i, (s, c) in enumerate(zip(recipe.stages, cfgs)):
        state = stage_progress(c, recipe.stage_dir(run, i))
        if state != "done" and any(p and not Path(p).exists()
                                   for p in (c.data.train, c.data.val)):
            state += "; data missing"
        start = (f"from {c.model.init}" if i == 0 and c.model.init
                 else "from scratch" if i == 0 else f"from {recipe.stages[i - 1].name}")
        lines.append(
            f"  [{i + 1}/{len(cfgs)}] {s.name:<{width}}  {s.steps:>6} steps  "
            f"{_fmt_minutes(s.minutes):>7}  {c.model.name} on {c.data.train}, unroll "
            f"{c.loss.unroll}, lr {c.optim.lr:g}, noise {c.data.noise_std:g} m, seed "
            f"{c.optim.seed}, {start}  [{state}]")
    lines += ["", f"estimated time on 2 cores: training {_fmt_minutes(train_min)}, data "
                  f"{_fmt_minutes(data_min)}, in all {_fmt_minutes(train_min + data_min)}; "
                  f"the network ends in {run / FINAL}"]
    return "\n".join(lines)


# ---------------------------------------------------------------------- running
def run_recipe(recipe: Recipe, out, overrides=(), device: str = "cpu",
               progress: bool | None = None, echo=print) -> Path:
    """Train every stage of ``recipe`` not yet done into ``out/<stage>/`` and copy the
    last stage's network to ``out/model.pt``; returns that path. Data folders of the
    stages still to run are checked before any training."""
    from ..outputs import atomic_file, write_text
    from .trainer import train

    out = Path(out)
    if (out / "config.toml").exists():
        raise DcdcError(f"{out} holds the run of a single config, not a recipe's stages; "
                        f"choose another --out")
    main = os.environ.get("RANK", "0") == "0"  # under torchrun rank 0 writes and reports
    say = echo if main else (lambda *_: None)
    n = len(recipe.stages)
    cfgs = {i: recipe.config(i, out, overrides) for i in range(n)}
    todo = {i: c for i, c in cfgs.items() if not stage_done(c, recipe.stage_dir(out, i))}
    recipe.check_data(todo)
    if main:
        out.mkdir(parents=True, exist_ok=True)
        write_text(out / "recipe.toml", recipe.path.read_text(encoding="utf-8"))
    for i in range(n):
        stage, where = recipe.stages[i], recipe.stage_dir(out, i)
        if i not in todo:
            say(f"[{i + 1}/{n}] {stage.name}: done ({where / FINAL})")
            continue
        say(f"[{i + 1}/{n}] {stage.name}: {stage.steps} steps into {where}")
        train(cfgs[i], where, resume=True, device=device, progress=progress, echo=echo)
    final = out / FINAL
    if not main:
        return final
    last = recipe.stage_dir(out, n - 1) / FINAL
    if recipe.serve:
        from ..model.checkpoint import serve_checkpoint
        serve_checkpoint(last, final, **recipe.serve)
    else:
        with atomic_file(final) as tmp:
            shutil.copyfile(last, tmp)
    served = "".join(f", {k} = {str(v).lower()}" for k, v in recipe.serve.items())
    say(f"{recipe.name}: {final} (the weights of the last stage, {recipe.stages[-1].name!r}"
        f"{served})")
    return final
