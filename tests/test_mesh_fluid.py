"""Fluid from meshes: ``[[fluid]] shape = "mesh"`` fills a closed mesh's interior on the
global lattice, ``[[emitter]] shape = "mesh"`` releases it repeatedly; placement (scale per
axis, rotation, translation), 2-D sections, resolution, the particle budget and errors."""
from pathlib import Path

import numpy as np
import pytest
import trimesh

from dcdc.errors import DcdcError
from dcdc.scene import load, parse
from helpers import dcdc_output

MODELS = Path(__file__).resolve().parent / "data" / "models"
CUBE, BOX, SHEET = MODELS / "SmallCube.obj", MODELS / "UnitBox.obj", MODELS / "Sheet.obj"


def scene_text(body: str, dim=3, lo=(-0.5, 0.0, -0.5), hi=(0.5, 1.0, 0.5), walls=True) -> str:
    v = (lambda a: "[" + ", ".join(str(float(c)) for c in a[:dim]) + "]")
    tank = (f'[walls.tank]\nshape = "box"\nmin = {v(lo)}\nmax = {v(hi)}\nhollow = true\n'
            if walls else "")
    return (f'name = "m"\ndim = {dim}\nradius = 0.025\n[domain]\nmin = {v(lo)}\nmax = {v(hi)}\n'
            f'[phases.water]\ndensity = 1000\n{tank}{body}')


def mesh_fluid(file, extra="", phase="water") -> str:
    return f'[[fluid]]\nphase = "{phase}"\nshape = "mesh"\nfile = "{file}"\n{extra}\n'


def sorted_rows(x):
    x = np.round(x, 9)
    return x[np.lexsort(x.T[::-1])]


def test_cube_mesh_fills_like_the_box_block():
    """A 0.2 m cube mesh gives exactly the particles of the same box block (4³ = 64)."""
    m = parse(scene_text(mesh_fluid(CUBE, "translate = [0.1, 0.3, 0.1]"))).realize()
    b = parse(scene_text('[[fluid]]\nphase = "water"\nshape = "box"\nmin = [0.0, 0.2, 0.0]\n'
                         'max = [0.2, 0.4, 0.2]\n')).realize()
    assert m.n_fluid == b.n_fluid == 64
    assert np.array_equal(sorted_rows(m.x), sorted_rows(b.x))
    assert np.array_equal(m.wall_x, b.wall_x)  # the fluid mesh adds no wall


def test_hollow_wall_plus_fill_pitfall_and_the_mesh_fluid_fix():
    """A hollow mesh wall of the fluid's shape with ``fill`` cages the fluid (walls are
    unioned: the solid around the cube swallows the tank); the same fluid as ``shape =
    "mesh"`` leaves the tank's walls as they are."""
    pit = parse(scene_text(f'[walls.shape]\nshape = "mesh"\nfile = "{CUBE}"\nscale = 2.0\n'
                           'translate = [0.0, 0.5, 0.0]\nhollow = true\n'
                           '[[fluid]]\nphase = "water"\nshape = "fill"\ninside = "shape"\n')).realize()
    fix = parse(scene_text(mesh_fluid(CUBE, "scale = 2.0\ntranslate = [0.0, 0.5, 0.0]"))).realize()
    tank = parse(scene_text('[[fluid]]\nphase = "water"\nshape = "box"\nmin = [0.0, 0.0, 0.0]\n'
                            'max = [0.1, 0.1, 0.1]\n')).realize()
    assert np.array_equal(fix.wall_x, tank.wall_x)
    cage = (lambda w: ((np.abs(w[:, 0]) > 0.2) & (np.abs(w[:, 0]) < 0.3) & (np.abs(w[:, 2]) < 0.2)
                       & (w[:, 1] > 0.35) & (w[:, 1] < 0.65)).sum())
    assert cage(fix.wall_x) == 0 and cage(pit.wall_x) > 0
    assert fix.n_fluid == 8 ** 3


def test_scale_per_axis_and_rotation():
    """UnitBox scaled [0.4, 0.2, 0.1], turned 90° about y: 0.1 × 0.2 × 0.4 m, 2 × 4 × 8."""
    s = parse(scene_text(mesh_fluid(BOX, "scale = [0.4, 0.2, 0.1]\nrotation_axis = [0.0, 1.0, 0.0]\n"
                                    "rotation_degrees = 90.0\ntranslate = [0.0, 0.5, 0.0]"))).realize()
    assert s.n_fluid == 2 * 4 * 8
    ext = s.x.max(0) - s.x.min(0)
    assert np.allclose(ext, [0.05, 0.15, 0.35])


def test_sphere_mesh_close_to_the_sphere_block(tmp_path):
    ico = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=3, radius=0.2).export(ico)
    m = parse(scene_text(mesh_fluid(ico, "translate = [0.0, 0.5, 0.0]"))).realize()
    b = parse(scene_text('[[fluid]]\nphase = "water"\nshape = "sphere"\ncenter = [0.0, 0.5, 0.0]\n'
                         'radius = 0.2\n')).realize()
    assert abs(m.n_fluid - b.n_fluid) <= 0.05 * b.n_fluid
    assert (np.linalg.norm(m.x - [0, 0.5, 0], axis=1) <= 0.2 - 0.025 + 1e-3).all()


def test_section_and_resolution(tmp_path):
    text = scene_text(mesh_fluid(CUBE, "scale = 2.0\ntranslate = [0.0, 0.5, 0.0]"))
    p = tmp_path / "s.toml"
    p.write_text(text)
    sc = load(p)
    assert sc.realize(dim=2).n_fluid == 8 * 8            # the z = 0 section: a 0.4 m square
    assert sc.realize(resolution=0.5).n_fluid == 4 ** 3  # every length halved


def test_mesh_emitter_releases_the_volume_repeatedly():
    s = parse(scene_text(f'[[emitter]]\nshape = "mesh"\nphase = "water"\nfile = "{CUBE}"\n'
                         'translate = [0.0, 0.6, 0.0]\nvelocity = [0.0, -1.0, 0.0]\n'
                         'start = 0.1\ninterval = 0.2\nstop = 0.6\n'))
    sy = s.realize()
    births, counts = np.unique(sy.birth, return_counts=True)
    assert np.allclose(births, [0.1, 0.3, 0.5]) and (counts == 64).all()
    assert np.allclose(sy.v, [0, -1, 0])
    assert s.realize(dim=2).n_fluid == 3 * 16


def test_clearance_drops_particles_near_walls_else_overlap_is_an_error():
    body = (f'[walls.rock]\nshape = "box"\nmin = [-0.1, 0.0, -0.1]\nmax = [0.1, 0.45, 0.1]\n'
            + mesh_fluid(CUBE, "scale = 2.0\ntranslate = [0.0, 0.5, 0.0]{}"))
    with pytest.raises(DcdcError, match=r"fluid\[0\].*inside or touching walls.rock"):
        parse(scene_text(body.format(""))).realize()
    s = parse(scene_text(body.format("\nclearance = 0.025"))).realize()
    above = (np.abs(s.x[:, 0]) < 0.1) & (np.abs(s.x[:, 2]) < 0.1)
    assert 0 < s.n_fluid < 8 ** 3 and above.any() and (s.x[above, 1] > 0.45 + 0.025 - 1e-9).all()


def test_budget_counts_mesh_fluid_and_emitter():
    """A mesh block counts as the lattice of its bounds, a mesh emitter once per release."""
    fl = parse(scene_text(mesh_fluid(CUBE, "scale = 2.0\ntranslate = [0.0, 0.5, 0.0]"), walls=False))
    assert fl.realize(max_particles=1000).n_fluid == 512
    with pytest.raises(DcdcError, match=r"needs ~6\d\d particles to sample"):
        fl.realize(max_particles=500)  # the bounds' lattice: 8-9 points per axis
    em = (lambda stop: parse(scene_text(
        f'[[emitter]]\nshape = "mesh"\nphase = "water"\nfile = "{CUBE}"\n'
        f'translate = [0.0, 0.5, 0.0]\ninterval = 0.1\nstop = {stop}\n', walls=False)))
    assert em(0.1).realize(max_particles=200).n_fluid == 64
    with pytest.raises(DcdcError, match=r"needs ~[\d,]+ particles to sample"):
        em(1.0).realize(max_particles=500)  # 10 releases of 4-5 points per axis


@pytest.mark.parametrize("extra, match", [
    ("scale = [1.0, -1.0, 1.0]", r"fluid\[0\]\.scale must be a number > 0 or a list of 3"),
    ("rotation_degrees = 30.0", r"fluid\[0\]\.rotation_axis must be a non-zero vector"),
    ("thickness = 0.1", r"fluid\[0\]\.thickness is not a known key"),
])
def test_mesh_fluid_fields_are_checked(extra, match):
    with pytest.raises(DcdcError, match=match):
        parse(scene_text(mesh_fluid(CUBE, extra)))


def test_open_or_missing_mesh_is_a_one_line_error(tmp_path, capsys):
    with pytest.raises(DcdcError, match=r"fluid\[0\]\.file: mesh .*Sheet.obj is not a closed surface "
                                        r"\(4 open edges\); a mesh fluid fills the inside of a closed mesh"):
        parse(scene_text(mesh_fluid(SHEET, "translate = [0.0, 0.5, 0.0]"))).realize()
    for f, what in ((SHEET, "is not a closed surface"), (tmp_path / "nope.obj", "not found")):
        p = tmp_path / "s.toml"
        p.write_text(scene_text(mesh_fluid(f, "translate = [0.0, 0.5, 0.0]")))
        code, out, err = dcdc_output(["scene", "show", p], capsys)
        assert code == 2 and err.startswith("error: ") and what in err
        assert err.count("\n") == 1 and "Traceback" not in err


def test_mesh_wall_rotation_and_axis_scale():
    """A wall mesh takes the same placement keys: a 0.2 m cube turned 45° about y reaches
    0.1·√2 from its axis in x."""
    body = (f'[walls.rock]\nshape = "mesh"\nfile = "{CUBE}"\nscale = [2.0, 1.0, 2.0]\n'
            'rotation_axis = [0.0, 1.0, 0.0]\nrotation_degrees = 45.0\ntranslate = [0.0, 0.1, 0.0]\n'
            '[[fluid]]\nphase = "water"\nshape = "box"\nmin = [-0.5, 0.5, -0.5]\nmax = [0.5, 0.6, 0.5]\n')
    s = parse(scene_text(body, walls=False)).realize()
    assert s.n_wall > 0
    assert np.abs(s.wall_x[:, 0]).max() > 0.2 and np.abs(s.wall_x[:, 0]).max() <= 0.2 * np.sqrt(2) + 1e-9


def test_generate_precheck_bounds_a_mesh_block_by_the_domain():
    """`dcdc generate` checks the budget before any mesh is read (dcdc.scene.budget.check on
    the scene variant): a mesh block counts as the domain's lattice there, not a KeyError."""
    from dcdc.scene.budget import check
    sc = parse(scene_text(mesh_fluid(CUBE, "translate = [0.0, 0.5, 0.0]"), walls=False))
    est = check(sc.variant(3, 1.0), sc.name)
    assert est["fluid"] >= 20 ** 3  # the 1 m domain at 5 cm spacing bounds the 64 particles
    with pytest.raises(DcdcError, match="needs ~"):
        check(sc.variant(3, 1.0), sc.name, max_particles=1000)
