import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.scene import SHOWCASES, builtin_names, get_scene, load, parse
from dcdc.scene.random import RandomSceneConfig, random_scene, random_scene_text

ROOT = Path(__file__).resolve().parents[1]

MINIMAL = """\
name = "t"
dim = 2
duration = 0.1

[domain]
min = [0.0, 0.0]
max = [1.0, 1.0]

[phases.water]
density = 1000

[phases.oil]
density = 800

[walls.tank]
shape = "box"
min = [0.0, 0.0]
max = [1.0, 1.0]
hollow = true

[[fluid]]
phase = "water"
shape = "box"
min = [0.0, 0.0]
max = [0.5, 0.3]

[[fluid]]
phase = "oil"
shape = "box"
min = [0.5, 0.0]
max = [1.0, 0.3]
velocity = [0.0, 0.5]
"""


def cli(*args):
    return subprocess.run([sys.executable, "-m", "dcdc.cli", *args], capture_output=True, text=True,
                          cwd=ROOT)


def test_minimal_scene_realises():
    s = parse(MINIMAL).realize()
    assert s.dim == 2 and s.n_fluid == 10 * 6 * 2
    assert s.counts_per_phase() == {"water": 60, "oil": 60}
    assert np.allclose(s.v[s.phase == 1], [0, 0.5])
    # the fluid lattice sits half a spacing from the walls, wall particles half a spacing inside
    assert np.isclose(s.x[:, 1].min(), 0.025)
    assert np.isclose(np.abs(s.wall_x[s.wall_x[:, 1] < 0][:, 1]).min(), 0.025)


@pytest.mark.parametrize("edit,msg", [
    (("density = 800", "density = -800"), "phases.oil.density must be > 0 (got -800) (line 13)"),
    (("density = 800", "density = 800\ndensty = 3"), "phases.oil.densty is not a known key"),
    (('phase = "oil"', 'phase = "olive"'), "fluid[1].phase names no phase"),
    (('shape = "box"\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]', 'shape = "cube"\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]'),
     "walls.tank.shape must be one of"),
    (("dim = 2", "dim = 4"), "dim must be 2 or 3"),
    (("max = [0.5, 0.3]", "max = [0.5, 0.3, 1.0]"), "fluid[0].max must be a list of 2 numbers"),
    (("duration = 0.1", "duration = 0.1\nfoo = 1"), "foo is not a known key"),
])
def test_validation_names_field_and_line(edit, msg):
    with pytest.raises(DcdcError) as e:
        parse(MINIMAL.replace(*edit), "t.toml")
    assert msg in str(e.value), str(e.value)
    assert "\n" not in str(e.value)


def test_solver_table_is_checked():
    sc = parse(MINIMAL + "\n[solver]\ncfl = 0.3\n")
    assert sc.check_solver().cfl == 0.3
    with pytest.raises(DcdcError, match=r"\[solver\]: unknown sph setting 'cfll'"):
        parse(MINIMAL + "\n[solver]\ncfll = 0.3\n").check_solver()


def test_line_numbers_point_at_the_field():
    with pytest.raises(DcdcError, match=r"fluid\[1\]\.velocity .* \(line 32\)"):
        parse(MINIMAL.replace("velocity = [0.0, 0.5]", "velocity = [0.0, 'x']"), "t.toml")


def test_overlap_inside_wall_and_outside_domain_are_reported():
    over = MINIMAL.replace("min = [0.5, 0.0]\nmax = [1.0, 0.3]", "min = [0.4, 0.0]\nmax = [1.0, 0.3]")
    with pytest.raises(DcdcError, match=r"fluid\[1\] \(oil\) overlaps fluid\[0\]"):
        parse(over).realize()
    inside = MINIMAL.replace('[[fluid]]\nphase = "water"', '[walls.rock]\nshape = "sphere"\n'
                             'center = [0.25, 0.1]\nradius = 0.1\n\n[[fluid]]\nphase = "water"')
    with pytest.raises(DcdcError, match=r"inside or touching walls.rock"):
        parse(inside).realize()
    out = MINIMAL.replace("max = [0.5, 0.3]", "max = [0.5, 1.3]")
    with pytest.raises(DcdcError, match="outside the domain"):
        parse(out).realize()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cocktail", "canyon"])
def test_stacked_fills_share_a_face_plane_once(name):
    """At resolution 0.5 a layer face of these scenes lies on a lattice plane that both
    stacked fills would take; it goes to the block listed first, with no duplicate points
    and no phase left empty (was refused as an overlap)."""
    for dim in (2, 3):
        p = get_scene(name).realize(dim=dim, resolution=0.5)
        assert len(np.unique(p.x.round(9), axis=0)) == len(p.x)
        assert set(np.unique(p.phase)) == set(range(len(p.phases)))
        full = get_scene(name).realize(dim=dim, resolution=1.0)
        assert 0 < len(p.x) < len(full.x)


def scene_with_mesh_wall(tmp_path, wall_fields: str) -> Path:
    """MINIMAL plus a mesh wall ``walls.m`` with the given TOML fields, written to a file."""
    text = MINIMAL.replace('[[fluid]]\nphase = "water"', '[walls.m]\nshape = "mesh"\n' + wall_fields
                           + '\n\n[[fluid]]\nphase = "water"')
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_missing_mesh_file_is_reported(tmp_path):
    p = scene_with_mesh_wall(tmp_path, 'file = "nope.obj"')
    with pytest.raises(DcdcError, match=r"walls.m.file: mesh file .*nope.obj not found"):
        load(p).realize()


def test_example_scene_with_mesh_and_emitter():
    sc = load(ROOT / "examples" / "my_scene.toml")
    s3 = sc.realize()
    assert s3.dim == 3 and (s3.birth > 0).any() and s3.n_wall > 0
    s2 = sc.realize(dim=2)
    assert s2.dim == 2 and s2.n_fluid > 0
    # emitted particles are born in layers between start and stop at the nozzle velocity
    born = s3.birth[s3.birth > 0]
    e = sc.data["emitter"][0]
    assert born.max() < e["stop"] and s3.birth.min() == 0


@pytest.mark.slow
def test_all_builtins_load_in_2d_and_3d():
    names = builtin_names()
    assert set(SHOWCASES) | {"dam_break", "double_dam_break", "rayleigh_taylor", "lock_exchange"} <= set(names)
    for n in names:
        sc = get_scene(n)
        s3, s2 = sc.realize(), sc.realize(dim=2)
        assert s3.dim == 3 and s2.dim == 2 and s2.n_fluid > 50, n
        assert s2.phase.max() == len(s2.phases) - 1 or len(s2.phases) == 1
        if n in SHOWCASES:
            assert 5_000 <= s3.n_fluid <= 30_000, (n, s3.n_fluid)
    assert len(get_scene("cocktail").data["phases"]) == 4
    assert len(get_scene("canyon").data["phases"]) == 3


def test_wavy_blocks_tile_without_gap():
    s = get_scene("rayleigh_taylor").realize(dim=2)
    assert s.n_fluid == 20 * 38  # the 1.0 x 1.9 m fluid region, fully tiled
    heavy = s.phase == 1
    assert s.x[heavy, 1].min() < 1.0 - 0.05 and s.x[~heavy, 1].max() > 1.0 + 0.05  # wavy interface


def test_resolution_scales_counts():
    sc = get_scene("dam_break")
    a, b = sc.realize(dim=2), sc.realize(dim=2, resolution=0.5)
    assert b.radius == a.radius
    assert 0.2 < b.n_fluid / a.n_fluid < 0.3


def test_showcase_physics_setup():
    s = get_scene("hourglass").realize(dim=2)
    heavy = s.phase == [p.name for p in s.phases].index("heavy")
    assert s.x[heavy, 1].mean() > s.x[~heavy, 1].mean() + 0.6   # heavy above light
    neck = np.abs(s.x[:, 1] - 0.95) < 0.1
    assert (heavy & neck).any() and (~heavy & neck).any()        # seeded, wavy interface
    c = get_scene("cocktail").realize(dim=2)
    rho = c.rest_density
    ys = [c.x[rho == d, 1].mean() for d in sorted(set(rho))]
    assert ys != sorted(ys, reverse=True)  # not stably stratified: must re-stratify
    assert np.abs(c.v[:, 0]).min() > 0     # sloshing


@pytest.mark.slow
def test_random_scenes_reproducible_and_bounded():
    a, b = random_scene_text(5), random_scene_text(5)
    assert a == b and a != random_scene_text(6)
    for seed in range(8):
        cfg = RandomSceneConfig(dim=2, max_ratio=3.0)
        s = random_scene(seed, cfg)
        rho = [p["density"] for p in s["phases"].values()]
        assert 1 <= len(s["fluid"]) <= 4 and 1 <= len(rho) <= 4
        assert max(rho) / min(rho) <= 3.0 + 1e-6 and 500 <= min(rho) and max(rho) <= 5000
        parse(random_scene_text(seed, cfg)).realize()
    held_out = RandomSceneConfig(dim=2, min_ratio=5.0, max_ratio=10.0)
    for seed in range(3):
        s = random_scene(seed, held_out)
        rho = [p["density"] for p in s["phases"].values()]
        assert 5.0 - 1e-6 <= max(rho) / min(rho) <= 10.0 + 1e-6
    s3 = random_scene(1, RandomSceneConfig(dim=3))
    assert s3["dim"] == 3


@pytest.mark.slow
def test_cli_list_show_random(tmp_path):
    r = cli("scene", "list")
    assert r.returncode == 0 and "cocktail" in r.stdout and "canyon" in r.stdout
    img = tmp_path / "h.png"
    r = cli("scene", "show", "hourglass", "--dim", "2", "--image", str(img))
    assert r.returncode == 0, r.stderr
    assert "heavy" in r.stdout and "domain" in r.stdout and img.stat().st_size > 10_000
    out = tmp_path / "r.toml"
    r = cli("scene", "random", "--seed", "3", "--max-ratio", "4", "-o", str(out))
    assert r.returncode == 0 and out.exists()
    assert cli("scene", "show", str(out)).returncode == 0
    bad = tmp_path / "bad.toml"
    bad.write_text(MINIMAL.replace("density = 1000", "density = 0"))
    r = cli("scene", "show", str(bad))
    assert r.returncode == 2 and r.stderr.startswith("error: bad.toml: phases.water.density must be > 0")
    assert cli("scene", "show", "no_such_scene").returncode == 2


def test_open_mesh_is_rejected(tmp_path):
    """A surface with a missing face encloses nothing: one-line error, not walls with holes."""
    import trimesh
    m = trimesh.creation.box(extents=[0.2, 0.2, 0.2])
    m.update_faces(m.face_normals[:, :2].min(1) > -0.5)  # drop the -x and -y sides: too large to patch
    m.remove_unreferenced_vertices()
    m.export(tmp_path / "open.obj")
    p = scene_with_mesh_wall(tmp_path, 'file = "open.obj"\ntranslate = [0.25, 0.8, 0.0]')
    with pytest.raises(DcdcError, match=r"open.obj is not a closed surface"):
        load(p).realize()
