"""``dcdc scene import``: DeepLagrangianFluids and SPlisHSPlasH scene JSON as dcdc scenes —
what maps, one warning per unmappable item, one-line errors for bad input, and imported
scenes that run in dcdc's SPH solver as written (tiny resolution, a few frames)."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.scene import load
from dcdc.scene.importers import import_scene
from helpers import dcdc_output

DATA = Path(__file__).resolve().parent / "data"
SCENES, MODELS = DATA / "scenes", DATA / "models"
DLF = next((p for p in (Path(__file__).resolve().parents[2] / "shared/anchors/dlf",
                        Path("/work/shared/anchors/dlf")) if p.is_dir()), None)
needs_dlf = pytest.mark.skipif(DLF is None, reason="DLF anchor scene not present")


def imported(src: Path, tmp_path: Path, name="scene.toml"):
    """Import ``src`` to tmp_path/name; (result, loaded scene)."""
    out = tmp_path / name
    res = import_scene(src, out)
    out.write_text(res.text)
    return res, load(out)


def run_sph(scene, resolution=1.0, duration=0.1):
    """A short SPH run of the scene; the final system."""
    from dcdc.sph import Simulator
    system = scene.realize(resolution=resolution)
    sim = Simulator(system, scene.check_solver())
    sim.run(duration, scene.frame_dt)
    x = sim.system.x
    lo, hi = system.domain
    assert np.isfinite(x).all() and ((x >= lo) & (x <= hi)).all()
    return sim.system


# ------------------------------------------------------------------ DeepLagrangianFluids
@pytest.mark.slow
@needs_dlf
def test_dlf_example_imports_and_runs(tmp_path):
    """Their example scene: Box.obj becomes a mesh container, Fluid.obj a mesh block with
    the same 8 000 particles as dcdc.scene.importers.dlf.scene_system; the scene runs in SPH."""
    from dcdc.scene.importers.dlf import scene_system
    res, sc = imported(DLF / "example_scene.json", tmp_path)
    assert res.format == "DeepLagrangianFluids" and res.warnings == []
    assert sc.data["walls"]["Box"]["hollow"] is True
    f = sc.data["fluid"][0]
    assert f["shape"] == "mesh" and f["translate"] == [0, 1, 0] and f["velocity"] == [0.3, 0, 0.2]
    full = sc.realize()
    ref = scene_system(DLF / "example_scene.json")
    assert full.n_fluid == ref.n_fluid == 8000
    key = (lambda x: x[np.lexsort(np.round(x, 9).T[::-1])])
    assert np.allclose(key(full.x), key(ref.x))
    small = run_sph(sc, resolution=0.3)  # 216 fluid particles, 5 frames
    assert small.n_fluid == 216


@pytest.mark.slow
def test_dlf_emitter_and_open_wall(tmp_path):
    """A fluid released at frames 0, 10, 20 is a mesh emitter (0, 0.2, 0.4 s); an open wall
    whose normals face the fluid (invert_normals) is a shell behind its faces."""
    res, sc = imported(SCENES / "dlf_emitter.json", tmp_path)
    w = sc.data["walls"]
    assert w["UnitBox"]["hollow"] is True
    assert w["Sheet"]["thickness"] == pytest.approx(0.1) and w["Sheet"]["invert_normals"] is False
    e = sc.data["emitter"][0]
    assert (e["shape"], e["start"], e["interval"], e["stop"]) == ("mesh", 0.0, 0.2, 0.6)
    assert not sc.data["fluid"]
    s = sc.realize()
    births, counts = np.unique(s.birth, return_counts=True)
    assert np.allclose(births, [0.0, 0.2, 0.4]) and (counts == 64).all()
    inner = s.wall_x[(np.abs(s.wall_x[:, 0]) < 0.4) & (np.abs(s.wall_x[:, 2]) < 0.4)
                     & (s.wall_x[:, 1] > 0.1) & (s.wall_x[:, 1] < 0.9)]  # the sheet's shell, away from the tank
    assert len(inner) and (inner[:, 1] >= 0.2 - 1e-9).all() and (inner[:, 1] <= 0.3 + 1e-9).all()
    run_sph(sc)


# ------------------------------------------------------------------ SPlisHSPlasH
def test_splishsplash_multiphase_imports_and_runs(tmp_path):
    """Three materials → three phases; container, rotated obstacle, blocks, a mesh fluid
    model and a round emitter pointing down; one warning per unmappable item; it runs."""
    res, sc = imported(SCENES / "splash_multiphase.json", tmp_path)
    assert res.format == "SPlisHSPlasH"
    d = sc.data
    assert {k: p["density"] for k, p in d["phases"].items()} == {"heavy": 2000, "light": 1000, "oil": 700}
    assert d["phases"]["heavy"]["viscosity"] == 0.01 and d["phases"]["light"]["viscosity"] == 1e-6
    # no viscosityMethod, no viscosity: SPlisHSPlasH's default standard viscosity, 0.01
    assert d["phases"]["oil"]["viscosity"] == 0.01 and "(oil): SPlisHSPlasH applies its default" in res.text
    box, rock = d["walls"]["UnitBox"], d["walls"]["SmallCube"]
    assert box["hollow"] is True and box["scale"] == [0.5, 0.4, 0.3]
    assert rock["hollow"] is False and rock["rotation_degrees"] == pytest.approx(45)
    assert [f["shape"] for f in d["fluid"]] == ["box", "box", "mesh"]
    assert d["fluid"][1]["velocity"] == [-0.2, 0, 0]
    em = d["emitter"][0]
    assert np.allclose(em["direction"], [0, -1, 0]) and em["radius"] == pytest.approx(0.05)
    assert (em["start"], em["stop"], d["duration"]) == (0.0, 0.1, 0.1)
    assert d["solver"] == {"cfl": 0.4, "dt_max": 0.005, "max_iterations": 100,
                           "density_tolerance": 0.0005, "divergence_tolerance": 0.001,
                           "divergence_solve": True}
    text = "\n".join(res.warnings)
    for what in ("XSPH viscosity", "surface tension (method 2", "dynamic rigid body",
                 "AnimationFields[0]", "viewer and export settings not used: Configuration.pause",
                 "emitter housing (cylinder 0.225 x 0.225 x 0.225 m"):
        assert what in text
    assert len(res.warnings) == 6 and "unused" not in text
    assert all(f"# warning: {w}" in res.text for w in res.warnings)
    s = sc.realize()
    # SPlisHSPlasH's blocks: round(L/2r) - 1 per axis, 2·2·5; the oil's mesh 2·2·4
    assert s.counts_per_phase() == {"heavy": 20, "light": 20 + 10, "oil": 16}
    assert (s.birth > 0).sum() == 5  # the emitter's second layer
    run_sph(sc)
    assert sc.realize(dim=2).n_fluid > 0  # its z = 0 section too


def test_splishsplash_other_mappings(tmp_path):
    """Particle boundaries without mapInvert: the container side from the fluid; WCSPH;
    a particle-file fluid model is reported; a 3 x 2 box emitter is a box nozzle of 3 x 2
    particles; maxEmitterParticles caps it at whole layers."""
    models = tmp_path / "models"
    shutil.copytree(MODELS, models)
    scene = {
        "Configuration": {"simulationMethod": 0, "exponent": 7, "stiffness": 1000,
                          "boundaryHandlingMethod": 0, "cflFactor": 3, "maxIterationsV": 50,
                          "density0": 1200, "particleRadius": 0.025},
        "RigidBodies": [{"geometryFile": "models/UnitBox.obj", "scale": 1, "translation": [0, 0.5, 0]}],
        "FluidBlocks": [{"start": [-0.5, 0, -0.5], "end": [0, 0.2, 0.5]}],
        "FluidModels": [{"particleFile": "models/bunny.bgeo"}],
        "Emitters": [{"width": 3, "height": 2, "translation": [0.2, 0.5, 0], "velocity": 1,
                      "rotationAxis": [0, 0, 1], "rotationAngle": 3.141592653589793}],
        "Fluid": {"maxEmitterParticles": 20, "viscosity": 0.001, "viscosityMethod": 7},
    }
    src = tmp_path / "other.json"
    src.write_text(json.dumps(scene))
    res, sc = imported(src, tmp_path)
    d = sc.data
    assert d["walls"]["UnitBox"]["hollow"] is True
    assert d["solver"]["solver"] == "wcsph" and d["solver"]["boundary"] == "particles"
    assert d["solver"]["stiffness_exponent"] == 7 and d["solver"]["cfl"] == 1.0
    assert d["phases"] == {"Fluid": {"density": 1200, "viscosity": 0.001,
                                     "color": d["phases"]["Fluid"]["color"]}}
    em = d["emitter"][0]
    assert np.allclose(em["direction"], [-1, 0, 0]) and em["stop"] < 2.0
    assert (em["shape"], em["width"], em["height"], em["up"]) == ("box", 0.15, 0.1, None)
    assert "domain" not in res.scene and sc.data["domain"] is None  # derived: the tank
    text = "\n".join(res.warnings)
    for what in ("Configuration.stiffness", "cflFactor 3", "maxIterationsV 50", "bunny.bgeo",
                 "viscosity method 7"):
        assert what in text
    assert "nozzle" not in text
    s = sc.realize()
    # the block (round(L/2r) - 1 per axis); 3 layers of 3 x 2 (maxEmitterParticles 20)
    assert s.n_fluid == 9 * 3 * 19 + 18
    assert np.allclose(np.unique(s.birth), [0.0, 0.05, 0.1])
    layer = s.x[s.birth == 0.05]
    assert np.allclose(layer[:, 0], 0.2) and np.allclose(np.ptp(layer[:, 1:], axis=0), [0.05, 0.1])
    assert np.allclose(s.meta["scene_domain"], [[-0.5, 0, -0.5], [0.5, 1, 0.5]])


def test_splishsplash_sim2d_scene_is_2d(tmp_path):
    """Configuration.sim2D: a 2-D dcdc scene in the plane z = 0. As in SPlisHSPlasH, every
    emitter turns about z and is a segment: a box of height h particles (its width is
    ignored), a circle of width w particles; no domain is written (derived: the tank)."""
    models = tmp_path / "models"
    shutil.copytree(MODELS, models)
    scene = {
        "Configuration": {"sim2D": True, "particleRadius": 0.025, "gravitation": [0, -9.81, 0],
                          "stopAt": 0.1},
        "RigidBodies": [{"geometryFile": "models/UnitBox.obj", "translation": [0, 0.5, 0],
                         "scale": [1, 1, 0.2], "mapInvert": True}],
        "FluidBlocks": [{"start": [-0.5, 0, -0.1], "end": [-0.2, 0.2, 0.1],
                         "initialVelocity": [0.5, 0, 0]}],
        "Emitters": [{"type": 0, "width": 8, "height": 3, "translation": [-0.3, 0.6, 0],
                      "velocity": 1, "emitEndTime": 0.05},
                     {"type": 1, "width": 4, "translation": [0.3, 0.6, 0], "velocity": 1,
                      "rotationAxis": [0, 1, 0], "rotationAngle": 3.141592653589793,
                      "emitEndTime": 0.05}],
    }
    src = tmp_path / "flat.json"
    src.write_text(json.dumps(scene))
    res, sc = imported(src, tmp_path)
    d = sc.data
    assert d["dim"] == 2 and d["gravity"] == [0, -9.81] and d["domain"] is None
    assert d["fluid"][0]["min"] == [-0.5, 0] and d["fluid"][0]["velocity"] == [0.5, 0]
    box, circle = d["emitter"]
    assert (box["shape"], box["height"], box["width"], box["position"]) == ("box", 0.15, None, [-0.3, 0.6])
    assert (circle["shape"], circle["height"]) == ("box", 0.2)
    assert np.allclose(box["direction"], [1, 0]) and np.allclose(circle["direction"], [-1, 0])
    assert not any("sim2D" in w for w in res.warnings) and "sim2D" in res.text
    assert "domain" not in res.text.split("[phases")[0]
    s = sc.realize()
    assert s.dim == 2 and np.allclose(s.meta["scene_domain"], [[-0.5, 0], [0.5, 1]])
    assert (s.birth == 0).sum() == 5 * 3 + 3 + 4  # the block, one layer of each nozzle
    first = s.x[s.birth == 0]
    assert np.allclose(np.sort(first[np.isclose(first[:, 0], 0.3), 1]), [0.525, 0.575, 0.625, 0.675])
    run_sph(sc)


def test_splishsplash_box_emitter_keeps_its_orientation(tmp_path):
    """A box emitter turned about its jet (x) keeps its height side: ``up`` is written."""
    scene = {"FluidBlocks": [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2]}],
             "Emitters": [{"type": 0, "width": 4, "height": 2, "translation": [0.5, 0.5, 0.5],
                           "rotationAxis": [1, 0, 0], "rotationAngle": 1.5707963267948966}]}
    src = tmp_path / "turned.json"
    src.write_text(json.dumps(scene))
    res, sc = imported(src, tmp_path)
    em = sc.data["emitter"][0]
    assert np.allclose(em["direction"], [1, 0, 0]) and np.allclose(em["up"], [0, 0, 1])
    assert sc.data["solver"]["on_escape"] == "remove"  # no container: an open scene
    s = sc.realize()
    layer = s.x[(s.birth == 0) & np.isclose(s.x[:, 0], 0.5)]  # the first layer, 4 x 2
    assert len(layer) == 8 and np.allclose(np.ptp(layer, axis=0), [0, 0.15, 0.05])


def test_splishsplash_method_blocks_and_blocks_in_walls(tmp_path):
    """Newer files: the chosen pressure solver's and force methods' blocks are read (other
    solvers' blocks are unused); a block reaching into a solid becomes a fill of its box
    inside the container, a block mostly in a solid is left out, one warning each."""
    scene = {"Configuration": {"particleRadius": 0.025, "simulationMethod": 4, "boundaryHandlingMethod": 0,
                               "DFSPH": {"minIterations": 2, "maxIterations": 50, "maxError": 0.05},
                               "WCSPH": {"stiffness": 50000, "exponent": 7}},
             "Materials": [{"id": "a", "viscosityMethod": 1, "Standard viscosity": {"viscosity": 0.02},
                            "Weiler et al. 2018": {"viscosity": 5}},
                           {"id": "b", "density0": 500, "vorticityMethod": 1,
                            "Bender et al. 2017": {"vorticity": 0.1, "viscosityOmega": 0.05}}],
             "RigidBodies": [{"geometryFile": BOX}, {"geometryFile": CUBE, "translation": [0, -0.4, 0]}],
             "FluidBlocks": [{"id": "a", "start": [-0.45, -0.45, -0.45], "end": [-0.1, 0.0, 0.45]},
                             {"id": "b", "start": [-0.05, -0.45, -0.1], "end": [0.3, -0.2, 0.1]},
                             {"id": "b", "start": [-0.1, -0.5, -0.1], "end": [0.1, -0.3, 0.1]}]}
    src = tmp_path / "blocks.json"
    src.write_text(json.dumps(scene))
    res, sc = imported(src, tmp_path)
    d = sc.data
    assert d["solver"]["max_iterations"] == 50 and d["solver"]["density_tolerance"] == pytest.approx(5e-4)
    assert d["phases"]["a"]["viscosity"] == 0.02 and d["phases"]["b"]["density"] == 500
    assert d["walls"]["UnitBox"]["hollow"] is True and d["walls"]["SmallCube"]["hollow"] is False
    assert [(f["shape"], f.get("inside")) for f in d["fluid"]] == [("box", None), ("fill", "UnitBox")]
    w = "\n".join(res.warnings)
    assert "vorticity (method 1, coefficient 0.1) not mapped" in w
    assert "FluidBlocks[1]: reaches into RigidBodies[1] (SmallCube.obj)" in w
    assert "FluidBlocks[2]: lies mostly in RigidBodies[1] (SmallCube.obj)" in w and "left out" in w
    assert sc.realize().n_fluid > 0


def _multiphase(path: Path) -> bool:
    """A SPlisHSPlasH scene whose fluid items use two or more material ids."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    if not isinstance(data, dict):
        return False
    items = [x for k in ("FluidBlocks", "FluidModels", "Emitters") for x in data.get(k, [])
             if isinstance(x, dict)]
    return len({x.get("id", "Fluid") for x in items}) > 1


def _shipped_scene_folders():
    """SPlisHSPlasH ``Scenes`` folders to test, without importing pysplishsplash (its import
    can crash the process): those under ``$DCDC_SPLISHSPLASH_DATA`` (a SPlisHSPlasH ``data/``
    folder), failing that the ones the installed pysplishsplash distribution lists (its
    wheel installs ``<prefix>/bin/data/Scenes``); (folders, where they were looked for)."""
    import importlib.metadata
    import os
    tried = []
    env = os.environ.get("DCDC_SPLISHSPLASH_DATA")
    if env:
        root = Path(env).expanduser()
        folders = sorted({p.parent for p in root.rglob("*.json") if p.parent.name == "Scenes"})
        if folders:
            return folders, f"DCDC_SPLISHSPLASH_DATA={root}"
        tried.append(f"DCDC_SPLISHSPLASH_DATA={root} (no Scenes/*.json under it)")
    else:
        tried.append("DCDC_SPLISHSPLASH_DATA (unset)")
    try:
        files = importlib.metadata.distribution("pysplishsplash").files or []
    except importlib.metadata.PackageNotFoundError:
        files = None
    folders = sorted({Path(f.locate()).resolve().parent for f in files or []
                      if f.suffix == ".json" and f.parent.name == "Scenes"})
    folders = [p for p in folders if p.is_dir()]
    if folders:
        return folders, "the installed pysplishsplash distribution's files"
    tried.append("pysplishsplash " + ("(not installed)" if files is None else "(its files list no Scenes)"))
    return [], ", ".join(tried)


def test_shipped_splishsplash_multiphase_scenes(tmp_path):
    """Every multiphase scene in SPlisHSPlasH's data/Scenes imports, validates and realizes.
    Set DCDC_SPLISHSPLASH_DATA=path/to/SPlisHSPlasH/data, or install pysplishsplash."""
    folders, where = _shipped_scene_folders()
    if not folders:
        pytest.skip(f"no SPlisHSPlasH data/Scenes folder: tried {where}; set "
                    "DCDC_SPLISHSPLASH_DATA=path/to/SPlisHSPlasH/data")
    scenes = [p for f in folders for p in sorted(f.glob("*.json")) if _multiphase(p)]
    if not scenes:
        pytest.skip(f"no multiphase scenes (fluid items of 2+ material ids) in "
                    f"{', '.join(map(str, folders))} ({where})")
    for p in scenes:
        res, sc = imported(p, tmp_path, p.stem + ".toml")
        assert sc.dim in (2, 3) and sc.data["phases"], p.name
        assert sc.realize(resolution=0.3).n_fluid > 0, p.name


# ------------------------------------------------------------------ command line, errors
def test_cli_writes_toml_and_one_warning_line_per_item(tmp_path, capsys):
    out = tmp_path / "s.toml"
    code, stdout, err = dcdc_output(["scene", "import", SCENES / "splash_multiphase.json", "-o", out],
                                    capsys)
    assert code == 0 and out.exists()
    lines = err.strip().splitlines()
    assert sum(ln.startswith("warning: ") for ln in lines) == 6
    assert lines[-1].startswith(f"wrote {out} (SPlisHSPlasH scene: 2 wall(s), 3 fluid block(s), 1 emitter")
    assert "../models/UnitBox.obj" not in out.read_text()  # two levels up: absolute
    code, _, err = dcdc_output(["scene", "import", SCENES / "splash_multiphase.json", "-o", out], capsys)
    assert code == 2 and "exists (use --overwrite" in err
    code, stdout, _ = dcdc_output(["scene", "import", SCENES / "dlf_emitter.json"], capsys)
    assert code == 0 and str(MODELS / "UnitBox.obj") in stdout


def _bad(tmp_path, name, content):
    p = tmp_path / name
    p.write_text(content if isinstance(content, str) else json.dumps(content))
    return p


BOX = str(MODELS / "UnitBox.obj")
CUBE = str(MODELS / "SmallCube.obj")
SHEET = str(MODELS / "Sheet.obj")
DLF_OK = {"walls": [{"path": BOX}], "fluids": [{"path": CUBE, "translation": [0, 0.1, 0]}]}


@pytest.mark.parametrize("content, match", [
    ("{not json", r"not valid JSON \(Expecting property name"),
    ({"objects": []}, r"neither a DeepLagrangianFluids scene .* nor a SPlisHSPlasH scene"),
    ([1, 2], r"neither a DeepLagrangianFluids scene"),
    ({**DLF_OK, "camera": 1}, r"the scene: unknown key 'camera'"),
    ({"walls": [{"paht": BOX}], "fluids": DLF_OK["fluids"]}, r"walls\[0\]: unknown key 'paht'"),
    ({"walls": [{"path": "nope.obj"}], "fluids": DLF_OK["fluids"]}, r"mesh nope.obj of the scene not found"),
    ({"walls": DLF_OK["walls"], "fluids": [{"path": SHEET}]}, r"fluids\[0\]: mesh .*Sheet.obj is not a closed"),
    ({"walls": DLF_OK["walls"], "fluids": [{"path": CUBE, "step": 0}]}, r"fluids\[0\]\.step must be >= 1"),
    ({"walls": DLF_OK["walls"], "fluids": [{"path": CUBE, "velocity": [1, 2]}]},
     r"fluids\[0\]\.velocity must be a list of 3 numbers"),
    ({"FluidBlocks": [{"start": [0, 0, 0], "end": [1, 1, 1]}], "Cameras": {}},
     r"unknown top-level key 'Cameras'"),
    ({"RigidBodies": [{"geometryFile": BOX, "mapInvrt": True}]}, r"RigidBodies\[0\]: unknown key 'mapInvrt'"),
    ({"RigidBodies": [{"geometryFile": "missing.obj"}]}, r"RigidBodies\[0\]: mesh file .*missing.obj not found"),
    ({"FluidBlocks": [{"start": "origin", "end": [1, 1, 1]}]}, r"FluidBlocks\[0\]\.start must be a list of 3"),
    ({"FluidModels": [{"particleFile": SHEET}]}, r"FluidModels\[0\]: mesh .*Sheet.obj is not a closed surface"),
    ({"Configuration": {"maxError": 0}, "FluidBlocks": [{"start": [0, 0, 0], "end": [1, 1, 1]}]},
     r"Configuration\.maxError must be > 0"),
    ({"Materials": [{"id": "Fluid", "density0": -1}], "FluidBlocks": [{"start": [0, 0, 0], "end": [1, 1, 1]}]},
     r"Materials\[0\]\.density0 must be > 0"),
    ({"Configuration": {"sim2D": True}, "Emitters": [{"direction": [0, 0, 1]}]},
     r"Emitters\[0\] jets along z, out of the plane of a 2-D scene"),
])
def test_bad_input_is_one_line_error(tmp_path, capsys, content, match):
    src = _bad(tmp_path, "bad.json", content)
    with pytest.raises(DcdcError, match=match):
        import_scene(src, tmp_path / "out.toml")
    code, out, err = dcdc_output(["scene", "import", src, "-o", tmp_path / "out.toml"], capsys)
    assert code == 2 and err.startswith("error: bad.json: ") and err.count("\n") == 1
    assert "Traceback" not in err and not (tmp_path / "out.toml").exists()


def test_missing_json_file(tmp_path, capsys):
    code, _, err = dcdc_output(["scene", "import", tmp_path / "none.json"], capsys)
    assert code == 2 and err.startswith("error: ") and "no such file" in err
