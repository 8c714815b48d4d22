"""Every user mistake ends in one line ``error: ...`` and exit status 2, before any
work starts (no traceback, no half-written output, no runaway allocation).

Each case runs the real CLI in-process (``dcdc.cli.main``), so a traceback would fail it.
"""
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from helpers import dcdc, tank_toml

ROOT = Path(__file__).resolve().parents[1]
READ_ONLY = Path("/sys")  # read-only even for root (permission bits alone are not, for root)

EMITTER = """
[[emitter]]
phase = "water"
position = [0.7, 0.8]
direction = [0.0, -1.0]
speed = 1.0
rate = {rate}
start = {start}
stop = 0.6
"""



def assert_one_line_error(code, err, *words):
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])


def scene_file(tmp_path, radius=0.025, duration=1.0, emitter=None, dim=None) -> Path:
    text = tank_toml(radius=radius, duration=duration)
    if dim is not None:
        text = text.replace("dim = 2", f"dim = {dim}")
    if emitter:
        text += EMITTER.format(**emitter)
    p = tmp_path / "tank.toml"
    p.write_text(text)
    return p


# ------------------------------------------------------------------ size budget
@pytest.mark.parametrize("case", ["radius", "resolution", "rate"])
def test_particle_budget_refuses_before_allocating(tmp_path, capsys, case):
    if case == "radius":
        args = ["scene", "show", scene_file(tmp_path, radius=1e-5)]
    elif case == "resolution":
        args = ["scene", "show", "cocktail", "--dim", "2", "--resolution", "1200"]
    else:
        args = ["scene", "show", scene_file(tmp_path, emitter={"rate": 1e12, "start": 0.0})]
    code, _, err = dcdc(capsys, *args)
    assert_one_line_error(code, err, "particles", "GiB", "--max-particles")


def test_budget_override_flag_is_honoured(tmp_path, capsys):
    f = scene_file(tmp_path)  # ~600 sampled points
    assert dcdc(capsys, "scene", "show", f)[0] == 0
    code, _, err = dcdc(capsys, "scene", "show", f, "--max-particles", "100")
    assert_one_line_error(code, err, "over the limit of 100")


def test_generate_checks_budget_before_work(tmp_path, capsys):
    out = tmp_path / "ds"
    code, _, err = dcdc(capsys, "generate", "cocktail", "--dim", "2", "--resolution", "1200", "-o", out)
    assert_one_line_error(code, err, "--max-particles")
    assert not out.exists() or not any(out.iterdir())


# ------------------------------------------------------------------ degenerate runs
@pytest.mark.parametrize("args, words", [
    (["--duration", "0"], ["positive"]),
    (["--duration", "-1"], ["positive"]),
    (["--duration", "nan"], ["positive"]),
    (["--duration", "0.005"], ["shorter than one frame"]),
    (["--resolution", "inf"], ["finite"]),
    (["--resolution", "0"], ["resolution"]),
])
def test_generate_refuses_degenerate_runs(tmp_path, capsys, args, words):
    code, _, err = dcdc(capsys, "generate", "lock_exchange", "--dim", "2", *args,
                        "--simulator", "ballistic", "--no-progress", "-o", tmp_path / "ds")
    assert_one_line_error(code, err, *words)
    assert not list((tmp_path / "ds").glob("*.h5")) if (tmp_path / "ds").exists() else True


def test_random_count_must_be_positive(tmp_path, capsys):
    code, _, err = dcdc(capsys, "generate", "--random", "-3", "-o", tmp_path / "ds")
    assert_one_line_error(code, err, "--random")


def test_frame_dt_longer_than_duration(tmp_path, capsys):
    f = scene_file(tmp_path, duration=0.01)  # frame_dt 0.02
    code, _, err = dcdc(capsys, "generate", f, "--simulator", "ballistic", "-o", tmp_path / "ds")
    assert_one_line_error(code, err, "shorter than one frame")


def test_emitter_after_the_end_is_refused(tmp_path, capsys):
    f = scene_file(tmp_path, duration=0.2, emitter={"rate": 100.0, "start": 0.4})
    code, _, err = dcdc(capsys, "generate", f, "--simulator", "ballistic", "-o", tmp_path / "ds")
    assert_one_line_error(code, err, "emitter[0] starts at 0.4 s")


@pytest.mark.parametrize("dim", ["2.0", "true", '"2"'])
def test_dim_must_be_an_integer(tmp_path, capsys, dim):
    code, _, err = dcdc(capsys, "scene", "show", scene_file(tmp_path, dim=dim))
    assert_one_line_error(code, err, "dim must be 2 or 3")


def test_show_resolution_inf(capsys):
    code, _, err = dcdc(capsys, "scene", "show", "lock_exchange", "--resolution", "inf")
    assert_one_line_error(code, err, "finite")


# ------------------------------------------------------------------ output paths
def _bad_places(tmp_path):
    (tmp_path / "afile").write_text("x")
    return {"read-only": (READ_ONLY / "x", "not writable"),
            "parent is a file": (tmp_path / "afile" / "x", "is a file"),
            "parent missing": (tmp_path / "missing" / "x", "does not exist")}


FILE_OUTPUTS = {  # command taking an output *file* -> argv with {out}
    "scene copy": ["scene", "copy", "lock_exchange", "{out}.toml"],
    "scene random -o": ["scene", "random", "--seed", "1", "-o", "{out}.toml"],
    "scene show --image": ["scene", "show", "lock_exchange", "--dim", "2", "--image", "{out}.png"],
    "scene random --image": ["scene", "random", "--seed", "1", "--image", "{out}.png"],
    "dataset merge": ["dataset", "merge", "{out}.h5", str(ROOT / "data/sample/test2d")],
}
DIR_OUTPUTS = {
    "generate": ["generate", "lock_exchange", "--simulator", "ballistic", "-o", "{out}"],
    "demo": ["demo", "--scene", "lock_exchange", "--out", "{out}"],
    "export-lagrangebench": ["dataset", "export-lagrangebench", "--train",
                             str(ROOT / "data/sample/train2d"), "-o", "{out}"],
}


@pytest.mark.parametrize("place", ["read-only", "parent is a file", "parent missing"])
@pytest.mark.parametrize("command", sorted(FILE_OUTPUTS))
def test_file_outputs_checked_first(tmp_path, capsys, command, place):
    out, words = _bad_places(tmp_path)[place]
    if place == "read-only" and not READ_ONLY.is_dir():
        pytest.skip("no read-only /sys here")
    argv = [a.format(out=out) for a in FILE_OUTPUTS[command]]
    code, _, err = dcdc(capsys, *argv)
    assert_one_line_error(code, err, words)


@pytest.mark.parametrize("place", ["read-only", "parent is a file"])
@pytest.mark.parametrize("command", sorted(DIR_OUTPUTS))
def test_dir_outputs_checked_first(tmp_path, capsys, command, place):
    out, words = _bad_places(tmp_path)[place]
    if place == "read-only" and not READ_ONLY.is_dir():
        pytest.skip("no read-only /sys here")
    argv = [a.format(out=out) for a in DIR_OUTPUTS[command]]
    code, _, err = dcdc(capsys, *argv)
    assert_one_line_error(code, err, words)


@pytest.mark.parametrize("command", ["scene copy", "scene random -o", "scene show --image"])
def test_existing_file_refused_unless_overwrite(tmp_path, capsys, command):
    out = tmp_path / "out"
    argv = [a.format(out=out) for a in FILE_OUTPUTS[command]]
    target = Path(next(a for a in argv if a.startswith(str(out))))
    target.write_text("precious")
    code, _, err = dcdc(capsys, *argv)
    assert_one_line_error(code, err, "exists", "--overwrite")
    assert target.read_text() == "precious"
    code, _, err = dcdc(capsys, *argv, "--overwrite")
    assert code == 0, err
    assert target.read_bytes() != b"precious"
    assert not list(tmp_path.glob(".*tmp*"))


@pytest.mark.parametrize("command", ["demo", "export-lagrangebench"])
def test_existing_output_dir_refused_unless_overwrite(tmp_path, capsys, command):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.gif").write_text("previous run")
    argv = [a.format(out=out) for a in DIR_OUTPUTS[command]]
    code, _, err = dcdc(capsys, *argv)
    assert_one_line_error(code, err, "exists", "--overwrite")
    assert (out / "old.gif").read_text() == "previous run"


def test_export_overwrite_replaces_the_whole_folder(tmp_path, capsys):
    out = tmp_path / "lb"
    out.mkdir()
    (out / "stale.h5").write_text("previous export")
    code, _, err = dcdc(capsys, "dataset", "export-lagrangebench", "--train",
                        ROOT / "data/sample/train2d", "-o", out, "--overwrite")
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["force.py", "metadata.json", "train.h5"]
    assert not list(tmp_path.glob(".*tmp*"))


# ------------------------------------------------------------------ damaged inputs
@pytest.mark.slow
def test_garbage_mesh_file(tmp_path, capsys):
    (tmp_path / "pillar.obj").write_bytes(np.random.default_rng(0).bytes(3000))
    shutil.copy(ROOT / "examples/my_scene.toml", tmp_path / "s.toml")
    code, _, err = dcdc(capsys, "scene", "show", tmp_path / "s.toml")
    assert_one_line_error(code, err, "pillar.obj")


@pytest.fixture
def dataset(tmp_path):
    from dcdc.data.generate import generate, random_jobs
    from dcdc.scene.random import RandomSceneConfig
    out = tmp_path / "ds"
    generate(random_jobs(2, 0, RandomSceneConfig(dim=2, max_ratio=4.0), duration=0.2), out,
             simulator="ballistic", progress=False)
    return out


def _flip_bits_in_chunk(path: Path, dataset: str, chunk: int = 3, n: int = 20):
    with h5py.File(path) as f:
        info = f[dataset].id.get_chunk_info(chunk)
    b = bytearray(path.read_bytes())
    for k in range(n):
        b[info.byte_offset + 5 + 3 * k] ^= 1 << (k % 8)
    path.write_bytes(bytes(b))


def test_flipped_bits_are_caught(dataset, capsys):
    _flip_bits_in_chunk(dataset / "random_0_2d.h5", "random_0_2d/position")
    code, out, err = dcdc(capsys, "dataset", "info", dataset, "--verify")
    assert_one_line_error(code, err, "corrupt", "random_0_2d")
    assert "1 checksummed and intact, 1 CORRUPT" in out
    for argv in (["dataset", "merge", dataset.parent / "m.h5", dataset],
                 ["dataset", "export-lagrangebench", "--train", dataset, "-o", dataset.parent / "lb"]):
        code, _, err = dcdc(capsys, *argv)
        assert_one_line_error(code, err, "corrupt")
    assert not (dataset.parent / "m.h5").exists() and not (dataset.parent / "lb").exists()


def test_damaged_header_is_one_line(dataset, capsys):
    p = dataset / "random_1_2d.h5"
    b = bytearray(p.read_bytes())
    b[8:24] = bytes(16)  # superblock
    p.write_bytes(bytes(b))
    code, _, err = dcdc(capsys, "dataset", "info", dataset)
    assert_one_line_error(code, err, "random_1_2d.h5", "not a readable HDF5 file")


def test_damaged_metadata_is_corrupt_not_unfinished(dataset, capsys):
    with h5py.File(dataset / "random_0_2d.h5", "r+") as f:
        f["random_0_2d"].attrs["radius"] = 0.026  # a flipped bit in an attribute
    code, _, err = dcdc(capsys, "dataset", "info", dataset)
    assert_one_line_error(code, err, "corrupt", "checksum")
    with h5py.File(dataset / "random_1_2d.h5", "r+") as f:
        del f["random_1_2d"].attrs["complete"]  # damage that looks like an unfinished run
    (dataset / "random_0_2d.h5").unlink()
    code, _, err = dcdc(capsys, "dataset", "info", dataset)
    assert_one_line_error(code, err, "corrupt", "random_1_2d")


@pytest.mark.parametrize("solver, words", [
    ('interfacial_model = "pairwise"\nwall_tension = { water = 1.0 }\n',
     ["wall_tension needs sph.interfacial_tension"]),
    ('interfacial_model = "pairwise"\nwall_tension = { milk = 1.0 }\n'
     '[solver.interfacial_tension]\n"water/water" = 1.0\n', ["two different phases"]),
    ('interfacial_model = "pairwise"\n[solver.interfacial_tension]\n"water/milk" = 1.0\n',
     ["names no phase 'milk'"]),
    ('wall_tension = { water = -1.0 }\n', ["wall_tension.water", ">= 0"]),
])
def test_tension_tables_are_checked_before_any_work(tmp_path, capsys, solver, words):
    """Interfacial and wall tensions name the scene's phases and need each other: a one-line
    error when the scene is read, before a dataset directory gets any file."""
    f = scene_file(tmp_path)
    f.write_text(f.read_text() + "\n[solver]\n" + solver)
    out = tmp_path / "ds"
    code, _, err = dcdc(capsys, "generate", f, "-o", out)
    assert_one_line_error(code, err, "[solver]", *words)
    assert not out.exists() or not any(out.iterdir())
