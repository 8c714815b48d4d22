"""dcdc train RECIPE: stages as data, each from the previous stage's weights, resumable;
--plan; one-line errors; the shipped models' recipes."""
from pathlib import Path

import pytest
import torch

from dcdc.configs import load_toml
from dcdc.errors import DcdcError
from dcdc.model.checkpoint import load_checkpoint, read_checkpoint
from dcdc.train import trainer as trainer_module
from dcdc.train.recipe import is_recipe, load_recipe, run_recipe
from dcdc.train.trainer import _config_differences
from helpers import dcdc

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "data" / "sample"
MODELS = sorted((ROOT / "configs" / "models").glob("*.toml"))

# Two stages on the sample data: the second has another lr, seed and unroll. Stage names,
# steps and settings are filled in by tiny_recipe().
TINY = """
[recipe]
name = "tiny"
description = "two stages on the sample data"

[data]
train = "{train}"
val = "{val}"
batch_scenes = 2

[model]
name = "dcdc"
channels = [8, 16, 16]

[optim]
lr = 1e-3

[curriculum]
stages = []

[loss]
unroll = 2
neighbor_scale = 13.3

[eval]
every = 0

[log]
checkpoint_every = 2
keep = 2
tensorboard = false
progress = false

[[dataset]]
path = "{sample}"
minutes = 1.5
generate = ["dcdc generate --random 3 --seed 0 --dim 2 --duration 1.0 -o {train}"]

[[stage]]
name = "first"
steps = 4
minutes = 0.5

[[stage]]
name = "second"
steps = {second_steps}
minutes = 0.25
optim = {{ lr = {second_lr}, seed = 1 }}
loss = {{ unroll = 3 }}
"""


def tiny_recipe(tmp_path, second_steps=4, second_lr="1e-4", extra="") -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(TINY.format(train=SAMPLE / "train2d", val=SAMPLE / "test2d", sample=SAMPLE,
                                second_steps=second_steps, second_lr=second_lr) + extra)
    return path


def weights(path):
    return load_checkpoint(path)[0].state_dict()


def same(a: dict, b: dict, atol=0.0) -> bool:
    return all(torch.allclose(a[k], b[k], rtol=0, atol=atol) for k in a)


# ---------------------------------------------------------------------- running
def test_two_stages_run_in_order_each_from_the_previous_weights(tmp_path):
    # lr = 1e-12 in the one step of the second stage: its weights stay the first stage's
    recipe = load_recipe(tiny_recipe(tmp_path, second_steps=1, second_lr="1e-12"))
    run, msgs = tmp_path / "run", []
    final = run_recipe(recipe, run, echo=msgs.append)

    assert final == run / "model.pt"
    first, second = run / "first" / "model.pt", run / "second" / "model.pt"
    ck1, ck2 = read_checkpoint(first), read_checkpoint(second)
    assert ck1["extra"]["step"] == 4 and ck2["extra"]["step"] == 1
    tc = ck2["extra"]["train_config"]
    assert tc["model"]["init"] == str(first)
    assert tc["optim"] == {**ck1["extra"]["train_config"]["optim"], "steps": 1, "lr": 1e-12,
                           "seed": 1}
    assert tc["loss"]["unroll"] == 3 and ck1["extra"]["train_config"]["loss"]["unroll"] == 2
    assert any(f"starting from the weights of {first}" in m for m in msgs)
    assert same(weights(first), weights(second), atol=1e-9)
    assert not same(weights(first), weights(run / "first" / "checkpoints" / "step_00000002.pt"))
    assert same(weights(final), weights(second))  # RUN/model.pt is the last stage's network
    assert (run / "recipe.toml").read_text() == recipe.path.read_text()
    for stage in ("first", "second"):  # each stage is an ordinary run directory
        assert (run / stage / "config.toml").exists() and (run / stage / "metrics.csv").exists()


def test_serve_sets_how_the_final_network_is_served(tmp_path):
    recipe = load_recipe(tiny_recipe(tmp_path, second_steps=1,
                                     extra="\n[serve]\nwall_far_faces = true\ncontact = false\n"))
    assert recipe.serve == {"wall_far_faces": True, "contact": False}
    run = tmp_path / "run"
    final = run_recipe(recipe, run, echo=lambda *_: None)
    last = read_checkpoint(run / "second" / "model.pt")
    ck = read_checkpoint(final)  # the digest is checked on reading
    assert last["config"]["wall_far_faces"] is False and "contact" not in last
    assert ck["config"]["wall_far_faces"] is True and ck["contact"] is False
    net = load_checkpoint(final)[0]
    assert net.cfg.wall_far_faces is True and net.contact_default is False
    assert same(net.state_dict(), weights(run / "second" / "model.pt"))


def test_a_stage_may_see_the_walls_otherwise(tmp_path):
    """Which wall particles the network sees is an input choice: a later stage may change
    it (the shipped 2-D recipes' last stage fills the gaps of slanted walls)."""
    extra = ("\n[[stage]]\nname = 'third'\nsteps = 1\n"
             "model = { wall_far_faces = true, wall_fill_gaps = true }\n"
             "\n[serve]\nwall_fill_gaps = true\n")
    recipe = load_recipe(tiny_recipe(tmp_path, extra=extra))
    last = recipe.config(len(recipe.stages) - 1, "RUN").model
    assert last.wall_fill_gaps is True and last.wall_far_faces is True
    assert recipe.config(0, "RUN").model.wall_fill_gaps is False
    assert recipe.serve == {"wall_fill_gaps": True}


def test_an_interrupted_recipe_resumes_and_skips_finished_stages(tmp_path, monkeypatch):
    recipe = load_recipe(tiny_recipe(tmp_path, second_steps=6))
    run = tmp_path / "run"
    real_step = trainer_module.Trainer.train_step

    def interrupted(self, step, cap):  # Ctrl-C during the second stage's fifth step
        if self.run_dir.name == "second" and step == 4:
            raise KeyboardInterrupt
        return real_step(self, step, cap)

    monkeypatch.setattr(trainer_module.Trainer, "train_step", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_recipe(recipe, run, echo=lambda *_: None)
    assert (run / "first" / "model.pt").exists() and not (run / "second" / "model.pt").exists()
    assert not (run / "model.pt").exists()
    first_written = (run / "first" / "model.pt").stat().st_mtime_ns
    monkeypatch.setattr(trainer_module.Trainer, "train_step", real_step)

    msgs = []
    run_recipe(recipe, run, echo=msgs.append)
    assert "[1/2] first: done" in msgs[0]
    assert any("(step 4)" in m and "resuming" in m for m in msgs), msgs
    assert (run / "first" / "model.pt").stat().st_mtime_ns == first_written
    rows = (run / "second" / "metrics.csv").read_text().splitlines()[1:]
    assert [int(r.split(",")[0]) for r in rows] == [1, 2, 3, 4, 5, 6]  # no gap, no repeat
    assert read_checkpoint(run / "model.pt")["extra"]["step"] == 6

    msgs = []  # a finished recipe: every stage skipped, nothing trained
    run_recipe(recipe, run, echo=msgs.append)
    assert [m.split(":")[0] for m in msgs[:2]] == ["[1/2] first", "[2/2] second"]
    assert all("done" in m for m in msgs[:2]) and len(msgs) == 3


def test_the_cli_runs_a_recipe_and_its_plan(tmp_path, capsys):
    path = tiny_recipe(tmp_path, second_steps=2)
    run = tmp_path / "run"
    code, out, err = dcdc(capsys, "train", path, "--plan", "--out", run)
    assert code == 0, err
    assert not run.exists()  # --plan trains nothing
    assert "tiny, 2 stage(s), 6 steps" in out
    assert f"{SAMPLE}  [there]  1.5 min" in out and "dcdc generate --random 3" in out
    assert "[1/2] first" in out and "from scratch  [to do]" in out
    assert "[2/2] second" in out and "unroll 3, lr 0.0001" in out and "from first" in out
    assert "in all 2.2 min" in out  # 0.5 + 0.25 training, 1.5 data

    code, out, err = dcdc(capsys, "train", path, "--out", run)
    assert code == 0, err
    assert out.strip().endswith(f"model: {run / 'model.pt'}")
    code, out, err = dcdc(capsys, "train", path, "--plan", "--out", run)
    assert out.count("[done]") == 2


# ---------------------------------------------------------------------- mistakes
BAD_STAGES = [
    ("[[stage]]\nsteps = 3\n", "stage '#3': missing 'name'"),
    ("[[stage]]\nname = 'third'\n", "stage 'third': missing 'steps'"),
    ("[[stage]]\nname = 'third'\nsteps = 0\n", "steps must be a positive integer"),
    ("[[stage]]\nname = 'third'\nsteps = 2\nlr = 1e-4\n", "unknown [[stage]] key 'lr'"),
    ("[[stage]]\nname = 'third'\nsteps = 2\noptim = { lrr = 1 }\n",
     "stage 'third': unknown setting optim.lrr"),
    ("[[stage]]\nname = 'third'\nsteps = 2\noptim = { lr = -1 }\n",
     "stage 'third': optim.lr must be > 0"),
    ("[[stage]]\nname = 'third'\nsteps = 2\noptim = { steps = 9 }\n",
     "optim.steps is the stage's own 'steps'"),
    ("[[stage]]\nname = 'first'\nsteps = 2\n", "two stages are named 'first'"),
    ("[[stage]]\nname = '../up'\nsteps = 2\n", "name must be a folder name"),
    ("[[stage]]\nname = 'third'\nsteps = 2\nmodel = { init = 'x.pt' }\n",
     "only the first stage may name one"),
    ("[[stage]]\nname = 'third'\nsteps = 2\nmodel = { channels = [4, 8, 8] }\n",
     "stage 'third': model.channels differs from the first stage's"),
    ("[optimizer]\nlr = 1\n", "unknown top-level key 'optimizer'"),
    ("[[dataset]]\ngenerate = ['x']\n", "path must be a folder name"),
    ("[[dataset]]\npath = 'd'\ncommand = 'x'\n", "unknown [[dataset]] key 'command'"),
    ("[serve]\ncontact = 'no'\n", "serve.contact must be true or false"),
    ("[serve]\nnoise = true\n", "unknown [serve] key 'noise'"),
]


@pytest.mark.parametrize("extra, msg", BAD_STAGES, ids=[m for _, m in BAD_STAGES])
def test_bad_recipes_are_one_line_errors(tmp_path, capsys, extra, msg):
    path = tiny_recipe(tmp_path, extra="\n" + extra)
    with pytest.raises(DcdcError) as e:
        load_recipe(path)
    assert msg in str(e.value) and str(e.value).startswith(str(path))
    assert "\n" not in str(e.value)
    code, out, err = dcdc(capsys, "train", path, "--out", tmp_path / "run")
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: ") and msg in err
    assert not (tmp_path / "run").exists()


def test_a_stage_without_its_data_names_the_command_that_makes_it(tmp_path, capsys):
    path = tiny_recipe(tmp_path)
    text = path.read_text().replace(
        "[[stage]]\nname = \"second\"",
        f"[[stage]]\nname = \"second\"\ndata = {{ train = \"{tmp_path / 'made' / 'train'}\" }}")
    path.write_text(text + f"\n[[dataset]]\npath = \"{tmp_path / 'made'}\"\n"
                           f"generate = [\"dcdc generate --random 5 -o {tmp_path / 'made'}/train\"]\n")
    code, out, err = dcdc(capsys, "train", path, "--out", tmp_path / "run")
    assert code == 2 and err.count("\n") == 1
    assert f"stage 'second': data.train {tmp_path / 'made' / 'train'} does not exist; " \
           f"make it with: dcdc generate --random 5 -o {tmp_path / 'made'}/train" in err
    assert not (tmp_path / "run" / "first").exists()  # refused before any training
    code, out, err = dcdc(capsys, "train", path, "--plan")
    assert code == 0 and "[to do; data missing]" in out and "[missing]" in out
    (tmp_path / "made").mkdir()
    code, out, err = dcdc(capsys, "train", path, "--plan")
    assert f"{tmp_path / 'made'}  [incomplete]" in out


def test_a_single_runs_directory_is_not_taken_for_a_recipes(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.toml").write_text("")
    code, out, err = dcdc(capsys, "train", tiny_recipe(tmp_path), "--out", run)
    assert code == 2 and "holds the run of a single config, not a recipe's stages" in err


def test_plan_needs_a_recipe_and_a_recipe_needs_stages(tmp_path, capsys):
    code, out, err = dcdc(capsys, "train", ROOT / "examples" / "train_2d_tiny.toml", "--plan")
    assert code == 2 and "--plan is for recipes" in err
    empty = tmp_path / "empty.toml"
    empty.write_text("[recipe]\nname = 'x'\n")
    code, out, err = dcdc(capsys, "train", empty)
    assert code == 2 and "a recipe needs at least one [[stage]] table" in err


# ---------------------------------------------------------------------- the shipped recipes
@pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
def test_every_model_recipe_parses_and_ends_with_its_shipped_config(path):
    assert is_recipe(load_toml(path))
    recipe = load_recipe(path)
    assert recipe.name == path.stem
    assert all(s.minutes for s in recipe.stages)  # every stage's time is stated
    for i in range(len(recipe.stages)):  # every data folder has the commands that make it
        cfg = recipe.config(i, "runs/x")
        for p in (cfg.data.train, cfg.data.val):
            assert recipe.source_of(p) is not None and recipe.source_of(p).generate, p
    # the last stage is the training the shipped network's checkpoint records
    shipped = ROOT / "dcdc" / "assets" / "models" / f"{path.stem}.pt"
    recorded = read_checkpoint(shipped)["extra"]["train_config"]
    mine = recipe.config(len(recipe.stages) - 1, "runs/x").to_dict()
    diff = [k for k in _config_differences(recorded, mine) if k != "model.init"]
    assert all(_get(recorded, k) is None for k in diff), diff  # only keys it predates
    ck = read_checkpoint(shipped)  # [serve]: how the shipped file serves the weights
    assert ck.get("contact") == recipe.serve.get("contact")
    for key in ("wall_far_faces", "wall_fill_gaps"):
        if key in recipe.serve:
            assert ck["config"][key] == recipe.serve[key]


def _get(d: dict, key: str):
    for part in key.split("."):
        d = d.get(part) if isinstance(d, dict) else None
    return d


def test_every_shipped_model_has_a_recipe():
    shipped = {p.stem for p in (ROOT / "dcdc" / "assets" / "models").glob("*.pt")}
    assert shipped == {p.stem for p in MODELS}
