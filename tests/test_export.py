import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.render.export import write_points


PLY_TYPES = {"float": "<f4", "int": "<i4", "uchar": "u1"}


def _read_ply(path):
    """(property names, PLY types, structured vertex table) of a binary PLY."""
    raw = open(path, "rb").read()
    head, body = raw.split(b"end_header\n", 1)
    props = [l.split()[1:] for l in head.splitlines() if l.startswith(b"property")]
    names, types = [p[1].decode() for p in props], [p[0].decode() for p in props]
    n = int([l for l in head.splitlines() if l.startswith(b"element vertex")][0].split()[-1])
    table = np.frombuffer(body, dtype=[(k, PLY_TYPES[t]) for k, t in zip(names, types)], count=n)
    return names, types, table


@pytest.mark.parametrize("dim", [2, 3])
def test_ply_roundtrip(tmp_path, dim):
    rng = np.random.default_rng(0)
    x = rng.normal(size=(50, dim))
    v = rng.normal(size=(50, dim))
    phase = rng.integers(0, 4, 50)
    names, types, table = _read_ply(write_points(tmp_path / "f.ply", x, {"velocity": v, "phase": phase}))
    assert names == ["x", "y", "z", "velocity_x", "velocity_y", "velocity_z", "phase"]
    assert types == ["float"] * 6 + ["int"]   # integer fields stay integers
    np.testing.assert_allclose(np.stack([table["x"], table["y"]], 1), x[:, :2], rtol=1e-6)
    np.testing.assert_allclose(table["velocity_y"], v[:, 1], rtol=1e-6)
    np.testing.assert_array_equal(table["phase"], phase)
    if dim == 2:
        assert np.all(table["z"] == 0)
    else:
        np.testing.assert_allclose(table["z"], x[:, 2], rtol=1e-6)


def test_vtk_layout(tmp_path):
    x = np.arange(12, dtype=float).reshape(4, 3)
    path = write_points(tmp_path / "f.vtk", x, {"density": np.array([1.0, 2, 3, 4])})
    raw = path.read_bytes()
    i = raw.index(b"POINTS 4 float\n") + len(b"POINTS 4 float\n")
    np.testing.assert_array_equal(np.frombuffer(raw[i:i + 48], ">f4").reshape(4, 3), x)
    j = raw.index(b"LOOKUP_TABLE default\n") + len(b"LOOKUP_TABLE default\n")
    np.testing.assert_array_equal(np.frombuffer(raw[j:j + 16], ">f4"), [1, 2, 3, 4])
    assert not list(tmp_path.glob("*.part"))


def test_bad_export_input(tmp_path):
    with pytest.raises(DcdcError, match="unknown point-cloud format"):
        write_points(tmp_path / "f.xyz", np.zeros((2, 3)))
    with pytest.raises(DcdcError, match="field 'a' has 3 values for 2"):
        write_points(tmp_path / "f.ply", np.zeros((2, 3)), {"a": np.zeros(3)})
    with pytest.raises(DcdcError, match="int32 range"):
        write_points(tmp_path / "f.ply", np.zeros((2, 3)), {"a": np.array([0, 2**40])})


# ----------------------------------------------------------------- dcdc export (whole runs)
import xml.etree.ElementTree as ET  # noqa: E402

from dcdc.render.figures import open_trajectory  # noqa: E402
from helpers import dcdc_exit as _cli  # noqa: E402

SAMPLE = "data/sample/test2d/hourglass_2d.h5"


def test_export_vtu_series_reads_back_with_meshio(tmp_path):
    meshio = pytest.importorskip("meshio")
    traj = open_trajectory(SAMPLE)
    out = tmp_path / "vtk"
    assert _cli("export", SAMPLE, "--format", "vtk", "--frames", "0:30", "--stride", 10,
                "--out", out, "--no-progress") == 0
    pvd = ET.parse(out / "hourglass_2d.pvd").getroot()
    sets = pvd.findall("./Collection/DataSet")
    frames = [d.get("file") for d in sets if d.get("part") == "0"]
    assert frames == ["frame_00000.vtu", "frame_00010.vtu", "frame_00020.vtu"]
    times = [float(d.get("timestep")) for d in sets if d.get("part") == "0"]
    np.testing.assert_allclose(times, traj.time[[0, 10, 20]])
    assert all(d.get("file") == "walls.vtu" for d in sets if d.get("part") == "1")
    m = meshio.read(out / "frame_00010.vtu")
    np.testing.assert_allclose(m.points[:, :2], traj.position[10], rtol=1e-6)
    assert np.all(m.points[:, 2] == 0)
    np.testing.assert_array_equal(m.point_data["phase"].ravel(), traj.phase)
    np.testing.assert_allclose(m.point_data["density"].ravel(), traj.density)
    np.testing.assert_allclose(m.point_data["velocity"][:, :2], traj.velocity[10], rtol=1e-6)
    assert m.cells[0].type == "vertex" and len(m.cells[0].data) == traj.n_particles
    w = meshio.read(out / "walls.vtu")
    np.testing.assert_allclose(w.points[:, :2], traj.wall_x, rtol=1e-6)
    np.testing.assert_allclose(w.point_data["normal"][:, :2], traj.wall_n, rtol=1e-6)


def test_export_ply_frames_read_back_with_meshio(tmp_path):
    meshio = pytest.importorskip("meshio")
    traj = open_trajectory(SAMPLE)
    out = tmp_path / "ply"
    assert _cli("export", SAMPLE, "--format", "ply", "--frames", "-1:", "--out", out,
                "--no-progress") == 0
    assert sorted(p.name for p in out.iterdir()) == ["frame_00050.ply", "walls.ply"]
    m = meshio.read(out / "frame_00050.ply")
    np.testing.assert_allclose(m.points[:, :2], traj.position[-1], rtol=1e-6)
    np.testing.assert_array_equal(m.point_data["phase"], traj.phase)
    np.testing.assert_array_equal(m.point_data["id"], np.arange(traj.n_particles))
    np.testing.assert_allclose(m.point_data["velocity_y"], traj.velocity[-1][:, 1], rtol=1e-6)
    red = m.point_data["red"].astype(np.uint8)  # meshio reads uchar as int8
    want = np.round(np.array([p.color for p in traj.phases])[traj.phase, 0] * 255)
    np.testing.assert_array_equal(red, want)


def test_export_ply_types_and_normals_read_back_with_trimesh(tmp_path):
    """Ids int32, phases uchar, wall normals nx ny nz: as trimesh's PLY reader parses them
    (and our own header reader)."""
    trimesh = pytest.importorskip("trimesh")
    traj = open_trajectory(SAMPLE)
    out = tmp_path / "ply"
    assert _cli("export", SAMPLE, "--format", "ply", "--frames", "20:21", "--out", out,
                "--no-progress") == 0
    frame = trimesh.load(out / "frame_00020.ply")
    v = frame.metadata["_ply_raw"]["vertex"]["data"]
    assert v.dtype["id"] == np.dtype("<i4") and v.dtype["phase"] == np.dtype("u1")
    assert v.dtype["density"] == np.dtype("<f4") and v.dtype["red"] == np.dtype("u1")
    np.testing.assert_array_equal(v["id"], np.arange(traj.n_particles))
    np.testing.assert_array_equal(v["phase"], traj.phase)
    np.testing.assert_allclose(frame.vertices[:, :2], traj.position[20], rtol=1e-6)
    names, types, _ = _read_ply(out / "frame_00020.ply")
    assert dict(zip(names, types))["id"] == "int" and dict(zip(names, types))["phase"] == "uchar"
    walls = trimesh.load(out / "walls.ply")
    w = walls.metadata["_ply_raw"]["vertex"]["data"]
    assert [k for k in w.dtype.names if k.startswith("n")] == ["nx", "ny", "nz"]
    assert not any(k.startswith("normal") for k in w.dtype.names)
    np.testing.assert_allclose(np.stack([w["nx"], w["ny"]], 1), traj.wall_n, rtol=1e-6)
    assert np.all(w["nz"] == 0)


def test_export_skips_unborn_particles(tmp_path):
    meshio = pytest.importorskip("meshio")
    from dcdc.render.export import export_trajectory

    class Late:  # a trajectory whose particle 0 is emitted after frame 0
        def __init__(self, t):
            self.t = t

        def __getattr__(self, k):
            return getattr(self.t, k)

        @property
        def birth(self):
            b = self.t.birth.copy()
            b[0] = 0.5
            return b

    traj = Late(open_trajectory(SAMPLE))
    export_trajectory(traj, "vtk", tmp_path, [0, 30])
    assert len(meshio.read(tmp_path / "frame_00000.vtu").points) == traj.n_particles - 1
    assert len(meshio.read(tmp_path / "frame_00030.vtu").points) == traj.n_particles


def test_export_refuses_existing_and_unknown(tmp_path, capsys):
    out = tmp_path / "e"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    for args, msg in [(("export", SAMPLE, "--format", "ply", "--out", out), "exists"),
                      (("export", SAMPLE, "--format", "ply", "--out", out, "--overwrite"), "holds other things"),
                      (("export", tmp_path / "no.h5", "--format", "vtk", "--out", tmp_path / "f"), "no such")]:
        assert _cli(*args) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and msg in err[0]
    assert (out / "keep.txt").exists()


MESH_SCENE = """name = "meshy"
dim = 3
[domain]
min = [-1.0, -1.0, -1.0]
max = [1.0, 1.0, 1.0]
[phases.a]
density = 1000.0
[walls.rock]
shape = "mesh"
file = "asset:rock.obj"
scale = 0.5
translate = [0.1, 0.2, 0.0]
[[fluid]]
phase = "a"
shape = "box"
min = [-0.5, 0.5, -0.5]
max = [0.5, 0.9, 0.5]
"""


def test_mesh_walls_exported_as_surfaces(tmp_path):
    """A scene with a mesh wall: the export holds the mesh as simulated (file, scale and
    translation of the stored scene, times the trajectory's resolution)."""
    meshio = pytest.importorskip("meshio")
    from importlib import resources

    from dcdc.geometry.shapes import load_mesh
    from dcdc.render.benchmark import block_trajectory
    from dcdc.render.export import export_trajectory

    path = block_trajectory(tmp_path / "m.h5", 3, 60, frames=2,
                            attrs={"scene_toml": MESH_SCENE, "resolution": 2.0, "source": "meshy"})
    traj = open_trajectory(path)
    want = load_mesh(resources.files("dcdc").joinpath("assets", "rock.obj"), 1.0, [0.2, 0.4, 0.0])
    export_trajectory(traj, "vtk", tmp_path / "v")
    m = meshio.read(tmp_path / "v" / "walls_mesh_rock.vtu")
    np.testing.assert_allclose(m.points, want.vertices, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(m.cells_dict["triangle"], want.faces)
    parts = {d.get("part") for d in ET.parse(tmp_path / "v" / "block.pvd").getroot().iter("DataSet")
             if d.get("file") == "walls_mesh_rock.vtu"}
    assert parts == {"2"}
    export_trajectory(traj, "ply", tmp_path / "p")
    m = meshio.read(tmp_path / "p" / "walls_mesh_rock.ply")
    np.testing.assert_array_equal(m.cells_dict["triangle"], want.faces)
    # a mesh that cannot be found is reported, the rest is exported
    notes = []
    lost = block_trajectory(tmp_path / "l.h5", 3, 60, frames=1,
                            attrs={"scene_toml": MESH_SCENE.replace("asset:rock.obj", "gone.obj")})
    export_trajectory(open_trajectory(lost), "ply", tmp_path / "q", warn=notes.append)
    assert len(notes) == 1 and "gone.obj not found" in notes[0]
    assert (tmp_path / "q" / "walls.ply").exists()


def test_missing_mesh_in_scene_without_domain_is_named(tmp_path):
    """A stored scene without [domain] (dcdc derives it from walls and fluid) whose wall
    mesh is missing: the note names that mesh, not the whole scene as unreadable; the
    trajectory's wall particles are still exported."""
    from dcdc.render.benchmark import block_trajectory
    from dcdc.render.export import export_trajectory
    from dcdc.render.walls import wall_meshes

    text = MESH_SCENE.replace("[domain]\nmin = [-1.0, -1.0, -1.0]\nmax = [1.0, 1.0, 1.0]\n", "")
    assert "[domain]" not in text
    lost = block_trajectory(tmp_path / "l.h5", 3, 60, frames=1,
                            attrs={"scene_toml": text.replace("asset:rock.obj", "gone.obj")})
    meshes, notes = wall_meshes(open_trajectory(lost))
    assert meshes == [] and len(notes) == 1
    assert "wall rock: mesh gone.obj not found" in notes[0] and "unreadable" not in notes[0]
    notes = []
    export_trajectory(open_trajectory(lost), "ply", tmp_path / "q", warn=notes.append)
    assert len(notes) == 1 and "gone.obj not found" in notes[0]
    assert (tmp_path / "q" / "walls.ply").exists()
    kept = block_trajectory(tmp_path / "k.h5", 3, 60, frames=1, attrs={"scene_toml": text})
    meshes, notes = wall_meshes(open_trajectory(kept))
    assert [m.name for m in meshes] == ["rock"] and notes == []
